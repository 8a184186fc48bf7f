//! OR: the depth of frame i - lag's visible set, its LODs re-chosen for
//! this camera and cut to the occluder budget, drawn depth only (GigaWalk
//! Section 5.1).

use web_time::Instant;

use gigawalk_cull::{reselect_lods, select_occluders, CullView, DrawItem};
use gigawalk_gpu::{DepthLevel, DepthPass, PassFigures, PendingLevel};
use gigawalk_scene::Skeleton;

use super::*;
use crate::streaming::Use;
use crate::ResolvedOptions;
use crate::{gpu_view, ms_since, RuntimeError, Stage};

/// What OR draws occluder depth on: a depth pass on a device
/// ([`GpuOccluders`]), or in tests the CPU's software depth.
pub(super) trait OccluderTarget {
    /// Whether occluders are streamed (OR ranks them best first so the
    /// pool keeps those that hide most).
    fn streaming(&self) -> bool {
        false
    }

    /// Level `level` of the pyramid of the depth of `lods` (frame
    /// `frame`'s occluders) seen from `view` (0: the depth itself).
    fn depth(
        &mut self,
        frame: u64,
        view: &CullView,
        lods: &[u32],
        level: u32,
    ) -> Result<DepthLevel, RuntimeError>;

    /// As [`OccluderTarget::depth`], without waiting where the target can
    /// (a device): [`OccluderTarget::try_take`] takes the level once made.
    fn submit(
        &mut self,
        frame: u64,
        view: &CullView,
        lods: &[u32],
        level: u32,
    ) -> Result<PendingDepth, RuntimeError> {
        self.depth(frame, view, lods, level).map(PendingDepth::Made)
    }

    /// The level `pending` reads once it is made; `Err` gives it back
    /// while it is not. Never blocks.
    fn try_take(
        &mut self,
        pending: PendingDepth,
    ) -> Result<Result<DepthLevel, PendingDepth>, RuntimeError> {
        match pending {
            PendingDepth::Made(d) => Ok(Ok(d)),
            waiting => Ok(Err(waiting)),
        }
    }
}

/// Occluder depth submitted and not yet taken.
pub(crate) enum PendingDepth {
    /// Already made (a target that does not wait, the CPU's).
    Made(DepthLevel),
    /// On its way back from the device.
    Device(PendingLevel),
}

fn or_error(source: gigawalk_gpu::GpuError) -> RuntimeError {
    RuntimeError::Gpu {
        stage: Stage::Or,
        source,
    }
}

/// OR's depth pass on its device.
pub(super) struct GpuOccluders<'a> {
    pub device: DeviceGeometry<'a>,
    pub pass: DepthPass,
}

impl GpuOccluders<'_> {
    /// Runs `f` on the depth pass with what to draw of `lods` seen from
    /// `view`: leaves with hidden objects drawn as the runs of those
    /// shown, and (streaming) resident occluders only, so culling stays
    /// conservative.
    fn with_pass<T>(
        &mut self,
        frame: u64,
        view: &CullView,
        lods: &[u32],
        f: impl FnOnce(
            &gigawalk_gpu::GpuContext,
            &mut DepthPass,
            &dyn gigawalk_gpu::Residency,
            &gigawalk_gpu::View,
            &[u32],
        ) -> T,
    ) -> Result<T, RuntimeError> {
        let (ctx, pass) = (self.device.ctx, &mut self.pass);
        pass.set_pieces(view.visibility().and_then(|v| v.lod_pieces()));
        let v = gpu_view(view);
        self.device
            .with(frame, lods, Use::Occluders, |residency, lods| {
                f(ctx, pass, residency, &v, lods)
            })
    }
}

impl OccluderTarget for GpuOccluders<'_> {
    fn streaming(&self) -> bool {
        self.device.plan.is_some()
    }

    fn depth(
        &mut self,
        frame: u64,
        view: &CullView,
        lods: &[u32],
        level: u32,
    ) -> Result<DepthLevel, RuntimeError> {
        self.with_pass(frame, view, lods, |ctx, pass, residency, v, lods| {
            pass.render_level(ctx, residency, v, lods, level)
        })?
        .map_err(or_error)
    }

    fn submit(
        &mut self,
        frame: u64,
        view: &CullView,
        lods: &[u32],
        level: u32,
    ) -> Result<PendingDepth, RuntimeError> {
        self.with_pass(frame, view, lods, |ctx, pass, residency, v, lods| {
            pass.submit_level(ctx, residency, v, lods, level)
        })
        .map(PendingDepth::Device)
    }

    fn try_take(
        &mut self,
        pending: PendingDepth,
    ) -> Result<Result<DepthLevel, PendingDepth>, RuntimeError> {
        match pending {
            PendingDepth::Made(d) => Ok(Ok(d)),
            PendingDepth::Device(p) => match self.pass.try_take_level(self.device.ctx, p) {
                Err(p) => Ok(Err(PendingDepth::Device(p))),
                Ok(level) => level.map(Ok).map_err(or_error),
            },
        }
    }
}

/// OR: the depth of frame i - lag's visible nodes, LODs re-selected for
/// camera i (Section 5.2), at the occluder resolution.
pub(crate) struct OrStage<'a> {
    pub(super) skeleton: &'a Skeleton,
    pub(super) opts: &'a ResolvedOptions,
    pub(super) budget: OrBudget<'a>,
    pub(super) render: Box<dyn OccluderTarget + 'a>,
}

