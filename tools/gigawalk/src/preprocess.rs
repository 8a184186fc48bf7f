//! `gigawalk preprocess`: model -> scene file. Argument parsing, progress
//! display and the stats table; the work is in gigawalk-preprocess.

use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use gigawalk_preprocess::shards::{mib, peak_text, threads_within, FIXED_MEMORY};

use anyhow::Context as _;
use gigawalk_preprocess::{
    preprocess_files, shards, LeafChains, Params, Phase, PositionBits, Progress,
};
use gigawalk_scene::{SceneReader, SceneStats};
use indicatif::{ProgressBar, ProgressStyle};

#[derive(clap::Args)]
pub struct Args {
    /// Input model: glTF 2.0 (.gltf, .glb), Wavefront OBJ (.obj) or IFC (.ifc: one object per product) files, or directories of them (searched recursively, in path order), all made into one model; with several files each object's name starts with its file's path
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
    /// LODs and HLODs (4.3): on: where edge collapse stalls (inner nodes' levels, a leaf's first coarser level, levels measured far off), a pair contraction across gaps is tried too (GAPS: edges and close vertex pairs that share no edge contracted by quadric error, which joins disjoint parts and closes holes), measured as every level is, and the better kept; on floors of real CAD 0.85-0.91x the triangles drawn at 1 px for 1.5-1.63x the preprocess CPU time (docs/preprocess.md, "Pair contraction across gaps"). off: edge collapse and clustering alone
    #[arg(long, value_enum, default_value_t = if Params::default().gaps { OnOff::On } else { OnOff::Off })]
    gaps: OnOff,
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
        gaps: args.gaps == OnOff::On,
        proxies: args.proxies == OnOff::On,
        proxy_cells: args.proxy_cells,
    };
    // Bad flags fail before the (possibly long) import.
    params.validate().context("bad parameter")?;

    let progress = PhaseBar::new();
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
                shards::ShardRun::Made => shards::shard_done_line(
                    k,
                    t.elapsed().as_secs_f64(),
                    gigawalk_preprocess::stats::peak_memory_bytes().unwrap_or(0),
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
        let exe = std::env::current_exe();
        let worker = |dir: &Path, k: usize, budget: Option<u64>| {
            let exe = exe
                .as_ref()
                .map_err(|e| std::io::Error::new(e.kind(), e.to_string()))?;
            let mut c = std::process::Command::new(exe);
            c.arg("preprocess")
                .arg("--work-dir")
                .arg(dir)
                .arg("--shard")
                .arg(k.to_string())
                .arg("--memory-budget")
                .arg(budget.map_or("all".into(), |b| b.to_string()));
            Ok(c)
        };
        let build = shards::SplitBuild {
            inputs: &args.input,
            label: &inputs,
            params: &params,
            shard_triangles: args.shard_triangles,
            work_dir: args.work_dir.as_deref(),
            output: &output,
            plan_only: args.plan_only,
            merge_only: args.merge,
            jobs: args.jobs,
            budget,
            worker: &worker,
        };
        match shards::build_split(&build, &progress)? {
            shards::SplitOutcome::Built { stats, files } => (*stats, files),
            shards::SplitOutcome::Planned { shards } => {
                crate::write_stdout(format_args!("{shards}\n"), false)?;
                return Ok(());
            }
        }
    } else {
        preprocess_files(&args.input, &inputs, &params, &output, budget, &progress)?
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

/// Progress on stderr: an indicatif bar per phase on a terminal, nothing
/// off one (logs, CI), where the commands print one plain line per phase
/// themselves. Preprocessing and the tiles export show their phases with
/// it.
pub(crate) struct PhaseBar {
    terminal: bool,
    bar: Mutex<Option<ProgressBar>>,
}

impl PhaseBar {
    pub(crate) fn new() -> Self {
        PhaseBar {
            terminal: std::io::stderr().is_terminal(),
            bar: Mutex::new(None),
        }
    }

    /// Shows a bar of `total` steps prefixed with `phase` and drawn by
    /// `template`; a spinner drawn by `spinner` instead when `total` is 0
    /// and one is given.
    pub(crate) fn show(&self, phase: &str, total: u64, template: &str, spinner: Option<&str>) {
        if !self.terminal {
            return;
        }
        let (bar, template) = match spinner {
            Some(spinner) if total == 0 => (ProgressBar::new_spinner(), spinner),
            _ => (ProgressBar::new(total), template),
        };
        if let Ok(style) = ProgressStyle::with_template(template) {
            bar.set_style(style.progress_chars("=> "));
        }
        bar.set_prefix(phase.to_string());
        bar.enable_steady_tick(std::time::Duration::from_millis(200));
        if let Ok(mut b) = self.bar.lock() {
            *b = Some(bar);
        }
    }

    /// Moves the shown bar on by `n` steps.
    pub(crate) fn inc(&self, n: u64) {
        if let Ok(b) = self.bar.lock() {
            if let Some(bar) = b.as_ref() {
                bar.inc(n);
            }
        }
    }

    /// Takes the shown bar off the terminal.
    pub(crate) fn clear(&self) {
        if let Ok(mut b) = self.bar.lock() {
            if let Some(bar) = b.take() {
                bar.finish_and_clear();
            }
        }
    }
}

impl Progress for PhaseBar {
    fn line(&self, s: &str) {
        eprintln!("{s}");
    }

    fn start(&self, phase: Phase, total: u64) {
        self.show(
            phase.name(),
            total,
            "{prefix:>13} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}",
            Some("{prefix:>13} {spinner} {elapsed_precise}"),
        );
    }

    fn advance(&self, n: u64) {
        self.inc(n);
    }

    fn finish(&self, phase: Phase, seconds: f64) {
        self.clear();
        // The peak so far, so a run near the machine's memory shows it
        // before the end.
        match gigawalk_preprocess::stats::peak_memory_bytes() {
            Some(peak) => eprintln!(
                "{:>13} done in {seconds:.2} s, {} so far",
                phase.name(),
                peak_text(peak)
            ),
            None => eprintln!("{:>13} done in {seconds:.2} s", phase.name()),
        }
    }
}
