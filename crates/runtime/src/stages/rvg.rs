//! RVG: the frame's visible items drawn as STC sends them, in chunks.

use std::time::Instant;

use gigawalk_cull::CullView;
use gigawalk_gpu::{DrawStyle, FrameImage, VisiblePass};

use super::*;
use crate::streaming::{StreamStats, Use};
use crate::{gpu_view, ms_since, Presenter, RuntimeError, RuntimeOptions, Stage};

/// RVG's drawing: a visible pass on a device, or the CPU.
pub(super) type RvgRender<'a> = Render<'a, VisiblePass>;

/// RVG: draws a frame's items as they arrive.
pub(crate) struct RvgStage<'a> {
    pub(super) render: RvgRender<'a>,
    pub(super) opts: &'a RuntimeOptions,
    pub(super) started: Option<Instant>,
    pub(super) frame: u64,
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
