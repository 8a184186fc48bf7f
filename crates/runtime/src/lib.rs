//! gigawalk's runtime: the three stages of the GigaWalk pipeline (paper
//! Section 5, Figures 3 and 6), the only crate that starts threads.
//!
//! Main types: [`Runtime`] (a scene's geometry resident on the devices),
//! [`RuntimeOptions`] (every knob), [`CameraSource`] (where cameras come
//! from: a replayed path or live input), [`FrameReport`] (what one frame
//! did, with timings and optionally its image).
//!
//! Pipelined schedule: OR (device A) renders the depth of frame i - lag's
//! visible set with LODs re-selected for camera i and hands it to STC; STC
//! builds the HZB, traverses, and streams draw items to RVG as it finds
//! them, ending each frame with a sentinel that carries the frame number,
//! the camera and the statistics; RVG (device B) draws the items in chunks.
//! STC also feeds its visible set back to OR for frame i + lag. Any stage's
//! error closes its queues, every other stage sees that and stops, and the
//! run returns the first error.

#![forbid(unsafe_code)]

mod cullers;
mod occluders;
mod options;
mod pipeline;
mod stages;
mod streaming;
pub mod target;
mod triangles;

use std::sync::{Arc, Mutex};
use web_time::Instant;

pub use gigawalk_cull::tiles::{TileGrid, TileMethod};
pub use gigawalk_cull::{
    default_near, Camera, CullReason, DrawItem, Reduction, TraversalOptions, TraversalStats,
    Viewport,
};
pub use gigawalk_gpu::{
    chosen_adapter, list_adapters, AdapterReport, Antialias, DrawStyle, FrameImage, GpuContext,
    GpuError, Look, LookChoice, Optional, QueryCounts, VisiblePass,
};
pub(crate) use options::ResolvedOptions;
pub use options::{
    auto_hzb_level, FailureHook, HzbBuild, HzbLevel, MemoryBudget, MemoryUnknown, OccluderBudget,
    OccluderSelection, OptionsError, Prefetching, RuntimeOptions, Schedule, Stage,
    AUTO_MEMORY_SHARE, CPU_OCCLUDER_BUDGET, HZB_READ_TEXELS, MAX_HZB_LEVEL,
};

// Every culler's public types (its options, flags and stats) and the
// registry's: the culler files are the only ones naming a culler.
pub use cullers::ct::*;
pub use cullers::grid::*;
pub use cullers::oq::*;
pub use cullers::*;
pub use pipeline::{Stepped, SteppedOptions, OR_IN_FLIGHT};
pub use stages::TileFrame;
pub use streaming::{scene_device_bytes, LodSource, StreamStats, PINNED_MAX, PINNED_SHARE};

use gigawalk_gpu::HostGeometry;
use gigawalk_scene::{ReadAt, SceneReader, Skeleton};
use stages::Target;
use streaming::{DeviceStream, Geometry, Plan};

/// Milliseconds since `t`.
pub(crate) fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// The GPU's view of a cull view: camera-relative matrices, eye in f64.
pub(crate) fn gpu_view(v: &gigawalk_cull::CullView) -> gigawalk_gpu::View {
    gigawalk_gpu::View {
        eye: v.camera.position,
        view_proj: v.camera.view_projection_rel(),
        forward: v.camera.forward().as_vec3(),
        clip: gigawalk_gpu::ClipPlanes::of_section(v.section().map(|s| &**s), v.camera.position),
    }
}

