//! The work of each stage for one frame, shared by the pipelined and the
//! sequential schedule (so both run the same algorithms).

use std::sync::{Arc, Mutex};
use std::time::Instant;

use gigawalk_cull::tiles::{self, TileFrustums, TileGrid, TileMethod};
use gigawalk_cull::{
    reselect_lods, select_occluders, BoxTest, Camera, Containment, CtStats, CullReason, CullView,
    DrawItem, Frustum, GridStats, NoOcclusion, OcclusionTest, RelBox, SoftDepth, TraversalOptions,
    TraversalStats, Traverser, TriangleSource, ALL_PLANES,
};
use gigawalk_gpu::{DepthImage, DepthPass, DrawStyle, FrameImage, GpuContext, VisiblePass};
use gigawalk_scene::Skeleton;

use crate::cullers::OqStats;
use crate::occluders::AdaptiveBudget;
use crate::streaming::{Geometry, Link, LodSource, Plan, Request, StreamStats, Use, PREFETCH_BAND};
use crate::triangles::TriangleCache;
use crate::{gpu_view, ms_since, Presenter, Runtime, RuntimeError, RuntimeOptions, Stage};

/// A stage's device, its geometry there, and (streaming) its end of the
/// run's loader queues.
pub(crate) struct DeviceGeometry<'a> {
    pub ctx: &'a GpuContext,
    pub geometry: &'a Geometry,
    pub skeleton: &'a Skeleton,
    pub plan: Option<&'a Plan>,
    pub link: Option<Link>,
}

impl<'a> DeviceGeometry<'a> {
    pub fn new(rt: &'a Runtime, device: usize, link: Option<Link>) -> Self {
        DeviceGeometry {
            ctx: &rt.devices[device],
            geometry: &rt.geometry[device],
            skeleton: rt.skeleton,
            plan: rt.plan.as_ref(),
            link,
        }
    }

    /// Runs `f` with what to draw for `lods` (see `Geometry::with`); an
    /// error when the loader has stopped (its own error is the cause).
    fn with<T>(
        &self,
        frame: u64,
        lods: &[u32],
        usage: Use,
        f: impl FnOnce(&dyn gigawalk_gpu::Residency, &[u32]) -> T,
    ) -> Result<T, RuntimeError> {
        self.geometry
            .with(
                self.ctx,
                self.skeleton,
                self.plan,
                self.link.as_ref(),
                frame,
                lods,
                usage,
                f,
            )
            .ok_or(RuntimeError::LoaderStopped)
    }

    pub fn take_stats(&self) -> StreamStats {
        self.geometry.take_stats()
    }
}

/// Absolute LOD ids (indices into `Skeleton::lods`) of draw items.
pub(crate) fn lod_ids(skeleton: &Skeleton, items: &[DrawItem]) -> Vec<u32> {
    items
        .iter()
        .map(|i| skeleton.nodes[i.node as usize].first_lod + i.lod)
        .collect()
}

/// The test hook `RuntimeOptions::inject_failure` (feature `testing`).
#[cfg(feature = "testing")]
pub(crate) fn check_injected(
    opts: &RuntimeOptions,
    stage: Stage,
    frame: u64,
) -> Result<(), RuntimeError> {
    match opts.inject_failure {
        // ">=": with asynchronous RVG, OR and STC may skip the exact frame.
        Some((s, f)) if s == stage && frame >= f => Err(RuntimeError::Injected { stage, frame: f }),
        _ => Ok(()),
    }
}

/// Without the `testing` feature there is no hook: nothing to check.
#[cfg(not(feature = "testing"))]
pub(crate) fn check_injected(_: &RuntimeOptions, _: Stage, _: u64) -> Result<(), RuntimeError> {
    Ok(())
}

/// What the stages draw on: the runtime's wgpu devices, or (the
/// `testing` feature's `run_on_cpu`) the CPU's software depth
/// rasterizer, so the schedules can be tested without an adapter.
#[derive(Clone, Copy)]
pub(crate) struct Target<'a> {
    pub skeleton: &'a Skeleton,
    pub source: &'a dyn LodSource,
    pub plan: Option<&'a Plan>,
    gpu: Option<&'a Runtime<'a>>,
    /// How many occluders OR draws (set by the schedule).
    pub occluders: OrBudget<'a>,
}

