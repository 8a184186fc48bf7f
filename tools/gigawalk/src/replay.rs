//! `gigawalk replay`: a camera path through a scene in the Table 2 modes,
//! written as a frame-time and accuracy report. Argument parsing, progress
//! bars and stopping on a signal only; the work is in gigawalk-replay.

use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context as _;
use gigawalk_replay::{Mode, Progress, Replay, ReplayOptions};
use gigawalk_runtime::{
    CullMethod, CullerArgs, HzbBuild, HzbLevel, MemoryBudget, OccluderBudget, Prefetching,
    Reduction, RuntimeOptions, Schedule, TileGrid, TileMethod,
};
use gigawalk_scene::path::CameraPath;
use gigawalk_scene::SceneReader;
use indicatif::{ProgressBar, ProgressStyle};

#[derive(clap::Args)]
pub struct Args {
    /// Scene file (.gwk) from `gigawalk preprocess`
    scene: PathBuf,
    /// Camera path to replay, one frame per pose (docs/path-format.md);
    /// with --view and no path, the saved view's camera alone
    #[arg(long, required_unless_present = "view")]
    path: Option<PathBuf>,
    /// Hide the objects whose name or path matches (as `gigawalk find`;
    /// repeatable): every run and the reference leave them out, so the
    /// report says what hiding costs in frame time and triangles
    #[arg(long, value_name = "PATTERN")]
    hide: Vec<String>,
    /// Hide every object but those that match (repeatable)
    #[arg(long, value_name = "PATTERN")]
    isolate: Vec<String>,
    /// Replay from a saved view (SCENE.views.json, docs/views-format.md):
    /// its hidden objects, and its camera when no --path is given
    #[arg(long, value_name = "NAME")]
    view: Option<String>,
    #[command(flatten)]
    section: crate::section::SectionArgs,
    /// X-ray: draw the hidden objects (--hide, --isolate, --view) as faint ghosts in the reference and every run, to time them (they write no depth: the surface accuracy figures are unchanged)
    #[arg(long)]
    xray: bool,
    #[command(flatten)]
    look: crate::look::LookArgs,
    /// Report directory: summary.md, summary.json, frames.csv, fps.png, tradeoff.png
    #[arg(long, default_value = "report")]
    out: PathBuf,
    /// Modes (the paper's Table 2): vfc = frustum only, hlod = HLOD + frustum, occ = occlusion + frustum, och = occlusion + HLOD
    #[arg(long, value_delimiter = ',', default_value = "vfc,hlod,occ,och", value_parser = parse_mode)]
    modes: Vec<Mode>,
    /// Pixel-error tolerance of hlod and och; a list sweeps (e.g. 0,1,2,4,8)
    #[arg(long, value_delimiter = ',', default_value = "1")]
    pixel_error: Vec<f64>,
    /// Occlusion cullers; occ and och run once with each: hzb = GigaWalk's hierarchical Z-buffer over the occluder pass's depth of frame i-2's visible set, grid = the lazy occlusion grid over a software depth image of the frame's own draws (Hey et al.; no occluder pass), oq = hardware occlusion queries of node boxes against the frame's own draws on RVG's device (Bartz et al.; the whole scene resident), ct = object-space tests against the scene's large convex occluders (Coorg and Teller; scenes preprocessed by revision 4 on)
    #[arg(long, value_delimiter = ',', default_value = "hzb")]
    cullers: Vec<CullMethod>,
    /// Replay at most this many poses from the start of the path
    #[arg(long)]
    frames: Option<usize>,
    /// Compare every K-th frame with a full-detail, frustum-only reference (0 = no accuracy)
    #[arg(long, default_value_t = 10)]
    accuracy_every: usize,
    /// Frames at the start of every run left out of the statistics
    #[arg(long, default_value_t = 5)]
    warmup: usize,
    /// Target frame rate: hlod and och choose each frame's pixel error (from --pixel-error up to --pixel-error-max) to hold it; the report gives the tolerance per frame (frames.csv pixel_error_used) and the accuracy it bought
    #[arg(long, conflicts_with = "target_ms")]
    target_fps: Option<f64>,
    /// Target frame time in ms (instead of --target-fps)
    #[arg(long)]
    target_ms: Option<f64>,
    /// Largest pixel error the target-frame-rate controller may choose
    #[arg(long, default_value_t = 16.0)]
    pixel_error_max: f64,
    #[command(flatten)]
    runtime: RuntimeArgs,
}

