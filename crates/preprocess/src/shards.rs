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

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::source::{Imported, Source};
use gigawalk_scene::{Colours, LodMesh};
use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::hlod::{Lod, WorkMesh};
use crate::{Done, Given, Layout, Params, PreprocessError, Progress, Role, Stats, REVISION};

/// Triangles a shard holds by default: the 10M plant makes about ten
/// shards. The number of shards is a function of the model and this, never
/// of how many workers run them.
pub const DEFAULT_SHARD_TRIANGLES: u64 = 1_000_000;

/// The plan file in a work directory.
pub const PLAN_FILE: &str = "plan.json";

const FORMAT: &str = "gigawalk-preprocess-plan";
const PLAN_VERSION: u32 = 1;
const SHARD_MAGIC: &[u8; 8] = b"GWSHARD2";

/// One input file as the plan saw it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputFile {
    /// As found (absolute, so jobs may run from any directory).
    pub path: PathBuf,
    pub bytes: u64,
    /// BLAKE3 of the file's bytes, hex.
    pub blake3: String,
}

/// One shard: whole subtrees of the hierarchy.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShardSpec {
    pub index: usize,
    /// The subtrees' roots (node indices of the hierarchy).
    pub roots: Vec<u32>,
    pub nodes: u64,
    pub triangles: u64,
}

/// `DIR/plan.json` (docs/preprocess.md, "Split builds").
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plan {
    pub format: String,
    pub version: u32,
    /// The preprocessor revision ([`REVISION`]) the plan is for.
    pub revision: u32,
    /// A hash of the inputs, the parameters, the shard size and the
    /// revision (hex): shard files carry it in their names.
    pub id: String,
    /// The scene's provenance names the model by this.
    pub source: String,
    pub inputs: Vec<InputFile>,
    pub params: Params,
    pub shard_triangles: u64,
    pub nodes: u64,
    pub triangles: u64,
    pub shards: Vec<ShardSpec>,
}

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

/// BLAKE3 of a file, hex, and its length.
fn hash_file(path: &Path) -> Result<(u64, String), ShardError> {
    let mut h = blake3::Hasher::new();
    let mut f = std::fs::File::open(path).map_err(io(path))?;
    let bytes = std::io::copy(&mut f, &mut h).map_err(io(path))?;
    Ok((bytes, h.finalize().to_hex().to_string()))
}

/// The model files and what they hold now.
fn describe_inputs(files: &[PathBuf]) -> Result<Vec<InputFile>, ShardError> {
    files
        .iter()
        .map(|f| {
            let path = std::path::absolute(f).map_err(io(f))?;
            let (bytes, blake3) = hash_file(&path)?;
            Ok(InputFile {
                path,
                bytes,
                blake3,
            })
        })
        .collect()
}