/// The occluder budget as OR applies it.
#[derive(Clone, Copy)]
pub(crate) enum OrBudget<'a> {
    All,
    Triangles(u64),
    Adaptive(&'a Mutex<AdaptiveBudget>),
}

impl<'a> Target<'a> {
    pub fn gpu(rt: &'a Runtime<'a>) -> Self {
        Target {
            skeleton: rt.skeleton,
            source: rt.source,
            plan: rt.plan.as_ref(),
            gpu: Some(rt),
            occluders: OrBudget::All,
        }
    }

    /// Depth only, no colour, no streaming (see [`CpuRaster`]).
    #[cfg_attr(not(feature = "testing"), allow(dead_code))]
    pub fn cpu(skeleton: &'a Skeleton, source: &'a dyn LodSource) -> Self {
        Target {
            skeleton,
            source,
            plan: None,
            gpu: None,
            occluders: OrBudget::All,
        }
    }

    /// The same target, OR drawing occluders by `occluders`.
    pub fn with_occluders<'b>(self, occluders: OrBudget<'b>) -> Target<'b>
    where
        'a: 'b,
    {
        Target { occluders, ..self }
    }

    /// Whether OR's time comes out of RVG's: one device, a CPU rasterizer
    /// (its cores are RVG's), or the sequential schedule.
    pub fn or_shares_rvg(&self, opts: &RuntimeOptions) -> bool {
        match self.gpu {
            None => true,
            Some(rt) => {
                opts.schedule == crate::Schedule::Sequential
                    || self.rvg_device(opts) == 0
                    || rt.devices.iter().any(GpuContext::is_cpu)
            }
        }
    }

    /// The device RVG draws on: the second when there are two and the
    /// options ask for two.
    pub fn rvg_device(&self, opts: &RuntimeOptions) -> usize {
        match self.gpu {
            Some(rt) if opts.devices >= 2 && rt.devices.len() >= 2 => 1,
            _ => 0,
        }
    }

    /// STC, with the occlusion-query culler's device state when the
    /// options ask for it (on RVG's device `rvg_device`, whose whole
    /// geometry must be resident).
    pub fn stc_stage(
        &self,
        opts: &'a RuntimeOptions,
        rvg_device: usize,
        prefetch: Option<Prefetch<'a>>,
    ) -> Result<StcStage<'a>, RuntimeError> {
        let mut stc = StcStage::new(self.skeleton, opts, prefetch);
        if opts.traversal.occlusion {
            let setup = crate::cullers::Setup {
                source: self.source,
                gpu: self.gpu,
                rvg_device,
            };
            stc.culler = Some(crate::cullers::State::new(&setup, opts)?);
        }
        Ok(stc)
    }

    /// OR on device 0.
    pub fn or_stage(&self, opts: &'a RuntimeOptions, link: Option<Link>) -> OrStage<'a> {
        let (w, h) = opts.occluder_size();
        let render = match self.gpu {
            Some(rt) => {
                let device = DeviceGeometry::new(rt, 0, link);
                OrRender::Gpu {
                    pass: Box::new(DepthPass::new(device.ctx, w, h)),
                    device,
                }
            }
            None => OrRender::Cpu(Box::new(CpuRaster::new(self.source, w, h))),
        };
        OrStage {
            skeleton: self.skeleton,
            opts,
            budget: self.occluders,
            render,
        }
    }

    /// RVG on `device`.
    pub fn rvg_stage(
        &self,
        opts: &'a RuntimeOptions,
        device: usize,
        link: Option<Link>,
    ) -> RvgStage<'a> {
        let render = match self.gpu {
            Some(rt) => {
                let device = DeviceGeometry::new(rt, device, link);
                RvgRender::Gpu {
                    pass: Box::new(VisiblePass::new(device.ctx, opts.width, opts.height)),
                    device,
                }
            }
            None => RvgRender::Cpu(Box::new(CpuRaster::new(
                self.source,
                opts.width,
                opts.height,
            ))),
        };
        RvgStage {
            render,
            opts,
            started: None,
            frame: 0,
        }
    }
}

