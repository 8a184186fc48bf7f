//! RVG: the frame's visible items drawn as STC sends them, in chunks.

use web_time::Instant;

use gigawalk_cull::CullView;
use gigawalk_gpu::{DrawStyle, FrameImage, Look, PassFigures, PendingFrame, VisiblePass};

use super::*;
use crate::streaming::{StreamStats, Use};
use crate::ResolvedOptions;
use crate::{gpu_view, ms_since, Presenter, RuntimeError, Stage};

/// What RVG draws the visible set on: a visible pass on a device
/// ([`GpuVisible`]), or in tests the CPU's software depth (no colour).
pub(super) trait VisibleTarget {
    fn begin(&mut self, view: &CullView, style: FrameStyle);
    /// The rectangle `[x, y, w, h]` later chunks draw into (a tile), or
    /// the whole viewport.
    fn scissor(&mut self, rect: Option<[u32; 4]>);
    /// Draws a chunk of frame `frame`'s LODs.
    fn draw(&mut self, frame: u64, lods: &[u32]) -> Result<(), RuntimeError>;
    /// Draws x-ray's ghosts over the frame, after its last chunk (nothing
    /// where there is no colour).
    fn ghosts(&mut self, _frame: u64, _lods: &[u32]) -> Result<(), RuntimeError> {
        Ok(())
    }
    /// The frame's streaming figures (zeros when nothing streams).
    fn stream_stats(&self) -> StreamStats {
        StreamStats::default()
    }
    /// Shows the finished frame, where there is something to show on.
    fn present(
        &mut self,
        _presenter: &mut dyn Presenter,
        _report: &crate::FrameReport,
    ) -> Result<(), RuntimeError> {
        Ok(())
    }
    fn read_back(&mut self) -> Result<FrameImage, RuntimeError>;
    /// Starts reading back the last finished frame without waiting (none
    /// where there is no device).
    fn submit_read_back(&mut self) -> Option<PendingFrame> {
        None
    }
    /// The frame `pending` reads once the device has copied it; `Err`
    /// gives it back while it has not. Never blocks.
    fn try_take_frame(
        &mut self,
        pending: PendingFrame,
    ) -> Result<Result<FrameImage, RuntimeError>, PendingFrame> {
        Err(pending)
    }
    /// Ends the frame (at most two in flight).
    fn finish(&mut self) -> Result<(), RuntimeError> {
        Ok(())
    }
    /// What the frame cost the CPU, step by step, since the last call.
    fn take_figures(&mut self) -> PassFigures {
        PassFigures::default()
    }
}

/// RVG's visible pass on its device.
pub(super) struct GpuVisible<'a> {
    pub device: DeviceGeometry<'a>,
    pub pass: VisiblePass,
    /// The frame's hidden objects and ghosts, so that no stand-in shows
    /// a hidden object (nor a ghost one that is shown).
    pub shown: Shown,
}

/// What the frame being drawn shows: its visibility and its ghosts'.
#[derive(Default)]
pub(super) struct Shown {
    visible: Option<std::sync::Arc<gigawalk_cull::Visibility>>,
    ghosts: Option<std::sync::Arc<gigawalk_cull::Visibility>>,
}

impl Shown {
    fn of(view: &CullView) -> Shown {
        Shown {
            visible: view.visibility().cloned(),
            ghosts: view.ghosts().cloned(),
        }
    }

    fn visible(&self) -> Use<'_> {
        Use::Visible {
            shown: self.visible.as_deref(),
        }
    }

    fn ghosts(&self) -> Use<'_> {
        Use::Visible {
            shown: self.ghosts.as_deref(),
        }
    }
}

