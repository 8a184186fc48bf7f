//! RVG: the visible set's colour and depth, drawn in chunks as the list
//! arrives, with an optional wireframe pipeline and a scissor for tiles.

use web_time::Instant;

use crate::passes::look::{LookPass, NORMAL_FORMAT};
use crate::passes::{
    depth_attachment, ms_since, pipeline, scene_pipelines, target, DrawStyle, Drawer, FrameImage,
    Look, PassFigures, ReadBack, ScenePipelines, Surface, View, COLOUR_FORMAT, DEPTH_FORMAT,
};
use crate::residency::{LodRange, Residency};
use crate::shader_types;
use crate::{GpuContext, GpuError};

/// RVG: draws the visible list in chunks as it arrives, to an offscreen
/// colour target (or a caller-provided view, e.g. a window's surface).
pub struct VisiblePass {
    drawer: Drawer,
    /// Pipelines writing colour alone.
    colour_only: Pipelines,
    /// Pipelines writing colour and the normal target, made when a look
    /// first needs normals.
    with_normals: Option<Pipelines>,
    style: DrawStyle,
    warned_no_wireframe: bool,
    colour: wgpu::Texture,
    depth: wgpu::Texture,
    /// The eye-facing normals (`look.wgsl`), made with the look's passes.
    normal: Option<wgpu::Texture>,
    /// What the shown image adds this frame, and its passes once a frame
    /// has asked for one.
    look: Look,
    look_pass: Option<LookPass>,
    /// X-ray's ghost pipelines (colour alone, and with the normal target),
    /// made when ghosts are first drawn, and the pieces ghost draws take.
    ghost_pipelines: [Option<ScenePipelines>; 2],
    ghost_pieces: Option<std::sync::Arc<gigawalk_scene::objects::LodPieces>>,
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

/// RVG's scene pipelines for one set of colour targets: filled, and in
/// line mode where the device supports it.
struct Pipelines {
    fill: ScenePipelines,
    wire: Option<ScenePipelines>,
}

impl Pipelines {
    fn new(
        ctx: &GpuContext,
        drawer: &Drawer,
        targets: &[Option<wgpu::TextureFormat>],
    ) -> Pipelines {
        let visible = |label, mode| {
            pipeline(
                ctx,
                drawer,
                label,
                (shader_types::VISIBLE_WGSL, shader_types::VISIBLE_CLIP_WGSL),
                targets,
                mode,
            )
        };
        Pipelines {
            fill: visible("visible", wgpu::PolygonMode::Fill),
            wire: ctx
                .supports_wireframe()
                .then(|| visible("visible wireframe", wgpu::PolygonMode::Line)),
        }
    }
}

impl VisiblePass {
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> VisiblePass {
        let (width, height) = (width.max(1), height.max(1));
        let drawer = Drawer::new(ctx, "visible");
        VisiblePass {
            colour_only: Pipelines::new(ctx, &drawer, &[Some(COLOUR_FORMAT)]),
            with_normals: None,
            normal: None,
            look: Look::PLAIN,
            look_pass: None,
            ghost_pipelines: [None, None],
            ghost_pieces: None,
            style: DrawStyle::Shaded,
            warned_no_wireframe: false,
            colour: target(ctx, "visible colour", width, height, COLOUR_FORMAT),
            depth: target(ctx, "visible depth", width, height, DEPTH_FORMAT),
            colour_readback: ReadBack::default(),
            depth_readback: ReadBack::default(),
            drawer,
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

    /// The image to show of the last finished frame: the look's, or
    /// where the look is plain the colour target itself
    /// (`COLOUR_FORMAT`, with `COPY_SRC`).
    pub fn shown_texture(&self) -> &wgpu::Texture {
        self.look_pass
            .as_ref()
            .and_then(LookPass::shown)
            .unwrap_or(&self.colour)
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

    /// Which LODs x-ray's ghost draws take in pieces (the hidden objects'
    /// runs of a leaf some of whose objects show), until set again.
    pub fn set_ghost_pieces(
        &mut self,
        pieces: Option<std::sync::Arc<gigawalk_scene::objects::LodPieces>>,
    ) {
        self.ghost_pieces = pieces;
    }

    /// Draws x-ray's ghosts over the frame drawn so far, faint and
    /// see-through, depth-tested against it and hiding nothing: after
    /// every chunk of the visible set, over the whole image.
    pub fn draw_ghosts(&mut self, ctx: &GpuContext, residency: &dyn Residency, lods: &[u32]) {
        if lods.is_empty() {
            return;
        }
        if !self.cleared {
            self.draw(ctx, &NoGeometry, &[]);
        }
        let normals = self.writes_normals();
        if self.ghost_pipelines[normals as usize].is_none() {
            let mut targets = vec![Some(COLOUR_FORMAT)];
            if normals {
                targets.push(Some(NORMAL_FORMAT));
            }
            self.ghost_pipelines[normals as usize] = Some(scene_pipelines(
                ctx,
                &self.drawer,
                "visible ghosts",
                (shader_types::VISIBLE_WGSL, shader_types::VISIBLE_CLIP_WGSL),
                &targets,
                wgpu::PolygonMode::Fill,
                Surface::Ghost,
            ));
        }
        let pieces = self.drawer.take_pieces();
        self.drawer.set_pieces(self.ghost_pieces.clone());
        let scissor = self.scissor.take();
        self.record_draws(ctx, residency, lods, true);
        self.scissor = scissor;
        self.drawer.set_pieces(pieces);
    }

    /// Starts a frame: the next [`VisiblePass::draw`] clears the targets.
    /// `look`: what the shown image adds once the frame ends (its passes
    /// and the normal target are made the first time a frame asks).
    pub fn begin(&mut self, ctx: &GpuContext, view: &View, style: DrawStyle, look: Look) {
        self.set_look(ctx, look);
        self.style = match style {
            DrawStyle::Wireframe if self.colour_only.wire.is_none() => {
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

    fn set_look(&mut self, ctx: &GpuContext, look: Look) {
        self.look = look;
        if look.is_plain() {
            return;
        }
        if look.needs_normals() && self.with_normals.is_none() {
            self.with_normals = Some(Pipelines::new(
                ctx,
                &self.drawer,
                &[Some(COLOUR_FORMAT), Some(NORMAL_FORMAT)],
            ));
        }
        if self.look_pass.is_none() {
            let normal = target(
                ctx,
                "visible normals",
                self.width,
                self.height,
                NORMAL_FORMAT,
            );
            self.look_pass = Some(LookPass::new(ctx, &self.colour, &self.depth, &normal));
            self.normal = Some(normal);
        }
    }

    /// Whether this frame's draws write the normal target (its look
    /// needs normals; `set_look` made the target then).
    fn writes_normals(&self) -> bool {
        self.look.needs_normals() && self.normal.is_some()
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
        self.record_draws(ctx, residency, lods, false);
    }

    /// Records and submits one chunk: the visible set's, or with `ghosts`
    /// x-ray's ghosts.
    fn record_draws(
        &mut self,
        ctx: &GpuContext,
        residency: &dyn Residency,
        lods: &[u32],
        ghosts: bool,
    ) {
        let view = self.view.expect("VisiblePass::begin before draw");
        let t = Instant::now();
        let draws = self.drawer.prepare(ctx, &view, residency, lods);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        {
            let cv = self.colour.create_view(&Default::default());
            let dv = self.depth.create_view(&Default::default());
            let nv = self
                .normal
                .as_ref()
                .filter(|_| self.writes_normals())
                .map(|n| n.create_view(&Default::default()));
            let attachment = |view, clear| {
                Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: if self.cleared {
                            wgpu::LoadOp::Load
                        } else {
                            wgpu::LoadOp::Clear(clear)
                        },
                        store: wgpu::StoreOp::Store,
                    },
                })
            };
            let mut colour = vec![attachment(&cv, BACKGROUND)];
            if let Some(nv) = &nv {
                colour.push(attachment(nv, wgpu::Color::TRANSPARENT));
            }
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("visible"),
                color_attachments: &colour,
                depth_stencil_attachment: Some(depth_attachment(&dv, !self.cleared)),
                ..Default::default()
            });
            let set = match (&self.with_normals, nv.is_some()) {
                (Some(with_normals), true) => with_normals,
                _ => &self.colour_only,
            };
            let pipelines = match (self.style, &set.wire) {
                _ if ghosts => self.ghost_pipelines[nv.is_some() as usize]
                    .as_ref()
                    .expect("made by draw_ghosts"),
                (DrawStyle::Wireframe, Some(wire)) => wire,
                _ => &set.fill,
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
        if let (Some(look_pass), Some(view)) = (&mut self.look_pass, &self.view) {
            if self.look.is_plain() {
                look_pass.skip();
            } else {
                let t = Instant::now();
                let mut enc = ctx.device.create_command_encoder(&Default::default());
                let shaded = self.style == DrawStyle::Shaded;
                look_pass.record(ctx, &mut enc, view, &self.look, shaded);
                self.figures.encode_ms += ms_since(t);
                self.submitted = Some(self.figures.submit(ctx, enc));
            }
        }
        self.view = None;
        let this_frame = self.submitted.take();
        if let Some(index) = std::mem::replace(&mut self.previous_frame, this_frame) {
            self.figures.wait(ctx, index)?;
        }
        ctx.check()
    }

    /// Reads back the last finished frame's shown image
    /// ([`VisiblePass::shown_texture`]: sRGB RGBA8, row 0 at the top),
    /// what the window and screenshots show.
    pub fn read_shown(&mut self, ctx: &GpuContext) -> Result<Vec<u8>, GpuError> {
        let shown = self.shown_texture().clone();
        self.read_rgba(ctx, &shown)
    }

    /// Reads back one of the pass's `COLOUR_FORMAT` textures.
    fn read_rgba(
        &mut self,
        ctx: &GpuContext,
        texture: &wgpu::Texture,
    ) -> Result<Vec<u8>, GpuError> {
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let rows = self.colour_readback.record_texture(
            ctx,
            &mut enc,
            texture,
            self.width,
            self.height,
            4,
            wgpu::TextureAspect::All,
        );
        self.colour_readback
            .submit_and_read(ctx, enc, rows, &mut self.figures)
    }

    /// Reads back the last finished frame's colour and depth.
    pub fn read_back(&mut self, ctx: &GpuContext) -> Result<FrameImage, GpuError> {
        let (w, h) = (self.width, self.height);
        let colour = self.read_rgba(ctx, &self.colour.clone())?;
        let depth = self
            .depth_readback
            .depth(ctx, &self.depth, w, h, &mut self.figures)?;
        Ok(FrameImage { colour, depth })
    }

    /// Asks for the last finished frame's colour and depth without
    /// waiting (a page's thread may not block): [`VisiblePass::try_take_frame`]
    /// takes them once the device has copied them, the same image
    /// [`VisiblePass::read_back`] gives. Until then no other read-back of
    /// this pass may start.
    pub fn submit_read_back(&mut self, ctx: &GpuContext) -> PendingFrame {
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
            .submit_async(ctx, enc, rows, &mut self.figures);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let rows = self
            .depth_readback
            .record_depth(ctx, &mut enc, &self.depth, w, h);
        let depth = self
            .depth_readback
            .submit_async(ctx, enc, rows, &mut self.figures);
        PendingFrame {
            colour: Part::Waiting(colour),
            depth: Part::Waiting(depth),
            width: w,
            height: h,
        }
    }

    /// The frame `pending` read, once the device has copied it; `Err`
    /// gives `pending` back while it has not. Never blocks.
    pub fn try_take_frame(
        &mut self,
        ctx: &GpuContext,
        pending: PendingFrame,
    ) -> Result<Result<FrameImage, GpuError>, PendingFrame> {
        let PendingFrame {
            colour,
            depth,
            width,
            height,
        } = pending;
        let colour = match colour.poll(&mut self.colour_readback, ctx, &mut self.figures) {
            Ok(c) => c,
            Err(e) => return Ok(Err(e)),
        };
        let depth = match depth.poll(&mut self.depth_readback, ctx, &mut self.figures) {
            Ok(d) => d,
            Err(e) => return Ok(Err(e)),
        };
        match (colour, depth) {
            (Part::Done(colour), Part::Done(bits)) => Ok(Ok(FrameImage {
                colour,
                depth: crate::passes::DepthImage::from_bits(width, height, bits),
            })),
            (colour, depth) => Err(PendingFrame {
                colour,
                depth,
                width,
                height,
            }),
        }
    }
}

/// A frame's colour and depth on their way back
/// ([`VisiblePass::submit_read_back`]).
pub struct PendingFrame {
    colour: Part<u8>,
    depth: Part<u32>,
    width: u32,
    height: u32,
}

/// One of a pending frame's read-backs: waiting, or its texels.
enum Part<T> {
    Waiting(crate::passes::Pending),
    Done(Vec<T>),
}

impl<T: bytemuck::Pod> Part<T> {
    /// Takes the texels if they have arrived.
    fn poll(
        self,
        readback: &mut ReadBack,
        ctx: &GpuContext,
        figures: &mut PassFigures,
    ) -> Result<Part<T>, GpuError> {
        match self {
            Part::Done(v) => Ok(Part::Done(v)),
            Part::Waiting(p) => match readback.try_finish::<T>(ctx, p, figures) {
                Err(p) => Ok(Part::Waiting(p)),
                Ok(r) => r.map(Part::Done),
            },
        }
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