/// The CPU's stand-in for a device: LODs drawn into a software depth
/// image (gigawalk-cull's conservative rasterizer) from triangles read
/// on first use. Depth only; colour reads back as zeros.
pub(crate) struct CpuRaster<'a> {
    triangles: TriangleCache<'a>,
    soft: SoftDepth,
    view_proj: glam::DMat4,
    eye: glam::DVec3,
    width: u32,
    height: u32,
}

impl<'a> CpuRaster<'a> {
    fn new(source: &'a dyn LodSource, width: u32, height: u32) -> Self {
        CpuRaster {
            triangles: TriangleCache::new(source, u64::MAX),
            soft: SoftDepth::new(),
            view_proj: glam::DMat4::IDENTITY,
            eye: glam::DVec3::ZERO,
            width,
            height,
        }
    }

    fn begin(&mut self, view: &CullView) {
        self.soft.reset(self.width, self.height);
        self.view_proj = view.camera.view_projection_rel_f64();
        self.eye = view.camera.position;
    }

    fn draw(&mut self, lods: &[u32]) {
        for &l in lods {
            if let Some(t) = self.triangles.lod_triangles(l) {
                self.soft
                    .draw_mesh(&self.view_proj, t.origin - self.eye, t.positions, t.indices);
            }
        }
    }

    fn depth(&self) -> DepthImage {
        DepthImage {
            width: self.width,
            height: self.height,
            depth: self.soft.depth().to_vec(),
        }
    }
}

/// OR's drawing: a depth pass on a device, or the CPU.
enum OrRender<'a> {
    Gpu {
        device: DeviceGeometry<'a>,
        pass: Box<DepthPass>,
    },
    Cpu(Box<CpuRaster<'a>>),
}

/// OR: the depth of frame i - lag's visible nodes, LODs re-selected for
/// camera i (Section 5.2), at the occluder resolution.
pub(crate) struct OrStage<'a> {
    skeleton: &'a Skeleton,
    opts: &'a RuntimeOptions,
    budget: OrBudget<'a>,
    render: OrRender<'a>,
}

pub(crate) struct OrOutput {
    pub depth: Option<DepthImage>,
    pub figures: OrFigures,
}

/// What OR did for a frame, as the frame's report carries it.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct OrFigures {
    pub items: usize,
    /// Occluder triangles drawn, and those before the budget.
    pub triangles: u64,
    pub candidates: u64,
    /// The budget applied (`None`: all).
    pub limit: Option<u64>,
    pub ms: f64,
}

impl<'a> OrStage<'a> {
    /// `occluders` is `None` during the startup bypass or with occlusion off.
    /// `tolerance` overrides the options' pixel error for this frame.
    pub fn run(
        &mut self,
        frame: u64,
        view: &CullView,
        tolerance: Option<f64>,
        occluders: Option<&[DrawItem]>,
    ) -> Result<OrOutput, RuntimeError> {
        let _span = tracing::info_span!("OR", frame).entered();
        let t = Instant::now();
        check_injected(self.opts, Stage::Or, frame)?;
        let none = |t: Instant, figures: OrFigures| OrOutput {
            depth: None,
            figures: OrFigures {
                ms: ms_since(t),
                ..figures
            },
        };
        let Some(occluders) = occluders else {
            return Ok(none(t, OrFigures::default()));
        };
        // The same LOD choice STC makes for this camera (conservative mode).
        let mut items = Vec::with_capacity(occluders.len());
        let traversal = TraversalOptions {
            pixel_tolerance: tolerance.unwrap_or(self.opts.traversal.pixel_tolerance),
            ..self.opts.traversal
        };
        reselect_lods(self.skeleton, view, &traversal, occluders, &mut |i| {
            items.push(i)
        });
        let candidates = item_triangles(self.skeleton, &items);
        let limit = match self.budget {
            OrBudget::All => None,
            OrBudget::Triangles(t) => Some(t),
            OrBudget::Adaptive(c) => crate::occluders::lock(c).limit_for(frame),
        };
        // Streaming, all of them best first too: the pool keeps those that
        // fit it first.
        let streaming =
            matches!(&self.render, OrRender::Gpu { device, .. } if device.plan.is_some());
        let triangles = match limit {
            Some(budget) => select_occluders(self.skeleton, view, &mut items, budget),
            None if streaming => select_occluders(self.skeleton, view, &mut items, u64::MAX),
            None => candidates,
        };
        let figures = OrFigures {
            items: items.len(),
            triangles,
            candidates,
            limit,
            ms: 0.0,
        };
        if items.is_empty() {
            // No occluder (a budget of 0, or nothing in view): an all-far
            // HZB would cull nothing, so STC skips occlusion for this frame.
            return Ok(none(t, figures));
        }
        let lods = lod_ids(self.skeleton, &items);
        let depth = match &mut self.render {
            OrRender::Gpu { device, pass } => {
                let ctx = device.ctx;
                // Streaming: resident occluders only (culling stays
                // conservative).
                device
                    .with(frame, &lods, Use::Occluders, |residency, lods| {
                        pass.render(ctx, residency, &gpu_view(view), lods)
                    })?
                    .map_err(|source| RuntimeError::Gpu {
                        stage: Stage::Or,
                        source,
                    })?
            }
            OrRender::Cpu(c) => {
                c.begin(view);
                c.draw(&lods);
                c.depth()
            }
        };
        Ok(OrOutput {
            depth: Some(depth),
            figures: OrFigures {
                ms: ms_since(t),
                ..figures
            },
        })
    }
}