/// Why the runtime could not start, or why a run stopped early (more
/// kinds may come: `testing` builds add one).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RuntimeError {
    /// Opening the devices or loading the scene's geometry onto them,
    /// before any stage runs.
    #[error("setup: {source}")]
    Setup { source: GpuError },
    #[error("setup: {count} devices given, the pipeline uses 1 or 2")]
    DeviceCount { count: usize },
    #[error("setup: a {width}x{height} viewport is larger than device {device} draws ({max} pixels a side at most)")]
    Viewport {
        width: u32,
        height: u32,
        device: String,
        max: u32,
    },
    #[error("{stage}: {source}")]
    Gpu { stage: Stage, source: GpuError },
    #[error("STC, frame {frame}: {source}")]
    Hzb {
        frame: u64,
        source: gigawalk_cull::HzbError,
    },
    #[error("bad runtime option: {0}")]
    Options(#[from] OptionsError),
    /// Only from [`RuntimeOptions::inject_failure`] (feature `testing`).
    #[error("{stage}: injected failure at frame {frame}")]
    Injected { stage: Stage, frame: u64 },
    #[error("{stage} stage panicked: {message}")]
    Panic { stage: Stage, message: String },
    #[error("cannot start the {stage} thread: {source}")]
    Spawn {
        stage: Stage,
        source: std::io::Error,
    },
    #[error("camera source: {0}")]
    Camera(#[from] CameraError),
    /// The loader could not read a LOD the walk needed (streaming).
    #[error("the {culler} culler cannot run here: {why}")]
    CullerUnavailable {
        culler: CullMethod,
        why: Unavailable,
    },
    #[error("loader: {source}")]
    Load {
        source: Box<gigawalk_scene::ReadError>,
    },
    /// A stage saw the loader stop; the loader's own error is the cause.
    #[error("the loader stopped")]
    LoaderStopped,
    #[error("setup: memory budget of {budget} bytes is below the minimum of {min} bytes")]
    MemoryBudget { budget: u64, min: u64 },
    #[error("setup: {0}")]
    MemoryBudgetUnknown(MemoryUnknown),
}

/// The smallest memory budget [`Runtime::streaming`] takes.
pub const MIN_MEMORY_BUDGET: u64 = 1 << 16;

/// Why a [`CameraSource`] gave no camera for a frame.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CameraError {
    #[error("frame {frame}: camera {camera:?} is not valid (non-finite position, bad orientation or field of view)")]
    Invalid { frame: u64, camera: Camera },
    #[error("frame {frame}: pixel error {value} must be a finite number >= 0")]
    PixelError { frame: u64, value: f64 },
    /// The source itself failed (e.g. the viewer's window thread is gone).
    #[error("frame {frame}: {source}")]
    Source {
        frame: u64,
        source: Box<dyn std::error::Error + Send + Sync>,
    },
}

/// One camera to render, as a [`CameraSource`] hands it out.
#[derive(Clone, Debug)]
pub struct CameraRequest {
    pub camera: Camera,
    /// Read back this frame's colour and depth (accuracy checks, screenshots).
    pub read_back: bool,
    /// Freeze culling: draw the last culled visible set (same nodes and
    /// LODs) with this camera; OR and STC do no work for this frame. The
    /// viewer uses it to fly around a frozen visible set.
    pub hold_culling: bool,
    /// How RVG draws this frame (the viewer's wireframe toggle). Culling
    /// does not depend on it.
    pub style: DrawStyle,
    /// What the shown image adds to the frame (edges, ambient occlusion,
    /// anti-aliasing, the sky): the window and screenshots show it, while
    /// the colour and depth read back stay the geometry as drawn.
    pub look: Look,
    /// This frame's pixel-error tolerance, overriding
    /// `RuntimeOptions::traversal` (a target-frame-rate controller sets it
    /// per frame); `None`: the options'. Must be finite and >= 0.
    pub pixel_error: Option<f64>,
    /// Hidden and highlighted objects this frame (`None`: every object
    /// shows whole): OR, STC and RVG all see the same set for a frame, so
    /// no drawn LOD and no occluder holds a hidden object.
    pub visibility: Option<std::sync::Arc<gigawalk_cull::Visibility>>,
    /// X-ray: the objects `visibility` hides, as a visibility of their own
    /// (`Visibility::ghosts`), drawn by RVG as faint ghosts after the
    /// frame, tested against its depth; they hide nothing and no culler
    /// sees them. `None`: hidden objects are simply not drawn.
    pub ghosts: Option<std::sync::Arc<gigawalk_cull::Visibility>>,
    /// Section planes and box this frame (`None`: nothing cut): traversal
    /// drops what lies wholly on the removed side, and OR, RVG and the
    /// query pass clip every fragment by it, so nothing removed is drawn
    /// or occludes.
    pub section: Option<std::sync::Arc<gigawalk_cull::Section>>,
}

