//! A build split into independent jobs: a plan, shards, a merge.
//!
//! Steps 1-5 (partition, clustering, hierarchy) are cheap next to the LODs
//! (about 1% of the time on the real-CAD floor), so every job makes them
//! again from the model and gets the same hierarchy. The plan cuts that
//! hierarchy into whole subtrees of at most `shard_triangles` triangles
//! (the highest nodes that small, or single leaves), grouped in tree order
//! into shards of about that many triangles. A shard makes the LODs and
//! HLODs of its subtrees, as GigaWalk's bottom-up HLOD generation needs
//! only a node's children (Section 4.3), and writes them to one file. The
//! merge makes the levels above the shards' roots from what the roots
//! leave for their parents, and writes the scene, taking every other
//! node's levels from the shards' files in the order a single-process
//! build makes them: the scene is byte-identical to that build, however
//! and wherever the shards ran.
//!
//! How the work splits depends on the model and the parameters only. Shard
//! files are written atomically and named by the plan's identity (a hash
//! of the input files, the parameters and the revision), so a rerun redoes
//! only what is missing or corrupt, a shard run twice at once writes the
//! same bytes twice, and a changed input is refused rather than mixed in.
//!
//! In parts: `plan` makes the plan and checks later jobs against it,
//! `file` writes and reads shard files, `run` runs the shards and the
//! merge, `drive` runs a whole split build from one command (in this
//! process or in worker processes) within a memory budget.

use std::path::{Path, PathBuf};

use crate::PreprocessError;

mod drive;
mod file;
mod plan;
mod run;

pub use drive::{
    build_split, mib, peak_text, shard_done_line, threads_for, threads_within, workers_for,
    SplitBuild, SplitError, SplitOutcome, WorkerCommand, FIXED_MEMORY, MIN_WORKER_BUDGET,
    THREAD_MEMORY,
};
pub(crate) use file::read_node_lods;
pub use file::shard_path;
pub use plan::{make_plan, plan, read_plan, spill_path, InputFile, Plan, ShardSpec};
pub use run::{merge, run_shard, unfinished_shards, Planned, ShardRun};

/// Triangles a shard holds by default: the 10M plant makes about ten
/// shards. The number of shards is a function of the model and this, never
/// of how many workers run them.
pub const DEFAULT_SHARD_TRIANGLES: u64 = 1_000_000;

/// The plan file in a work directory.
pub const PLAN_FILE: &str = "plan.json";

/// Why a split build failed.
#[derive(Debug, thiserror::Error)]
pub enum ShardError {
    #[error(transparent)]
    Import(#[from] gigawalk_import::ImportError),
    #[error(transparent)]
    Preprocess(#[from] PreprocessError),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: not a preprocess plan: {reason}")]
    BadPlan { path: PathBuf, reason: String },
    #[error("{dir} holds a plan for other inputs or parameters (plan {old}, this run {new}); use another --work-dir or remove it")]
    OtherPlan {
        dir: PathBuf,
        old: String,
        new: String,
    },
    #[error(
        "{path} changed since the plan was made ({what}); use another --work-dir or remove it"
    )]
    InputChanged { path: PathBuf, what: String },
    #[error("shard {index} is not in the plan ({count} shards: 0 to {})", count.saturating_sub(1))]
    NoSuchShard { index: usize, count: usize },
    #[error("the model's hierarchy differs from the plan's ({what}): the inputs or the preprocessor changed")]
    LayoutChanged { what: String },
    #[error("{path}: shard output is corrupt: {reason}")]
    Corrupt { path: PathBuf, reason: String },
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> ShardError + '_ {
    move |source| ShardError::Io {
        path: path.to_path_buf(),
        source,
    }
}
