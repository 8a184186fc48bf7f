//! OR: the depth of frame i - lag's visible set, its LODs re-chosen for
//! this camera and cut to the occluder budget, drawn depth only (GigaWalk
//! Section 5.1).

use web_time::Instant;

use gigawalk_cull::{reselect_lods, select_occluders, CullView, DrawItem, TraversalOptions};
use gigawalk_gpu::{DepthLevel, DepthPass, PassFigures};
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
}

/// OR's depth pass on its device.
pub(super) struct GpuOccluders<'a> {
    pub device: DeviceGeometry<'a>,
    pub pass: DepthPass,
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
        let (ctx, pass) = (self.device.ctx, &mut self.pass);
        // Leaves with hidden objects: only the runs of those shown.
        pass.set_pieces(view.visibility().and_then(|v| v.lod_pieces()));
        // Streaming: resident occluders only (culling stays conservative).
        self.device
            .with(frame, lods, Use::Occluders, |residency, lods| {
                pass.render_level(ctx, residency, &gpu_view(view), lods, level)
            })?
            .map_err(|source| RuntimeError::Gpu {
                stage: Stage::Or,
                source,
            })
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
        self.opts.inject_failure.check(Stage::Or, frame)?;
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
            pixel_error: pixel_error.unwrap_or(self.opts.traversal.pixel_error),
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
        if items.is_empty() {
            // No occluder (a budget of 0, or nothing in view): an all-far
            // HZB would cull nothing, so STC skips occlusion for this frame.
            return Ok(none(t, figures));
        }
        let lods = lod_ids(self.skeleton, &items);
        let depth = self
            .render
            .depth(frame, view, &lods, self.opts.hzb_read_level())?;
        Ok(OrOutput {
            figures: OrFigures {
                ms: ms_since(t),
                level: depth.level,
                pass: depth.figures,
                ..figures
            },
            depth: Some(depth),
        })
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