/// Triangles of `items`' LODs (those the skeleton has).
fn item_triangles(skeleton: &Skeleton, items: &[DrawItem]) -> u64 {
    items
        .iter()
        .filter_map(|i| {
            let n = skeleton.nodes.get(i.node as usize)?;
            (i.lod < n.lod_count).then_some(())?;
            skeleton.lods.get((n.first_lod + i.lod) as usize)
        })
        .map(|l| u64::from(l.triangles))
        .sum()
}

/// STC's end of the loader's request queue (streaming with prefetch).
pub(crate) struct Prefetch<'a> {
    pub requests: crossbeam_channel::Sender<Request>,
    pub plan: &'a Plan,
    /// The run's devices (bits of `Plan::held`).
    pub mask: u8,
}

impl Prefetch<'_> {
    /// Asks for what `item` switches to when the camera comes closer, if
    /// its pixel error is within [`PREFETCH_BAND`] of the tolerance: the
    /// node's next finer LOD, or for an inner node's finest HLOD its
    /// children's coarsest LODs.
    fn item(
        &self,
        skeleton: &Skeleton,
        view: &CullView,
        tolerance: f64,
        frame: u64,
        item: DrawItem,
    ) {
        let n = &skeleton.nodes[item.node as usize];
        let Some(l) = skeleton.lods.get((n.first_lod + item.lod) as usize) else {
            return;
        };
        let (min, max) = view.rel_f64(&n.bounds);
        let pe = gigawalk_cull::lod::pixel_error(
            l.error,
            view.lod_distance(min, max),
            view.pixels_per_radian,
        );
        if pe <= PREFETCH_BAND * tolerance {
            return;
        }
        if item.lod > 0 {
            self.ask(frame, n.first_lod + item.lod - 1);
        } else {
            for c in n.children() {
                let c = &skeleton.nodes[c as usize];
                if c.lod_count > 0 {
                    self.ask(frame, c.first_lod + c.lod_count - 1);
                }
            }
        }
    }

    /// Asks for `lod` unless every device of the run holds it; a full
    /// queue drops the request (prefetching is best effort).
    fn ask(&self, frame: u64, lod: u32) -> bool {
        let ask = !self.plan.held_by(lod, self.mask);
        if ask {
            let _ = self.requests.try_send(Request {
                lod,
                frame: self.plan.frame(frame),
                prefetch: true,
            });
        }
        ask
    }

    /// Asks for what the view would draw in a ring around its frustum
    /// ([`PREFETCH_MARGIN`] wider, at the view's own pixel scale), near
    /// first: what a turn or a sideways step brings into view. Occlusion
    /// is not tested (what a turn reveals is not known yet); subtrees
    /// wholly inside the frustum are skipped (the frame itself asks for
    /// what it draws there).
    fn margin(
        &self,
        traverser: &mut Traverser,
        skeleton: &Skeleton,
        view: &CullView,
        options: &TraversalOptions,
        frame: u64,
    ) {
        let half = (view.camera.fovy * 0.5).tan() * (1.0 + PREFETCH_MARGIN);
        let wide_camera = Camera {
            fovy: 2.0 * half.atan(),
            ..view.camera
        };
        let mut wide = CullView::new(wide_camera, view.viewport);
        wide.pixels_per_radian = view.pixels_per_radian;
        let mut asked = 0;
        let mut sink = |item: DrawItem| {
            let n = &skeleton.nodes[item.node as usize];
            if asked < PREFETCH_MARGIN_LODS && self.ask(frame, n.first_lod + item.lod) {
                asked += 1;
            }
        };
        let ring = TraversalOptions {
            occlusion: true,
            ..*options
        };
        traverser.traverse(skeleton, &wide, &OutsideOf(&view.frustum), &ring, &mut sink);
    }
}

