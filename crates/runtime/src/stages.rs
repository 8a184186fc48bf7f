//! The work of each stage for one frame, shared by the pipelined and the
//! sequential schedule (so both run the same algorithms).

use std::sync::Arc;
use std::time::Instant;

use gigawalk_cull::{
    reselect_lods, select_occluders, CullReason, CullView, DrawItem, Hzb, HzbOcclusion,
    NoOcclusion, TraversalOptions, TraversalStats, Traverser,
};
use gigawalk_gpu::{DepthImage, DepthPass, DrawStyle, FrameImage, GpuContext, View, VisiblePass};
use gigawalk_scene::Skeleton;

use crate::streaming::{Geometry, Link, Plan, Request, StreamStats, Use, PREFETCH_BAND};
use crate::{OccluderBudget, Runtime, RuntimeError, RuntimeOptions, Stage};

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

pub(crate) fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// The GPU's view of a cull view: camera-relative matrices, eye in f64.
pub(crate) fn gpu_view(v: &CullView) -> View {
    View {
        eye: v.camera.position,
        view_proj: v.camera.view_projection_rel(),
        forward: v.camera.forward().as_vec3(),
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

/// OR: the depth of frame i - lag's visible nodes, LODs re-selected for
/// camera i (Section 5.2), at the occluder resolution.
pub(crate) struct OrStage<'a> {
    pub device: DeviceGeometry<'a>,
    pub opts: &'a RuntimeOptions,
    pub pass: DepthPass,
}

pub(crate) struct OrOutput {
    pub depth: Option<DepthImage>,
    pub occluder_items: usize,
    pub ms: f64,
}

impl<'a> OrStage<'a> {
    pub fn new(device: DeviceGeometry<'a>, opts: &'a RuntimeOptions) -> Self {
        let (w, h) = opts.occluder_size();
        OrStage {
            pass: DepthPass::new(device.ctx, w, h),
            device,
            opts,
        }
    }

    /// `occluders` is `None` during the startup bypass or with occlusion off.
    pub fn run(
        &mut self,
        frame: u64,
        view: &CullView,
        occluders: Option<&[DrawItem]>,
    ) -> Result<OrOutput, RuntimeError> {
        let _span = tracing::info_span!("OR", frame).entered();
        let t = Instant::now();
        check_injected(self.opts, Stage::Or, frame)?;
        let Some(occluders) = occluders else {
            return Ok(OrOutput {
                depth: None,
                occluder_items: 0,
                ms: ms_since(t),
            });
        };
        // The same LOD choice STC makes for this camera (conservative mode).
        let mut items = Vec::with_capacity(occluders.len());
        reselect_lods(
            self.device.skeleton,
            view,
            &self.opts.traversal,
            occluders,
            &mut |i| items.push(i),
        );
        // `run_presenting` resolved `Auto` for these devices.
        if let OccluderBudget::Triangles(budget) = self.opts.occluder_budget {
            select_occluders(self.device.skeleton, view, &mut items, budget);
        }
        if items.is_empty() {
            // No occluder (a budget of 0, or nothing in view): an all-far
            // HZB would cull nothing, so STC skips occlusion for this frame.
            return Ok(OrOutput {
                depth: None,
                occluder_items: 0,
                ms: ms_since(t),
            });
        }
        let lods = lod_ids(self.device.skeleton, &items);
        let (pass, ctx) = (&mut self.pass, self.device.ctx);
        // Streaming: resident occluders only (culling stays conservative).
        let depth = self
            .device
            .with(frame, &lods, Use::Occluders, |residency, lods| {
                pass.render(ctx, residency, &gpu_view(view), lods)
            })?
            .map_err(|source| RuntimeError::Gpu {
                stage: Stage::Or,
                source,
            })?;
        Ok(OrOutput {
            depth: Some(depth),
            occluder_items: items.len(),
            ms: ms_since(t),
        })
    }
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
        let distance = gigawalk_cull::lod::distance_to_rel_box(min, max);
        let pe = gigawalk_cull::lod::pixel_error(l.error, distance, view.pixels_per_radian);
        if pe <= PREFETCH_BAND * tolerance {
            return;
        }
        let frame = self.plan.frame(frame);
        let ask = |lod: u32| {
            if !self.plan.held_by(lod, self.mask) {
                // A full queue drops it: prefetching is best effort.
                let _ = self.requests.try_send(Request {
                    lod,
                    frame,
                    prefetch: true,
                });
            }
        };
        if item.lod > 0 {
            ask(n.first_lod + item.lod - 1);
        } else {
            for c in n.children() {
                let c = &skeleton.nodes[c as usize];
                if c.lod_count > 0 {
                    ask(c.first_lod + c.lod_count - 1);
                }
            }
        }
    }
}

/// STC: HZB from OR's depth, then traversal (Algorithm 5.2).
pub(crate) struct StcStage<'a> {
    pub skeleton: &'a Skeleton,
    pub opts: &'a RuntimeOptions,
    traverser: Traverser,
    hzb: Hzb,
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
    pub ms: f64,
}

