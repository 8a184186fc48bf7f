//! Hardware occlusion queries (Bartz, Meissner and Huettner): the depth of
//! what a frame has drawn so far, on the device, and node boxes drawn
//! against it inside occlusion queries, a batch per round trip.

use glam::Vec3;

use crate::passes::{
    depth_attachment, device_error, map_and_wait, pipeline, target, Drawer, PassFigures,
    ScenePipelines, DEPTH_COMPARE, DEPTH_FORMAT,
};
use crate::shader_types;
use crate::{GpuContext, GpuError, Residency, View};

pub const QUERY_BOX_WGSL: &str = include_str!("../../../shaders/query_box.wgsl");

/// A box for a query, relative to the eye, in f32 (rounded outward by the
/// caller).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct QueryBox {
    pub min: [f32; 4],
    pub max: [f32; 4],
}

impl QueryBox {
    pub fn new(min: Vec3, max: Vec3) -> Self {
        QueryBox {
            min: min.extend(0.0).to_array(),
            max: max.extend(0.0).to_array(),
        }
    }
}

const BOX_ATTRIBUTES: [wgpu::VertexAttribute; 2] =
    wgpu::vertex_attr_array![4 => Float32x4, 5 => Float32x4];

/// A frame's depth on the device and the queries against it. Per frame:
/// [`QueryPass::begin`], then any mix of [`QueryPass::draw`] (LODs that
/// write depth, recorded with the next round trip) and
/// [`QueryPass::query`] (one round trip: the draws so far, then one
/// occlusion query per box; returns the samples each passed).
pub struct QueryPass {
    drawer: Drawer,
    depth_pipelines: ScenePipelines,
    box_pipeline: wgpu::RenderPipeline,
    depth: wgpu::Texture,
    queries: wgpu::QuerySet,
    capacity: u32,
    resolve: wgpu::Buffer,
    read: wgpu::Buffer,
    boxes: wgpu::Buffer,
    /// LODs drawn since the last round trip.
    pending: Vec<u32>,
    /// Whether the frame's depth still needs its clear.
    clear: bool,
    view: Option<View>,
}