/// The runtime's knobs, shared by `replay` and `demo`.
#[derive(clap::Args)]
pub struct RuntimeArgs {
    /// Viewport width
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Viewport height
    #[arg(long, default_value_t = 360)]
    pub height: u32,
    /// Use the GPU adapter whose name contains this (case-insensitive; the name as `gigawalk info --adapters` lists it, backend included: `--adapter gl` picks GL); WGPU_BACKEND=vulkan|gl|metal|dx12 picks the backend. `--adapter null` runs on no GPU at all: every GPU operation is free and draws nothing, so the frame rates are the CPU's ceiling (what it can feed a GPU, with nothing occluded) and accuracy is not measured [default: the best adapter that qualifies, hardware first]
    #[arg(long, value_name = "NAME")]
    pub adapter: Option<String>,
    /// Occluders of frame i are the visible set of frame i - lag (1 or 2; paper: 2)
    #[arg(long, default_value_t = 2)]
    occluder_lag: u32,
    /// Occluder depth resolution as a fraction of the viewport (1 = conservative)
    #[arg(long, default_value_t = 1.0)]
    occluder_scale: f64,
    /// Occluder triangles OR draws a frame, those hiding most per triangle first (conservative at any budget): adaptive = chosen frame by frame from what OR costs against what its occluders save RVG, starting from all (each frame's choice is frames.csv's occluder_limit; measured faster than all on the 4M plant and the real-CAD floor), all (the paper; the same triangles every run), a count (30000, 30k), or auto = 30k on CPU rasterizers such as lavapipe, all on GPUs
    #[arg(
        long,
        value_name = "adaptive|all|TRIANGLES|auto",
        default_value = "adaptive"
    )]
    occluder_budget: OccluderBudget,
    /// HZB keeps the n-th farthest depth of each 2x2 block instead of the farthest (approximate; 1 = farthest; builds the HZB on the CPU, as --hzb cpu)
    #[arg(long)]
    nth_farthest: Option<u8>,
    /// Where the HZB pyramid is built: gpu = on OR's device, only a small level of it read back (--hzb-level); cpu = the whole depth image read back and the pyramid built on the CPU (the paper's way; culls a little more, costs a full-resolution read-back a frame)
    #[arg(long, value_name = "gpu|cpu", default_value = "gpu")]
    hzb: HzbBuild,
    /// With --hzb gpu: the pyramid level read back (0 = the whole image; each level halves both sides): auto = the finest with at most 131,072 texels (0.5 MiB; level 1 at 640x360, 2 at 1920x1080, 3 at 3840x2160). Coarser reads less and culls less, never wrongly
    #[arg(long, value_name = "auto|LEVEL", default_value = "auto")]
    hzb_level: HzbLevel,
    /// wgpu devices in the pipelined schedule (1 or 2)
    #[arg(long, default_value_t = 2)]
    devices: usize,
    /// Asynchronous RVG (Section 5.3): draw the newest finished visible set with the newest camera (approximate, less latency)
    #[arg(long = "async")]
    async_rvg: bool,
    /// One thread, one device, the stages one after another (the baseline of the pipeline)
    #[arg(long)]
    sequential: bool,
    /// Visible items per RVG submission
    #[arg(long, default_value_t = 256)]
    chunk: usize,
    /// Near plane distance in model units [default: 1e-5 of the scene's bounding-box diagonal]
    #[arg(long)]
    pub near: Option<f64>,
    /// Geometry memory a device may hold: all (load the whole scene first), a size (256M, 1G; K/M/G are powers of 1024) or auto (a quarter of RAM); a scene bigger than the budget is streamed from disk while the walk runs, drawing coarser stand-ins until LODs arrive
    #[arg(long, value_name = "all|BYTES|auto", default_value = "all")]
    pub memory_budget: MemoryBudget,
    /// Streaming: what STC asks the loader for before it is needed: band = the next finer LOD of what is drawn near its switching distance, ring = what a frustum a quarter wider would draw, both, or off (on the 50M plant's walk neither drew fewer stand-ins; band drew fewer frames with one)
    #[arg(long, value_name = "off|band|ring|both", default_value = "off")]
    prefetch: Prefetching,
    /// Speculative RVG (the paper's Section 8 proposal): when STC's list for the next camera is late, draw the last finished list with that camera instead of waiting (extra frames, counted in frames.csv speculative_before); pipelined, synchronous RVG only
    #[arg(long)]
    speculative_rvg: bool,
    /// Measurement: STC sleeps this many ms a frame (a slow STC, to see what speculative or asynchronous RVG save); hidden from --help, for docs/results.md's reruns
    #[arg(long, default_value_t = 0.0, hide = true)]
    stc_delay_ms: f64,
    /// Tiled display (Nirnimesh et al.): split the viewport into COLSxROWS tiles (1-64 each; e.g. 4x4), each an off-axis frustum from the same eye drawn from its own list under its own scissor; the stitched image is what accuracy compares with the single-view reference
    #[arg(long, value_name = "COLSxROWS")]
    tiles: Option<TileGrid>,
    /// Tiled display: each tile's resolution (e.g. 1920x1080); the viewport becomes COLS x W by ROWS x H, in place of --width and --height
    #[arg(long, value_name = "WxH", requires = "tiles", value_parser = parse_tile_size)]
    tile_size: Option<(u32, u32)>,
    /// Tiled display: how culled items are sent to tiles: adaptive (the paper's object and frustum hierarchies together), naive (every item against every tile's frustum), object-hierarchy, frustum-hierarchy or binning (screen rectangles); adaptive and naive are both timed every frame
    #[arg(long, value_name = "METHOD", default_value = "adaptive")]
    tile_culling: TileMethod,
    /// Every culler's flags (`--grid-*`, `--oq-*`, `--ct-*`), from the
    /// runtime's culler files.
    #[command(flatten)]
    cullers: CullerArgs,
}

