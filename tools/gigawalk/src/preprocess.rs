//! `gigawalk preprocess`: model -> scene file. Argument parsing, progress
//! display and the stats table; the work is in gigawalk-preprocess.

use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use anyhow::Context as _;
use gigawalk_preprocess::{preprocess, shards, LeafChains, Params, Phase, PositionBits, Progress};
use gigawalk_scene::{SceneReader, SceneStats};
use indicatif::{ProgressBar, ProgressStyle};

#[derive(clap::Args)]
pub struct Args {
    /// Input model: glTF 2.0 (.gltf, .glb) or Wavefront OBJ (.obj) files, or directories of them (searched recursively, in path order), all made into one model; with several files each object's name starts with its file's path
    #[arg(num_args = 1.., value_name = "MODEL", required_unless_present_any = ["shard", "merge"], conflicts_with_all = ["shard", "merge"])]
    input: Vec<PathBuf>,
    /// Output scene file (.gwk), written atomically: nothing appears on failure
    #[arg(short, long, required_unless_present_any = ["shard", "plan_only"], conflicts_with = "shard")]
    output: Option<PathBuf>,
    /// Split the build into shards kept in this directory (plan.json, the model's spill and one file per shard, docs/preprocess.md "Split builds"): a rerun with the same inputs and parameters redoes only the shards that did not finish, and any number of machines sharing the directory may run them
    #[arg(long, value_name = "DIR")]
    work_dir: Option<PathBuf>,
    /// With --work-dir and MODEL: write DIR/plan.json and print the number of shards N on stdout, nothing else (-o may be given and is not written: --merge writes it)
    #[arg(long, requires = "work_dir", conflicts_with_all = ["shard", "merge"])]
    plan_only: bool,
    /// With --work-dir: run shard K of DIR's plan (0 <= K < N; nothing to do when its output is there and valid)
    #[arg(
        long,
        value_name = "K",
        requires = "work_dir",
        conflicts_with = "merge"
    )]
    shard: Option<usize>,
    /// With --work-dir and -o: finish the scene from DIR's shards (making any that are missing or corrupt)
    #[arg(long, requires = "work_dir")]
    merge: bool,
    /// Worker processes for the shards (each a `gigawalk preprocess --shard K`); above 1 the build is split (in --work-dir, or a temporary directory beside the output). The scene is the same bytes at any count. One process already uses every core, so on one machine this is slower (1.10x on the 10M plant, 2 cores): it is for resumable runs and for trying a split before a cluster runs it
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=256))]
    jobs: u32,
    /// Triangles per shard of a split build (e.g. 500k, 2M): how the work splits depends on the model and this only, never on --jobs
    #[arg(long, default_value = "1M", value_parser = crate::generate::parse_count)]
    shard_triangles: u64,
    /// Memory the run may use, besides a fixed 60-110 MiB: all (hold the whole model in memory), auto (half the machine's memory, at most 2G) or a size such as 512M or 4G. A model whose objects would take more than 40% of it (or the process more than 50%) is written to an unnamed spill file beside the output as it is read, and read back an object at a time; split builds keep one spill in --work-dir for every worker. Threads and --jobs workers are capped by it too. Levels are made 65,536 triangles at a time whatever the budget, and the scene is the same bytes at any budget (docs/preprocess.md "Memory")
    #[arg(long, default_value = "auto", value_name = "all|auto|BYTES")]
    memory_budget: gigawalk_runtime::MemoryBudget,
    /// Also write the run's statistics as JSON to this file
    #[arg(long)]
    stats: Option<PathBuf>,
    /// Partition-I: split objects with more triangles than this (paper 4.2.1, 6.3.1: t1 = 1000)
    #[arg(long, default_value_t = Params::default().t1)]
    t1: u32,
    /// Partition-I: ...and a box diagonal above this fraction of the model's diagonal (6.3.1: s1 = 0.1 x model size)
    #[arg(long, default_value_t = Params::default().s1)]
    s1: f64,
    /// Partition-I: ...or a box aspect ratio (largest/smallest side) above this (6.3.1: r1 = 2.5)
    #[arg(long, default_value_t = Params::default().r1)]
    r1: f64,
    /// Clustering: objects closer than this fraction of the largest object box dimension share an edge (4.2.2, 6.3.1: D = 0.1 x max box dimension)
    #[arg(long, default_value_t = Params::default().d)]
    d: f64,
    /// Clustering: largest cluster box volume as a fraction of the scene box volume (6.3.1: V = 1e-3 x scene volume)
    #[arg(long, default_value_t = Params::default().v)]
    v: f64,
    /// Clustering: the cluster volume is also at most what N triangles fill at the model's mean density (scene volume x N / triangles), so clusters and leaves near the eye stay the same as the model grows; 4000 binds above 4M triangles, where it is --v's default; 0: --v alone (the paper)
    #[arg(long, value_name = "N", default_value_t = Params::default().v_triangles.unwrap_or(0))]
    v_triangles: u64,
    /// Clustering: Felzenszwalb-Huttenlocher K, in thousandths of D (6.3.1: K = 1500; see docs/preprocess.md for the units)
    #[arg(long, default_value_t = Params::default().k)]
    k: f64,
    /// Partition-II triangle threshold as a multiple of t1 (4.2.3; the paper's 6.3.1 uses 10). Default 1: long clusters near the eye would draw their full detail far away too
    #[arg(long, default_value_t = Params::default().t2_factor)]
    t2_factor: f64,
    /// Partition-II size threshold as a multiple of s1 (6.3.1: s2 = 2 s1)
    #[arg(long, default_value_t = Params::default().s2_factor)]
    s2_factor: f64,
    /// Partition-II aspect threshold as a multiple of r1 (6.3.1: r2 = 0.5 r1)
    #[arg(long, default_value_t = Params::default().r2_factor)]
    r2_factor: f64,
    /// LODs (4.3): each level aims for this fraction of the previous level's triangles (and keeps at most 65% of them, so at most 0.65); 0.4-0.6 drew the same triangles on the 4M plant with one collapse level, 0.35 draws a little more with the defaults
    #[arg(long, default_value_t = Params::default().lod_ratio)]
    lod_ratio: f64,
    /// LODs (4.3): a chain stops once a level has at most this many triangles (16 drew 1-2% fewer triangles on the 4M and 20M plants at 1 px for 12-20% more bound-violating pixels)
    #[arg(long, default_value_t = Params::default().lod_floor)]
    lod_floor: u32,
    /// LODs (4.3): simplified levels 1..=N of every chain use edge collapse (meshopt simplify), coarser ones sloppy vertex clustering (1 draws 20% more triangles on the 4M plant at 1 px, in about the same preprocess time)
    #[arg(long, default_value_t = Params::default().collapse_levels)]
    collapse_levels: u32,
    /// LODs (4.3): kept: a leaf's chain keeps a triangle of every piece a level makes vanish. best: a second chain covers vanished pieces per error-sized cell as an inner node's does, and the one that draws fewer triangles over the distances the leaf may be seen from is kept (real-CAD floor: 0.90x the triangles drawn at 1 px for 1.55x the preprocess time; generated plant: 0.97x for 1.27x)
    #[arg(long, value_enum, default_value_t = LeafChainsArg::Kept)]
    leaf_chains: LeafChainsArg,
    /// LODs and HLODs (4.3): on: beside every chain, merged proxies (watertight shells of the geometry's distance field at an offset of a cell, on cells of 1/8 to 1/128 of the node, simplified) are measured as every level is, and kept where they draw fewer triangles at a lower error; they merge the small, thin, disjoint parts that edge collapse cannot (docs/preprocess.md, "Merged proxies"; on two floors of real CAD 0.97x and 0.94x the triangles drawn at 1 px for 1.6x and 4.5x the preprocess time, so not the default). off: the chains alone
    #[arg(long, value_enum, default_value_t = OnOff::Off)]
    proxies: OnOff,
    /// LODs and HLODs (4.3), with --proxies on: the finest proxies' cells across a node's longest side; proxies are tried on 8, 16, ... up to this many (8-128). Each halving of the cell costs about 4x the last: on a held-out real-CAD floor 32 drew 0.983x the triangles for 1.70x the preprocess time, 64 0.973x for 2.98x, 128 0.942x for 4.5x (docs/results.md, "The far field on real CAD")
    #[arg(long, default_value_t = Params::default().proxy_cells)]
    proxy_cells: u32,
    /// HLODs (4.3): triangles of an inner node's finest HLOD; its children are cut at a matching error and merged to about this / lod-ratio, then simplified to it (with one collapse level, 512 drew 8% and 10% fewer triangles than 1024 at 1 px on the 4M and 20M plants, in a 1.2x smaller scene)
    #[arg(long, default_value_t = Params::default().node_budget)]
    node_budget: u32,
    /// LOD errors: each stored error is a measured bound on the Hausdorff distance to the full-detail surface; samples cover each surface to this fraction of the distance found. Tighter errors draw fewer triangles at a tolerance and cost preprocess time (4M plant: 0.1 = -2.4% triangles at 1 px, +19% time; 0.5 = +7.6%, -7%; docs/results.md)
    #[arg(long, default_value_t = Params::default().bound_spacing)]
    bound_spacing: f64,
    /// LOD errors: the finest sample cover, as a fraction of the node's box diagonal
    #[arg(long, default_value_t = Params::default().bound_floor)]
    bound_floor: f64,
    /// Object-space culling (ct): levels of the view-cell kD-tree over the eye's space (Coorg and Teller 3.1: 8, about 250 cells); 0: one cell
    #[arg(long, default_value_t = Params::default().cell_height)]
    cell_height: u32,
    /// Object-space culling (ct): occluders listed per view cell and direction, best first by the area-angle metric (paper: 32)
    #[arg(long, default_value_t = Params::default().cell_occluders)]
    cell_occluders: u32,
    /// Object-space culling (ct): view directions per cell: 4, 8 (the paper's count) or 16 around the up axis (+Y, glTF's), or 6, 14 or 26 over the whole sphere
    #[arg(long, default_value_t = Params::default().cell_directions)]
    cell_directions: u32,
    /// Storage: each LOD's positions on a grid of this many bits per axis over its own box (8-24), meshopt-encoded with its normals, colours and indices; each LOD's stored error grows by the farthest any of its vertices moved (16 bits: 1/65535 of the box). f32: raw f32 positions, nothing encoded or compressed (format 1's layout: 59.2 MiB on the 1M plant against 13.3 MiB with the defaults)
    #[arg(long, value_name = "BITS|f32", default_value_t = Params::default().position_bits)]
    position_bits: PositionBits,
    /// Storage: bits of each octahedral normal coordinate of encoded LODs: 8 (within 0.93 degrees, 0.34 on average; on the 1M plant's walk no channel of a full-detail frame moved by more than 2 of 255 against 16 bits, for a 12% smaller scene) or 16 (within 0.004 degrees)
    #[arg(long, value_name = "16|8", default_value_t = Params::default().normal_bits)]
    normal_bits: u8,
    /// Storage: zstd over each encoded LOD after meshopt's codecs, with a dictionary trained on the scene's first 4 MB of them and stored once (on the 1M plant the scene is 0.66x the size without; reading costs the decompression), or none
    #[arg(long, value_enum, default_value_t = Compression::Zstd)]
    compress: Compression,
}

