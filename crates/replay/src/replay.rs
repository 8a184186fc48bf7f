//! Replaying a camera path: the reference render of every K-th pose, then
//! one run of the runtime per (mode, pixel error), one frame per pose, each
//! frame recorded with its timings, counts and accuracy.

use std::time::Instant;

use gigawalk_cull::{default_near, Camera, Viewport};
use gigawalk_gpu::FrameImage;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use gigawalk_runtime::target::FrameRateController;
use gigawalk_runtime::{
    CameraError, CameraRequest, CameraSource, CullMethod, FrameReport, MemoryBudget, Runtime,
    RuntimeError, RuntimeOptions, Schedule,
};
use gigawalk_scene::path::Pose;
use gigawalk_scene::{ReadAt, SceneReader};
use serde::Serialize;

use crate::accuracy::{popping, Accuracy};
use crate::mode::{runs, Mode, Run};

/// What to replay, and how.
#[derive(Clone, Debug)]
pub struct ReplayOptions {
    /// Modes to compare, in report order.
    pub modes: Vec<Mode>,
    /// Pixel-error tolerances for the modes that use one (`hlod`, `och`);
    /// more than one is a sweep.
    pub pixel_errors: Vec<f64>,
    /// Occlusion cullers: the modes that cull by occlusion (`occ`, `och`)
    /// run once with each.
    pub cullers: Vec<CullMethod>,
    /// Every runtime knob; `traversal` is set per mode.
    pub runtime: RuntimeOptions,
    /// Geometry a device may hold; a scene that does not fit is streamed.
    pub memory_budget: MemoryBudget,
    /// Near plane distance in model units, shared by the reference and
    /// every run; `None`: [`gigawalk_cull::default_near`] of the scene's
    /// bounds, so a model in millimetres replays like the same model in
    /// metres.
    pub near: Option<f64>,
    /// Replay at most this many poses (from the start of the path).
    pub frames: Option<usize>,
    /// Compare every K-th frame (0, K, 2K, ...) with the reference; 0 = no
    /// accuracy measurement.
    pub accuracy_every: usize,
    /// Frames at the start of every run left out of the statistics (they
    /// are still in frames.csv). They cover the startup bypass (the first
    /// `occluder_lag` frames have no occluders), the pipeline filling, and
    /// first-use allocations in the driver.
    pub warmup: usize,
    /// A target frame rate: the runs of modes with a pixel error (`hlod`,
    /// `och`) choose each frame's tolerance to hold it, starting from their
    /// pixel error ([`gigawalk_runtime::target`]); `None`: fixed.
    pub target: Option<TargetFps>,
    /// Open devices only on an adapter whose name contains this
    /// (case-insensitive; `--adapter`); `None`: the best that qualifies.
    pub adapter: Option<String>,
    /// Hidden objects (`--hide`, `--isolate`, `--view`), the same for the
    /// reference and every run, so accuracy is measured against the full
    /// detail of the objects shown; `None`: every object shows.
    pub visibility: Option<Arc<gigawalk_cull::Visibility>>,
    /// Section planes and box (`--section`, `--section-box`, `--view`),
    /// the same for the reference and every run: accuracy is measured
    /// against the full detail of what the section keeps.
    pub section: Option<Arc<gigawalk_cull::Section>>,
    /// What every run's shown image adds (edges, ambient occlusion, FXAA,
    /// the sky): its passes run each frame and cost what the frame times
    /// show; accuracy reads the frame as drawn, before them.
    pub look: gigawalk_runtime::Look,
    /// X-ray (`--xray`): the hidden objects drawn as ghosts in the
    /// reference and every run (they write no depth, so the accuracy
    /// figures that compare surfaces are unchanged; colour comparisons
    /// see them); `None`: hidden objects are not drawn.
    pub ghosts: Option<Arc<gigawalk_cull::Visibility>>,
}

/// `--target-fps` / `--target-ms`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TargetFps {
    /// Frame time aimed for, ms.
    pub ms: f64,
    /// Largest tolerance the controller may choose, pixels.
    pub max_pixel_error: f64,
}