/// The subtrees a shard holds, grouped: the highest nodes with at most
/// `limit` triangles below them (or leaves), in tree order, packed into
/// shards of at most `limit` triangles (one root alone may be bigger only
/// when it is a leaf).
pub(crate) fn cut(layout: &Layout, limit: u64) -> Vec<ShardSpec> {
    let tri = layout.subtree_triangles();
    let tree = &layout.tree;
    if tree.is_empty() {
        return Vec::new();
    }
    let mut nodes_below = vec![1u64; tree.len()];
    for i in (0..tree.len()).rev() {
        let n = &tree[i];
        for c in n.first_child..n.first_child + n.child_count {
            nodes_below[i] += nodes_below[c as usize];
        }
    }
    let roots = crate::subtree_roots(tree, &tri, limit);
    let mut shards: Vec<ShardSpec> = Vec::new();
    for r in roots {
        let t = tri[r as usize];
        match shards.last_mut() {
            Some(s) if s.triangles + t <= limit => {
                s.roots.push(r);
                s.triangles += t;
                s.nodes += nodes_below[r as usize];
            }
            _ => shards.push(ShardSpec {
                index: shards.len(),
                roots: vec![r],
                nodes: nodes_below[r as usize],
                triangles: t,
            }),
        }
    }
    shards
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

fn plan_id(
    inputs: &[InputFile],
    source: &str,
    params: &Params,
    shard_triangles: u64,
) -> Result<String, ShardError> {
    let key = serde_json::json!({
        "revision": REVISION,
        "inputs": inputs,
        "source": source,
        "params": params,
        "shard_triangles": shard_triangles,
    });
    let bytes = serde_json::to_vec(&key).map_err(|e| ShardError::BadPlan {
        path: PathBuf::from(PLAN_FILE),
        reason: e.to_string(),
    })?;
    Ok(blake3::hash(&bytes).to_hex()[..32].to_string())
}

/// Reads `DIR/plan.json`.
pub fn read_plan(dir: &Path) -> Result<Plan, ShardError> {
    let path = dir.join(PLAN_FILE);
    let text = std::fs::read_to_string(&path).map_err(io(&path))?;
    let plan: Plan = serde_json::from_str(&text).map_err(|e| ShardError::BadPlan {
        path: path.clone(),
        reason: e.to_string(),
    })?;
    let bad = |reason: String| ShardError::BadPlan {
        path: path.clone(),
        reason,
    };
    if plan.format != FORMAT || plan.version != PLAN_VERSION {
        return Err(bad(format!(
            "format {:?} version {} (this gigawalk reads {FORMAT:?} version {PLAN_VERSION})",
            plan.format, plan.version
        )));
    }
    if plan.revision != REVISION {
        return Err(bad(format!(
            "made for preprocessor revision {}, this is revision {REVISION}: remove the work directory and plan again",
            plan.revision
        )));
    }
    plan.params
        .validate()
        .map_err(|e| bad(format!("parameters: {e}")))?;
    if plan.shards.iter().enumerate().any(|(i, s)| s.index != i) {
        return Err(bad("shards are not numbered 0, 1, 2, ...".into()));
    }
    Ok(plan)
}

/// Makes the plan for `inputs` in `dir` (created if need be), or finds the
/// same plan already there. A different plan there is refused. The plan
/// needs the whole model (imported and laid out once).
pub fn make_plan(
    inputs: &[PathBuf],
    source: &str,
    params: &Params,
    shard_triangles: u64,
    dir: &Path,
    progress: &dyn Progress,
) -> Result<Plan, ShardError> {
    Ok(plan(inputs, source, params, shard_triangles, dir, None, progress)?.plan)
}

/// [`make_plan`], keeping the model (imported under `budget`,
/// [`crate::source::import_within`], spilled into `dir` if need be) and
/// its layout for shards and the merge run in this process. An existing
/// plan's inputs are checked as [`Planned::open`] checks them.
pub fn plan(
    inputs: &[PathBuf],
    source: &str,
    params: &Params,
    shard_triangles: u64,
    dir: &Path,
    budget: Option<u64>,
    progress: &dyn Progress,
) -> Result<Planned, ShardError> {
    params.validate().map_err(PreprocessError::from)?;
    let files = gigawalk_import::model_files(inputs)?;
    let described = describe_inputs(&files)?;
    let id = plan_id(&described, source, params, shard_triangles)?;
    if dir.join(PLAN_FILE).exists() {
        let old = read_plan(dir)?;
        if old.id != id {
            return Err(ShardError::OtherPlan {
                dir: dir.to_path_buf(),
                old: old.id,
                new: id,
            });
        }
        return Planned::open(dir, budget, progress);
    }
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let spill = crate::source::import_to_named_spill(
        &files,
        &dir.join(format!("model-{id}.spill")),
        &id,
        crate::source::cache_bytes(budget),
        &mut |_, _, _| {},
    )?;
    let model = Imported::Spilled(Box::new(spill));
    let layout = crate::layout(model.source(), params, progress)?;
    let shards = cut(&layout, shard_triangles.max(1));
    let plan = Plan {
        format: FORMAT.into(),
        version: PLAN_VERSION,
        revision: REVISION,
        id,
        source: source.into(),
        inputs: described,
        params: params.clone(),
        shard_triangles,
        nodes: layout.tree.len() as u64,
        triangles: layout.stats.triangles,
        shards,
    };
    let text = serde_json::to_string_pretty(&plan).map_err(|e| ShardError::BadPlan {
        path: dir.join(PLAN_FILE),
        reason: e.to_string(),
    })?;
    let path = dir.join(PLAN_FILE);
    gigawalk_scene::write_atomic(&path, text.as_bytes()).map_err(io(&path))?;
    Ok(Planned {
        dir: dir.to_path_buf(),
        plan,
        model,
        layout,
    })
}

/// Where shard `index`'s output goes.
pub fn shard_path(dir: &Path, plan: &Plan, index: usize) -> PathBuf {
    dir.join(format!("shard-{index:05}-{}.bin", plan.id))
}

/// The plan's model, refused if any input changed since the plan: the
/// work directory's spill of it ([`spill_path`]), made now if it is not
/// there (or not whole), read through a cache sized by `budget`.
fn import_planned(plan: &Plan, dir: &Path, budget: Option<u64>) -> Result<Imported, ShardError> {
    for f in &plan.inputs {
        let (bytes, hash) = hash_file(&f.path)?;
        if bytes != f.bytes || hash != f.blake3 {
            return Err(ShardError::InputChanged {
                path: f.path.clone(),
                what: format!(
                    "{bytes} bytes, BLAKE3 {}, against {} bytes, {} in the plan",
                    &hash[..16],
                    f.bytes,
                    &f.blake3[..16.min(f.blake3.len())]
                ),
            });
        }
    }
    let path = spill_path(dir, plan);
    let cache = crate::source::cache_bytes(budget);
    let spill = match crate::source::Spill::open(&path, &plan.id, cache) {
        Some(s) => s,
        None => {
            let files: Vec<PathBuf> = plan.inputs.iter().map(|f| f.path.clone()).collect();
            crate::source::import_to_named_spill(&files, &path, &plan.id, cache, &mut |_, _, _| {})?
        }
    };
    Ok(Imported::Spilled(Box::new(spill)))
}

/// Where the plan's model is spilled in `dir`, for every process that
/// runs a shard or the merge to read instead of importing it again.
pub fn spill_path(dir: &Path, plan: &Plan) -> PathBuf {
    dir.join(format!("model-{}.spill", plan.id))
}

/// The model's layout, checked against the plan's.
fn planned_layout(
    plan: &Plan,
    model: &dyn Source,
    progress: &dyn Progress,
) -> Result<Layout, ShardError> {
    let layout = crate::layout(model, &plan.params, progress)?;
    if layout.tree.len() as u64 != plan.nodes || layout.stats.triangles != plan.triangles {
        return Err(ShardError::LayoutChanged {
            what: format!(
                "{} nodes and {} triangles against {} and {}",
                layout.tree.len(),
                layout.stats.triangles,
                plan.nodes,
                plan.triangles
            ),
        });
    }
    let shards = cut(&layout, plan.shard_triangles.max(1));
    if shards != plan.shards {
        return Err(ShardError::LayoutChanged {
            what: "other shards".into(),
        });
    }
    Ok(layout)
}

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
    dir: PathBuf,
    plan: Plan,
    model: Imported,
    layout: Layout,
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
        let (dir, plan) = (&self.dir, &self.plan);
        let mut given = Given::default();
        for spec in &plan.shards {
            let path = shard_path(dir, plan, spec.index);
            let shard = match read_shard(&path, plan, spec.index) {
                Ok(s) => s,
                Err(e) => {
                    redo(spec.index, &e);
                    self.make(spec, progress)?;
                    read_shard(&path, plan, spec.index)?
                }
            };
            let (file, (lods, done)) = shard;
            let f = given.files.len();
            given.files.push(file);
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
            Role::Merge { given: &mut given },
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

/// Writes a shard file as its nodes' LODs come (only one node's are held),
/// then the index of where each node's lie and the roots' [`Done`]:
///
/// - header: [`SHARD_MAGIC`], the plan id, the shard index (u32), the
///   node count (u32);
/// - per node, in the order they were made: its LOD count (u32), then
///   per LOD its error (f32) and mesh;
/// - the trailer: the node count again, per node its index (u32) and
///   the byte range of its LODs (two u64); the root count, per root its
///   index, its levels (count, then error and mesh each) and its full
///   detail (flag u8, then the mesh);
/// - where the trailer starts (u64), and the CRC-32 of every byte before.
///
/// Written to a temporary file and renamed into place when whole.
struct ShardWriter {
    path: PathBuf,
    out: std::io::BufWriter<gigawalk_scene::TempFile>,
    crc: crc32fast::Hasher,
    pos: u64,
    /// The current node's LODs, encoded.
    node: Put,
    count: usize,
    index: Put,
    nodes: u64,
}

impl ShardWriter {
    fn create(path: &Path, plan: &Plan, index: usize, nodes: u64) -> Result<Self, ShardError> {
        let tmp = gigawalk_scene::temp_file_for(path).map_err(io(path))?;
        let mut w = ShardWriter {
            path: path.to_path_buf(),
            out: std::io::BufWriter::with_capacity(1 << 20, tmp),
            crc: crc32fast::Hasher::new(),
            pos: 0,
            node: Put(Vec::new()),
            count: 0,
            index: Put(Vec::new()),
            nodes: 0,
        };
        let mut h = Put(Vec::new());
        h.0.extend_from_slice(SHARD_MAGIC);
        h.0.extend_from_slice(plan.id.as_bytes());
        h.len(index);
        h.len(nodes as usize);
        w.write(&h.0).map_err(io(path))?;
        w.index.len(nodes as usize);
        Ok(w)
    }

    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        use std::io::Write as _;
        self.out.write_all(bytes)?;
        self.crc.update(bytes);
        self.pos += bytes.len() as u64;
        Ok(())
    }

    /// The trailer and checksum, then the rename into place.
    fn finish(mut self, roots: &[(u32, Done)]) -> Result<(), ShardError> {
        let path = self.path.clone();
        let trailer_at = self.pos;
        let mut t = std::mem::replace(&mut self.index, Put(Vec::new()));
        t.len(roots.len());
        for (ni, d) in roots {
            t.u32(*ni);
            t.len(d.levels.len());
            for l in &d.levels {
                t.f32(l.error);
                t.work_mesh(&l.mesh);
            }
            match &d.full {
                None => t.u8(0),
                Some(m) => {
                    t.u8(1);
                    t.work_mesh(m);
                }
            }
        }
        t.0.extend_from_slice(&trailer_at.to_le_bytes());
        self.write(&t.0).map_err(io(&path))?;
        let crc = self.crc.clone().finalize();
        self.write(&crc.to_le_bytes()).map_err(io(&path))?;
        let tmp = self
            .out
            .into_inner()
            .map_err(|e| io(&path)(e.into_error()))?;
        tmp.as_file().sync_all().map_err(io(&path))?;
        tmp.persist(&path).map_err(io(&path))
    }
}

impl crate::LodSink for ShardWriter {
    type Error = ShardError;
    fn add_lod(&mut self, mesh: &LodMesh, error: f32) -> Result<u32, ShardError> {
        self.node.f32(error);
        self.node.lod_mesh(mesh);
        self.count += 1;
        Ok(0)
    }
    fn node_done(&mut self, node: u32) -> Result<(), ShardError> {
        let start = self.pos;
        let mut c = Put(Vec::new());
        c.len(self.count);
        let body = std::mem::replace(&mut self.node, Put(Vec::new()));
        let path = self.path.clone();
        self.write(&c.0).map_err(io(&path))?;
        self.write(&body.0).map_err(io(&path))?;
        self.index.u32(node);
        self.index.0.extend_from_slice(&start.to_le_bytes());
        self.index.0.extend_from_slice(&self.pos.to_le_bytes());
        self.count = 0;
        self.nodes += 1;
        Ok(())
    }
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

// ---- shard files ----

struct Put(Vec<u8>);

impl Put {
    fn u8(&mut self, v: u8) {
        self.0.push(v);
    }
    fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn len(&mut self, n: usize) {
        self.u32(u32::try_from(n).expect("a shard's arrays fit in u32"));
    }
    fn dvec3(&mut self, v: DVec3) {
        self.f64(v.x);
        self.f64(v.y);
        self.f64(v.z);
    }
    fn vec3s(&mut self, v: &[[f32; 3]]) {
        self.len(v.len());
        for p in v {
            p.iter().for_each(|&x| self.f32(x));
        }
    }
    fn rgba(&mut self, v: &[[u8; 4]]) {
        self.len(v.len());
        for c in v {
            self.0.extend_from_slice(c);
        }
    }
    fn u32s(&mut self, v: &[u32]) {
        self.len(v.len());
        v.iter().for_each(|&x| self.u32(x));
    }
    fn lod_mesh(&mut self, m: &LodMesh) {
        self.dvec3(m.origin);
        self.vec3s(&m.positions);
        self.vec3s(&m.normals);
        match &m.colours {
            Colours::Uniform(c) => {
                self.u8(0);
                self.0.extend_from_slice(c);
            }
            Colours::PerVertex(v) => {
                self.u8(1);
                self.rgba(v);
            }
        }
        self.u32s(&m.indices);
    }
    fn work_mesh(&mut self, m: &WorkMesh) {
        self.dvec3(m.origin);
        self.vec3s(&m.positions);
        self.vec3s(&m.normals);
        self.rgba(&m.colours);
        self.u32s(&m.indices);
    }
}

/// A bounds-checked reader; every failure is a message, never a panic.
struct Get<'a> {
    b: &'a [u8],
}

type R<T> = Result<T, String>;

impl<'a> Get<'a> {
    fn take(&mut self, n: usize) -> R<&'a [u8]> {
        if n > self.b.len() {
            return Err(format!(
                "ends early ({n} bytes wanted, {} left)",
                self.b.len()
            ));
        }
        let (h, t) = self.b.split_at(n);
        self.b = t;
        Ok(h)
    }
    fn u8(&mut self) -> R<u8> {
        Ok(self.take(1)?[0])
    }
    fn u32(&mut self) -> R<u32> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().map_err(|_| "u32")?,
        ))
    }
    fn f32(&mut self) -> R<f32> {
        Ok(f32::from_le_bytes(
            self.take(4)?.try_into().map_err(|_| "f32")?,
        ))
    }
    fn f64(&mut self) -> R<f64> {
        Ok(f64::from_le_bytes(
            self.take(8)?.try_into().map_err(|_| "f64")?,
        ))
    }
    fn u64(&mut self) -> R<u64> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().map_err(|_| "u64")?,
        ))
    }
    /// A length, checked against the bytes left (`each` bytes an item).
    fn len(&mut self, each: usize) -> R<usize> {
        let n = self.u32()? as usize;
        if n.saturating_mul(each) > self.b.len() {
            return Err(format!("an array of {n} items runs past the end"));
        }
        Ok(n)
    }
    fn dvec3(&mut self) -> R<DVec3> {
        Ok(DVec3::new(self.f64()?, self.f64()?, self.f64()?))
    }
    fn vec3s(&mut self) -> R<Vec<[f32; 3]>> {
        let n = self.len(12)?;
        (0..n)
            .map(|_| Ok([self.f32()?, self.f32()?, self.f32()?]))
            .collect()
    }
    fn rgba(&mut self) -> R<Vec<[u8; 4]>> {
        let n = self.len(4)?;
        (0..n)
            .map(|_| Ok(self.take(4)?.try_into().map_err(|_| "rgba")?))
            .collect()
    }
    fn u32s(&mut self) -> R<Vec<u32>> {
        let n = self.len(4)?;
        (0..n).map(|_| self.u32()).collect()
    }
    fn lod_mesh(&mut self) -> R<LodMesh> {
        let origin = self.dvec3()?;
        let positions = self.vec3s()?;
        let normals = self.vec3s()?;
        let colours = match self.u8()? {
            0 => Colours::Uniform(self.take(4)?.try_into().map_err(|_| "rgba")?),
            1 => Colours::PerVertex(self.rgba()?),
            k => return Err(format!("colour kind {k}")),
        };
        let indices = self.u32s()?;
        check_mesh(positions.len(), normals.len(), &indices)?;
        Ok(LodMesh {
            origin,
            positions,
            normals,
            colours,
            indices,
        })
    }
    /// One node's LODs, as `Put::node_lods` wrote them.
    fn node_lods(&mut self) -> R<Vec<(LodMesh, f32)>> {
        let n = self.len(8)?;
        (0..n)
            .map(|_| {
                let e = self.f32()?;
                Ok((self.lod_mesh()?, e))
            })
            .collect()
    }
    fn work_mesh(&mut self) -> R<WorkMesh> {
        let origin = self.dvec3()?;
        let positions = self.vec3s()?;
        let normals = self.vec3s()?;
        let colours = self.rgba()?;
        let indices = self.u32s()?;
        check_mesh(positions.len(), normals.len(), &indices)?;
        if colours.len() != positions.len() {
            return Err("colours and positions differ in number".into());
        }
        Ok(WorkMesh {
            origin,
            positions,
            normals,
            colours,
            indices,
        })
    }
}

