//! Running a plan: a shard makes the levels of its subtrees into its
//! file; the merge makes the levels above the shards' roots from what the
//! roots leave for their parents and writes the scene, taking every other
//! node's levels from the shard files (remaking any that are missing or
//! corrupt) in the order a single-process build makes them.

use std::path::{Path, PathBuf};

use super::file::{read_shard, shard_path, ShardWriter};
use super::plan::{import_planned, planned_layout, read_plan};
use super::{Plan, ShardError, ShardSpec};
use crate::source::{Imported, Source};
use crate::{Given, Layout, Progress, Role, Stats};

/// What [`run_shard`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShardRun {
    Made,
    /// A valid output was already there.
    AlreadyDone,
}

/// Runs shard `index` of the plan in `dir`, unless its output is there
/// and valid (then nothing is imported); the model is imported under
/// `budget` ([`crate::source::import_within`]).
pub fn run_shard(
    dir: &Path,
    index: usize,
    budget: Option<u64>,
    progress: &dyn Progress,
) -> Result<ShardRun, ShardError> {
    let plan = read_plan(dir)?;
    let spec = shard_spec(&plan, index)?;
    if read_shard(&shard_path(dir, &plan, index), &plan, index).is_ok() {
        return Ok(ShardRun::AlreadyDone);
    }
    Planned::open(dir, budget, progress)?.make(spec, progress)?;
    Ok(ShardRun::Made)
}

fn shard_spec(plan: &Plan, index: usize) -> Result<&ShardSpec, ShardError> {
    plan.shards.get(index).ok_or(ShardError::NoSuchShard {
        index,
        count: plan.shards.len(),
    })
}

/// A plan's model, its inputs checked, imported and laid out once, for
/// any number of shards and the merge in one process.
pub struct Planned {
    pub(super) dir: PathBuf,
    pub(super) plan: Plan,
    pub(super) model: Imported,
    pub(super) layout: Layout,
}

impl Planned {
    /// The plan in `dir` and its model, imported under `budget`
    /// ([`crate::source::import_within`], spilled into `dir` if need be).
    pub fn open(
        dir: &Path,
        budget: Option<u64>,
        progress: &dyn Progress,
    ) -> Result<Planned, ShardError> {
        let plan = read_plan(dir)?;
        let model = import_planned(&plan, dir, budget)?;
        let layout = planned_layout(&plan, model.source(), progress)?;
        Ok(Planned {
            dir: dir.to_path_buf(),
            plan,
            model,
            layout,
        })
    }

    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// Bytes of the model in a spill file (0: in memory).
    pub fn spilled_bytes(&self) -> u64 {
        self.model.spilled_bytes()
    }

    /// Runs shard `index`, unless its output is there and valid.
    pub fn run_shard(&self, index: usize, progress: &dyn Progress) -> Result<ShardRun, ShardError> {
        let spec = shard_spec(&self.plan, index)?;
        if read_shard(&shard_path(&self.dir, &self.plan, index), &self.plan, index).is_ok() {
            return Ok(ShardRun::AlreadyDone);
        }
        self.make(spec, progress)?;
        Ok(ShardRun::Made)
    }

    /// Makes shard `spec` and writes its output.
    fn make(&self, spec: &ShardSpec, progress: &dyn Progress) -> Result<(), ShardError> {
        let path = shard_path(&self.dir, &self.plan, spec.index);
        make_shard(
            &self.plan,
            spec,
            self.model.source(),
            &self.layout,
            &path,
            progress,
        )
    }

    /// Finishes the scene: any shard not done (or whose output is
    /// corrupt) is made first, here, and `redo` hears of it; then the
    /// levels above the shards, and the scene file, written atomically to
    /// `output`.
    pub fn merge(
        self,
        output: &Path,
        progress: &dyn Progress,
        redo: &mut dyn FnMut(usize, &ShardError),
    ) -> Result<Stats, ShardError> {
        use rayon::prelude::*;
        let (dir, plan) = (&self.dir, &self.plan);
        let mut given = Given::default();
        // Every shard file is read whole to check it: on all cores, each
        // keeping only its index; the ones to make again are made in order.
        let checked: Vec<_> = plan
            .shards
            .par_iter()
            .map(|spec| read_shard(&shard_path(dir, plan, spec.index), plan, spec.index))
            .collect();
        for (spec, checked) in plan.shards.iter().zip(checked) {
            let path = shard_path(dir, plan, spec.index);
            let (_, (lods, done)) = match checked {
                Ok(s) => s,
                Err(e) => {
                    redo(spec.index, &e);
                    self.make(spec, progress)?;
                    read_shard(&path, plan, spec.index)?
                }
            };
            let f = given.files.len();
            given.files.push(path);
            given
                .lods
                .extend(lods.into_iter().map(|(ni, r)| (ni, (f, r))));
            given.done.extend(done);
        }
        // Every node below a shard root is given, and nothing else.
        let roots: Vec<u32> = plan.shards.iter().flat_map(|s| s.roots.clone()).collect();
        let mask = subtree_mask(&self.layout.tree, &roots);
        let expected = mask.iter().filter(|&&m| m).count();
        if given.lods.len() != expected
            || !given
                .lods
                .keys()
                .all(|&k| mask.get(k as usize) == Some(&true))
            || roots.iter().any(|r| !given.done.contains_key(r))
        {
            return Err(ShardError::LayoutChanged {
                what: format!(
                    "the shards hold {} nodes, the plan's subtrees {expected}",
                    given.lods.len()
                ),
            });
        }
        let mut stats = crate::write_scene(
            self.model.source(),
            &plan.params,
            self.layout,
            output,
            &plan.source,
            progress,
            Role::Merge { given: &given },
        )?;
        stats.spilled_bytes = self.model.spilled_bytes();
        Ok(stats)
    }
}

fn make_shard(
    plan: &Plan,
    spec: &ShardSpec,
    model: &dyn Source,
    layout: &Layout,
    path: &Path,
    progress: &dyn Progress,
) -> Result<(), ShardError> {
    let mine = subtree_mask(&layout.tree, &spec.roots);
    let mut sink = ShardWriter::create(path, plan, spec.index, spec.nodes)?;
    let (_, roots) = crate::build_role(
        model,
        &plan.params,
        layout,
        &mut sink,
        progress,
        Role::Shard {
            mine: &mine,
            roots: &spec.roots,
        },
    )?;
    sink.finish(&roots)
}

/// Nodes in the subtrees of `roots`.
fn subtree_mask(tree: &[crate::hierarchy::HNode], roots: &[u32]) -> Vec<bool> {
    let mut mine = vec![false; tree.len()];
    let mut stack: Vec<u32> = roots.to_vec();
    while let Some(i) = stack.pop() {
        mine[i as usize] = true;
        let n = &tree[i as usize];
        stack.extend(n.first_child..n.first_child + n.child_count);
    }
    mine
}

/// Shards of the plan in `dir` whose output is missing or corrupt.
pub fn unfinished_shards(dir: &Path, plan: &Plan) -> Vec<usize> {
    (0..plan.shards.len())
        .filter(|&i| read_shard(&shard_path(dir, plan, i), plan, i).is_err())
        .collect()
}

/// Finishes the scene from the plan in `dir` ([`Planned::merge`]), the
/// model imported under `budget`.
pub fn merge(
    dir: &Path,
    output: &Path,
    budget: Option<u64>,
    progress: &dyn Progress,
    redo: &mut dyn FnMut(usize, &ShardError),
) -> Result<Stats, ShardError> {
    Planned::open(dir, budget, progress)?.merge(output, progress, redo)
}