/// How much wider (in the tangent of the half field of view, both ways)
/// than the view the ring STC prefetches around the frustum is.
pub const PREFETCH_MARGIN: f64 = 0.25;
/// At most this many LODs of that ring are asked for a frame.
const PREFETCH_MARGIN_LODS: usize = 256;

/// "Visible" for a box not wholly inside `frustum`: a traversal with it
/// as its occlusion test visits only the ring outside that frustum.
struct OutsideOf<'a>(&'a Frustum);

impl OcclusionTest for OutsideOf<'_> {
    fn is_visible(&self, _: &CullView, b: &RelBox) -> bool {
        let (min, max) = (b.min.as_dvec3(), b.max.as_dvec3());
        self.0.test(min, max, ALL_PLANES).0 != Containment::Inside
    }
}

/// STC: HZB from OR's depth, then traversal (Algorithm 5.2); or the lazy
/// occlusion grid over what it draws itself.
pub(crate) struct StcStage<'a> {
    pub skeleton: &'a Skeleton,
    pub opts: &'a RuntimeOptions,
    traverser: Traverser,
    /// The occlusion culler's state (with occlusion on).
    culler: Option<crate::cullers::State<'a>>,
    prefetch: Option<Prefetch<'a>>,
}

/// One frame's culling result. Cheap to clone: the visible set is shared
/// by RVG, OR's occluders of a later frame, a held frame and the report.
#[derive(Clone)]
pub(crate) struct StcOutput {
    pub stats: TraversalStats,
    pub visible: Arc<[DrawItem]>,
    pub culled: Arc<[(u32, CullReason)]>,
    pub occlusion_used: bool,
    pub hzb_ms: f64,
    /// The lazy occlusion grid's work (grid culler only).
    pub grid: Option<GridStats>,
    /// The occlusion queries' work (oq culler only).
    pub oq: Option<OqStats>,
    /// The object-space culler's work (ct culler only).
    pub ct: Option<CtStats>,
    /// The tiles' draw lists (a tiled display only).
    pub tiles: Option<Arc<TileFrame>>,
    /// The pixel-error tolerance traversal used.
    pub tolerance: f64,
    pub ms: f64,
}

/// One frame's tiles: what each draws, and what sending items to them
/// cost.
#[derive(Clone, Debug)]
pub struct TileFrame {
    pub grid: TileGrid,
    /// Per tile, its pixel rectangle `[x, y, w, h]` and the indices of the
    /// frame's visible items it draws.
    pub rects: Vec<[u32; 4]>,
    pub lists: Vec<Vec<u32>>,
    /// Milliseconds sending the items to the tiles by the adaptive and the
    /// naive method (both run every frame), and box tests of the one used.
    pub ms_adaptive: f64,
    pub ms_naive: f64,
    pub tests: u64,
    /// Triangles of the busiest tile, and the mean over tiles.
    pub max_triangles: u64,
    pub mean_triangles: f64,
}