impl<'a> StcStage<'a> {
    pub fn new(
        skeleton: &'a Skeleton,
        opts: &'a RuntimeOptions,
        prefetch: Option<Prefetch<'a>>,
    ) -> Self {
        StcStage {
            skeleton,
            opts,
            traverser: Traverser::new(),
            hzb: Hzb::new(),
            prefetch,
        }
    }

    /// Traverses, handing every item to `emit` as it is found.
    pub fn run(
        &mut self,
        frame: u64,
        view: &CullView,
        depth: Option<&DepthImage>,
        emit: &mut dyn FnMut(DrawItem),
    ) -> Result<StcOutput, RuntimeError> {
        let _span = tracing::info_span!("STC", frame).entered();
        let t = Instant::now();
        check_injected(self.opts, Stage::Stc, frame)?;
        let mut hzb_ms = 0.0;
        let occlusion = match depth {
            Some(d) if self.opts.traversal.occlusion => {
                let th = Instant::now();
                let _s = tracing::info_span!("HZB build", frame).entered();
                self.hzb
                    .rebuild(d.width, d.height, &d.depth, self.opts.hzb_reduction)
                    .map_err(|source| RuntimeError::Hzb { frame, source })?;
                hzb_ms = ms_since(th);
                true
            }
            _ => false,
        };
        let options = TraversalOptions {
            occlusion,
            ..self.opts.traversal
        };
        let mut visible = Vec::new();
        let tolerance = options.pixel_tolerance;
        let prefetch = self
            .prefetch
            .as_ref()
            .filter(|_| options.hlod && tolerance > 0.0);
        let skeleton = self.skeleton;
        let mut sink = |item: DrawItem| {
            visible.push(item);
            emit(item);
            if let Some(p) = prefetch {
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
        let stats = if occlusion {
            let hzb = HzbOcclusion::new(&self.hzb);
            self.traverser.traverse_recording(
                self.skeleton,
                view,
                &hzb,
                &options,
                &mut sink,
                &mut on_cull,
            )
        } else {
            self.traverser.traverse_recording(
                self.skeleton,
                view,
                &NoOcclusion,
                &options,
                &mut sink,
                &mut on_cull,
            )
        };
        Ok(StcOutput {
            stats,
            culled: culled.into(),
            visible: visible.into(),
            occlusion_used: occlusion,
            hzb_ms,
            ms: ms_since(t),
        })
    }
}

/// RVG: draws a frame's items as they arrive.
pub(crate) struct RvgStage<'a> {
    pub device: DeviceGeometry<'a>,
    pub opts: &'a RuntimeOptions,
    pub pass: VisiblePass,
    started: Option<Instant>,
    frame: u64,
}

impl<'a> RvgStage<'a> {
    pub fn new(device: DeviceGeometry<'a>, opts: &'a RuntimeOptions) -> Self {
        RvgStage {
            pass: VisiblePass::new(device.ctx, opts.width, opts.height),
            device,
            opts,
            started: None,
            frame: 0,
        }
    }

    pub fn begin(
        &mut self,
        frame: u64,
        view: &CullView,
        style: DrawStyle,
    ) -> Result<(), RuntimeError> {
        check_injected(self.opts, Stage::Rvg, frame)?;
        self.started = Some(Instant::now());
        self.frame = frame;
        self.pass.begin(self.device.ctx, &gpu_view(view), style);
        Ok(())
    }

    /// Draws a chunk of the frame's LODs (streaming: resident ones and
    /// stand-ins for the rest).
    pub fn draw(&mut self, lods: &[u32]) -> Result<(), RuntimeError> {
        let _span = tracing::info_span!("RVG chunk", items = lods.len()).entered();
        let (pass, ctx) = (&mut self.pass, self.device.ctx);
        self.device
            .with(self.frame, lods, Use::Visible, |residency, lods| {
                pass.draw(ctx, residency, lods)
            })
    }

    /// The frame's streaming figures (call once, as the frame ends).
    pub fn stream_stats(&self) -> StreamStats {
        self.device.take_stats()
    }

    /// Reads back the finished frame's colour and depth.
    pub fn read_back(&mut self) -> Result<Option<FrameImage>, RuntimeError> {
        self.pass
            .read_back(self.device.ctx)
            .map(Some)
            .map_err(|source| RuntimeError::Gpu {
                stage: Stage::Rvg,
                source,
            })
    }

    /// Waits for the frame; returns its image if asked and the stage's ms.
    pub fn finish(&mut self, read_back: bool) -> Result<(Option<FrameImage>, f64), RuntimeError> {
        let image = self
            .pass
            .finish(self.device.ctx, read_back)
            .map_err(|source| RuntimeError::Gpu {
                stage: Stage::Rvg,
                source,
            })?;
        Ok((image, self.started.take().map_or(0.0, ms_since)))
    }
}