impl VisibleTarget for GpuVisible<'_> {
    fn begin(&mut self, view: &CullView, style: FrameStyle) {
        self.shown = Shown::of(view);
        self.pass
            .set_pieces(view.visibility().and_then(|v| v.lod_pieces()));
        self.pass
            .set_ghost_pieces(view.ghosts().and_then(|g| g.lod_pieces()));
        self.pass
            .begin(self.device.ctx, &gpu_view(view), style.draw, style.look);
    }

    fn scissor(&mut self, rect: Option<[u32; 4]>) {
        self.pass.set_scissor(rect);
    }

    /// Streaming: resident LODs and stand-ins for the rest.
    fn draw(&mut self, frame: u64, lods: &[u32]) -> Result<(), RuntimeError> {
        let (ctx, pass) = (self.device.ctx, &mut self.pass);
        self.device
            .with(frame, lods, self.shown.visible(), |residency, lods| {
                pass.draw(ctx, residency, lods)
            })
    }

    fn ghosts(&mut self, frame: u64, lods: &[u32]) -> Result<(), RuntimeError> {
        let (ctx, pass) = (self.device.ctx, &mut self.pass);
        self.device
            .with(frame, lods, self.shown.ghosts(), |residency, lods| {
                pass.draw_ghosts(ctx, residency, lods)
            })
    }

    fn stream_stats(&self) -> StreamStats {
        self.device.take_stats()
    }

    fn present(
        &mut self,
        presenter: &mut dyn Presenter,
        report: &crate::FrameReport,
    ) -> Result<(), RuntimeError> {
        presenter
            .present(self.device.ctx, &self.pass, report)
            .map_err(rvg_error)
    }

    fn read_back(&mut self) -> Result<FrameImage, RuntimeError> {
        self.pass.read_back(self.device.ctx).map_err(rvg_error)
    }

    fn submit_read_back(&mut self) -> Option<PendingFrame> {
        Some(self.pass.submit_read_back(self.device.ctx))
    }

    fn try_take_frame(
        &mut self,
        pending: PendingFrame,
    ) -> Result<Result<FrameImage, RuntimeError>, PendingFrame> {
        self.pass
            .try_take_frame(self.device.ctx, pending)
            .map(|f| f.map_err(rvg_error))
    }

    fn finish(&mut self) -> Result<(), RuntimeError> {
        self.pass.end(self.device.ctx).map_err(rvg_error)
    }

    fn take_figures(&mut self) -> PassFigures {
        self.pass.take_figures()
    }
}

/// RVG: draws a frame's items as they arrive.
pub(crate) struct RvgStage<'a> {
    pub(super) render: Box<dyn VisibleTarget + 'a>,
    pub(super) opts: &'a ResolvedOptions,
    pub(super) started: Option<Instant>,
    pub(super) frame: u64,
}

/// How RVG draws a frame and what the shown image adds to it; culling
/// depends on neither.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameStyle {
    pub draw: DrawStyle,
    pub look: Look,
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
        style: FrameStyle,
    ) -> Result<(), RuntimeError> {
        self.opts.inject_failure.check(Stage::Rvg, frame)?;
        self.started = Some(Instant::now());
        self.frame = frame;
        self.render.begin(view, style);
        Ok(())
    }

    /// The rectangle `[x, y, w, h]` later chunks draw into (a tile), or
    /// the whole viewport.
    pub fn scissor(&mut self, rect: Option<[u32; 4]>) {
        self.render.scissor(rect);
    }

    /// Draws a chunk of the frame's LODs (streaming: resident ones and
    /// stand-ins for the rest).
    pub fn draw(&mut self, lods: &[u32]) -> Result<(), RuntimeError> {
        let _span = tracing::info_span!("RVG chunk", items = lods.len()).entered();
        self.render.draw(self.frame, lods)
    }

    /// Draws x-ray's ghosts over the frame, after its last chunk.
    pub fn ghosts(&mut self, lods: &[u32]) -> Result<(), RuntimeError> {
        if lods.is_empty() {
            return Ok(());
        }
        let _span = tracing::info_span!("RVG ghosts", items = lods.len()).entered();
        self.render.ghosts(self.frame, lods)
    }

    /// The frame's streaming figures (call once, as the frame ends).
    pub fn stream_stats(&self) -> StreamStats {
        self.render.stream_stats()
    }

    /// Shows the finished frame (a device only).
    pub fn present(
        &mut self,
        presenter: &mut dyn Presenter,
        report: &crate::FrameReport,
    ) -> Result<(), RuntimeError> {
        self.render.present(presenter, report)
    }

    /// Reads back the finished frame's colour and depth.
    pub fn read_back(&mut self) -> Result<Option<FrameImage>, RuntimeError> {
        self.render.read_back().map(Some)
    }

    /// Starts reading back the last finished frame without waiting.
    pub fn submit_read_back(&mut self) -> Option<PendingFrame> {
        self.render.submit_read_back()
    }

    /// The frame `pending` reads, once copied; never blocks.
    pub fn try_take_frame(
        &mut self,
        pending: PendingFrame,
    ) -> Result<Result<FrameImage, RuntimeError>, PendingFrame> {
        self.render.try_take_frame(pending)
    }

    /// Ends the frame (at most two in flight); returns the stage's ms.
    pub fn finish(&mut self) -> Result<f64, RuntimeError> {
        self.render.finish()?;
        Ok(self.started.take().map_or(0.0, ms_since))
    }

    /// What the frame cost the CPU on RVG's device, step by step.
    pub fn take_figures(&mut self) -> PassFigures {
        self.render.take_figures()
    }
}
