//! RVG: the visible set's colour and depth, drawn in chunks as the list
//! arrives, with an optional wireframe pipeline and a scissor for tiles.

use std::time::Instant;

use crate::passes::{
    depth_attachment, ms_since, pipeline, target, DrawStyle, Drawer, FrameImage, PassFigures,
    ReadBack, ScenePipelines, View, COLOUR_FORMAT, DEPTH_FORMAT,
};
use crate::residency::{LodRange, Residency};
use crate::shader_types;
use crate::{GpuContext, GpuError};

/// RVG: draws the visible list in chunks as it arrives, to an offscreen
/// colour target (or a caller-provided view, e.g. a window's surface).
pub struct VisiblePass {
    drawer: Drawer,
    pipelines: ScenePipelines,
    /// The line-mode pipelines, where the device supports them.
    wire_pipelines: Option<ScenePipelines>,
    style: DrawStyle,
    warned_no_wireframe: bool,
    colour: wgpu::Texture,
    depth: wgpu::Texture,
    colour_readback: ReadBack,
    depth_readback: ReadBack,
    width: u32,
    height: u32,
    /// Whether the current frame's targets have been cleared yet.
    cleared: bool,
    view: Option<View>,
    /// Where later draws of the frame may write (a tile), `[x, y, w, h]`.
    scissor: Option<[u32; 4]>,
    /// This frame's last submission, and the last frame's: a frame ends
    /// by waiting for the one before it, so at most two are in flight.
    submitted: Option<wgpu::SubmissionIndex>,
    previous_frame: Option<wgpu::SubmissionIndex>,
    /// What the frame so far cost the CPU.
    figures: PassFigures,
}

/// Background colour (linear): a dark blue-grey, so black geometry shows.
const BACKGROUND: wgpu::Color = wgpu::Color {
    r: 0.02,
    g: 0.025,
    b: 0.035,
    a: 1.0,
};

impl VisiblePass {
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> VisiblePass {
        let (width, height) = (width.max(1), height.max(1));
        let drawer = Drawer::new(ctx, "visible");
        let visible = |label, mode| {
            pipeline(
                ctx,
                &drawer,
                label,
                (shader_types::VISIBLE_WGSL, shader_types::VISIBLE_CLIP_WGSL),
                Some(COLOUR_FORMAT),
                mode,
            )
        };
        let pipelines = visible("visible", wgpu::PolygonMode::Fill);
        let wire_pipelines = ctx
            .supports_wireframe()
            .then(|| visible("visible wireframe", wgpu::PolygonMode::Line));
        VisiblePass {
            wire_pipelines,
            style: DrawStyle::Shaded,
            warned_no_wireframe: false,
            colour: target(ctx, "visible colour", width, height, COLOUR_FORMAT),
            depth: target(ctx, "visible depth", width, height, DEPTH_FORMAT),
            colour_readback: ReadBack::default(),
            depth_readback: ReadBack::default(),
            drawer,
            pipelines,
            width,
            height,
            cleared: false,
            scissor: None,
            view: None,
            submitted: None,
            previous_frame: None,
            figures: PassFigures::default(),
        }
    }

    /// What the frame cost the CPU since the last call, step by step.
    pub fn take_figures(&mut self) -> PassFigures {
        std::mem::take(&mut self.figures)
    }

    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The offscreen colour target (`COLOUR_FORMAT`), for presenting and
    /// overlays once a frame is finished.
    pub fn colour_texture(&self) -> &wgpu::Texture {
        &self.colour
    }

    /// The depth target (`DEPTH_FORMAT`, reversed-Z), for overlays that
    /// depth-test against the frame.
    pub fn depth_texture(&self) -> &wgpu::Texture {
        &self.depth
    }

    /// Which LODs later draws take in pieces (the runs of the objects
    /// shown of a leaf some of whose objects are hidden or highlighted;
    /// highlighted pieces tinted where the pass has colour), until set
    /// again; `None`: every LOD whole.
    pub fn set_pieces(
        &mut self,
        pieces: Option<std::sync::Arc<gigawalk_scene::objects::LodPieces>>,
    ) {
        self.drawer.set_pieces(pieces);
    }