impl TileFrame {
    /// Sends `visible` to the tiles of `grid` by `method`, timing the
    /// adaptive and naive methods on the same items.
    pub fn new(
        skeleton: &Skeleton,
        view: &CullView,
        grid: TileGrid,
        method: TileMethod,
        visible: &[DrawItem],
    ) -> TileFrame {
        let timed = |m: TileMethod| {
            let t = Instant::now();
            let tiles = TileFrustums::new(view, grid);
            let lists = tiles::assign(skeleton, view, &tiles, visible, m);
            (lists, ms_since(t))
        };
        let (adaptive, ms_adaptive) = timed(TileMethod::Adaptive);
        let (naive, ms_naive) = timed(TileMethod::Naive);
        let used = match method {
            TileMethod::Adaptive => adaptive,
            TileMethod::Naive => naive,
            m => timed(m).0,
        };
        let triangles: Vec<u64> = used
            .lists
            .iter()
            .map(|l| {
                l.iter()
                    .map(|&i| {
                        let it = visible[i as usize];
                        let lod = skeleton.nodes[it.node as usize].first_lod + it.lod;
                        skeleton
                            .lods
                            .get(lod as usize)
                            .map_or(0, |l| l.triangles as u64)
                    })
                    .sum()
            })
            .collect();
        let (w, h) = (view.viewport.width, view.viewport.height);
        TileFrame {
            grid,
            rects: (0..grid.count()).map(|t| grid.rect(t, w, h)).collect(),
            lists: used.lists,
            ms_adaptive,
            ms_naive,
            tests: used.tests,
            max_triangles: triangles.iter().copied().max().unwrap_or(0),
            mean_triangles: triangles.iter().sum::<u64>() as f64 / triangles.len().max(1) as f64,
        }
    }
}

impl<'a> StcStage<'a> {
    /// Without a culler; [`Target::stc_stage`] sets it up.
    fn new(
        skeleton: &'a Skeleton,
        opts: &'a RuntimeOptions,
        prefetch: Option<Prefetch<'a>>,
    ) -> Self {
        StcStage {
            skeleton,
            opts,
            traverser: Traverser::new(),
            culler: None,
            prefetch,
        }
    }

    /// Traverses, handing every item to `emit` as it is found; `tolerance`
    /// overrides the options' pixel error for this frame.
    pub fn run(
        &mut self,
        frame: u64,
        view: &CullView,
        tolerance: Option<f64>,
        depth: Option<&DepthImage>,
        emit: &mut dyn FnMut(DrawItem),
    ) -> Result<StcOutput, RuntimeError> {
        let _span = tracing::info_span!("STC", frame).entered();
        let t = Instant::now();
        if self.opts.stc_delay_ms > 0.0 {
            std::thread::sleep(std::time::Duration::from_secs_f64(
                self.opts.stc_delay_ms / 1e3,
            ));
        }
        check_injected(self.opts, Stage::Stc, frame)?;
        // The culler, when occlusion is on, and whether it culls this
        // frame (the HZB needs OR's depth: none in the startup bypass).
        let (occlusion, hzb_ms) = match self.culler.as_mut() {
            Some(c) => c.prepare(frame, depth, self.opts)?,
            None => (false, 0.0),
        };
        let options = TraversalOptions {
            occlusion,
            pixel_tolerance: tolerance.unwrap_or(self.opts.traversal.pixel_tolerance),
            ..self.opts.traversal
        };
        let mut visible = Vec::new();
        let tolerance = options.pixel_tolerance;
        let band = self
            .prefetch
            .as_ref()
            .filter(|_| self.opts.prefetch.band() && options.hlod && tolerance > 0.0);
        let skeleton = self.skeleton;
        let mut sink = |item: DrawItem| {
            visible.push(item);
            emit(item);
            if let Some(p) = band {
                p.item(skeleton, view, tolerance, frame, item);
            }
        };
        let mut culled = Vec::new();
        let record = self.opts.record_culled;
        let mut on_cull = |node, why| {
            if record {
                culled.push((node, why));
            }
        };
        let (stats, work) = match self.culler.as_mut().filter(|_| occlusion) {
            Some(c) => c.cull(
                &mut crate::cullers::Traversal {
                    traverser: &mut self.traverser,
                    skeleton,
                    view,
                    options: &options,
                    sink: &mut sink,
                    on_cull: &mut on_cull,
                },
                self.opts,
            )?,
            None => (
                self.traverser.traverse_culled(
                    skeleton,
                    view,
                    &mut BoxTest(&NoOcclusion),
                    &options,
                    &mut sink,
                    &mut on_cull,
                ),
                crate::cullers::Work::default(),
            ),
        };
        if let Some(p) = self.prefetch.as_ref().filter(|_| self.opts.prefetch.ring()) {
            p.margin(&mut self.traverser, skeleton, view, &options, frame);
        }
        let tiles = self.opts.tiles.map(|grid| {
            let _s = tracing::info_span!("tiles", frame).entered();
            Arc::new(TileFrame::new(
                skeleton,
                view,
                grid,
                self.opts.tile_culling,
                &visible,
            ))
        });
        Ok(StcOutput {
            tiles,
            tolerance: options.pixel_tolerance,
            stats,
            culled: culled.into(),
            visible: visible.into(),
            occlusion_used: occlusion,
            hzb_ms,
            grid: work.grid,
            oq: work.oq,
            ct: work.ct,
            ms: ms_since(t),
        })
    }
}