impl Default for ReplayOptions {
    fn default() -> Self {
        ReplayOptions {
            modes: Mode::ALL.to_vec(),
            pixel_errors: vec![1.0],
            cullers: vec![CullMethod::Hzb],
            runtime: RuntimeOptions::default(),
            memory_budget: MemoryBudget::All,
            near: None,
            frames: None,
            accuracy_every: 10,
            warmup: 5,
            target: None,
            adapter: None,
            visibility: None,
            section: None,
            look: gigawalk_runtime::Look::PLAIN,
            ghosts: None,
        }
    }
}

/// A replay option that cannot be used.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum BadOption {
    #[error("no modes given")]
    NoModes,
    #[error("no pixel errors given")]
    NoPixelErrors,
    #[error("no cullers given")]
    NoCullers,
    #[error("pixel error {0} must be a finite number >= 0")]
    PixelError(f64),
    #[error("near plane {0} must be a finite number > 0")]
    Near(f64),
    #[error("frames must be at least 1")]
    NoFrames,
}

/// Why a replay could not run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReplayError {
    #[error("bad replay option: {0}")]
    Options(#[source] BadOption),
    /// A culler asked for that this scene or runtime cannot run
    /// ([`RuntimeError::CullerUnavailable`]).
    #[error("bad replay option: {0}")]
    Culler(#[source] Box<RuntimeError>),
    #[error("bad runtime option: {0}")]
    RuntimeOptions(#[source] gigawalk_runtime::OptionsError),
    #[error("the camera path has no poses")]
    EmptyPath,
    #[error("cannot start the runtime: {0}")]
    Start(#[source] Box<RuntimeError>),
    #[error("{run}: {source}")]
    Run {
        run: String,
        #[source]
        source: Box<RuntimeError>,
        /// What was measured before the error (`complete` false), for a
        /// report of it.
        partial: Option<Box<Replay>>,
    },
}

/// One frame's tiled-display figures: milliseconds sending the items to
/// the tiles by the adaptive and the naive method (both run every frame),
/// box tests of the method drawn, and triangles of the busiest tile and
/// of the mean tile.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TileFigures {
    pub ms_adaptive: f64,
    pub ms_naive: f64,
    pub tests: u64,
    pub max_triangles: u64,
    pub mean_triangles: f64,
}

/// One frame of one run.
#[derive(Clone, Debug, Serialize)]
pub struct FrameRecord {
    pub frame: u64,
    /// The pose's time on the path, seconds.
    pub pose_time_s: f64,
    /// Interval between this frame and the previous one finishing at RVG;
    /// `None` for frame 0.
    pub frame_ms: Option<f64>,
    /// Camera sampled -> frame finished.
    pub latency_ms: f64,
    pub or_ms: f64,
    pub hzb_ms: f64,
    pub stc_ms: f64,
    pub rvg_ms: f64,
    /// Occluder triangles OR drew, and the budget it drew them with
    /// (`None`: all; the adaptive controller's choice with `adaptive`).
    pub occluder_triangles: u64,
    pub occluder_limit: Option<u64>,
    pub visited: u64,
    pub frustum_culled: u64,
    pub occlusion_culled: u64,
    /// Nodes wholly on the removed side of the section.
    #[serde(default)]
    pub section_culled: u64,
    pub drawn_nodes: u64,
    pub drawn_triangles: u64,
    pub occlusion_used: bool,
    /// The pixel-error tolerance the frame was culled with (the run's, or
    /// the target-frame-rate controller's choice).
    pub pixel_error_used: f64,
    /// Microseconds the target-frame-rate controller took on this frame.
    #[serde(skip)]
    pub controller_us: Option<f64>,
    /// Speculative frames RVG drew just before this one (STC was late).
    pub speculative_before: u32,
    /// Milliseconds RVG waited for STC before this frame (pipelined).
    pub rvg_wait_ms: f64,
    /// What the culler did beyond traversal (its counts are in
    /// frames.csv; none for the HZB).
    #[serde(skip)]
    pub culler_work: Option<gigawalk_runtime::CullerWork>,
    /// A tiled display's figures (`--tiles` only; in frames.csv).
    #[serde(skip)]
    pub tiles: Option<TileFigures>,
    /// Streaming (zeros when the scene is resident): device bytes the
    /// resident LODs take after the frame, bytes that arrived, loader
    /// requests sent, stand-ins drawn for LODs not resident, and chosen
    /// LODs with no stand-in at all.
    pub resident_bytes: u64,
    pub loaded_bytes: u64,
    pub requests: u64,
    pub substituted_draws: u64,
    pub missing_draws: u64,
    /// Left out of the statistics (see [`ReplayOptions::warmup`]).
    pub warmup: bool,
    /// On compared frames: the share of pixels that change from this frame
    /// to the next where the reference's do not (LOD switches and culling
    /// changes, not camera motion; [`crate::accuracy::popping`]).
    pub popping: Option<f64>,
    /// Against the reference, on every K-th frame.
    pub accuracy: Option<Accuracy>,
    /// Where the stages' CPU time went.
    pub cpu: CpuSplit,
}

/// Where a frame's CPU time went, step by step (ms), and what crossed
/// from the devices to the host: with the null adapter (every GPU
/// operation free) this is the whole frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct CpuSplit {
    /// The level of OR's depth pyramid read back (0: the whole image).
    pub hzb_level: u32,
    /// OR: recording its depth pass (and pyramid), submitting it, waiting
    /// for the read-back, copying it out of mapped memory.
    pub or_encode_ms: f64,
    pub or_submit_ms: f64,
    pub or_wait_ms: f64,
    pub or_copy_ms: f64,
    /// STC: traversal, and the culler's tests within it (the HZB build
    /// is `FrameRecord::hzb_ms`).
    pub traversal_ms: f64,
    pub cull_test_ms: f64,
    /// RVG: recording its chunks, submitting them, waiting for the device
    /// (the frame before, or a read-back), copying read-backs out.
    pub rvg_encode_ms: f64,
    pub rvg_submit_ms: f64,
    pub rvg_wait_ms: f64,
    pub rvg_copy_ms: f64,
    /// Bytes OR read back (its depth, or the level of its pyramid), and
    /// RVG (frames compared for accuracy); how many times a stage waited
    /// for a device.
    pub or_read_bytes: u64,
    pub rvg_read_bytes: u64,
    pub device_waits: u32,
}

impl CpuSplit {
    fn of(r: &FrameReport) -> CpuSplit {
        let (o, v) = (&r.or_pass, &r.rvg_pass);
        CpuSplit {
            hzb_level: r.hzb_level,
            or_encode_ms: o.encode_ms,
            or_submit_ms: o.submit_ms,
            or_wait_ms: o.wait_ms,
            or_copy_ms: o.copy_ms,
            traversal_ms: r.traversal_ms,
            cull_test_ms: r.cull_test_ms,
            rvg_encode_ms: v.encode_ms,
            rvg_submit_ms: v.submit_ms,
            rvg_wait_ms: v.wait_ms,
            rvg_copy_ms: v.copy_ms,
            or_read_bytes: o.read_bytes,
            rvg_read_bytes: v.read_bytes,
            device_waits: o.waits + v.waits,
        }
    }
}

/// One run: a mode at a pixel error along the path.
#[derive(Clone, Debug)]
pub struct RunRecord {
    pub mode: Mode,
    pub pixel_error: f64,
    /// The occlusion culler (`None` for modes without occlusion).
    pub culler: Option<CullMethod>,
    /// Held to the replay's target frame rate (`pixel_error` is where the
    /// controller started).
    pub target: bool,
    pub frames: Vec<FrameRecord>,
}

impl RunRecord {
    /// "och 1px" style label ("och 1px grid" for a culler other than the
    /// HZB).
    pub fn label(&self) -> String {
        run_label(self.mode, self.pixel_error, self.culler, self.target)
    }
}

pub(crate) fn run_label(
    mode: Mode,
    pixel_error: f64,
    culler: Option<CullMethod>,
    target: bool,
) -> String {
    let base = if target {
        format!("{mode} target")
    } else if mode.uses_pixel_error() {
        format!("{mode} {pixel_error}px")
    } else {
        mode.name().to_string()
    };
    match culler {
        Some(c) if c != CullMethod::Hzb => format!("{base} {c}"),
        _ => base,
    }
}

/// Everything a replay measured; [`Replay::summary`] and
/// [`Replay::write_report`] turn it into the report.
#[derive(Clone, Debug)]
pub struct Replay {
    pub scene: String,
    pub path: String,
    /// Poses replayed per run.
    pub frames: usize,
    /// The near plane every frame used, model units (`options.near`
    /// resolved against the scene).
    pub near: f64,
    pub options: ReplayOptions,
    /// The occluder budget the runs used on these devices
    /// (`options.runtime.occluder_budget` resolved).
    pub occluder_selection: gigawalk_runtime::OccluderSelection,
    pub devices: Vec<String>,
    /// Ran on the null adapter ([`Runtime::is_null`]): no accuracy.
    pub null_adapter: bool,
    pub runs: Vec<RunRecord>,
    /// False when the replay was stopped early ([`Progress::keep_going`]).
    pub complete: bool,
    /// Reference frames rendered (every K-th pose and the pose after it,
    /// for popping).
    pub reference_frames: usize,
    /// Streaming: device bytes a device may hold (`None`: the whole scene
    /// is resident), and reference frames that did not settle (still drew
    /// a stand-in when taken: [`SETTLE_FRAMES`] frames at their pose, or
    /// [`STALLED_FRAMES`] without progress).
    pub memory_budget: Option<u64>,
    pub unsettled_reference_frames: usize,
    pub seconds: f64,
}

/// Frames a streamed reference camera is held still for its LODs to
/// arrive before its image is taken as it is ...
pub const SETTLE_FRAMES: usize = 200;
/// ... or frames without fewer stand-ins than its best frame so far.
pub const STALLED_FRAMES: usize = 8;

/// Watches a replay; every method has a do-nothing default. The library
/// prints nothing: the CLI draws bars.
pub trait Progress {
    /// A run begins ("reference", "vfc", "och 1px", ...) of `frames` frames.
    fn start(&mut self, _label: &str, _frames: u64) {}
    /// One more frame of the current run is done.
    fn frame(&mut self) {}
    /// The current run ended.
    fn finish(&mut self, _label: &str) {}
    /// Before the first run: `done` of the `total` LODs read before the
    /// first frame can be drawn (all of them when resident, the pinned set
    /// under a memory budget).
    fn loading(&mut self, _done: u64, _total: u64) {}
    /// False stops the replay after the current frame (Ctrl-C); what was
    /// measured so far is kept.
    fn keep_going(&self) -> bool {
        true
    }
}

/// A [`Progress`] that ignores everything.
pub struct NoProgress;
impl Progress for NoProgress {}

/// Replays `poses` over `scene` in every run of `opts`. `scene_name` and
/// `path_name` go into the report.
pub fn replay<R: ReadAt + Sync>(
    scene: &SceneReader<R>,
    scene_name: &str,
    poses: &[Pose],
    path_name: &str,
    opts: &ReplayOptions,
    progress: &mut dyn Progress,
) -> Result<Replay, ReplayError> {
    validate(opts)?;
    if poses.is_empty() {
        return Err(ReplayError::EmptyPath);
    }
    let rt = Runtime::open(
        scene,
        device_count(opts),
        opts.adapter.as_deref(),
        opts.memory_budget,
        &mut |done, total| progress.loading(done, total),
    )
    .map_err(|e| ReplayError::Start(Box::new(e)))?;
    replay_on(&rt, scene_name, poses, path_name, opts, progress)
}

/// Devices a replay with `opts` opens: one in the sequential schedule.
fn device_count(opts: &ReplayOptions) -> usize {
    match opts.runtime.schedule {
        Schedule::Sequential => 1,
        Schedule::Pipelined => opts.runtime.devices,
    }
}

/// Opens the devices a replay with `opts` would use, checks the viewport
/// fits them, and closes them again ([`gigawalk_runtime::probe_devices`]):
/// call it before long work (generating, preprocessing, loading a scene)
/// so a machine that cannot render hears so at once. Returns the devices'
/// names.
pub fn probe_devices(opts: &ReplayOptions) -> Result<Vec<String>, ReplayError> {
    validate(opts)?;
    gigawalk_runtime::probe_devices(
        device_count(opts),
        opts.adapter.as_deref(),
        opts.runtime.width,
        opts.runtime.height,
    )
    .map_err(|e| ReplayError::Start(Box::new(e)))
}

/// Like [`replay()`] on a runtime the caller made (tests open their own
/// devices to skip without an adapter).
pub fn replay_on(
    rt: &Runtime,
    scene_name: &str,
    poses: &[Pose],
    path_name: &str,
    opts: &ReplayOptions,
    progress: &mut dyn Progress,
) -> Result<Replay, ReplayError> {
    let start = Instant::now();
    validate(opts)?;
    // Cullers this scene or runtime cannot run fail here, before the
    // reference is rendered, not with a partial report after it.
    let occluding = opts.modes.iter().any(|m| m.traversal(0.0).occlusion);
    // A stored but corrupt OCCL or OCVC is an error naming it, not "none".
    if occluding {
        for &c in &opts.cullers {
            match rt.check_culler(c) {
                Ok(()) => {}
                Err(e @ gigawalk_runtime::RuntimeError::CullerUnavailable { .. }) => {
                    return Err(ReplayError::Culler(Box::new(e)))
                }
                Err(e) => return Err(ReplayError::Start(Box::new(e))),
            }
        }
    }
    let n = opts.frames.unwrap_or(poses.len()).min(poses.len());
    if n == 0 {
        return Err(ReplayError::EmptyPath);
    }
    let (w, h) = (opts.runtime.width, opts.runtime.height);
    // The null adapter draws nothing: there is no image to compare.
    let null_adapter = rt.is_null();
    let k = if null_adapter { 0 } else { opts.accuracy_every };
    let near = opts
        .near
        .unwrap_or_else(|| default_near(&rt.skeleton().bounds()));
    let cameras: Vec<CameraRequest> = poses[..n]
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let camera = Camera::of_pose(p, Viewport::new(w, h), near);
            CameraRequest {
                visibility: opts.visibility.clone(),
                section: opts.section.clone(),
                look: opts.look,
                ghosts: opts.ghosts.clone(),
                ..CameraRequest::new(camera, compared_or_next(i, k))
            }
        })
        .collect();
    // The frames the reference renders: each compared frame and the one
    // after it (for popping), in order; by frame, its place in that list.
    let ref_frames: Vec<usize> = (0..n).filter(|&i| compared_or_next(i, k)).collect();
    let mut ref_at = vec![usize::MAX; n];
    for (j, &i) in ref_frames.iter().enumerate() {
        ref_at[i] = j;
    }
    let mut out = Replay {
        scene: scene_name.to_string(),
        path: path_name.to_string(),
        frames: n,
        near,
        options: ReplayOptions {
            accuracy_every: k,
            ..opts.clone()
        },
        occluder_selection: rt.occluder_selection(opts.runtime.occluder_budget),
        devices: rt.device_names(),
        null_adapter,
        runs: Vec::new(),
        complete: true,
        reference_frames: 0,
        memory_budget: rt.is_streaming().then(|| rt.resident_bytes()),
        unsettled_reference_frames: 0,
        seconds: 0.0,
    };

    // The reference: full detail, frustum culling only, one thread, one
    // device, only the frames that are compared. Streamed, each camera is
    // held until its frame draws no stand-in, so the reference is the
    // full-detail image and the runs' accuracy includes what streaming
    // costs them.
    let mut reference: Vec<Option<FrameImage>> = Vec::new();
    if k > 0 {
        let advance = Arc::new(AtomicBool::new(false));
        let mut list = Settle {
            cameras: ref_frames.iter().map(|&i| cameras[i].clone()).collect(),
            next: 0,
            advance: advance.clone(),
        };
        let ro = RuntimeOptions {
            schedule: Schedule::Sequential,
            // Sequential runs synchronously whatever the runs use.
            async_rvg: false,
            traversal: Mode::Vfc.traversal(0.0),
            // One view: the runs' stitched tiles are compared with it.
            tiles: None,
            speculative_rvg: false,
            stc_delay_ms: 0.0,
            ..opts.runtime.clone()
        };
        progress.start("reference", list.cameras.len() as u64);
        let mut stopped = false;
        let (mut held, mut unsettled) = (0, 0);
        // The fewest stand-ins a held camera drew, and frames since.
        let (mut best, mut since_best) = (u64::MAX, 0);
        rt.run(&ro, &mut list, &mut |r: FrameReport| {
            let waiting = r.streaming.substituted + r.streaming.missing;
            let settled = waiting == 0;
            held += 1;
            if waiting < best {
                (best, since_best) = (waiting, 0);
            } else {
                since_best += 1;
            }
            // A full-detail view bigger than the budget never settles:
            // stop holding when it stops getting better.
            let take = settled || held >= SETTLE_FRAMES || since_best >= STALLED_FRAMES;
            if take {
                unsettled += usize::from(!settled);
                reference.push(r.image);
                (held, best, since_best) = (0, u64::MAX, 0);
                progress.frame();
            }
            advance.store(take, Ordering::Relaxed);
            stopped = !progress.keep_going();
            !stopped
        })
        .map_err(|source| ReplayError::Run {
            run: "reference".into(),
            source: Box::new(source),
            partial: None,
        })?;
        progress.finish("reference");
        out.reference_frames = reference.len();
        out.unsettled_reference_frames = unsettled;
        if stopped {
            out.complete = false;
            out.seconds = start.elapsed().as_secs_f64();
            return Ok(out);
        }
    }

    let held = opts.target.is_some();
    let all_runs = runs(&opts.modes, &opts.pixel_errors, &opts.cullers, held).len();
    for Run {
        mode,
        pixel_error,
        culler,
        target,
    } in runs(&opts.modes, &opts.pixel_errors, &opts.cullers, held)
    {
        let label = run_label(mode, pixel_error, culler, target);
        let ro = RuntimeOptions {
            traversal: mode.traversal(pixel_error),
            culler: culler.unwrap_or(opts.runtime.culler),
            ..opts.runtime.clone()
        };
        // A target frame rate steers the runs that have a pixel error.
        let ctrl = opts.target.filter(|_| target).map(|t| {
            Arc::new(Mutex::new(FrameRateController::new(
                t.ms,
                pixel_error,
                t.max_pixel_error,
            )))
        });
        let mut list = Controlled {
            cameras: cameras.clone(),
            ctrl: ctrl.clone(),
        };
        let mut frames: Vec<FrameRecord> = Vec::with_capacity(n);
        // Compared frames' images, by index into `frames`: compared after
        // the run, so that neither the comparison (the bound's window
        // search is the costly part) nor rayon's threads running it share
        // the CPU with the frames being timed.
        let mut compared: Vec<(usize, FrameImage)> = Vec::new();
        // The frames after compared ones (popping), by frame number.
        let mut next_images: std::collections::HashMap<usize, FrameImage> = Default::default();
        let mut last_finish: Option<Instant> = None;
        let mut stopped = false;
        progress.start(&label, n as u64);
        let mut speculative = 0u32;
        let result = rt.run(&ro, &mut list, &mut |r: FrameReport| {
            if r.speculative {
                // An extra frame drawn while STC was late: counted on the
                // real frame that follows, and the interval to it starts
                // here (it is what the screen showed).
                speculative += 1;
                last_finish = Some(r.finished_at);
                return !stopped;
            }
            let i = r.frame as usize;
            let frame_ms = last_finish.map(|t| (r.finished_at - t).as_secs_f64() * 1e3);
            let controller_us = match (&ctrl, frame_ms) {
                (Some(c), Some(ms)) => {
                    let t = Instant::now();
                    if let Ok(mut c) = c.lock() {
                        c.update(ms, r.stats.drawn_triangles, r.pixel_error);
                    }
                    Some(t.elapsed().as_secs_f64() * 1e6)
                }
                _ => None,
            };
            frames.push(FrameRecord {
                frame: r.frame,
                pose_time_s: poses.get(i).map_or(0.0, |p| p.time),
                frame_ms,
                latency_ms: r.latency_ms(),
                or_ms: r.or_ms,
                hzb_ms: r.hzb_ms,
                stc_ms: r.stc_ms,
                rvg_ms: r.rvg_ms,
                occluder_triangles: r.occluder_triangles,
                occluder_limit: r.occluder_limit,
                visited: r.stats.visited,
                frustum_culled: r.stats.frustum_culled,
                occlusion_culled: r.stats.occlusion_culled,
                section_culled: r.stats.section_culled,
                drawn_nodes: r.stats.drawn_nodes,
                drawn_triangles: r.stats.drawn_triangles,
                occlusion_used: r.occlusion_used,
                pixel_error_used: r.pixel_error,
                controller_us,
                speculative_before: std::mem::take(&mut speculative),
                rvg_wait_ms: r.rvg_wait_ms,
                culler_work: r.culler_work,
                tiles: r.tiles.as_ref().map(|t| TileFigures {
                    ms_adaptive: t.ms_adaptive,
                    ms_naive: t.ms_naive,
                    tests: t.tests,
                    max_triangles: t.max_triangles,
                    mean_triangles: t.mean_triangles,
                }),
                resident_bytes: r.streaming.resident_bytes,
                loaded_bytes: r.streaming.loaded_bytes,
                requests: r.streaming.requests,
                substituted_draws: r.streaming.substituted,
                missing_draws: r.streaming.missing,
                warmup: i < opts.warmup,
                popping: None,
                accuracy: None,
                cpu: CpuSplit::of(&r),
            });
            if let Some(img) = r.image {
                if k > 0 && i.is_multiple_of(k) {
                    compared.push((frames.len() - 1, img));
                } else if compared_or_next(i, k) {
                    next_images.insert(i, img);
                }
            }
            last_finish = Some(r.finished_at);
            progress.frame();
            stopped = !progress.keep_going();
            !stopped
        });
        // Each frame's bound is the tolerance it was culled with.
        let reference_of = |i: usize| {
            ref_at
                .get(i)
                .and_then(|&j| reference.get(j))
                .and_then(|x| x.as_ref())
        };
        for (at, img) in compared {
            let i = frames[at].frame as usize;
            let ppr = cameras.get(i).map_or(f64::NAN, |c| {
                c.camera.pixels_per_radian(Viewport::new(w, h))
            });
            frames[at].accuracy = reference_of(i)
                .and_then(|r| Accuracy::compare(r, &img, frames[at].pixel_error_used, ppr));
            frames[at].popping = match (
                reference_of(i),
                reference_of(i + 1),
                next_images.get(&(i + 1)),
            ) {
                (Some(ra), Some(rb), Some(b)) => popping(ra, rb, &img, b),
                _ => None,
            };
        }
        progress.finish(&label);
        out.runs.push(RunRecord {
            mode,
            pixel_error,
            culler,
            target,
            frames,
        });
        if let Err(source) = result {
            out.complete = false;
            out.reference_frames = out.reference_frames.min(reference.len());
            out.seconds = start.elapsed().as_secs_f64();
            return Err(ReplayError::Run {
                run: label,
                source: Box::new(source),
                partial: Some(Box::new(out)),
            });
        }
        if stopped {
            break;
        }
    }
    // Complete when everything was measured, even if the stop came with
    // the last frame.
    out.complete = out.runs.len() == all_runs
        && out.runs.iter().all(|r| r.frames.len() == n)
        && out.reference_frames == ref_frames.len();
    out.seconds = start.elapsed().as_secs_f64();
    Ok(out)
}

