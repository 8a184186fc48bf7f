//! OR: the occluders' depth at its own resolution, and what of it STC
//! reads: a level of the HZB pyramid built here on the device (the
//! default), or the whole image (the CPU builds the pyramid).

use web_time::Instant;

use crate::passes::hzb::{level_size, Pyramid};
use crate::passes::{
    depth_attachment, ms_since, pipeline, target, DepthImage, Drawer, PassFigures, Pending,
    PyramidPath, ReadBack, Rows, ScenePipelines, View, DEPTH_FORMAT,
};
use crate::residency::Residency;
use crate::shader_types;
use crate::{GpuContext, GpuError};

/// OR: renders occluders' depth at its own resolution and reads back a
/// level of its pyramid.
pub struct DepthPass {
    drawer: Drawer,
    pipelines: ScenePipelines,
    depth: wgpu::Texture,
    readback: ReadBack,
    /// Made on the first read of a level above 0.
    pyramid: Option<Pyramid>,
    width: u32,
    height: u32,
}

/// Level `level` of the pyramid of OR's `width x height` depth image, as
/// read back: at level 0 the image itself, above it each texel the
/// farthest depth of the pixels it covers (`gigawalk_cull::Hzb`'s
/// levels, the same sizes).
#[derive(Clone, Debug, PartialEq)]
pub struct DepthLevel {
    pub level: u32,
    /// The size of level 0 (the depth image).
    pub width: u32,
    pub height: u32,
    /// The level's texels.
    pub image: DepthImage,
    /// What drawing and reading it cost the CPU.
    pub figures: PassFigures,
}

impl DepthPass {
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> DepthPass {
        let drawer = Drawer::new(ctx, "occluder depth");
        let pipelines = pipeline(
            ctx,
            &drawer,
            "occluder depth",
            (
                shader_types::OCCLUDER_DEPTH_WGSL,
                shader_types::OCCLUDER_DEPTH_CLIP_WGSL,
            ),
            &[],
            wgpu::PolygonMode::Fill,
        );
        DepthPass {
            depth: target(
                ctx,
                "occluder depth",
                width.max(1),
                height.max(1),
                DEPTH_FORMAT,
            ),
            drawer,
            pipelines,
            readback: ReadBack::default(),
            pyramid: None,
            width: width.max(1),
            height: height.max(1),
        }
    }

    /// The pyramid's top level (1x1) for this pass's size: the coarsest
    /// level [`DepthPass::render_level`] reads.
    pub fn top_level(&self) -> u32 {
        let side = self.width.max(self.height);
        u32::BITS - (side - 1).leading_zeros()
    }