fn check_mesh(positions: usize, normals: usize, indices: &[u32]) -> R<()> {
    if normals != positions {
        return Err("normals and positions differ in number".into());
    }
    if !indices.len().is_multiple_of(3) || indices.iter().any(|&i| i as usize >= positions) {
        return Err("indices out of range".into());
    }
    Ok(())
}

/// Where each node's LODs lie in a shard file, and its roots' [`Done`].
type ShardIndex = (HashMap<u32, std::ops::Range<usize>>, HashMap<u32, Done>);

/// Shard `index`'s output at `path`, checked against the plan (every byte
/// read, a piece at a time, and its checksum verified; only the trailer is
/// kept); the open file, for reading the LODs again where the index says.
fn read_shard(
    path: &Path,
    plan: &Plan,
    index: usize,
) -> Result<(std::fs::File, ShardIndex), ShardError> {
    use std::io::Read as _;
    use std::os::unix::fs::FileExt as _;
    let corrupt = |reason: String| ShardError::Corrupt {
        path: path.to_path_buf(),
        reason,
    };
    let file = std::fs::File::open(path).map_err(io(path))?;
    let len = file.metadata().map_err(io(path))?.len();
    if len < 12 {
        return Err(corrupt("too short".into()));
    }
    let mut crc = crc32fast::Hasher::new();
    let mut left = len - 4;
    let mut r = std::io::BufReader::with_capacity(1 << 20, &file);
    let mut buf = vec![0u8; 1 << 20];
    while left > 0 {
        let n = left.min(buf.len() as u64) as usize;
        r.read_exact(&mut buf[..n]).map_err(io(path))?;
        crc.update(&buf[..n]);
        left -= n as u64;
    }
    let mut tail = [0u8; 12];
    file.read_exact_at(&mut tail, len - 12).map_err(io(path))?;
    if crc.finalize() != u32::from_le_bytes([tail[8], tail[9], tail[10], tail[11]]) {
        return Err(corrupt("checksum mismatch".into()));
    }
    let trailer_at = u64::from_le_bytes(tail[..8].try_into().map_err(|_| corrupt("u64".into()))?);
    let head_len = SHARD_MAGIC.len() + plan.id.len() + 8;
    if trailer_at < head_len as u64 || trailer_at > len - 12 {
        return Err(corrupt(format!(
            "trailer at {trailer_at}, the file has {len} bytes"
        )));
    }
    let mut head = vec![0u8; head_len];
    file.read_exact_at(&mut head, 0).map_err(io(path))?;
    let mut trailer = vec![0u8; (len - 12 - trailer_at) as usize];
    file.read_exact_at(&mut trailer, trailer_at)
        .map_err(io(path))?;
    let index = decode_shard(&head, &trailer, trailer_at, plan, index).map_err(corrupt)?;
    Ok((file, index))
}