/// Frame `i` is compared with the reference (every `k`-th) or follows a
/// compared one (popping needs the pair).
fn compared_or_next(i: usize, k: usize) -> bool {
    k > 0 && (i.is_multiple_of(k) || i % k == 1)
}

/// A run's cameras, each with the target-frame-rate controller's
/// tolerance when there is one.
struct Controlled {
    cameras: Vec<CameraRequest>,
    ctrl: Option<Arc<Mutex<FrameRateController>>>,
}

impl CameraSource for Controlled {
    fn next_camera(&mut self, frame: u64) -> Result<Option<CameraRequest>, CameraError> {
        let pixel_error = self
            .ctrl
            .as_ref()
            .and_then(|c| c.lock().ok().map(|c| c.pixel_error()));
        Ok(self.cameras.get(frame as usize).map(|c| CameraRequest {
            pixel_error,
            ..c.clone()
        }))
    }
}

/// The reference's cameras, each handed out again until the frame report
/// says to move on (`advance`: it drew no stand-in, or was held for
/// [`SETTLE_FRAMES`]). The sequential schedule reports a frame before it
/// asks for the next camera, so `advance` speaks of the camera handed out
/// last.
struct Settle {
    cameras: Vec<CameraRequest>,
    next: usize,
    advance: Arc<AtomicBool>,
}