fn query_buffers(
    ctx: &GpuContext,
    n: u32,
) -> (wgpu::QuerySet, wgpu::Buffer, wgpu::Buffer, wgpu::Buffer) {
    let d = &ctx.device;
    let queries = d.create_query_set(&wgpu::QuerySetDescriptor {
        label: Some("occlusion queries"),
        ty: wgpu::QueryType::Occlusion,
        count: n,
    });
    let bytes = n as u64 * 8;
    let buf = |label, usage| {
        d.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes,
            usage,
            mapped_at_creation: false,
        })
    };
    let resolve = buf(
        "query resolve",
        wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
    );
    let read = buf(
        "query read",
        wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
    );
    let boxes = d.create_buffer(&wgpu::BufferDescriptor {
        label: Some("query boxes"),
        size: n as u64 * std::mem::size_of::<QueryBox>() as u64,
        usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    (queries, resolve, read, boxes)
}

impl QueryPass {
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> QueryPass {
        let mut drawer = Drawer::new(ctx, "query depth");
        // Boxes are drawn nearer by twice the device's depth error (GL's):
        // box and node are rounded independently.
        drawer.depth_bias = 2.0 * ctx.depth_error();
        let depth_pipelines = pipeline(
            ctx,
            &drawer,
            "query depth",
            (
                shader_types::OCCLUDER_DEPTH_WGSL,
                shader_types::OCCLUDER_DEPTH_CLIP_WGSL,
            ),
            &[],
            wgpu::PolygonMode::Fill,
        );
        let module = ctx
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("query box"),
                source: wgpu::ShaderSource::Wgsl(
                    shader_types::shader_source(QUERY_BOX_WGSL).into(),
                ),
            });
        let box_pipeline = ctx
            .device
            .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("query box"),
                layout: Some(&drawer.layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout {
                        array_stride: std::mem::size_of::<QueryBox>() as u64,
                        step_mode: wgpu::VertexStepMode::Instance,
                        attributes: &BOX_ATTRIBUTES,
                    })],
                },
                primitive: wgpu::PrimitiveState {
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(false),
                    depth_compare: Some(DEPTH_COMPARE),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: None,
                multiview_mask: None,
                cache: None,
            });
        let capacity = 256;
        let (queries, resolve, read, boxes) = query_buffers(ctx, capacity);
        QueryPass {
            drawer,
            depth_pipelines,
            box_pipeline,
            depth: target(
                ctx,
                "query depth",
                width.max(1),
                height.max(1),
                DEPTH_FORMAT,
            ),
            queries,
            capacity,
            resolve,
            read,
            boxes,
            pending: Vec::new(),
            clear: true,
            view: None,
        }
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

    /// Starts a frame: its depth clears with the first round trip.
    pub fn begin(&mut self, ctx: &GpuContext, view: &View) {
        self.drawer.begin(ctx, view, false);
        self.pending.clear();
        self.clear = true;
        self.view = Some(*view);
    }

    /// LODs the frame drew: their depth is written with the next round
    /// trip, before its queries.
    pub fn draw(&mut self, lods: &[u32]) {
        self.pending.extend_from_slice(lods);
    }

    /// One round trip: the pending draws, then a query per box; waits and
    /// returns the samples each box passed (the count where the driver
    /// counts; WebGPU only promises zero or not). More boxes than a query
    /// set holds ([`wgpu::QUERY_SET_MAX_QUERIES`]) take one round trip per
    /// set's worth.
    pub fn query(
        &mut self,
        ctx: &GpuContext,
        residency: Option<&dyn Residency>,
        boxes: &[QueryBox],
    ) -> Result<Vec<u64>, GpuError> {
        let max = wgpu::QUERY_SET_MAX_QUERIES as usize;
        if boxes.len() <= max {
            return self.query_set(ctx, residency, boxes);
        }
        let mut out = Vec::with_capacity(boxes.len());
        for chunk in boxes.chunks(max) {
            out.extend(self.query_set(ctx, residency, chunk)?);
        }
        Ok(out)
    }

    fn query_set(
        &mut self,
        ctx: &GpuContext,
        residency: Option<&dyn Residency>,
        boxes: &[QueryBox],
    ) -> Result<Vec<u64>, GpuError> {
        let Some(view) = self.view else {
            return Ok(vec![u64::MAX; boxes.len()]);
        };
        let n = boxes.len() as u32;
        if n > self.capacity {
            self.capacity = n.next_power_of_two().min(wgpu::QUERY_SET_MAX_QUERIES);
            (self.queries, self.resolve, self.read, self.boxes) = query_buffers(ctx, self.capacity);
        }
        let pending = std::mem::take(&mut self.pending);
        let draws = match residency {
            Some(r) => self.drawer.prepare(ctx, &view, r, &pending),
            None => Vec::new(),
        };
        if n > 0 {
            ctx.queue
                .write_buffer(&self.boxes, 0, bytemuck::cast_slice(boxes));
        }
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        {
            let dv = self.depth.create_view(&Default::default());
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("occlusion queries"),
                color_attachments: &[],
                depth_stencil_attachment: Some(depth_attachment(&dv, self.clear)),
                occlusion_query_set: (n > 0).then_some(&self.queries),
                ..Default::default()
            });
            if let Some(r) = residency.filter(|_| !draws.is_empty()) {
                self.drawer
                    .record(&mut pass, r, &draws, &self.depth_pipelines);
            }
            pass.set_pipeline(&self.box_pipeline);
            pass.set_bind_group(0, &self.drawer.bind_group, &[]);
            pass.set_vertex_buffer(0, self.boxes.slice(..));
            for i in 0..n {
                pass.begin_occlusion_query(i);
                pass.draw(0..36, i..i + 1);
                pass.end_occlusion_query();
            }
        }
        self.clear = false;
        if n == 0 {
            ctx.queue.submit([enc.finish()]);
            return Ok(Vec::new());
        }
        enc.resolve_query_set(&self.queries, 0..n, &self.resolve, 0);
        enc.copy_buffer_to_buffer(&self.resolve, 0, &self.read, 0, n as u64 * 8);
        let index = ctx.queue.submit([enc.finish()]);
        let bytes = n as u64 * 8;
        map_and_wait(
            ctx,
            self.read.slice(..bytes),
            index,
            &mut PassFigures::default(),
        )?;
        let out = {
            let data = self
                .read
                .slice(..bytes)
                .get_mapped_range()
                .map_err(|e| device_error(ctx, e))?;
            data.chunks_exact(8)
                .map(|c| u64::from_le_bytes(c.try_into().expect("8 bytes")))
                .collect()
        };
        self.read.unmap();
        Ok(out)
    }
}

/// What a device's occlusion queries count: WebGPU promises only zero
/// against non-zero; lavapipe and most drivers count samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QueryCounts {
    /// Queries return the samples that passed.
    Exact,
    /// Queries say only whether any sample passed.
    Boolean,
}

/// The start-up self-test: a flat box covering exactly the middle quarter
/// of a 64x64 target (32x32 pixel centres; its two coincident faces both
/// count) must pass 2048 samples.
pub fn query_counts(ctx: &GpuContext) -> Result<QueryCounts, GpuError> {
    let mut pass = QueryPass::new(ctx, 64, 64);
    // An orthographic-like setup: identity rotation, a view-projection
    // that maps camera space x, y in [-1, 1] at depth 1 onto the image.
    let view = View {
        eye: glam::DVec3::ZERO,
        view_proj: glam::Mat4::from_cols(
            glam::Vec4::new(1.0, 0.0, 0.0, 0.0),
            glam::Vec4::new(0.0, 1.0, 0.0, 0.0),
            glam::Vec4::new(0.0, 0.0, 0.0, -1.0),
            glam::Vec4::new(0.0, 0.0, 0.1, 0.0),
        ),
        forward: Vec3::NEG_Z,
        clip: crate::passes::ClipPlanes::NONE,
    };
    pass.begin(ctx, &view);
    let b = QueryBox::new(Vec3::new(-0.5, -0.5, -1.0), Vec3::new(0.5, 0.5, -1.0));
    let n = pass.query(ctx, None, &[b])?;
    Ok(match n.first() {
        Some(&2048) => QueryCounts::Exact,
        _ => QueryCounts::Boolean,
    })
}