/// One node's LODs from a shard file checked by [`read_shard`], at the
/// range its index gave.
pub(crate) fn read_node_lods(
    file: &mut std::fs::File,
    range: std::ops::Range<usize>,
) -> Result<Vec<(LodMesh, f32)>, String> {
    use std::io::{Read as _, Seek as _};
    let mut bytes = vec![0u8; range.len()];
    file.seek(std::io::SeekFrom::Start(range.start as u64))
        .and_then(|_| file.read_exact(&mut bytes))
        .map_err(|e| format!("cannot read a shard file again: {e}"))?;
    let mut g = Get { b: &bytes };
    let lods = g.node_lods()?;
    if !g.b.is_empty() {
        return Err("a node's LODs do not fill their range".into());
    }
    Ok(lods)
}

/// A shard file's header and trailer (at `trailer_at`), checked against
/// the plan: where each node's LODs lie, and the roots' [`Done`].
fn decode_shard(
    head: &[u8],
    trailer: &[u8],
    trailer_at: u64,
    plan: &Plan,
    index: usize,
) -> R<ShardIndex> {
    let mut g = Get { b: head };
    if g.take(SHARD_MAGIC.len())? != SHARD_MAGIC {
        return Err("not a shard file".into());
    }
    if g.take(plan.id.len())? != plan.id.as_bytes() {
        return Err("made for another plan".into());
    }
    if g.u32()? as usize != index {
        return Err(format!("not shard {index}'s"));
    }
    let spec = plan.shards.get(index).ok_or("no such shard in the plan")?;
    let nodes = g.u32()? as u64;
    let mut g = Get { b: trailer };
    if nodes != spec.nodes || g.u32()? as u64 != nodes {
        return Err(format!("{nodes} nodes, the plan says {}", spec.nodes));
    }
    let mut lods = HashMap::with_capacity(nodes as usize);
    let mut at = head.len() as u64;
    for _ in 0..nodes {
        let ni = g.u32()?;
        let (start, end) = (g.u64()?, g.u64()?);
        // Nodes lie one after another, up to the trailer.
        if start != at || end < start.saturating_add(4) || end > trailer_at {
            return Err(format!("node {ni}'s LODs at {start}..{end}"));
        }
        at = end;
        if lods.insert(ni, start as usize..end as usize).is_some() {
            return Err(format!("node {ni} twice"));
        }
    }
    if at != trailer_at {
        return Err("the nodes' LODs do not reach the trailer".into());
    }
    let roots = g.len(9)?;
    let mut done = HashMap::with_capacity(roots);
    for _ in 0..roots {
        let ni = g.u32()?;
        let n = g.len(8)?;
        let levels = (0..n)
            .map(|_| {
                let error = g.f32()?;
                Ok(Lod {
                    mesh: g.work_mesh()?,
                    error,
                })
            })
            .collect::<R<Vec<_>>>()?;
        let full = match g.u8()? {
            0 => None,
            1 => Some(g.work_mesh()?),
            k => return Err(format!("full-detail flag {k}")),
        };
        done.insert(ni, Done { levels, full });
    }
    if !g.b.is_empty()
        || spec.roots.iter().any(|r| !done.contains_key(r))
        || done.len() != spec.roots.len()
    {
        return Err("its roots are not the plan's".into());
    }
    Ok((lods, done))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_shard_file_round_trips_and_every_flipped_byte_is_caught() {
        let mesh = WorkMesh {
            origin: DVec3::new(1e7, -2.5, 0.125),
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, f32::MIN_POSITIVE],
            ],
            normals: vec![[0.0, 0.0, 1.0]; 3],
            colours: vec![[1, 2, 3, 255]; 3],
            indices: vec![0, 1, 2],
        };
        let plan = Plan {
            format: FORMAT.into(),
            version: PLAN_VERSION,
            revision: REVISION,
            id: "0123456789abcdef0123456789abcdef".into(),
            source: "m.glb".into(),
            inputs: Vec::new(),
            params: Params::default(),
            shard_triangles: 10,
            nodes: 3,
            triangles: 2,
            shards: vec![ShardSpec {
                index: 0,
                roots: vec![1],
                nodes: 2,
                triangles: 2,
            }],
        };
        let lods: Vec<(u32, Vec<(LodMesh, f32)>)> = vec![
            (
                1,
                vec![(mesh.to_lod_mesh(), 0.5), (mesh.to_lod_mesh(), 1.5)],
            ),
            (2, vec![]),
        ];
        let done = vec![(
            1,
            Done {
                levels: vec![Lod {
                    mesh: mesh.clone(),
                    error: 0.25,
                }],
                full: Some(mesh.clone()),
            },
        )];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.bin");
        let mut w = ShardWriter::create(&path, &plan, 0, 2).unwrap();
        for (ni, l) in &lods {
            for (m, e) in l {
                crate::LodSink::add_lod(&mut w, m, *e).unwrap();
            }
            crate::LodSink::node_done(&mut w, *ni).unwrap();
        }
        w.finish(&done).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let (mut file, (l, d)) = read_shard(&path, &plan, 0).unwrap();
        assert_eq!(read_node_lods(&mut file, l[&1].clone()).unwrap(), lods[0].1);
        assert!(read_node_lods(&mut file, l[&2].clone()).unwrap().is_empty());
        assert!(read_node_lods(&mut file, l[&1].start..l[&1].end - 1).is_err());
        assert_eq!(d[&1], done[0].1);
        let check = |b: &[u8], plan: &Plan, index: usize| {
            std::fs::write(dir.path().join("t.bin"), b).unwrap();
            read_shard(&dir.path().join("t.bin"), plan, index).map(|_| ())
        };
        for i in (0..bytes.len()).step_by(7) {
            let mut b = bytes.clone();
            b[i] ^= 0x10;
            assert!(check(&b, &plan, 0).is_err(), "byte {i}");
        }
        for cut in [0, 11, bytes.len() / 2, bytes.len() - 1] {
            assert!(check(&bytes[..cut], &plan, 0).is_err(), "cut at {cut}");
        }
        assert!(check(&bytes, &plan, 1).is_err());
        let other = Plan {
            id: "ffffffffffffffffffffffffffffffff".into(),
            ..plan.clone()
        };
        assert!(check(&bytes, &other, 0).is_err());
    }
}
