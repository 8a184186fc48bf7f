//! gigawalk's preprocessor (GigaWalk Section 4): an imported [`Model`] in,
//! a scene file out.
//!
//! Main items: [`preprocess`] (the whole pipeline into a scene file),
//! [`build`] (the same into any [`LodSink`]), [`Params`] (every knob, with
//! the paper's defaults), [`Stats`] (what a run did), [`Progress`] (how a
//! caller watches it). The pipeline, one file per step:
//!
//! 1. input checks ([`parts`]): bad indices or NaN are errors, degenerate
//!    triangles are dropped and counted;
//! 2. Partition-I ([`partition`], Section 4.2.1);
//! 3. clustering ([`cluster`], Section 4.2.2);
//! 4. Partition-II ([`partition`] again, Section 4.2.3);
//! 5. the AABB hierarchy ([`hierarchy`], Section 4.2.4);
//! 6. LODs and HLODs ([`hlod`], Section 4.3), streamed to the sink
//!    bottom-up so only one batch of nodes' geometry is in memory.
//!
//! The library draws no progress bars and prints nothing; the CLI does.
//! Results depend only on the model and parameters, never on the number
//! of threads.

#![forbid(unsafe_code)]

pub mod cluster;
mod files;
pub mod hausdorff;
pub mod hierarchy;
pub mod hlod;
mod identity;
pub mod occluders;
pub mod params;
pub mod partition;
pub mod parts;
mod planar;
mod schedule;
pub mod shards;
pub mod source;
mod spent;
pub mod stats;
#[cfg(test)]
mod test_models;
#[cfg(test)]
mod tests;
pub mod verify;

/// Changes whenever the same model and parameters give a different scene
/// file (a new simplification or error measurement): caches of built
/// scenes (`gigawalk demo`'s) compare it, and provenance records it.
/// 2: error-driven LOD levels, every leaf piece kept, Partition-II at t1;
/// 3: vanished pieces of inner nodes covered; 4: occluders (OCCL); 5:
/// their view cells (OCVC); 6: errors measured a cluster at a time (as
/// sound, slightly different bounds); 7: a collapsed level measured far
/// beyond its simplifier's limit gives way to clustering when that is
/// nearer; 8: inner nodes' levels made by the same error-driven chain as
/// leaves' (collapse and clustering both measured, the lower error per
/// triangle kept; no jump far below a level's target), measured against
/// the full detail below a node of at most 65,536 triangles, vanished
/// pieces covered at the level's error limit; 9: levels made and stored
/// unit by unit (subtrees of at most 2^16 triangles), so memory no longer
/// grows with the model (the same levels, in another order in the file);
/// 10: a level's pieces settled once within the last level's error (its
/// error is at least that anyway), and triangles kept from the last level
/// bounded by it without a query (as sound, slightly different bounds);
/// 11: those triangles bounded by the last level's own error (10 used the
/// level before it), and an inner node's first level held to the node
/// budget where its simplifier stalled above it; 12: positions on a
/// 16-bit grid over each LOD's box and every stream meshopt-encoded
/// (scene format 2), each LOD's error raised by what its vertices moved;
/// 13: each encoded LOD's position and normal bits in its record (format
/// 2.1: a runtime sizes its device layout without reading the blob), and
/// encoded blobs zstd-compressed with a dictionary trained on the scene;
/// 14: object identity (OBJT), each leaf's full detail in runs of
/// triangles per object; 15: a level measured far off its error limit
/// gives way to a gentler edge collapse that measures nearer.
pub const REVISION: u32 = 15;

use std::path::Path;
use std::time::Instant;

use gigawalk_scene::{Aabb, LodMesh, Node, Provenance, SceneWriter, WriteError};
use rayon::prelude::*;

pub use files::{preprocess_files, FilesError};
pub use params::{LeafChains, ParamError, Params, PositionBits, Resolved};
pub use parts::InputError;
pub use source::{Source, Spill, SpillError, SpillWriter};
pub use stats::Stats;

use crate::cluster::ClusterParams;
use crate::hlod::{ChainParams, Lod};
use crate::partition::{SplitAt, SplitRule};
use crate::parts::{Part, Piece, Tris};

/// The pipeline's phases, in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    Check,
    PartitionI,
    Cluster,
    PartitionII,
    Hierarchy,
    Hlod,
    Write,
}

impl Phase {
    pub fn name(self) -> &'static str {
        match self {
            Phase::Check => "check",
            Phase::PartitionI => "partition-I",
            Phase::Cluster => "cluster",
            Phase::PartitionII => "partition-II",
            Phase::Hierarchy => "hierarchy",
            Phase::Hlod => "hlod",
            Phase::Write => "write",
        }
    }
}