impl RuntimeArgs {
    pub fn options(&self) -> RuntimeOptions {
        RuntimeOptions {
            schedule: if self.sequential {
                Schedule::Sequential
            } else {
                Schedule::Pipelined
            },
            width: match (self.tiles, self.tile_size) {
                (Some(t), Some((w, _))) => t.cols.saturating_mul(w),
                _ => self.width,
            },
            height: match (self.tiles, self.tile_size) {
                (Some(t), Some((_, h))) => t.rows.saturating_mul(h),
                _ => self.height,
            },
            occluder_lag: self.occluder_lag,
            occluder_scale: self.occluder_scale,
            occluder_budget: self.occluder_budget,
            hzb_reduction: match self.nth_farthest {
                None | Some(1) => Reduction::Farthest,
                Some(n) => Reduction::NthFarthest(n),
            },
            hzb: match self.hzb {
                HzbBuild::Gpu(_) => HzbBuild::Gpu(self.hzb_level),
                HzbBuild::Cpu => HzbBuild::Cpu,
            },
            devices: self.devices,
            chunk: self.chunk,
            async_rvg: self.async_rvg,
            prefetch: self.prefetch,
            tiles: self.tiles,
            speculative_rvg: self.speculative_rvg,
            stc_delay_ms: self.stc_delay_ms,
            tile_culling: self.tile_culling,
            cullers: self.cullers.options(),
            ..RuntimeOptions::default()
        }
    }
}

/// `WxH`, each 1..=16384.
fn parse_tile_size(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("tile size {s:?}: expected WIDTHxHEIGHT in pixels, e.g. 1920x1080");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let n = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|n| (1..=16384).contains(n))
    };
    Ok((n(w).ok_or_else(bad)?, n(h).ok_or_else(bad)?))
}