/// RVG's drawing: a visible pass on a device, or the CPU.
enum RvgRender<'a> {
    Gpu {
        device: DeviceGeometry<'a>,
        pass: Box<VisiblePass>,
    },
    Cpu(Box<CpuRaster<'a>>),
}

/// RVG: draws a frame's items as they arrive.
pub(crate) struct RvgStage<'a> {
    render: RvgRender<'a>,
    opts: &'a RuntimeOptions,
    started: Option<Instant>,
    frame: u64,
}

fn rvg_error(source: gigawalk_gpu::GpuError) -> RuntimeError {
    RuntimeError::Gpu {
        stage: Stage::Rvg,
        source,
    }
}

impl<'a> RvgStage<'a> {
    pub fn begin(
        &mut self,
        frame: u64,
        view: &CullView,
        style: DrawStyle,
    ) -> Result<(), RuntimeError> {
        check_injected(self.opts, Stage::Rvg, frame)?;
        self.started = Some(Instant::now());
        self.frame = frame;
        match &mut self.render {
            RvgRender::Gpu { device, pass } => pass.begin(device.ctx, &gpu_view(view), style),
            RvgRender::Cpu(c) => c.begin(view),
        }
        Ok(())
    }

    /// The rectangle `[x, y, w, h]` later chunks draw into (a tile), or
    /// the whole viewport.
    pub fn scissor(&mut self, rect: Option<[u32; 4]>) {
        match &mut self.render {
            RvgRender::Gpu { pass, .. } => pass.set_scissor(rect),
            RvgRender::Cpu(c) => c.soft.set_scissor(rect),
        }
    }

    /// Draws a chunk of the frame's LODs (streaming: resident ones and
    /// stand-ins for the rest).
    pub fn draw(&mut self, lods: &[u32]) -> Result<(), RuntimeError> {
        let _span = tracing::info_span!("RVG chunk", items = lods.len()).entered();
        match &mut self.render {
            RvgRender::Gpu { device, pass } => {
                let ctx = device.ctx;
                device.with(self.frame, lods, Use::Visible, |residency, lods| {
                    pass.draw(ctx, residency, lods)
                })
            }
            RvgRender::Cpu(c) => {
                c.draw(lods);
                Ok(())
            }
        }
    }

    /// The frame's streaming figures (call once, as the frame ends).
    pub fn stream_stats(&self) -> StreamStats {
        match &self.render {
            RvgRender::Gpu { device, .. } => device.take_stats(),
            RvgRender::Cpu(_) => StreamStats::default(),
        }
    }

    /// Shows the finished frame (a device only).
    pub fn present(
        &mut self,
        presenter: &mut dyn Presenter,
        report: &crate::FrameReport,
    ) -> Result<(), RuntimeError> {
        match &self.render {
            RvgRender::Gpu { device, pass } => presenter
                .present(device.ctx, pass, report)
                .map_err(rvg_error),
            RvgRender::Cpu(_) => Ok(()),
        }
    }

    /// Reads back the finished frame's colour and depth.
    pub fn read_back(&mut self) -> Result<Option<FrameImage>, RuntimeError> {
        match &mut self.render {
            RvgRender::Gpu { device, pass } => {
                pass.read_back(device.ctx).map(Some).map_err(rvg_error)
            }
            RvgRender::Cpu(c) => Ok(Some(FrameImage {
                colour: vec![0; c.width as usize * c.height as usize * 4],
                depth: c.depth(),
            })),
        }
    }