/// `--leaf-chains`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum LeafChainsArg {
    Kept,
    Best,
}

/// `--proxies`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum OnOff {
    On,
    Off,
}

/// `--compress`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum Compression {
    Zstd,
    None,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let params = Params {
        t1: args.t1,
        s1: args.s1,
        r1: args.r1,
        d: args.d,
        v: args.v,
        v_triangles: (args.v_triangles > 0).then_some(args.v_triangles),
        k: args.k,
        t2_factor: args.t2_factor,
        s2_factor: args.s2_factor,
        r2_factor: args.r2_factor,
        lod_ratio: args.lod_ratio,
        lod_floor: args.lod_floor,
        collapse_levels: args.collapse_levels,
        node_budget: args.node_budget,
        bound_spacing: args.bound_spacing,
        bound_floor: args.bound_floor,
        cell_height: args.cell_height,
        cell_occluders: args.cell_occluders,
        cell_directions: args.cell_directions,
        position_bits: args.position_bits,
        normal_bits: args.normal_bits,
        compress: args.compress == Compression::Zstd,
        leaf_chains: match args.leaf_chains {
            LeafChainsArg::Kept => LeafChains::Kept,
            LeafChainsArg::Best => LeafChains::Best,
        },
        proxies: args.proxies == OnOff::On,
        proxy_cells: args.proxy_cells,
    };
    // Bad flags fail before the (possibly long) import.
    params.validate().context("bad parameter")?;

    let progress = Display::new();
    let budget = preprocess_budget(args.memory_budget)?;
    if let Some(b) = budget {
        threads_within(b, &progress);
    }
    if let Some(dir) = &args.work_dir {
        if let Some(k) = args.shard {
            let t = Instant::now();
            let done = shards::run_shard(dir, k, budget, &progress)
                .with_context(|| format!("shard {k} of {}", dir.display()))?;
            progress.line(&match done {
                shards::ShardRun::Made => format!(
                    "shard {k} done in {:.1} s, {PEAK}{}",
                    t.elapsed().as_secs_f64(),
                    mib(gigawalk_preprocess::stats::peak_memory_bytes().unwrap_or(0))
                ),
                shards::ShardRun::AlreadyDone => format!("shard {k} was already done"),
            });
            return Ok(());
        }
    }
    let output = args.output.clone().unwrap_or_default();
    let inputs = args
        .input
        .iter()
        .map(|p| p.display().to_string())
        .collect::<Vec<_>>()
        .join(" ");
    let split = args.work_dir.is_some() || args.jobs > 1;
    let (mut stats, files) = if split {
        match split_build(&args, &params, &inputs, &output, budget, &progress)? {
            Some(built) => built,
            None => return Ok(()), // --plan-only
        }
    } else {
        single_build(&args.input, &inputs, &params, &output, budget, &progress)?
    };
    stats.input_file_bytes = files
        .iter()
        .map(|f| std::fs::metadata(f).map_or(0, |m| m.len()))
        .sum();
    stats.finish();
    if let (Some(b), Some(p)) = (budget, stats.peak_memory_bytes) {
        if p > b.saturating_add(FIXED_MEMORY) {
            eprintln!(
                "warning: peak memory {} is over the memory budget {} plus the run's fixed {}: \
                 what stays in memory whatever the budget is each input file's glTF document \
                 and 4-8 bytes a triangle of bookkeeping (docs/preprocess.md \"Memory\")",
                mib(p),
                mib(b),
                mib(FIXED_MEMORY)
            );
        }
    }

    // The LOD structure's health, from the file as a reader sees it. The
    // scene is written either way: a failure to read it back is said, not
    // fatal.
    let scene = match SceneReader::open(&output) {
        Ok(r) => Some(SceneStats::of(&r)),
        Err(e) => {
            eprintln!("warning: cannot read back the scene to check its LODs: {e}");
            None
        }
    };

    // Files first: a reader that closes standard output early must not
    // cost the stats file.
    if let Some(path) = &args.stats {
        // The run's statistics and, read back from the scene file, its
        // leaf floor and switch factors (as `gigawalk info` has them; null
        // when the scene could not be read back). Through a JSON value, so
        // the keys come out sorted.
        let mut file = serde_json::to_value(&stats).context("cannot encode the stats")?;
        if let Some(o) = file.as_object_mut() {
            let health = scene.as_ref();
            o.insert(
                "leaf_floor_triangles".into(),
                health.map(|s| s.leaf_floor_triangles).into(),
            );
            o.insert(
                "switch_factors".into(),
                serde_json::to_value(health.map(|s| &s.switch_factors))
                    .context("cannot encode the switch factors")?,
            );
        }
        let json = serde_json::to_string_pretty(&file).context("cannot encode the stats")?;
        gigawalk_scene::write_atomic(path, (json + "\n").as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    crate::write_stdout(format_args!("{}", stats.table()), false)?;
    if let Some(s) = &scene {
        out!(
            "leaf floor        {} triangles (every leaf at its coarsest LOD)",
            s.leaf_floor_triangles
        )?;
        let f = &s.switch_factors;
        out!(
            "switch factors    median {:.2}, p90 {:.2}, max {:.2}; {} of {} inner nodes above 8 (gigawalk info: the worst)",
            f.median,
            f.p90,
            f.max,
            f.over_8,
            f.count
        )?;
    }
    if stats.input_file_bytes > 0 {
        out!(
            "input file        {:.1} MiB; scene / input file = {:.2}x",
            stats.input_file_bytes as f64 / (1024.0 * 1024.0),
            stats.output_bytes as f64 / stats.input_file_bytes.max(1) as f64
        )?;
    }
    out!("wrote {}", output.display())?;
    Ok(())
}

/// Import and build in this process (no shards).
fn single_build(
    input: &[PathBuf],
    inputs: &str,
    params: &Params,
    output: &Path,
    budget: Option<u64>,
    progress: &Display,
) -> anyhow::Result<(gigawalk_preprocess::Stats, Vec<PathBuf>)> {
    let t = Instant::now();
    let files =
        gigawalk_import::model_files(input).with_context(|| format!("cannot import {inputs}"))?;
    let model = gigawalk_preprocess::source::import_within(
        &files,
        budget,
        output_dir(output),
        &mut |i, n, path| {
            progress.line(&match n {
                1 => format!("importing {}", path.display()),
                _ => format!("importing {}/{n}: {}", i + 1, path.display()),
            })
        },
    )
    .with_context(|| format!("cannot import {inputs}"))?;
    let import_secs = t.elapsed().as_secs_f64();
    let import_stats = model.stats().clone();
    let spilled = model.spilled_bytes();
    progress.line(&format!(
        "import: {} objects, {} triangles ({} degenerate dropped) in {import_secs:.2} s, {}",
        model.source().len(),
        import_stats.triangles - import_stats.degenerate_triangles_dropped,
        import_stats.degenerate_triangles_dropped,
        match spilled {
            0 => format!("in memory, {PEAK}{}", mib(peak_memory())),
            b => format!(
                "spilled to disk ({}: the objects would take over {:.0}% of the memory budget, or the process over {:.0}%), {PEAK}{}",
                mib(b),
                100.0 * gigawalk_preprocess::source::MEMORY_SHARE,
                100.0 * gigawalk_preprocess::source::RESIDENT_SHARE,
                mib(peak_memory())
            ),
        }
    ));
    for w in &import_stats.warnings {
        tracing::warn!("{w}");
    }
    let import_dropped = import_stats.degenerate_triangles_dropped;
    let mut stats = preprocess(model.source(), params, output, inputs, progress)
        .with_context(|| format!("cannot preprocess {inputs} into {}", output.display()))?;
    stats.spilled_bytes = spilled;
    drop(model);
    stats
        .phase_seconds
        .insert(0, ("import".into(), import_secs));
    // Triangles the importer dropped never reach the preprocessor; count them too.
    stats.degenerate_dropped += import_dropped;
    stats.input_triangles += import_dropped;
    Ok((stats, files))
}

/// The directory `output` goes in.
fn output_dir(output: &Path) -> &Path {
    match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

fn peak_memory() -> u64 {
    gigawalk_preprocess::stats::peak_memory_bytes().unwrap_or(0)
}

/// The memory budget in bytes, `None` for all.
fn preprocess_budget(b: gigawalk_runtime::MemoryBudget) -> anyhow::Result<Option<u64>> {
    use gigawalk_runtime::MemoryBudget;
    Ok(match b {
        MemoryBudget::All => None,
        MemoryBudget::Bytes(n) => Some(n),
        MemoryBudget::Auto => Some(
            gigawalk_preprocess::source::auto_budget().context(
                "memory budget auto: cannot read this machine's memory size (/proc/meminfo); give a size such as 2G, or all",
            )?,
        ),
    })
}

/// A build split into shards: plan (or find the plan), run the shards not
/// done (here, or in `--jobs` worker processes), merge. Returns the
/// merge's statistics and the model files, `None` after `--plan-only`.
fn split_build(
    args: &Args,
    params: &Params,
    inputs: &str,
    output: &Path,
    budget: Option<u64>,
    progress: &Display,
) -> anyhow::Result<Option<(gigawalk_preprocess::Stats, Vec<PathBuf>)>> {
    // Without --work-dir (--jobs above 1): a temporary one beside the
    // output, removed however the run ends.
    let temp;
    let dir: &Path = match &args.work_dir {
        Some(d) => d,
        None => {
            let parent = match output.parent() {
                Some(p) if !p.as_os_str().is_empty() => p,
                _ => Path::new("."),
            };
            // Named with this process's id: should it be killed, a later
            // run removes the directory (gigawalk_scene's atomic writes).
            let prefix = gigawalk_scene::work_dir_prefix();
            temp = tempfile::Builder::new()
                .prefix(&prefix)
                .tempdir_in(parent)
                .with_context(|| format!("cannot make a work directory in {}", parent.display()))?;
            temp.path()
        }
    };
    // The model imported and laid out once for the shards run here and
    // the merge.
    let open = || {
        shards::Planned::open(dir, budget, progress)
            .with_context(|| format!("cannot read the plan and model of {}", dir.display()))
    };
    let mut planned = None;
    if !args.merge {
        let t = Instant::now();
        progress.line(&format!("planning {inputs}"));
        let here = shards::plan(
            &args.input,
            inputs,
            params,
            args.shard_triangles,
            dir,
            budget,
            progress,
        )
        .with_context(|| format!("cannot plan {inputs} in {}", dir.display()))?;
        let plan = here.plan().clone();
        let todo = shards::unfinished_shards(dir, &plan);
        progress.line(&format!(
            "plan: {} shards of at most {} triangles ({} triangles, {} nodes), {} to do, in {:.1} s: {}",
            plan.shards.len(),
            plan.shard_triangles,
            plan.triangles,
            plan.nodes,
            todo.len(),
            t.elapsed().as_secs_f64(),
            dir.join(shards::PLAN_FILE).display()
        ));
        if args.plan_only {
            crate::write_stdout(format_args!("{}\n", plan.shards.len()), false)?;
            return Ok(None);
        }
        if args.jobs <= 1 || todo.is_empty() {
            run_shards_here(&here, &todo, progress)?;
            planned = Some(here);
        } else {
            // The workers share the budget; this process holds nothing
            // meanwhile and imports the model again for the merge.
            drop(here);
            let jobs = workers_within(args.jobs, budget, progress);
            run_workers(
                dir,
                &plan,
                &todo,
                jobs,
                budget.map(|b| b / jobs as u64),
                progress,
            )?;
        }
    }
    let planned = match planned {
        Some(p) => p,
        None => open()?,
    };
    let files = planned
        .plan()
        .inputs
        .iter()
        .map(|f| f.path.clone())
        .collect();
    let t = Instant::now();
    let stats = planned
        .merge(output, progress, &mut |k, why| {
            progress.line(&format!("shard {k} is not done ({why}): making it here"))
        })
        .with_context(|| format!("cannot merge {} into {}", dir.display(), output.display()))?;
    progress.line(&format!("merge done in {:.1} s", t.elapsed().as_secs_f64()));
    Ok(Some((stats, files)))
}

/// How a finished shard reports its peak memory on stderr (the parent
/// reads it back from a worker's output).
const PEAK: &str = "peak memory ";

fn mib(bytes: u64) -> String {
    format!("{:.0} MiB", bytes as f64 / (1024.0 * 1024.0))
}

/// The run's one progress line after each shard: shards and triangles
/// done, triangles per second, time left at that rate, peak memory.
struct ShardProgress<'a> {
    plan: &'a shards::Plan,
    todo: u64,
    started: Instant,
    shards: usize,
    triangles: u64,
    worker_peak: u64,
}

impl ShardProgress<'_> {
    fn done(&mut self, k: usize, peak: Option<u64>) -> String {
        self.shards += 1;
        self.triangles += self.plan.shards[k].triangles;
        self.worker_peak = self.worker_peak.max(peak.unwrap_or(0));
        let secs = self.started.elapsed().as_secs_f64().max(1e-3);
        let rate = self.triangles as f64 / secs;
        let left = self.todo.saturating_sub(self.triangles) as f64 / rate.max(1.0);
        let own = gigawalk_preprocess::stats::peak_memory_bytes().unwrap_or(0);
        format!(
            "shards {}/{} done ({} of {} triangles), {:.0} triangles/s, {:.0} s, eta {:.0} s, {PEAK}{} (largest worker {})",
            self.shards,
            self.plan.shards.len(),
            self.triangles,
            self.todo,
            rate,
            secs,
            left,
            mib(own),
            mib(self.worker_peak)
        )
    }
}