fn parse_mode(s: &str) -> Result<Mode, String> {
    s.parse()
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let target_ms = match (args.target_fps, args.target_ms) {
        (Some(f), _) if f.is_finite() && f > 0.0 => Some(1e3 / f),
        (None, Some(ms)) if ms.is_finite() && ms > 0.0 => Some(ms),
        (None, None) => None,
        (f, ms) => anyhow::bail!(
            "--target-fps {f:?} / --target-ms {ms:?}: a target must be a finite number above 0"
        ),
    };
    if !(args.pixel_error_max.is_finite() && args.pixel_error_max > 0.0) {
        anyhow::bail!(
            "--pixel-error-max {}: must be a finite number above 0",
            args.pixel_error_max
        );
    }
    let look = args.look.choice(1.0)?.over(gigawalk_runtime::Look::PLAIN);
    // The path first: a bad one is named before the scene is read.
    let given_path = match &args.path {
        Some(p) => Some(CameraPath::read(p).context("cannot read the camera path")?),
        None => None,
    };
    let scene = SceneReader::open(&args.scene).context("cannot open the scene")?;
    let view = match &args.view {
        Some(name) => {
            let file = gigawalk_scene::views::Views::file_for(&args.scene);
            let views = gigawalk_scene::views::Views::read(&file)?;
            Some(views.get(&file, name)?.clone())
        }
        None => None,
    };
    let (path, path_name) = match (given_path, &args.path, &view) {
        (Some(given), Some(p), _) => (given, p.display().to_string()),
        (_, _, Some(v)) => (
            CameraPath {
                poses: vec![v
                    .pose()
                    .map_err(|e| anyhow::anyhow!("view {:?}: {e}", v.name))?],
            },
            format!("view {:?}", v.name),
        ),
        _ => anyhow::bail!("replay needs --path or --view"),
    };
    let visibility = if args.hide.is_empty() && args.isolate.is_empty() && view.is_none() {
        None
    } else {
        let h = gigawalk_review::select::hidden(
            &scene,
            &args.scene,
            &gigawalk_review::select::HideRequest {
                hide: args.hide.clone(),
                isolate: args.isolate.clone(),
                view: view.clone(),
            },
        )?;
        if !h.missing.is_empty() {
            eprintln!(
                "warning: view {:?} names {} object(s) this scene no longer has (left out): {}",
                args.view.as_deref().unwrap_or(""),
                h.missing.len(),
                h.missing.join(", ")
            );
        }
        eprintln!("hiding {} of {} objects", h.hidden, h.objects);
        Some((h.visibility, h.ghosts))
    };
    if args.xray && visibility.is_none() {
        anyhow::bail!(
            "--xray draws hidden objects as ghosts: give --hide, --isolate or --view too"
        );
    }
    let (visibility, ghosts) = match visibility {
        Some((v, g)) => (Some(v), g.filter(|_| args.xray)),
        None => (None, None),
    };
    let opts = ReplayOptions {
        modes: args.modes,
        pixel_errors: args.pixel_error,
        cullers: args.cullers,
        runtime: args.runtime.options(),
        memory_budget: args.runtime.memory_budget,
        near: args.runtime.near,
        frames: args.frames,
        accuracy_every: args.accuracy_every,
        warmup: args.warmup,
        target: target_ms.map(|ms| gigawalk_replay::TargetFps {
            ms,
            max_pixel_error: args.pixel_error_max,
        }),
        adapter: args.runtime.adapter.clone(),
        visibility,
        section: args.section.section(
            view.as_ref().and_then(|v| v.section.as_ref()),
            &scene.skeleton().bounds(),
        )?,
        look,
        ghosts,
    };
    let replay = run_replay(
        &scene,
        &args.scene.display().to_string(),
        &path,
        &path_name,
        &opts,
        &args.out,
    )?;
    write_and_print(&replay, &args.out)
}