    /// How the pyramid is built on `ctx` for this pass's size.
    pub fn pyramid_path(&self, ctx: &GpuContext) -> PyramidPath {
        Pyramid::path_for(ctx, self.width, self.height)
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

    /// Draws the LODs' depth and reads the whole image back (call it on
    /// the OR thread: it blocks only that stage).
    pub fn render(
        &mut self,
        ctx: &GpuContext,
        residency: &dyn Residency,
        view: &View,
        lods: &[u32],
    ) -> Result<DepthImage, GpuError> {
        Ok(self.render_level(ctx, residency, view, lods, 0)?.image)
    }

    /// Draws the LODs' depth, builds its pyramid up to `level` (at most
    /// [`DepthPass::top_level`]) on the device and reads that level back,
    /// waiting for this submission only (call it on the OR thread: it
    /// blocks only that stage). Level 0 reads the whole image.
    pub fn render_level(
        &mut self,
        ctx: &GpuContext,
        residency: &dyn Residency,
        view: &View,
        lods: &[u32],
        level: u32,
    ) -> Result<DepthLevel, GpuError> {
        let (enc, rows, mut shape) = self.record_level(ctx, residency, view, lods, level);
        let bits = self
            .readback
            .submit_and_read(ctx, enc, rows, &mut shape.figures)?;
        Ok(shape.with(bits))
    }

    /// As [`DepthPass::render_level`], without waiting: the level is
    /// taken by [`DepthPass::try_take_level`] once the device has made it.
    /// Where nothing may block (a browser's page thread), OR submits one
    /// frame's occluders and a later frame takes their depth.
    pub fn submit_level(
        &mut self,
        ctx: &GpuContext,
        residency: &dyn Residency,
        view: &View,
        lods: &[u32],
        level: u32,
    ) -> PendingLevel {
        let (enc, rows, mut shape) = self.record_level(ctx, residency, view, lods, level);
        let pending = self
            .readback
            .submit_async(ctx, enc, rows, &mut shape.figures);
        PendingLevel { pending, shape }
    }

    /// The level `pending` read, once the device has made it; `Err` gives
    /// `pending` back while it has not. Never blocks.
    pub fn try_take_level(
        &mut self,
        ctx: &GpuContext,
        pending: PendingLevel,
    ) -> Result<Result<DepthLevel, GpuError>, PendingLevel> {
        let PendingLevel { pending, mut shape } = pending;
        match self.readback.try_finish(ctx, pending, &mut shape.figures) {
            Err(pending) => Err(PendingLevel { pending, shape }),
            Ok(bits) => Ok(bits.and_then(|bits| {
                ctx.check()?;
                Ok(shape.with(bits))
            })),
        }
    }

    /// Records the depth of `lods` and the making and copy of `level`.
    fn record_level(
        &mut self,
        ctx: &GpuContext,
        residency: &dyn Residency,
        view: &View,
        lods: &[u32],
        level: u32,
    ) -> (wgpu::CommandEncoder, Rows, LevelShape) {
        let level = level.min(self.top_level());
        let mut figures = PassFigures::default();
        let t = Instant::now();
        self.drawer.begin(ctx, view, false);
        let draws = self.drawer.prepare(ctx, view, residency, lods);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        {
            let dv = self.depth.create_view(&Default::default());
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("occluder depth"),
                color_attachments: &[],
                depth_stencil_attachment: Some(depth_attachment(&dv, true)),
                ..Default::default()
            });
            self.drawer
                .record(&mut pass, residency, &draws, &self.pipelines);
        }
        let size = (self.width, self.height);
        let rows = if level == 0 {
            self.readback
                .record_depth(ctx, &mut enc, &self.depth, size.0, size.1)
        } else {
            let path = Pyramid::path_for(ctx, size.0, size.1);
            let pyramid = match &mut self.pyramid {
                Some(p) if p.path() == path => p,
                slot => slot.insert(Pyramid::new(ctx, path)),
            };
            pyramid.record(ctx, &mut enc, &self.depth, size, level, &mut self.readback)
        };
        figures.encode_ms += ms_since(t);
        let shape = LevelShape {
            level,
            width: size.0,
            height: size.1,
            figures,
        };
        (enc, rows, shape)
    }

    /// The size of level 0 (the depth image).
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }
}

/// A level of OR's pyramid submitted and not yet read
/// ([`DepthPass::submit_level`]).
pub struct PendingLevel {
    pending: Pending,
    shape: LevelShape,
}

impl PendingLevel {
    /// The level asked for (as [`DepthLevel::level`] will be).
    pub fn level(&self) -> u32 {
        self.shape.level
    }
}

/// All of a [`DepthLevel`] but its texels.
struct LevelShape {
    level: u32,
    width: u32,
    height: u32,
    figures: PassFigures,
}

impl LevelShape {
    fn with(self, bits: Vec<u32>) -> DepthLevel {
        let (w, h) = level_size(self.width, self.height, self.level);
        DepthLevel {
            level: self.level,
            width: self.width,
            height: self.height,
            image: DepthImage::from_bits(w, h, bits),
            figures: self.figures,
        }
    }
}