impl<'a> ShardProgress<'a> {
    fn new(plan: &'a shards::Plan, todo: &[usize]) -> Self {
        ShardProgress {
            plan,
            todo: todo.iter().map(|&k| plan.shards[k].triangles).sum(),
            started: Instant::now(),
            shards: plan.shards.len() - todo.len(),
            triangles: 0,
            worker_peak: 0,
        }
    }
}

/// Runs shards `todo` in this process, [`SHARDS_IN_FLIGHT`] at a time on
/// the one thread pool: a shard's top nodes and its file's write run
/// with few tasks ready, and the next shard's leaves fill the cores
/// meanwhile. Stops at the first shard that fails (those in flight
/// finish); the shards done are kept, so a rerun resumes.
fn run_shards_here(
    planned: &shards::Planned,
    todo: &[usize],
    progress: &Display,
) -> anyhow::Result<()> {
    let line = std::sync::Mutex::new(ShardProgress::new(planned.plan(), todo));
    let next = std::sync::atomic::AtomicUsize::new(0);
    let failed = std::sync::atomic::AtomicBool::new(false);
    let worker = || -> anyhow::Result<()> {
        use std::sync::atomic::Ordering;
        while !failed.load(Ordering::Relaxed) {
            let Some(&k) = todo.get(next.fetch_add(1, Ordering::Relaxed)) else {
                break;
            };
            if let Err(e) = planned.run_shard(k, progress) {
                failed.store(true, Ordering::Relaxed);
                return Err(anyhow::Error::new(e).context(format!("shard {k}")));
            }
            let done = line.lock().unwrap_or_else(|e| e.into_inner()).done(k, None);
            progress.line(&done);
        }
        Ok(())
    };
    let results: Vec<anyhow::Result<()>> = std::thread::scope(|s| {
        let workers: Vec<_> = (0..SHARDS_IN_FLIGHT.min(todo.len()))
            .map(|_| s.spawn(worker))
            .collect();
        workers
            .into_iter()
            .map(|w| w.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
            .collect()
    });
    results.into_iter().collect()
}

/// Shards a process runs at once ([`run_shards_here`]): two keep the
/// cores busy through one shard's serial end; each holds its unit window
/// (a few MiB a thread) beside the other's.
const SHARDS_IN_FLIGHT: usize = 2;

/// What a run needs whatever its budget (code, threads' working sets,
/// one unit of levels): 60-110 MiB measured on the plants, 2 cores.
const FIXED_MEMORY: u64 = 128 << 20;

/// What each thread of a run needs of the budget: a unit's working set
/// and one node's chain (2 threads held 15 MiB more than one on the 2M
/// plant; twice that, for larger nodes).
const THREAD_MEMORY: u64 = 32 << 20;

/// Caps this process's threads so each has [`THREAD_MEMORY`] of `budget`
/// (unless RAYON_NUM_THREADS says how many), and says so when that is
/// fewer than the cores.
fn threads_within(budget: u64, progress: &Display) {
    if std::env::var_os("RAYON_NUM_THREADS").is_some() {
        return;
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let fit = ((budget / THREAD_MEMORY) as usize).clamp(1, cores);
    if fit < cores
        && rayon::ThreadPoolBuilder::new()
            .num_threads(fit)
            .build_global()
            .is_ok()
    {
        progress.line(&format!(
            "{fit} threads, not {cores}: the memory budget of {} gives each {}",
            mib(budget),
            mib(THREAD_MEMORY)
        ));
    }
}

/// The least memory a worker is given: what one shard of the default size
/// needs, with the model spilled (about 150 MiB measured on the plants,
/// docs/results.md "Memory").
const MIN_WORKER_BUDGET: u64 = 192 << 20;

/// `jobs`, or fewer when the budget cannot give each worker
/// [`MIN_WORKER_BUDGET`] (said on the progress line).
fn workers_within(jobs: u32, budget: Option<u64>, progress: &Display) -> u32 {
    let Some(b) = budget else {
        return jobs;
    };
    let fit = (b / MIN_WORKER_BUDGET).clamp(1, jobs as u64) as u32;
    if fit < jobs {
        progress.line(&format!(
            "{fit} workers, not {jobs}: the memory budget of {} gives each at least {}",
            mib(b),
            mib(MIN_WORKER_BUDGET)
        ));
    }
    fit
}

/// Runs shards `todo` of the plan in `dir` in `jobs` worker processes of
/// this binary at a time. The first failure stops new shards and is the
/// error, with the worker's output.
fn run_workers(
    dir: &Path,
    plan: &shards::Plan,
    todo: &[usize],
    jobs: u32,
    budget: Option<u64>,
    progress: &Display,
) -> anyhow::Result<()> {
    let line = Mutex::new(ShardProgress::new(plan, todo));
    let exe =
        std::env::current_exe().context("cannot find the gigawalk binary to start workers")?;
    let next = std::sync::atomic::AtomicUsize::new(0);
    let failed: Mutex<Option<anyhow::Error>> = Mutex::new(None);
    std::thread::scope(|s| {
        for _ in 0..jobs.min(todo.len() as u32) {
            s.spawn(|| loop {
                if failed.lock().map_or(true, |f| f.is_some()) {
                    return;
                }
                let i = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                let Some(&k) = todo.get(i) else {
                    return;
                };
                let out = std::process::Command::new(&exe)
                    .arg("preprocess")
                    .arg("--work-dir")
                    .arg(dir)
                    .arg("--shard")
                    .arg(k.to_string())
                    .arg("--memory-budget")
                    .arg(budget.map_or("all".into(), |b| b.to_string()))
                    .stdin(std::process::Stdio::null())
                    .output();
                let stderr = match out {
                    Ok(o) if o.status.success() => String::from_utf8_lossy(&o.stderr).into_owned(),
                    failure => {
                        let e = match failure {
                            Ok(o) => anyhow::anyhow!(
                                "shard {k}'s worker failed ({}):\n{}",
                                o.status,
                                String::from_utf8_lossy(&o.stderr).trim_end()
                            ),
                            Err(e) => anyhow::anyhow!("cannot start a worker for shard {k}: {e}"),
                        };
                        if let Ok(mut f) = failed.lock() {
                            f.get_or_insert(e);
                        }
                        return;
                    }
                };
                // "shard K done in S s, peak memory N MiB"
                let peak = stderr.rsplit_once(PEAK).and_then(|(_, r)| {
                    let mib: f64 = r.split_whitespace().next()?.parse().ok()?;
                    Some((mib * 1024.0 * 1024.0) as u64)
                });
                if let Ok(mut l) = line.lock() {
                    progress.line(&format!("{} [{jobs} workers]", l.done(k, peak)));
                }
            });
        }
    });
    match failed.into_inner().ok().flatten() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// Progress on stderr: an indicatif bar per phase on a terminal, one plain
/// line per phase otherwise (logs, CI).
struct Display {
    terminal: bool,
    bar: Mutex<Option<ProgressBar>>,
}

impl Display {
    fn new() -> Self {
        Display {
            terminal: std::io::stderr().is_terminal(),
            bar: Mutex::new(None),
        }
    }

    fn line(&self, s: &str) {
        eprintln!("{s}");
    }
}

impl Progress for Display {
    fn start(&self, phase: Phase, total: u64) {
        if !self.terminal {
            return;
        }
        let bar = if total > 0 {
            ProgressBar::new(total)
        } else {
            ProgressBar::new_spinner()
        };
        let template = if total > 0 {
            "{prefix:>13} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}"
        } else {
            "{prefix:>13} {spinner} {elapsed_precise}"
        };
        if let Ok(style) = ProgressStyle::with_template(template) {
            bar.set_style(style.progress_chars("=> "));
        }
        bar.set_prefix(phase.name());
        bar.enable_steady_tick(std::time::Duration::from_millis(200));
        if let Ok(mut b) = self.bar.lock() {
            *b = Some(bar);
        }
    }

    fn advance(&self, n: u64) {
        if let Ok(b) = self.bar.lock() {
            if let Some(bar) = b.as_ref() {
                bar.inc(n);
            }
        }
    }

    fn finish(&self, phase: Phase, seconds: f64) {
        if let Ok(mut b) = self.bar.lock() {
            if let Some(bar) = b.take() {
                bar.finish_and_clear();
            }
        }
        // The peak so far, so a run near the machine's memory shows it
        // before the end.
        match gigawalk_preprocess::stats::peak_memory_bytes() {
            Some(peak) => eprintln!(
                "{:>13} done in {seconds:.2} s, {PEAK}{} so far",
                phase.name(),
                mib(peak)
            ),
            None => eprintln!("{:>13} done in {seconds:.2} s", phase.name()),
        }
    }
}