impl CameraRequest {
    pub fn new(camera: Camera, read_back: bool) -> Self {
        CameraRequest {
            camera,
            read_back,
            hold_culling: false,
            style: DrawStyle::Shaded,
            look: Look::PLAIN,
            pixel_error: None,
            visibility: None,
            ghosts: None,
            section: None,
        }
    }
}

/// Shows frames as they finish, on the RVG thread: the viewer blits the
/// offscreen target to its window, draws overlays and presents.
pub trait Presenter: Send {
    /// Called after `pass` holds the finished frame (before any read-back).
    fn present(
        &mut self,
        ctx: &GpuContext,
        pass: &VisiblePass,
        report: &FrameReport,
    ) -> Result<(), GpuError>;
}

/// A presenter that shows nothing (replay, tests).
pub struct NoPresenter;

impl Presenter for NoPresenter {
    fn present(
        &mut self,
        _: &GpuContext,
        _: &VisiblePass,
        _: &FrameReport,
    ) -> Result<(), GpuError> {
        Ok(())
    }
}

/// Where cameras come from: a replayed path, or the viewer's input. Called
/// on the OR thread once per frame; `None` ends the run.
pub trait CameraSource: Send {
    fn next_camera(&mut self, frame: u64) -> Result<Option<CameraRequest>, CameraError>;
}

/// Cameras from a list (a replayed path), one frame each.
pub struct CameraList {
    pub cameras: Vec<CameraRequest>,
}

impl CameraList {
    /// One camera per pose, rendering to `viewport` with its near plane at
    /// `near`, every frame read back.
    pub fn from_poses(
        poses: &[gigawalk_scene::path::Pose],
        viewport: gigawalk_cull::Viewport,
        near: f64,
    ) -> Self {
        CameraList {
            cameras: poses
                .iter()
                .map(|p| CameraRequest::new(Camera::of_pose(p, viewport, near), true))
                .collect(),
        }
    }
}

impl CameraSource for CameraList {
    fn next_camera(&mut self, frame: u64) -> Result<Option<CameraRequest>, CameraError> {
        Ok(self.cameras.get(frame as usize).cloned())
    }
}