    /// Starts a frame: the next [`VisiblePass::draw`] clears the targets.
    pub fn begin(&mut self, ctx: &GpuContext, view: &View, style: DrawStyle) {
        self.style = match style {
            DrawStyle::Wireframe if self.wire_pipelines.is_none() => {
                if !self.warned_no_wireframe {
                    tracing::warn!(
                        "{}: no POLYGON_MODE_LINE, drawing shaded instead of wireframe",
                        ctx.name()
                    );
                    self.warned_no_wireframe = true;
                }
                DrawStyle::Shaded
            }
            s => s,
        };
        self.drawer
            .begin(ctx, view, self.style == DrawStyle::Wireframe);
        self.cleared = false;
        self.view = Some(*view);
        self.scissor = None;
    }

    /// Later draws of this frame write only pixels in `[x, y, w, h]` (a
    /// tile of a tiled display; clamped to the targets), or anywhere. The
    /// first draw still clears the whole targets.
    pub fn set_scissor(&mut self, rect: Option<[u32; 4]>) {
        self.scissor = rect;
    }

    /// Draws one chunk of the frame's visible LODs and submits it, so the
    /// GPU works while the rest of the list is still being culled.
    pub fn draw(&mut self, ctx: &GpuContext, residency: &dyn Residency, lods: &[u32]) {
        let view = self.view.expect("VisiblePass::begin before draw");
        let t = Instant::now();
        let draws = self.drawer.prepare(ctx, &view, residency, lods);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        {
            let cv = self.colour.create_view(&Default::default());
            let dv = self.depth.create_view(&Default::default());
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("visible"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &cv,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: if self.cleared {
                            wgpu::LoadOp::Load
                        } else {
                            wgpu::LoadOp::Clear(BACKGROUND)
                        },
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(depth_attachment(&dv, !self.cleared)),
                ..Default::default()
            });
            let pipelines = match (self.style, &self.wire_pipelines) {
                (DrawStyle::Wireframe, Some(wire)) => wire,
                _ => &self.pipelines,
            };
            if let Some([x, y, w, h]) = self.scissor {
                let (tw, th) = (self.width, self.height);
                let (x, y) = (x.min(tw), y.min(th));
                pass.set_scissor_rect(x, y, w.min(tw - x), h.min(th - y));
            }
            self.drawer.record(&mut pass, residency, &draws, pipelines);
        }
        self.cleared = true;
        self.figures.encode_ms += ms_since(t);
        self.submitted = Some(self.figures.submit(ctx, enc));
    }

    /// Ends the frame and optionally reads back its colour and depth
    /// (waiting for them): [`VisiblePass::end`], then the read.
    pub fn finish(
        &mut self,
        ctx: &GpuContext,
        read_back: bool,
    ) -> Result<Option<FrameImage>, GpuError> {
        self.end(ctx)?;
        if read_back {
            self.read_back(ctx).map(Some)
        } else {
            Ok(None)
        }
    }

    /// Ends the frame, waiting only for the frame before it to leave the
    /// device: the GPU may still draw this one while the CPU prepares the
    /// next, so at most two frames are in flight, and a device that keeps
    /// up costs no wait.
    pub fn end(&mut self, ctx: &GpuContext) -> Result<(), GpuError> {
        if !self.cleared {
            // An empty frame still clears its targets.
            self.draw(ctx, &NoGeometry, &[]);
        }
        self.view = None;
        let this_frame = self.submitted.take();
        if let Some(index) = std::mem::replace(&mut self.previous_frame, this_frame) {
            self.figures.wait(ctx, index)?;
        }
        ctx.check()
    }

    /// Reads back the last finished frame's colour and depth.
    pub fn read_back(&mut self, ctx: &GpuContext) -> Result<FrameImage, GpuError> {
        let (w, h) = (self.width, self.height);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let rows = self.colour_readback.record_texture(
            ctx,
            &mut enc,
            &self.colour,
            w,
            h,
            4,
            wgpu::TextureAspect::All,
        );
        let colour = self
            .colour_readback
            .submit_and_read(ctx, enc, rows, &mut self.figures)?;
        let depth = self
            .depth_readback
            .depth(ctx, &self.depth, w, h, &mut self.figures)?;
        Ok(FrameImage { colour, depth })
    }
}

struct NoGeometry;
impl Residency for NoGeometry {
    fn range(&self, _: u32) -> Option<LodRange> {
        None
    }
    fn buffers(&self, _: u32) -> (&wgpu::Buffer, &wgpu::Buffer) {
        unreachable!("no geometry is ever bound")
    }
}