impl CameraSource for Settle {
    fn next_camera(&mut self, frame: u64) -> Result<Option<CameraRequest>, CameraError> {
        if frame > 0 && self.advance.load(Ordering::Relaxed) {
            self.next += 1;
        }
        Ok(self.cameras.get(self.next).cloned())
    }
}

fn validate(opts: &ReplayOptions) -> Result<(), ReplayError> {
    let bad = |b: BadOption| Err(ReplayError::Options(b));
    if opts.modes.is_empty() {
        return bad(BadOption::NoModes);
    }
    if opts.pixel_errors.is_empty() {
        return bad(BadOption::NoPixelErrors);
    }
    if opts.cullers.is_empty() {
        return bad(BadOption::NoCullers);
    }
    if let Some(e) = opts
        .pixel_errors
        .iter()
        .find(|e| !(e.is_finite() && **e >= 0.0))
    {
        return bad(BadOption::PixelError(*e));
    }
    if let Some(near) = opts.near {
        if !(near > 0.0 && near.is_finite()) {
            return bad(BadOption::Near(near));
        }
    }
    if opts.frames == Some(0) {
        return bad(BadOption::NoFrames);
    }
    opts.runtime.validate().map_err(ReplayError::RuntimeOptions)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_options_are_typed_and_say_what_is_wrong() {
        let with = |f: &dyn Fn(&mut ReplayOptions)| {
            let mut o = ReplayOptions::default();
            f(&mut o);
            validate(&o)
        };
        assert!(with(&|_| {}).is_ok());
        type Case<'a> = (&'a dyn Fn(&mut ReplayOptions), BadOption, &'a str);
        let cases: [Case; 6] = [
            (&|o| o.modes.clear(), BadOption::NoModes, "no modes given"),
            (
                &|o| o.pixel_errors.clear(),
                BadOption::NoPixelErrors,
                "no pixel errors",
            ),
            (&|o| o.cullers.clear(), BadOption::NoCullers, "no cullers"),
            (
                &|o| o.pixel_errors = vec![1.0, -2.0],
                BadOption::PixelError(-2.0),
                "pixel error -2 must be",
            ),
            (
                &|o| o.near = Some(0.0),
                BadOption::Near(0.0),
                "near plane 0 must",
            ),
            (
                &|o| o.frames = Some(0),
                BadOption::NoFrames,
                "frames must be at least 1",
            ),
        ];
        for (f, want, text) in cases {
            let e = with(f).unwrap_err();
            let msg = e.to_string();
            assert!(matches!(&e, ReplayError::Options(b) if *b == want), "{e:?}");
            assert!(
                msg.starts_with("bad replay option: ") && msg.contains(text),
                "{msg}"
            );
        }
        // NaN pixel errors are refused too (NaN != NaN, so by message).
        let e = with(&|o| o.pixel_errors = vec![f64::NAN]).unwrap_err();
        assert!(e.to_string().contains("pixel error NaN"), "{e}");
    }
}