/// What one frame did.
#[derive(Clone, Debug)]
pub struct FrameReport {
    pub frame: u64,
    pub camera: Camera,
    /// When OR took the camera, and when RVG finished the frame.
    pub sampled_at: Instant,
    pub finished_at: Instant,
    /// Whether STC culled against an HZB (false in the startup bypass).
    pub occlusion_used: bool,
    pub occluder_items: usize,
    /// Occluder triangles OR drew, and those it had before the budget
    /// (frame i - lag's visible set with LODs re-selected for camera i).
    pub occluder_triangles: u64,
    pub occluder_candidates: u64,
    /// The budget OR drew with (`None`: all occluders), the adaptive
    /// controller's choice with `--occluder-budget adaptive`.
    pub occluder_limit: Option<u64>,
    pub or_ms: f64,
    pub hzb_ms: f64,
    /// The level of OR's depth pyramid the HZB was built from: read back
    /// from OR's device, coarser levels reduced by STC (0: the whole
    /// image, the pyramid built by STC).
    pub hzb_level: u32,
    /// STC's traversal (LOD selection and the culler's tests), and the
    /// culler's tests alone (ms; within `stc_ms`).
    pub traversal_ms: f64,
    pub cull_test_ms: f64,
    /// What OR's depth pass and RVG's visible pass cost the CPU this
    /// frame, step by step: encoding, submitting, waiting for the
    /// device, copying read-back data, and the bytes read back.
    pub or_pass: gigawalk_gpu::PassFigures,
    pub rvg_pass: gigawalk_gpu::PassFigures,
    /// What the culler did this frame beyond traversal (typed, and as
    /// named counts; none for the HZB).
    pub culler_work: Option<CullerWork>,
    /// The tiles' lists and what making them cost (tiled display only).
    pub tiles: Option<Arc<TileFrame>>,
    /// The pixel-error tolerance the frame was culled with (the options',
    /// or the request's).
    pub pixel_error: f64,
    /// A speculative frame (`RuntimeOptions::speculative_rvg`): the last
    /// finished visible set drawn with camera `frame` while STC was late;
    /// the real frame `frame` follows.
    pub speculative: bool,
    /// Milliseconds RVG waited for STC before this frame (pipelined
    /// schedule; 0 elsewhere).
    pub rvg_wait_ms: f64,
    /// All of STC, HZB build included.
    pub stc_ms: f64,
    pub rvg_ms: f64,
    pub stats: TraversalStats,
    /// Streaming figures of the device that drew the frame (zeros when the
    /// whole scene is resident).
    pub streaming: StreamStats,
    /// The nodes drawn and their LODs, in STC's order. Shared, not copied,
    /// with the stages that use the same set (OR's occluders, held frames).
    pub visible: Arc<[DrawItem]>,
    /// Nodes culled and why, when `RuntimeOptions::record_culled` is set.
    pub culled: Arc<[(u32, CullReason)]>,
    /// The frame reused an older visible set: culling was held (frozen), or
    /// asynchronous RVG drew before STC had this camera's set.
    pub reused_visible_set: bool,
    pub image: Option<FrameImage>,
}

impl FrameReport {
    /// Camera sampled -> frame finished.
    pub fn latency_ms(&self) -> f64 {
        (self.finished_at - self.sampled_at).as_secs_f64() * 1e3
    }

    /// What the adaptive occluder budget learns from the frame: nothing
    /// from a frame that drew another frame's set (speculative, held,
    /// asynchronous) or had no occluders to choose from.
    fn observation(&self) -> Option<occluders::Observation> {
        (!self.speculative && !self.reused_visible_set && self.occluder_candidates > 0).then_some(
            occluders::Observation {
                frame: self.frame,
                limit: self.occluder_limit,
                occluder_triangles: self.occluder_triangles,
                candidate_triangles: self.occluder_candidates,
                or_ms: self.or_ms,
                drawn_triangles: self.stats.drawn_triangles,
                rvg_ms: self.rvg_ms,
            },
        )
    }
}

/// A scene ready to render: its skeleton, and its geometry on each device
/// (all of it, or streamed under a memory budget).
pub struct Runtime<'s> {
    skeleton: &'s Skeleton,
    devices: Vec<GpuContext>,
    geometry: Vec<Geometry>,
    host_bytes: u64,
    /// Where LODs come from (streaming's loader, the grid culler's
    /// triangles).
    source: &'s dyn LodSource,
    /// Streaming: the pinned set and who holds what.
    plan: Option<Plan>,
}

impl<'s> Runtime<'s> {
    /// Opens `devices` (1 or 2) wgpu devices and uploads every LOD to each.
    pub fn new<R: ReadAt + Sync>(
        scene: &'s SceneReader<R>,
        devices: usize,
    ) -> Result<Self, RuntimeError> {
        Self::with_devices(scene, open_devices(devices, None)?)
    }

    /// Like [`Runtime::new`] with devices the caller opened (1 or 2).
    pub fn with_devices<R: ReadAt + Sync>(
        scene: &'s SceneReader<R>,
        devices: Vec<GpuContext>,
    ) -> Result<Self, RuntimeError> {
        Self::resident_reporting(scene, devices, &mut |_, _| {})
    }