/// Watches a run. Called from worker threads, hence `Sync`; every method
/// has a do-nothing default.
pub trait Progress: Sync {
    /// A phase begins; `total` is in the phase's own units (triangles for
    /// partitioning, nodes for HLODs), 0 when unknown.
    fn start(&self, _phase: Phase, _total: u64) {}
    /// `n` more units of the current phase are done.
    fn advance(&self, _n: u64) {}
    /// The current phase ended after `seconds`.
    fn finish(&self, _phase: Phase, _seconds: f64) {}
    /// A line for the user: what was imported, planned, capped, done.
    fn line(&self, _text: &str) {}
}

/// A [`Progress`] that ignores everything.
pub struct NoProgress;
impl Progress for NoProgress {}

/// Where LODs go as they are made: a scene file, or memory in tests.
pub trait LodSink {
    type Error: std::error::Error + Send + Sync + 'static;
    /// A LOD made ready to store on the thread that made it.
    type Prepared: Send;
    /// Prepares LODs on any thread: the part of storing a LOD that does
    /// not depend on the LODs before it (for a scene file: quantizing,
    /// encoding, compressing), so it runs on every core rather than on
    /// the one that stores. `runs`: for a leaf's full detail, its
    /// triangles' counts per object, which must stay consecutive and in
    /// order (empty otherwise); a sink that stores triangles as given
    /// needs nothing more.
    #[allow(clippy::type_complexity)]
    fn preparer(&self) -> Box<dyn Fn(&LodMesh, f32, &[u32]) -> Self::Prepared + Send + Sync>;
    /// Stores one prepared LOD; returns its index. A node's LODs arrive
    /// consecutively, finest first.
    fn add_prepared(&mut self, lod: Self::Prepared) -> Result<u32, Self::Error>;
    /// Prepares and stores one LOD on this thread.
    fn add_lod(&mut self, mesh: &LodMesh, error: f32) -> Result<u32, Self::Error> {
        let lod = self.preparer()(mesh, error, &[]);
        self.add_prepared(lod)
    }
    /// Every LOD of node `node` has been added (called once per node the
    /// run makes, after its LODs, even when it has none).
    fn node_done(&mut self, _node: u32) -> Result<(), Self::Error> {
        Ok(())
    }
}

impl LodSink for SceneWriter {
    type Error = WriteError;
    type Prepared = gigawalk_scene::EncodedLod;
    fn preparer(&self) -> Box<dyn Fn(&LodMesh, f32, &[u32]) -> Self::Prepared + Send + Sync> {
        let encoder = self.encoder();
        Box::new(move |mesh, error, runs| encoder.encode(mesh, error, runs))
    }
    fn add_prepared(&mut self, lod: Self::Prepared) -> Result<u32, WriteError> {
        self.add_encoded(lod)
    }
}