/// Replays with bars; once the first run starts, SIGINT or SIGTERM ends
/// the current frame and the report holds what was measured (a second
/// signal exits at once). A run that fails (a corrupted LOD the streaming
/// loader found) still gets the report of what was measured before it,
/// in `out`, and then the error. Shared with `gigawalk demo`.
pub fn run_replay(
    scene: &SceneReader,
    scene_name: &str,
    path: &CameraPath,
    path_name: &str,
    opts: &ReplayOptions,
    out: &Path,
) -> anyhow::Result<Replay> {
    let mut bars = Bars {
        terminal: std::io::stderr().is_terminal(),
        bar: None,
        started: Instant::now(),
    };
    match gigawalk_replay::replay(scene, scene_name, &path.poses, path_name, opts, &mut bars) {
        Ok(r) => Ok(r),
        Err(mut e) => {
            if let gigawalk_replay::ReplayError::Run { partial, .. } = &mut e {
                if let Some(p) = partial.take() {
                    eprintln!("the replay failed; writing the report of what was measured first");
                    write_and_print(&p, out)?;
                }
            }
            Err(anyhow::Error::new(e))
                .with_context(|| format!("cannot replay {path_name} through {scene_name}"))
        }
    }
}

pub fn write_and_print(replay: &Replay, out: &Path) -> anyhow::Result<()> {
    let written = replay
        .write_report(out)
        .context("cannot write the report")?;
    let summary = replay.summary();
    out!(
        "{} frames per run, {}x{}, near plane {:.3e} units, on {}",
        summary.frames,
        summary.width,
        summary.height,
        replay.near,
        summary.devices.join(" + ")
    )?;
    crate::write_stdout(format_args!("{}", summary.table()), false)?;
    if !replay.complete {
        out!("stopped early: the report covers the frames measured before the stop")?;
    }
    for f in &written.files {
        out!("wrote {}", f.display())?;
    }
    Ok(())
}

/// An indicatif bar per run on a terminal, one line per run otherwise.
struct Bars {
    terminal: bool,
    bar: Option<ProgressBar>,
    started: Instant,
}

impl Progress for Bars {
    fn start(&mut self, label: &str, frames: u64) {
        // Loading the scene (before the first run) is not worth keeping:
        // a signal then exits at once. From the first frame on, it stops
        // the replay and the report is written.
        crate::signals::stop_gracefully();
        self.started = Instant::now();
        if !self.terminal {
            eprintln!("{label}: {frames} frames");
            return;
        }
        let bar = ProgressBar::new(frames);
        if let Ok(style) = ProgressStyle::with_template(
            "{prefix:>10} [{bar:40}] {pos}/{len} frames {per_sec} eta {eta}",
        ) {
            bar.set_style(style.progress_chars("=> "));
        }
        bar.set_prefix(label.to_string());
        self.bar = Some(bar);
    }

    fn frame(&mut self) {
        if let Some(b) = &self.bar {
            b.inc(1);
        }
    }

    fn finish(&mut self, label: &str) {
        if let Some(b) = self.bar.take() {
            b.finish_and_clear();
        }
        eprintln!(
            "{label:>10} done in {:.1} s",
            self.started.elapsed().as_secs_f64()
        );
    }

    fn loading(&mut self, done: u64, total: u64) {
        if done <= 1 {
            self.started = Instant::now();
            if self.terminal {
                let bar = ProgressBar::new(total);
                if let Ok(style) = ProgressStyle::with_template(
                    "{prefix:>10} [{bar:40}] {pos}/{len} LODs eta {eta}",
                ) {
                    bar.set_style(style.progress_chars("=> "));
                }
                bar.set_prefix("loading");
                self.bar = Some(bar);
            } else {
                eprintln!("loading: {total} LODs before the first frame");
            }
        }
        if let Some(b) = &self.bar {
            b.set_position(done);
        }
        if done == total {
            self.finish("loading");
        }
    }

    fn keep_going(&self) -> bool {
        !crate::signals::stop_requested()
    }
}