pub(crate) struct OrOutput {
    pub depth: Option<DepthLevel>,
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
    /// The level of the depth's pyramid read back (0: the whole image).
    pub level: u32,
    /// What the depth pass cost the CPU, step by step.
    pub pass: PassFigures,
}

impl<'a> OrStage<'a> {
    /// `occluders` is `None` during the startup bypass or with occlusion off.
    /// `pixel_error` overrides the options' pixel error for this frame.
    pub fn run(
        &mut self,
        frame: u64,
        view: &CullView,
        pixel_error: Option<f64>,
        occluders: Option<&[DrawItem]>,
    ) -> Result<OrOutput, RuntimeError> {
        let _span = tracing::info_span!("OR", frame).entered();
        let t = Instant::now();
        let (lods, figures) = self.choose(frame, view, pixel_error, occluders)?;
        if lods.is_empty() {
            return Ok(OrOutput::none(t, figures));
        }
        let depth = self
            .render
            .depth(frame, view, &lods, self.opts.hzb_read_level())?;
        Ok(OrOutput::made(t, figures, depth))
    }

    /// As [`OrStage::run`], without waiting for the device: the depth is
    /// taken by [`OrStage::try_take`] once made (a schedule on a thread
    /// that must not block, a page's).
    pub fn submit(
        &mut self,
        frame: u64,
        view: &CullView,
        pixel_error: Option<f64>,
        occluders: Option<&[DrawItem]>,
    ) -> Result<OrSubmitted, RuntimeError> {
        let _span = tracing::info_span!("OR submit", frame).entered();
        let t = Instant::now();
        let (lods, mut figures) = self.choose(frame, view, pixel_error, occluders)?;
        let depth = match lods.is_empty() {
            true => None,
            false => Some(
                self.render
                    .submit(frame, view, &lods, self.opts.hzb_read_level())?,
            ),
        };
        figures.ms = ms_since(t);
        Ok(OrSubmitted { figures, depth })
    }

    /// The output of `submitted` once its depth is made (at once when it
    /// has none); `Err` gives it back while it is not. Never blocks.
    pub fn try_take(
        &mut self,
        submitted: OrSubmitted,
    ) -> Result<Result<OrOutput, OrSubmitted>, RuntimeError> {
        let OrSubmitted { figures, depth } = submitted;
        let Some(pending) = depth else {
            return Ok(Ok(OrOutput {
                depth: None,
                figures,
            }));
        };
        let t = Instant::now();
        Ok(match self.render.try_take(pending)? {
            Err(pending) => Err(OrSubmitted {
                figures,
                depth: Some(pending),
            }),
            Ok(depth) => {
                let mut out = OrOutput::made(t, figures, depth);
                out.figures.ms += figures.ms;
                Ok(out)
            }
        })
    }

    /// The occluders' LODs for `view` (none: no depth this frame) and the
    /// figures so far.
    fn choose(
        &mut self,
        frame: u64,
        view: &CullView,
        pixel_error: Option<f64>,
        occluders: Option<&[DrawItem]>,
    ) -> Result<(Vec<u32>, OrFigures), RuntimeError> {
        self.opts.inject_failure.check(Stage::Or, frame)?;
        let Some(occluders) = occluders else {
            return Ok((Vec::new(), OrFigures::default()));
        };
        // The same LOD choice STC makes for this camera (conservative mode).
        let mut items = Vec::with_capacity(occluders.len());
        let traversal = self.opts.traversal_at(pixel_error);
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
        let streaming = self.render.streaming();
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
            level: 0,
            pass: PassFigures::default(),
        };
        // No occluder (a budget of 0, or nothing in view): no LODs, so no
        // depth; an all-far HZB would cull nothing, so STC skips
        // occlusion for this frame.
        Ok((lod_ids(self.skeleton, &items), figures))
    }
}

/// OR's frame submitted ([`OrStage::submit`]): its figures, and its depth
/// on its way (none: no occluders this frame).
pub(crate) struct OrSubmitted {
    figures: OrFigures,
    depth: Option<PendingDepth>,
}

impl OrOutput {
    /// No depth this frame: `figures` as chosen, timed from `t`.
    fn none(t: Instant, figures: OrFigures) -> OrOutput {
        OrOutput {
            depth: None,
            figures: OrFigures {
                ms: ms_since(t),
                ..figures
            },
        }
    }

    /// `depth` made for `figures`, timed from `t`.
    fn made(t: Instant, figures: OrFigures, depth: DepthLevel) -> OrOutput {
        OrOutput {
            figures: OrFigures {
                ms: ms_since(t),
                level: depth.level,
                pass: depth.figures,
                ..figures
            },
            depth: Some(depth),
        }
    }
}

/// Triangles of `items`' LODs (an earlier frame's traversal of this
/// skeleton chose them).
fn item_triangles(skeleton: &Skeleton, items: &[DrawItem]) -> u64 {
    items
        .iter()
        .map(|i| {
            u64::from(
                skeleton
                    .lod(skeleton.node(i.node).first_lod + i.lod)
                    .triangles,
            )
        })
        .sum()
}
