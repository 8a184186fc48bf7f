//! OR: the occluders' depth at its own resolution, read back for the HZB.

use crate::passes::{
    depth_attachment, pipeline, target, DepthImage, Drawer, ReadBack, ScenePipelines, View,
    DEPTH_FORMAT,
};
use crate::residency::Residency;
use crate::shader_types;
use crate::{GpuContext, GpuError};

/// OR: renders occluders' depth at its own resolution and reads it back.
pub struct DepthPass {
    drawer: Drawer,
    pipelines: ScenePipelines,
    depth: wgpu::Texture,
    readback: ReadBack,
    width: u32,
    height: u32,
}

impl DepthPass {
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> DepthPass {
        let drawer = Drawer::new(ctx, "occluder depth");
        let pipelines = pipeline(
            ctx,
            &drawer,
            "occluder depth",
            shader_types::OCCLUDER_DEPTH_WGSL,
            None,
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
            width: width.max(1),
            height: height.max(1),
        }
    }

    /// Draws the LODs' depth and waits for the readback (call it on the
    /// OR thread: it blocks only that stage).
    pub fn render(
        &mut self,
        ctx: &GpuContext,
        residency: &dyn Residency,
        view: &View,
        lods: &[u32],
    ) -> Result<DepthImage, GpuError> {
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
        ctx.queue.submit([enc.finish()]);
        self.readback
            .depth(ctx, &self.depth, self.width, self.height)
    }
}