/// Why a preprocess failed.
#[derive(Debug, thiserror::Error)]
pub enum PreprocessError {
    #[error(transparent)]
    Params(#[from] ParamError),
    #[error(transparent)]
    Input(#[from] InputError),
    #[error("cannot write the scene file")]
    Write(#[source] Box<dyn std::error::Error + Send + Sync>),
    /// A merge could not read back a node's levels from a shard file
    /// that had passed its checks.
    #[error("a shard's output: node {node}: {reason}")]
    Shard { node: u32, reason: String },
}

/// The hierarchy and the run's statistics; the LODs are in the sink.
#[derive(Clone, Debug)]
pub struct Built {
    pub nodes: Vec<Node>,
    pub stats: Stats,
    /// The object table, with the runs of every leaf's full detail the
    /// sink took (docs/scene-format.md, "OBJT").
    pub objects: gigawalk_scene::objects::ObjectTable,
}

/// Runs the whole pipeline into `output` (atomically: nothing appears at
/// `output` unless everything succeeds). `source` names the input for the
/// file's provenance.
pub fn preprocess(
    model: &dyn Source,
    params: &Params,
    output: &Path,
    source: &str,
    progress: &dyn Progress,
) -> Result<Stats, PreprocessError> {
    let layout = layout(model, params, progress)?;
    write_scene(model, params, layout, output, source, progress, Role::All)
}

/// Most threads the object table is compressed on: each holds about 90
/// MiB of zstd's level-19 tables, so more would take the memory the
/// levels have just given back, and more.
const IDENTITY_WORKERS: usize = 4;

/// Step 6 for `role` (every node, or a merge's) into a scene file at
/// `output`, with its provenance and occluders.
pub(crate) fn write_scene(
    model: &dyn Source,
    params: &Params,
    layout: Layout,
    output: &Path,
    source: &str,
    progress: &dyn Progress,
    role: Role,
) -> Result<Stats, PreprocessError> {
    // On any error below, dropping the writer removes its temporary file.
    let mut writer = SceneWriter::create(output).map_err(|e| PreprocessError::Write(e.into()))?;
    writer
        .set_position_bits(params.position_bits.bits())
        .and_then(|()| writer.set_normal_bits(params.normal_bits))
        .and_then(|()| writer.set_compression(params.compress))
        .map_err(|e| PreprocessError::Write(e.into()))?;
    // The occluders depend on the model alone: found beside the levels,
    // on the same threads, rather than after them on fewer.
    let (built, found) = std::thread::scope(|s| {
        let found = s.spawn(|| {
            let occluders = occluders::scene_occluders(model)?;
            let bounds =
                occluders::model_bounds(model).unwrap_or((glam::DVec3::ZERO, glam::DVec3::ZERO));
            let cells = occluders::occluder_cells(
                &occluders,
                bounds,
                &occluders::CellParams {
                    height: params.cell_height,
                    k: params.cell_occluders,
                    directions: params.cell_directions,
                },
            );
            Ok::<_, SpillError>((occluders, cells))
        });
        let built = build_role(model, params, &layout, &mut writer, progress, role);
        let found = found
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        (built, found)
    });
    let (mut built, _) = built?;
    let (occluders, cells) = found.map_err(InputError::from)?;
    let mut clock = PhaseClock::new(progress);
    clock.start(Phase::Write, 0);
    let mut parameters = params.to_json();
    if let Some(r) = &built.stats.resolved {
        if let Ok(serde_json::Value::Object(m)) = serde_json::to_value(r) {
            parameters.insert(
                "resolved_in_model_units".into(),
                serde_json::Value::Object(m),
            );
        }
    }
    let provenance = Provenance {
        source: source.to_string(),
        tool: format!(
            "gigawalk-preprocess {} (revision {REVISION})",
            env!("CARGO_PKG_VERSION")
        ),
        parameters,
    };
    built.stats.occluders = occluders.len();
    built.stats.occluder_cells = cells.leaves();
    // Compressed on as many threads as the levels were made on, up to
    // IDENTITY_WORKERS; its CPU seconds and jobs say what more cores would
    // make of it.
    let cpu = stats::process_cpu_seconds();
    let workers = rayon::current_num_threads().min(IDENTITY_WORKERS);
    let jobs = std::cell::Cell::new(0);
    let objects = built.objects.encode_with(|body| {
        jobs.set(body.len().div_ceil(identity::COMPRESSION_JOB_BYTES));
        identity::compress(body, workers)
    });
    let jobs = jobs.get();
    built.stats.identity_bytes = objects.len() as u64;
    if let (Some(before), Some(after)) = (cpu, stats::process_cpu_seconds()) {
        built.stats.identity_compression =
            stats::Pieces::even(jobs, after - before, IDENTITY_WORKERS);
    }
    writer.add_optional_section(gigawalk_scene::objects::TAG_OBJECTS, objects);
    writer.add_optional_section(
        gigawalk_scene::occluders::TAG_OCCLUDERS,
        gigawalk_scene::occluders::encode_occluders(&occluders),
    );
    writer.add_optional_section(
        gigawalk_scene::occluder_cells::TAG_OCCLUDER_CELLS,
        gigawalk_scene::occluder_cells::encode_occluder_cells(&cells),
    );
    let summary = writer
        .finish(built.nodes, provenance)
        .map_err(|e| PreprocessError::Write(e.into()))?;
    let stats = &mut built.stats;
    clock.finish(stats);
    stats.output_bytes = summary.bytes;
    stats.finish();
    Ok(built.stats)
}

/// Runs the pipeline, handing every LOD to `sink`; returns the nodes (with
/// LOD indices from the sink) and the statistics.
pub fn build<S: LodSink>(
    model: &dyn Source,
    params: &Params,
    sink: &mut S,
    progress: &dyn Progress,
) -> Result<Built, PreprocessError> {
    let layout = layout(model, params, progress)?;
    Ok(build_role(model, params, &layout, sink, progress, Role::All)?.0)
}

/// Steps 1-5: the parts and the hierarchy over them, before any LOD.
/// Cheap next to the LODs, and a function of the model and parameters
/// only, so every shard of a split build makes the same one.
#[derive(Clone)]
pub(crate) struct Layout {
    parts: Vec<Part>,
    /// The object table's entries, and which each imported object is.
    identities: identity::Identities,
    pub(crate) tree: Vec<hierarchy::HNode>,
    resolved: Resolved,
    stats: Stats,
}

impl Layout {
    /// Triangles at full detail below each node.
    pub(crate) fn subtree_triangles(&self) -> Vec<u64> {
        subtree_triangles(&self.tree, &self.parts)
    }
}

/// Which nodes' levels a run makes ([`build_role`]).
pub(crate) enum Role<'a> {
    /// Every node: the single-process build.
    All,
    /// A shard: the nodes with `mine` set (whole subtrees); the [`Done`]
    /// of `roots` is returned for the nodes above.
    Shard { mine: &'a [bool], roots: &'a [u32] },
    /// The nodes above the shards; every other node's levels (and a shard
    /// root's [`Done`]) are taken from `given`, in the order a
    /// single-process build makes them, so the sink sees the same LODs in
    /// the same order.
    Merge { given: &'a Given },
}

/// Levels made by shards, for the merge: where each node's LODs are in
/// the (checked) shard files, read as a task of the node's own on the
/// thread pool once its children are done, so the nodes in flight are
/// bounded as a build's are; and the shard roots' [`Done`]. The files are
/// named, not held open: a merge of thousands of shards stays within the
/// limit on open files.
#[derive(Default)]
pub(crate) struct Given {
    pub(crate) files: Vec<std::path::PathBuf>,
    pub(crate) lods: std::collections::HashMap<u32, (usize, std::ops::Range<usize>)>,
    pub(crate) done: std::collections::HashMap<u32, Done>,
}

pub(crate) fn layout(
    model: &dyn Source,
    params: &Params,
    progress: &dyn Progress,
) -> Result<Layout, PreprocessError> {
    params.validate()?;
    let mut stats = Stats {
        raw_input_bytes: model.raw_bytes(),
        ..Default::default()
    };
    let mut clock = PhaseClock::new(progress);

    // 1. Input checks.
    clock.start(Phase::Check, 0);
    let (parts, dropped, identities) = parts::initial_parts_identified(model)?;
    stats.degenerate_dropped = dropped;
    stats.triangles = parts.iter().map(|p| p.triangles as u64).sum();
    stats.input_triangles = stats.triangles + dropped;
    stats.objects_init = parts.len();
    let scene = parts.iter().fold(Aabb::EMPTY, |a, p| a.union(&p.bounds));
    let resolved = params.resolve(&scene, stats.triangles);
    clock.finish(&mut stats);

    let split = |parts, (max_triangles, max_diagonal, max_aspect, at)| {
        let rule = SplitRule {
            max_triangles,
            max_diagonal,
            max_aspect,
            at,
        };
        partition::partition(model, parts, &rule, &|n| progress.advance(n))
            .map_err(InputError::from)
    };

    // 2. Partition-I (Section 4.2.1): split at the box middle.
    clock.start(Phase::PartitionI, stats.triangles);
    let rule1 = (resolved.t1, resolved.s1, resolved.r1, SplitAt::Midpoint);
    let parts = split(parts, rule1)?;
    stats.objects_part1 = parts.len();
    clock.finish(&mut stats);

    // 3. Clustering (Section 4.2.2).
    clock.start(Phase::Cluster, 0);
    let max_dim = parts
        .iter()
        .map(|p| p.bounds.extent().max_element())
        .fold(0.0, f64::max);
    let resolved = resolved.with_d(params, max_dim);
    let boxes: Vec<Aabb> = parts.iter().map(|p| p.bounds).collect();
    let cp = ClusterParams {
        d: params.d,
        v: resolved.v,
        k: params.k,
        min_extent: resolved.min_extent,
    };
    let (clusters, edges) = cluster::cluster(&boxes, &cp);
    stats.cluster_edges = edges;
    let parts = merge_clusters(parts, &clusters);
    stats.objects_clust = parts.len();
    clock.finish(&mut stats);

    // 4. Partition-II (Section 4.2.3): split about the centre of mass.
    clock.start(Phase::PartitionII, stats.triangles);
    let rule2 = (resolved.t2, resolved.s2, resolved.r2, SplitAt::CentreOfMass);
    let parts = split(parts, rule2)?;
    stats.objects_part2 = parts.len();
    clock.finish(&mut stats);

    // 5. The AABB hierarchy (Section 4.2.4).
    clock.start(Phase::Hierarchy, 0);
    let boxes: Vec<Aabb> = parts.iter().map(|p| p.bounds).collect();
    let tree = hierarchy::build(&boxes);
    stats.nodes = tree.len();
    stats.leaves = tree.iter().filter(|n| n.object.is_some()).count();
    stats.depth = tree.iter().map(|n| n.depth).max().unwrap_or(0);
    clock.finish(&mut stats);
    stats.objects = identities.len();
    Ok(Layout {
        parts,
        identities,
        tree,
        resolved,
        stats,
    })
}

/// Step 6, LODs and HLODs (Section 4.3), bottom-up, for the nodes `role`
/// says; the rest of [`build`]. Returns the [`Done`] of a shard's roots
/// (empty for the other roles).
#[allow(clippy::type_complexity)]
pub(crate) fn build_role<S: LodSink>(
    model: &dyn Source,
    params: &Params,
    layout: &Layout,
    sink: &mut S,
    progress: &dyn Progress,
    role: Role,
) -> Result<(Built, Vec<(u32, Done)>), PreprocessError> {
    let Layout {
        parts,
        identities,
        tree,
        resolved,
        stats,
    } = layout;
    let mut stats = stats.clone();
    let mut clock = PhaseClock::new(progress);
    let mine = |ni: usize, role: &Role| match role {
        Role::Shard { mine, .. } => mine[ni],
        _ => true,
    };
    let given = match &role {
        Role::Merge { given } => Some(&**given),
        _ => None,
    };
    clock.start(Phase::Hlod, tree.len() as u64);
    let chain = ChainParams::of(params);
    let keep = chain.merge_budget();
    let tally = hlod::Tally::default();
    let mut lod_ranges = vec![(0u32, 0u32); tree.len()];
    let mut lod_runs: Vec<(u32, Vec<gigawalk_scene::objects::ObjectRun>)> = Vec::new();
    let prepare = sink.preparer();
    let mut emit = |ni: usize,
                    lods: Vec<Prepared<S::Prepared>>,
                    per_level: &mut Vec<u64>|
     -> Result<(), PreprocessError> {
        let (mut first, count) = (None, lods.len() as u32);
        for (k, lod) in lods.into_iter().enumerate() {
            let i = sink
                .add_prepared(lod.lod)
                .map_err(|e| PreprocessError::Write(e.into()))?;
            if let Some(runs) = lod.runs {
                lod_runs.push((i, runs));
            }
            first.get_or_insert(i);
            if per_level.len() <= k {
                per_level.push(0);
            }
            per_level[k] += lod.triangles;
        }
        sink.node_done(ni as u32)
            .map_err(|e| PreprocessError::Write(e.into()))?;
        lod_ranges[ni] = (first.unwrap_or(0), count);
        Ok(())
    };
    let below = subtree_triangles(tree, parts);
    // A node's full detail is kept for its parent only when the parent
    // will be measured against it: when the parent has at most
    // EXACT_REFERENCE triangles below it.
    let wanted = |ni: usize| {
        let p = tree[ni].parent;
        p != gigawalk_scene::NO_NODE && below[p as usize] <= EXACT_REFERENCE as u64
    };
    // Children before parents, in the order the sink sees them.
    let sequence: Vec<usize> = order(tree, &below)
        .into_iter()
        .flatten()
        .filter(|&i| mine(i, &role))
        .collect();
    let window = (rayon::current_num_threads() as u64 + 1) * UNIT_TRIANGLES;
    let cost = |ni: usize| match tree[ni].object {
        Some(_) => below[ni],
        None => 0,
    };
    // A node's levels made ready for the sink; a leaf's full detail keeps
    // its triangles in runs per object.
    let ready = |ni: usize, lods: Lods| -> Vec<Prepared<S::Prepared>> {
        let mut runs = tree[ni].object.map(|part| {
            let pieces = &parts[part as usize].pieces;
            identities.runs(pieces.iter().map(|p| (p.object, p.triangles.len() as u32)))
        });
        lods.into_iter()
            .map(|(mesh, error)| {
                let runs = runs.take();
                let counts: Vec<u32> = runs.iter().flatten().map(|r| r.triangles).collect();
                Prepared {
                    lod: spent::timed(spent::Kind::Prepare, || prepare(&mesh, error, &counts)),
                    triangles: mesh.triangle_count() as u64,
                    runs,
                }
            })
            .collect()
    };
    let make = |ni: usize,
                children: Vec<ForParent>|
     -> Result<(ForParent, Vec<Prepared<S::Prepared>>), PreprocessError> {
        if let Some((lods, d)) = take(given, ni)? {
            let lowest = lowest_of(&tree[ni], &lods, &children);
            return Ok(((d, lowest), ready(ni, lods)));
        }
        let (lods, d) = match tree[ni].object {
            Some(object) => make_leaf(
                model,
                &parts[object as usize],
                &tree[ni],
                &chain,
                &tally,
                keep,
                wanted(ni),
            )
            .map_err(InputError::from)?,
            None => make_inner(&tree[ni], &children, (&chain, &tally), keep, wanted(ni)),
        };
        let lowest = lowest_of(&tree[ni], &lods, &children);
        Ok(((d, lowest), ready(ni, lods)))
    };
    let mut hand_on =
        |ni: usize, lods: Vec<Prepared<S::Prepared>>| -> Result<(), PreprocessError> {
            match tree[ni].object {
                Some(_) => emit(ni, lods, &mut stats.leaf_lod_triangles)?,
                None => emit(ni, lods, &mut stats.inner_lod_triangles)?,
            }
            progress.advance(1);
            Ok(())
        };
    let (mut left, work) = schedule::run(tree, &sequence, window, &cost, &make, &mut hand_on)?;
    stats.schedule = Some(stats::Schedule::of(&work, tree));
    stats.lods = lod_ranges.iter().map(|r| r.1 as usize).sum();
    lod_runs.sort_unstable_by_key(|(lod, _)| *lod);
    // A shard's levels go to its file and the merge writes the object
    // table: a table per shard would copy every object's record (names,
    // paths, metadata) each time, a quarter of a shard's CPU time at
    // 6.7M objects.
    let objects = match role {
        Role::Shard { .. } => Default::default(),
        _ => identities.table(lod_runs),
    };
    stats.certification = tally.snapshot();
    clock.finish(&mut stats);

    let nodes = tree
        .iter()
        .zip(&lod_ranges)
        .map(|(n, &(first_lod, lod_count))| Node {
            bounds: n.bounds,
            parent: n.parent,
            first_child: n.first_child,
            child_count: n.child_count,
            first_lod,
            lod_count,
        })
        .collect();
    stats.resolved = Some(resolved.clone());
    let roots = match role {
        Role::Shard { roots, .. } => roots
            .iter()
            .map(|&r| {
                let (d, _) = left[r as usize].take().expect("a shard's roots are done");
                (r, d)
            })
            .collect(),
        _ => Vec::new(),
    };
    Ok((
        Built {
            nodes,
            stats,
            objects,
        },
        roots,
    ))
}

/// A leaf's levels, and what it leaves for its parent.
fn make_leaf(
    model: &dyn Source,
    part: &Part,
    node: &hierarchy::HNode,
    chain: &ChainParams,
    tally: &hlod::Tally,
    keep: usize,
    full_wanted: bool,
) -> Result<Finished, SpillError> {
    let mesh = spent::timed(spent::Kind::Read, || {
        hlod::leaf_mesh(model, part, node.bounds.center())
    })?;
    let full = (full_wanted && mesh.triangles() <= EXACT_REFERENCE).then(|| mesh.clone());
    let lods = hlod::leaf_lods(mesh, node.bounds.diagonal(), chain, tally);
    let (out, levels) = finish_chain(lods, keep);
    Ok((out, Done { levels, full }))
}

/// An inner node's levels (its children are done: what they left for it,
/// in child order), and what it leaves for its parent.
fn make_inner(
    node: &hierarchy::HNode,
    below: &[ForParent],
    (chain, tally): (&ChainParams, &hlod::Tally),
    keep: usize,
    full_wanted: bool,
) -> Finished {
    let children: Vec<&[Lod]> = below.iter().map(|(d, _)| d.levels.as_slice()).collect();
    // Every child's full detail, or none: a reference missing a child
    // would not bound the node.
    let full: Option<Vec<&hlod::WorkMesh>> = below.iter().map(|(d, _)| d.full.as_ref()).collect();
    let full = full
        .filter(|b| b.len() == node.child_count as usize)
        .filter(|b| b.iter().map(|m| m.triangles()).sum::<usize>() <= EXACT_REFERENCE)
        .map(|b| hlod::merge(&b, node.bounds.center()));
    let mut lods = hlod::inner_lods(
        &children,
        full.as_ref(),
        node.bounds.center(),
        node.bounds.diagonal(),
        chain,
        tally,
    );
    // Never claim less error than a stored level below (the scene file's
    // rule: errors do not decrease from a node to its nearest ancestor
    // with LODs).
    let lowest = lowest_below(below);
    for l in &mut lods {
        l.error = l.error.max(lowest);
    }
    let stored = hlod::worth_drawing(&lods, &children);
    let (out, levels) = finish_chain(lods, keep);
    (
        out.into_iter().skip(stored.start).collect(),
        Done {
            levels,
            full: full.filter(|_| full_wanted),
        },
    )
}

/// Triangles a unit of [`order`] holds at most (unless it is one leaf):
/// what bounds the levels and full detail that wait for their parents
/// (about 100 bytes a triangle: some 6 MiB), whatever the model's size.
/// Smaller units idle cores at each unit's top levels (one or two nodes a
/// stage); on the 2M plant 2^16 took the same time as 2^18 and 40 MiB less
/// at its peak. A unit's root keeps no full detail for its parent (that
/// has more than [`EXACT_REFERENCE`] triangles below it), so no unit
/// leaves more than its coarse levels behind.
const UNIT_TRIANGLES: u64 = 1 << 16;

/// The order nodes' levels are made in, as stages of nodes that only
/// depend on earlier stages: unit by unit (the highest subtrees of at
/// most [`UNIT_TRIANGLES`] triangles, or single leaves, in tree order),
/// each its leaves then its inner nodes deepest first, then the nodes
/// above the units deepest first. Within a stage nodes are in index
/// order. A function of the tree only, so every run (and every shard,
/// taking its own nodes) makes and emits the same levels in the same
/// order.
pub(crate) fn order(tree: &[hierarchy::HNode], triangles: &[u64]) -> Vec<Vec<usize>> {
    let mut stages = Vec::new();
    let by_depth = |nodes: &mut Vec<usize>, stages: &mut Vec<Vec<usize>>| {
        nodes.sort_by_key(|&i| (std::cmp::Reverse(tree[i].depth), i));
        for run in nodes.chunk_by(|&a, &b| tree[a].depth == tree[b].depth) {
            stages.push(run.to_vec());
        }
    };
    let roots = subtree_roots(tree, triangles, UNIT_TRIANGLES);
    let mut in_unit = vec![false; tree.len()];
    for &r in &roots {
        let (mut leaves, mut inner) = (Vec::new(), Vec::new());
        let mut stack = vec![r];
        while let Some(i) = stack.pop() {
            in_unit[i as usize] = true;
            let n = &tree[i as usize];
            match n.object {
                Some(_) => leaves.push(i as usize),
                None => inner.push(i as usize),
            }
            stack.extend(n.first_child..n.first_child + n.child_count);
        }
        leaves.sort_unstable();
        stages.push(leaves);
        by_depth(&mut inner, &mut stages);
    }
    let mut top: Vec<usize> = (0..tree.len()).filter(|&i| !in_unit[i]).collect();
    by_depth(&mut top, &mut stages);
    stages
}

/// The highest nodes with at most `limit` triangles below them, or
/// leaves, in tree order (depth first, children in order).
pub(crate) fn subtree_roots(tree: &[hierarchy::HNode], triangles: &[u64], limit: u64) -> Vec<u32> {
    let mut roots = Vec::new();
    let mut stack = if tree.is_empty() { vec![] } else { vec![0u32] };
    while let Some(i) = stack.pop() {
        let n = &tree[i as usize];
        if triangles[i as usize] <= limit || n.object.is_some() {
            roots.push(i);
        } else {
            stack.extend((n.first_child..n.first_child + n.child_count).rev());
        }
    }
    roots
}

/// Triangles at full detail below each node.
pub(crate) fn subtree_triangles(tree: &[hierarchy::HNode], parts: &[Part]) -> Vec<u64> {
    let mut t = vec![0u64; tree.len()];
    for i in (0..tree.len()).rev() {
        let n = &tree[i];
        t[i] += match n.object {
            Some(o) => parts[o as usize].triangles as u64,
            None => (n.first_child..n.first_child + n.child_count)
                .map(|c| t[c as usize])
                .sum(),
        };
    }
    t
}

/// A merge's node made by a shard: its levels, and what it leaves for its
/// parent (a shard root's [`Done`]; nothing for a node inside a shard,
/// whose parent was made there too).
fn take(given: Option<&Given>, ni: usize) -> Result<Option<Finished>, PreprocessError> {
    let Some(given) = given else {
        return Ok(None);
    };
    let Some((file, range)) = given.lods.get(&(ni as u32)) else {
        return Ok(None);
    };
    let lods = spent::timed(spent::Kind::Read, || {
        shards::read_node_lods(&given.files[*file], range.clone())
    })
    .map_err(|reason| PreprocessError::Shard {
        node: ni as u32,
        reason,
    })?;
    let done = given.done.get(&(ni as u32)).cloned().unwrap_or(Done {
        levels: Vec::new(),
        full: None,
    });
    Ok(Some((lods, done)))
}

/// A node's levels in the scene file's form.
type Lods = Vec<(LodMesh, f32)>;

/// A level made ready for the sink ([`LodSink::preparer`]), with what the
/// run records of it: its triangles, and a leaf's full detail's runs per
/// object.
struct Prepared<P> {
    lod: P,
    triangles: u64,
    runs: Option<Vec<gigawalk_scene::objects::ObjectRun>>,
}

/// A node's levels in the scene file's form, and what it leaves for its
/// parent.
type Finished = (Lods, Done);

/// What a done node leaves for its parent: its [`Done`], and its finest
/// stored error (0 for a leaf, whose finest level is its full detail), or
/// without stored levels the largest such error below it.
type ForParent = (Done, f32);

/// What a done node leaves for its parent's HLODs.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Done {
    /// The levels its parent may merge.
    pub(crate) levels: Vec<Lod>,
    /// Its full-detail surface, while that has at most [`EXACT_REFERENCE`]
    /// triangles, for its parent's levels to be measured against.
    pub(crate) full: Option<hlod::WorkMesh>,
}

/// An inner node whose leaves hold at most this many triangles has its
/// levels measured against them, not against its children's levels: the
/// stored error is then the measured distance itself rather than a sum
/// that compounds with every level of the tree.
const EXACT_REFERENCE: usize = 1 << 16;

/// The largest of a node's children's `lowest` errors: what the node may
/// never claim less than (the scene file's rule that errors do not
/// decrease from a node to its nearest ancestor with LODs).
fn lowest_below(children: &[ForParent]) -> f32 {
    children.iter().map(|c| c.1).fold(0.0f32, f32::max)
}

/// A node's `lowest`: 0 for a leaf (its finest level is its full
/// detail); an inner node's finest stored error, or (without stored
/// levels) the largest below it.
fn lowest_of(node: &hierarchy::HNode, lods: &[(LodMesh, f32)], children: &[ForParent]) -> f32 {
    match (node.object, lods.first()) {
        (Some(_), _) => 0.0,
        (None, Some(l)) => l.1,
        (None, None) => lowest_below(children),
    }
}

/// The scene-file form of every level, and the levels kept for the
/// parent's HLODs.
fn finish_chain(mut lods: Vec<Lod>, keep: usize) -> (Vec<(LodMesh, f32)>, Vec<Lod>) {
    let out = lods
        .iter()
        .map(|l| (l.mesh.to_lod_mesh(), l.error))
        .collect();
    // A parent merges at most `keep` triangles of all its children, so a
    // finer level is never picked; the coarsest always may be.
    let coarsest = lods.len().saturating_sub(1);
    let first = lods
        .iter()
        .position(|l| l.mesh.triangles() <= keep)
        .unwrap_or(coarsest);
    lods.drain(..first);
    (out, lods)
}

/// One part per cluster: the union of its members' pieces, per object.
fn merge_clusters(parts: Vec<Part>, clusters: &[Vec<u32>]) -> Vec<Part> {
    let mut slots: Vec<Option<Part>> = parts.into_iter().map(Some).collect();
    let groups: Vec<Vec<Part>> = clusters
        .iter()
        .map(|c| c.iter().filter_map(|&i| slots[i as usize].take()).collect())
        .collect();
    groups
        .into_par_iter()
        .map(|mut g| {
            if g.len() == 1 {
                return g.pop().unwrap_or_else(|| unreachable!());
            }
            let bounds = g.iter().fold(Aabb::EMPTY, |a, p| a.union(&p.bounds));
            let triangles = g.iter().map(|p| p.triangles).sum();
            let mut pieces: Vec<Piece> = g.into_iter().flat_map(|p| p.pieces).collect();
            pieces.sort_by_key(|p| p.object);
            let mut merged: Vec<Piece> = Vec::with_capacity(pieces.len());
            // Two pieces of one object (split by Partition-I, joined by
            // clustering) become one list.
            for p in pieces {
                match merged.last_mut() {
                    Some(m) if m.object == p.object => {
                        let mut list = m.triangles.to_vec();
                        list.extend(p.triangles.iter());
                        list.sort_unstable();
                        m.triangles = Tris::List(list);
                    }
                    _ => merged.push(p),
                }
            }
            Part {
                pieces: merged,
                bounds,
                triangles,
            }
        })
        .collect()
}

/// Times phases and reports them to the progress watcher and the stats.
struct PhaseClock<'a> {
    progress: &'a dyn Progress,
    phase: Phase,
    started: Instant,
    cpu: Option<f64>,
}

impl<'a> PhaseClock<'a> {
    fn new(progress: &'a dyn Progress) -> Self {
        PhaseClock {
            progress,
            phase: Phase::Check,
            started: Instant::now(),
            cpu: None,
        }
    }
    fn start(&mut self, phase: Phase, total: u64) {
        self.phase = phase;
        self.started = Instant::now();
        self.cpu = stats::process_cpu_seconds();
        self.progress.start(phase, total);
    }
    fn finish(&mut self, stats: &mut Stats) {
        let secs = self.started.elapsed().as_secs_f64();
        self.progress.finish(self.phase, secs);
        tracing::info!(phase = self.phase.name(), seconds = secs, "phase done");
        stats.phase_seconds.push((self.phase.name().into(), secs));
        if let (Some(a), Some(b)) = (self.cpu, stats::process_cpu_seconds()) {
            if secs > 0.0 {
                stats
                    .phase_cores
                    .push((self.phase.name().into(), (b - a) / secs));
            }
        }
    }
}