    fn resident_reporting<R: ReadAt + Sync>(
        scene: &'s SceneReader<R>,
        devices: Vec<GpuContext>,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<Self, RuntimeError> {
        check_device_count(devices.len())?;
        check_index_range(scene.skeleton(), &devices)?;
        let host =
            HostGeometry::load_reporting(scene, buffer_limit(&devices), progress).map_err(setup)?;
        let geometry = devices
            .iter()
            .map(|d| host.upload(d).map(Geometry::Resident))
            .collect::<Result<Vec<_>, _>>()
            .map_err(setup)?;
        Ok(Runtime {
            skeleton: scene.skeleton(),
            devices,
            geometry,
            host_bytes: host.bytes(),
            source: scene,
            plan: None,
        })
    }

    /// Like [`Runtime::with_devices`], keeping at most `budget` bytes of
    /// geometry on each device: the scene's LODs are read while the walk
    /// runs (out of core). Only the pinned set is loaded here, so this
    /// returns in about the time it takes to read that. A scene that fits
    /// in the budget is loaded whole, as by [`Runtime::with_devices`].
    pub fn streaming<R: ReadAt + Sync>(
        scene: &'s SceneReader<R>,
        devices: Vec<GpuContext>,
        budget: u64,
    ) -> Result<Self, RuntimeError> {
        Self::streaming_reporting(scene, devices, budget, &mut |_, _| {})
    }

    /// Like [`Runtime::streaming`], streaming even a scene that fits the
    /// budget, with a pinned set of at most `pinned_max` bytes (read here:
    /// the first frame waits for it). For a page, which fetches what the
    /// walk needs rather than the file.
    pub fn streamed<R: ReadAt + Sync>(
        scene: &'s SceneReader<R>,
        devices: Vec<GpuContext>,
        budget: u64,
        pinned_max: u64,
    ) -> Result<Self, RuntimeError> {
        Self::stream(scene, devices, budget, pinned_max, &mut |_, _| {})
    }

    fn streaming_reporting<R: ReadAt + Sync>(
        scene: &'s SceneReader<R>,
        devices: Vec<GpuContext>,
        budget: u64,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<Self, RuntimeError> {
        if budget >= MIN_MEMORY_BUDGET && scene_device_bytes(scene.skeleton()) <= budget {
            return Self::resident_reporting(scene, devices, progress);
        }
        Self::stream(scene, devices, budget, PINNED_MAX, progress)
    }

    fn stream<R: ReadAt + Sync>(
        scene: &'s SceneReader<R>,
        devices: Vec<GpuContext>,
        budget: u64,
        pinned_max: u64,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<Self, RuntimeError> {
        check_device_count(devices.len())?;
        check_index_range(scene.skeleton(), &devices)?;
        if budget < MIN_MEMORY_BUDGET {
            return Err(RuntimeError::MemoryBudget {
                budget,
                min: MIN_MEMORY_BUDGET,
            });
        }
        let skeleton = scene.skeleton();
        let limit = buffer_limit(&devices);
        let plan = Plan::new(skeleton, budget, pinned_max);
        let mut streams = devices
            .iter()
            .enumerate()
            .map(|(i, d)| DeviceStream::new(d, i, skeleton, &plan, limit))
            .collect::<Result<Vec<_>, _>>()?;
        // The pinned set, read once for every device.
        let total = plan.pinned().count() as u64;
        if total == 0 {
            // Nothing fits the pinned share (the first node's coarsest LOD
            // is larger): say so rather than nothing.
            progress(0, 0);
        }
        for (done, l) in (1..).zip(plan.pinned()) {
            let lod =
                gigawalk_gpu::DecodedLod::read(scene, l).map_err(|source| RuntimeError::Load {
                    source: Box::new(source),
                })?;
            for (s, d) in streams.iter_mut().zip(&devices) {
                s.pin(d, &plan, l, &lod);
            }
            progress(done, total);
        }
        for d in &devices {
            d.flush();
        }
        let geometry = streams
            .into_iter()
            .map(|s| Geometry::Streamed(Box::new(Mutex::new(s))))
            .collect();
        Ok(Runtime {
            skeleton,
            devices,
            geometry,
            host_bytes: 0,
            source: scene,
            plan: Some(plan),
        })
    }

    /// Opens `devices` (1 or 2) wgpu devices (on an adapter whose name
    /// contains `adapter`, if given), then as [`Runtime::with_budget`].
    pub fn open<R: ReadAt + Sync>(
        scene: &'s SceneReader<R>,
        devices: usize,
        adapter: Option<&str>,
        budget: MemoryBudget,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<Self, RuntimeError> {
        Self::with_budget(scene, open_devices(devices, adapter)?, budget, progress)
    }

    /// Loads the scene whole onto `devices` ([`Runtime::with_devices`]) or
    /// streams it under `budget` a device ([`Runtime::streaming`]).
    /// `progress` hears (LODs read, LODs to read) after each LOD read before
    /// the first frame: every LOD when resident, the pinned set when
    /// streamed; (0, 0) once when there is none to read.
    pub fn with_budget<R: ReadAt + Sync>(
        scene: &'s SceneReader<R>,
        devices: Vec<GpuContext>,
        budget: MemoryBudget,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<Self, RuntimeError> {
        match budget
            .resolve()
            .map_err(RuntimeError::MemoryBudgetUnknown)?
        {
            None => Self::resident_reporting(scene, devices, progress),
            Some(bytes) => Self::streaming_reporting(scene, devices, bytes, progress),
        }
    }

    /// Whether `culler` can run on this runtime and scene: an error
    /// ([`RuntimeError::CullerUnavailable`]) saying why not. The scene's
    /// occluders are read (and checked) only for the culler that uses
    /// them; a stored but corrupt section is a load error naming it.
    pub fn check_culler(&self, culler: CullMethod) -> Result<(), RuntimeError> {
        let host = Host {
            device: true,
            resident: !self.is_streaming(),
            occluders: !culler.reads_occluders() || self.has_occluders()?,
        };
        culler
            .check(&host)
            .map_err(|why| RuntimeError::CullerUnavailable { culler, why })
    }

    /// Whether the scene stores occluders for the `ct` culler: reads its
    /// OCCL and OCVC sections. `false` only when the file has no OCCL
    /// section; a stored OCCL or OCVC that fails its checksum or its
    /// checks is an error naming the file and section, not "no occluders".
    pub fn has_occluders(&self) -> Result<bool, RuntimeError> {
        let load = |source| RuntimeError::Load {
            source: Box::new(source),
        };
        let Some(records) = self.source.occluders().map_err(load)? else {
            return Ok(false);
        };
        self.source.occluder_cells(records.len()).map_err(load)?;
        Ok(true)
    }

    /// Whether geometry is streamed under a memory budget.
    pub fn is_streaming(&self) -> bool {
        self.plan.is_some()
    }

    /// LODs of the pinned set (empty when not streaming). For tests
    /// (feature `testing`).
    #[cfg(feature = "testing")]
    pub fn pinned_lods(&self) -> Vec<u32> {
        self.plan
            .as_ref()
            .map_or(Vec::new(), |p| p.pinned().collect())
    }

    /// Whether every device holds every pinned LOD (the invariant that
    /// eviction never breaks, and asserts; trivially true when not
    /// streaming). For tests (feature `testing`).
    #[cfg(feature = "testing")]
    pub fn pinned_resident(&self) -> bool {
        let pinned = self.pinned_lods();
        self.geometry.iter().all(|g| match g {
            Geometry::Resident(_) => true,
            Geometry::Streamed(s) => {
                let s = s.lock().unwrap_or_else(|p| p.into_inner());
                pinned.iter().all(|&l| s.pool().contains(l))
            }
        })
    }

    pub fn skeleton(&self) -> &Skeleton {
        self.skeleton
    }

    /// Bytes of geometry each device holds: the whole scene, or when
    /// streaming the device memory of its pool (the budget, rounded down).
    pub fn resident_bytes(&self) -> u64 {
        match self.geometry.first() {
            Some(Geometry::Streamed(s)) => s
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .pool()
                .capacity_bytes(),
            _ => self.host_bytes,
        }
    }

    pub fn device_names(&self) -> Vec<String> {
        self.devices.iter().map(|d| d.name().to_string()).collect()
    }

    /// Whether the devices are the null adapter's (every GPU operation
    /// free, nothing drawn, depth read back as zeros): frame times are
    /// then what the CPU can feed.
    pub fn is_null(&self) -> bool {
        self.devices.iter().any(GpuContext::is_null)
    }

    /// Runs frames until the source ends, `on_frame` returns false, or a
    /// stage fails. `on_frame` is called on the caller's thread, in frame
    /// order.
    pub fn run(
        &self,
        opts: &RuntimeOptions,
        source: &mut dyn CameraSource,
        on_frame: &mut dyn FnMut(FrameReport) -> bool,
    ) -> Result<u64, RuntimeError> {
        self.run_presenting(opts, source, on_frame, &mut NoPresenter)
    }

    /// Like [`Runtime::run`], showing every frame through `presenter` on
    /// the RVG thread.
    pub fn run_presenting(
        &self,
        opts: &RuntimeOptions,
        source: &mut dyn CameraSource,
        on_frame: &mut dyn FnMut(FrameReport) -> bool,
        presenter: &mut dyn Presenter,
    ) -> Result<u64, RuntimeError> {
        let opts = opts.resolve(self.rasterizes_on_cpu())?;
        schedule(Target::gpu(self), &opts, source, on_frame, presenter)
    }

    /// What the occluder budget `budget` means on these devices (resolves
    /// [`OccluderBudget::Auto`]).
    pub fn occluder_selection(&self, budget: OccluderBudget) -> OccluderSelection {
        budget.resolve(self.rasterizes_on_cpu())
    }

    /// Whether any device rasterizes on the CPU (llvmpipe, lavapipe): its
    /// cores are the CPU stages' too.
    pub(crate) fn rasterizes_on_cpu(&self) -> bool {
        self.devices.iter().any(GpuContext::is_cpu)
    }

    /// Device `i` (0 = OR's; RVG uses 1 when there are two; the last one
    /// for any larger `i`). A runtime always has one or two devices.
    pub fn device(&self, i: usize) -> &GpuContext {
        &self.devices[i.min(self.devices.len().saturating_sub(1))]
    }
}

/// Runs `opts`'s schedule on `target` with the occluder budget resolved;
/// an adaptive budget hears of every finished frame before `on_frame`.
fn schedule(
    target: Target,
    opts: &ResolvedOptions,
    source: &mut dyn CameraSource,
    on_frame: &mut dyn FnMut(FrameReport) -> bool,
    presenter: &mut dyn Presenter,
) -> Result<u64, RuntimeError> {
    let control = Mutex::new(occluders::AdaptiveBudget::new(target.or_shares_rvg(opts)));
    let selection = opts.occluders;
    let target = target.with_occluders(match selection {
        OccluderSelection::All => stages::OrBudget::All,
        OccluderSelection::Triangles(t) => stages::OrBudget::Triangles(t),
        OccluderSelection::Adaptive => stages::OrBudget::Adaptive(&control),
    });
    let adaptive = selection == OccluderSelection::Adaptive;
    let on_frame = &mut |r: FrameReport| {
        if let Some(o) = adaptive.then(|| r.observation()).flatten() {
            occluders::lock(&control).observe(o);
        }
        on_frame(r)
    };
    match (opts.schedule, opts.async_rvg) {
        (Schedule::Sequential, _) => {
            pipeline::run_sequential(target, opts, source, on_frame, presenter)
        }
        (Schedule::Pipelined, false) => {
            pipeline::run_pipelined(target, opts, source, on_frame, presenter)
        }
        (Schedule::Pipelined, true) => {
            pipeline::run_async(target, opts, source, on_frame, presenter)
        }
    }
}

/// Runs `opts`'s schedule (threads, queues, occluder lag, frozen culling,
/// asynchronous RVG: the same code as [`Runtime::run`]) with OR and RVG
/// drawing on the CPU: gigawalk-cull's conservative software depth
/// rasterizer, LODs read from `source` on first use, colour all zeros, no
/// streaming, `devices` ignored, `auto` occluder budget as on a CPU
/// rasterizer. For testing the schedules without an adapter (feature
/// `testing`).
#[cfg(feature = "testing")]
pub fn run_on_cpu(
    skeleton: &Skeleton,
    source: &dyn LodSource,
    opts: &RuntimeOptions,
    cameras: &mut dyn CameraSource,
    on_frame: &mut dyn FnMut(FrameReport) -> bool,
) -> Result<u64, RuntimeError> {
    let opts = opts.resolve(true)?;
    schedule(
        Target::cpu(skeleton, source),
        &opts,
        cameras,
        on_frame,
        &mut NoPresenter,
    )
}

/// The pipeline uses one or two devices.
fn check_device_count(count: usize) -> Result<(), RuntimeError> {
    if (1..=2).contains(&count) {
        Ok(())
    } else {
        Err(RuntimeError::DeviceCount { count })
    }
}

/// Every LOD's indices stay within each device's index range (some GL
/// drivers index at most 2^24 vertices): an error naming the largest LOD
/// when it does not, before anything is loaded. Indices are local to a
/// LOD; should a driver bound `base_vertex + index` instead, the geometry
/// buffers' 256 MiB cap ([`buffer_limit`]: at most 13.4M 20-byte vertices
/// a buffer) keeps that within 2^24 too.
fn check_index_range(skeleton: &Skeleton, devices: &[GpuContext]) -> Result<(), RuntimeError> {
    let Some((lod, most)) = (0..)
        .zip(skeleton.lods())
        .max_by_key(|(_, l)| l.vertices)
        .map(|(k, l)| (k, l.vertices as u64))
    else {
        return Ok(());
    };
    for d in devices {
        if most > d.max_lod_vertices() {
            return Err(setup(GpuError::IndexRange {
                lod,
                vertices: most,
                device: d.name().to_string(),
                max: d.max_lod_vertices(),
            }));
        }
    }
    Ok(())
}

/// Whether every device of `devices` draws a `width` x `height` viewport.
pub(crate) fn check_viewport(
    devices: &[GpuContext],
    width: u32,
    height: u32,
) -> Result<(), RuntimeError> {
    for d in devices {
        let max = d.max_texture_side();
        if width > max || height > max {
            return Err(RuntimeError::Viewport {
                width,
                height,
                device: d.name().to_string(),
                max,
            });
        }
    }
    Ok(())
}

/// Opens the `count` (1 or 2) devices a run would use (on an adapter whose
/// name contains `adapter`, if given), checks that they take a `width` x
/// `height` viewport, and closes them again; returns their names. For
/// callers with long work before the run (generating, preprocessing,
/// loading): a machine that cannot render hears so in about a second.
pub fn probe_devices(
    count: usize,
    adapter: Option<&str>,
    width: u32,
    height: u32,
) -> Result<Vec<String>, RuntimeError> {
    let devices = open_devices(count, adapter)?;
    check_viewport(&devices, width, height)?;
    Ok(devices.iter().map(|d| d.name().to_string()).collect())
}

/// Opens `count` (1 or 2) wgpu devices, on an adapter whose name contains
/// `adapter` if given.
fn open_devices(count: usize, adapter: Option<&str>) -> Result<Vec<GpuContext>, RuntimeError> {
    check_device_count(count)?;
    gigawalk_gpu::open_devices_on(count, adapter).map_err(setup)
}

/// The largest geometry buffer every device takes (at most 256 MiB).
fn buffer_limit(devices: &[GpuContext]) -> u64 {
    devices
        .iter()
        .map(|d| d.max_buffer_size())
        .min()
        .unwrap_or(1 << 28)
        .min(1 << 28)
}

/// A device-setup error: opening devices or loading geometry onto them.
fn setup(source: GpuError) -> RuntimeError {
    RuntimeError::Setup { source }
}
