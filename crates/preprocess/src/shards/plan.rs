//! The plan of a split build: the hierarchy cut into whole subtrees by
//! triangle count and packed into shards, and the identity of what it was
//! made from (a hash of the input files, the parameters, the shard size
//! and the revision), written to `DIR/plan.json`. Every later job reads
//! it back and checks the inputs and the model's layout against it, so a
//! changed input is refused rather than mixed in.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::run::Planned;
use super::{io, ShardError, PLAN_FILE};
use crate::source::{Imported, Source};
use crate::{Layout, Params, PreprocessError, Progress, REVISION};

pub(super) const FORMAT: &str = "gigawalk-preprocess-plan";
pub(super) const PLAN_VERSION: u32 = 1;

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
fn cut(layout: &Layout, limit: u64) -> Vec<ShardSpec> {
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

/// The plan's model, refused if any input changed since the plan: the
/// work directory's spill of it ([`spill_path`]), made now if it is not
/// there (or not whole), read through a cache sized by `budget`.
pub(super) fn import_planned(
    plan: &Plan,
    dir: &Path,
    budget: Option<u64>,
) -> Result<Imported, ShardError> {
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
pub(super) fn planned_layout(
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