    /// Waits for the frame; returns the stage's ms.
    pub fn finish(&mut self) -> Result<f64, RuntimeError> {
        if let RvgRender::Gpu { device, pass } = &mut self.render {
            pass.finish(device.ctx, false).map_err(rvg_error)?;
        }
        Ok(self.started.take().map_or(0.0, ms_since))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gigawalk_cull::Viewport;
    use gigawalk_scene::{Aabb, IndexFormat, LodInfo, Node, Skeleton, NO_NODE};
    use glam::DVec3;

    /// A root (no LODs) over one-LOD unit boxes every 2 degrees on a
    /// horizontal circle of radius 40 around the origin.
    fn ring() -> (Skeleton, Vec<f64>) {
        let angles: Vec<f64> = (0..180).map(|i| (i * 2) as f64).collect();
        let leaf = |a: f64| {
            let c = DVec3::new(a.to_radians().cos(), 0.0, a.to_radians().sin()) * 40.0;
            Aabb {
                min: c - 0.5,
                max: c + 0.5,
            }
        };
        let mut nodes = vec![Node {
            bounds: Aabb {
                min: DVec3::splat(-41.0),
                max: DVec3::splat(41.0),
            },
            parent: NO_NODE,
            first_child: 1,
            child_count: angles.len() as u32,
            first_lod: 0,
            lod_count: 0,
        }];
        let mut lods = Vec::new();
        for (i, &a) in angles.iter().enumerate() {
            nodes.push(Node {
                bounds: leaf(a),
                parent: 0,
                first_child: 0,
                child_count: 0,
                first_lod: i as u32,
                lod_count: 1,
            });
            lods.push(LodInfo {
                error: 0.0,
                triangles: 12,
                vertices: 8,
                origin: leaf(a).center(),
                index_format: IndexFormat::U16,
                uniform_colour: None,
                offset: 0,
                len: 0,
                checksum: 0,
            });
        }
        let skeleton = Skeleton {
            origin: DVec3::ZERO,
            bounds: nodes[0].bounds,
            nodes,
            lods,
            provenance: Default::default(),
        };
        (skeleton, angles)
    }

    #[test]
    fn prefetch_asks_for_the_ring_just_outside_the_frustum_and_nothing_else() {
        let (skeleton, angles) = ring();
        let plan = Plan::new(&skeleton, 1 << 30);
        let opts = RuntimeOptions {
            prefetch: crate::Prefetching::Ring,
            ..Default::default()
        };
        let (tx, rx) = crossbeam_channel::unbounded();
        let prefetch = Prefetch {
            requests: tx,
            plan: &plan,
            mask: 1,
        };
        let mut stc = StcStage::new(&skeleton, &opts, Some(prefetch));
        // Looking along +x, 60 degrees both ways (aspect 1): the wide
        // frustum reaches atan(1.25 tan 30) = 35.8 degrees.
        let camera = Camera::look_at(DVec3::ZERO, DVec3::X, 60f64.to_radians(), 1.0, 0.1);
        let view = CullView::new(camera, Viewport::new(64, 64));
        let mut drawn = Vec::new();
        stc.run(0, &view, None, None, &mut |i| drawn.push(i.node))
            .unwrap();
        let asked: std::collections::BTreeSet<u32> = rx.try_iter().map(|r| r.lod).collect();
        // A unit box at radius 40 spans +-0.72 degrees around its angle.
        let off = |a: f64| a.min(360.0 - a);
        for (lod, &a) in angles.iter().enumerate() {
            let a = off(a);
            let lod = lod as u32;
            if (31.0..=35.0).contains(&a) {
                assert!(asked.contains(&lod), "leaf at {a} degrees not prefetched");
            }
            if !(29.0..=37.0).contains(&a) {
                assert!(!asked.contains(&lod), "leaf at {a} degrees prefetched");
            }
        }
        assert!(!asked.is_empty());
        // The frame itself drew what is inside, and nothing of the ring
        // outside the frustum.
        assert!(drawn.iter().all(|&n| off(angles[n as usize - 1]) < 31.0));
        // The prefetch traversal does not disturb the frame's own result.
        let mut again = Vec::new();
        let mut plain = StcStage::new(&skeleton, &opts, None);
        plain
            .run(0, &view, None, None, &mut |i| again.push(i.node))
            .unwrap();
        assert_eq!(drawn, again);
    }
}
