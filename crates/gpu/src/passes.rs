//! The two render passes: OR (depth of the occluders, read back for the
//! HZB) and RVG (colour + depth of the visible set, to an offscreen target
//! or a window). Both draw a list of LODs camera-relatively.

use glam::{DVec3, Mat4, Vec3};

use crate::residency::{LodRange, Residency};
use crate::shader_types::{self, DrawInstance, FrameUniforms};
use crate::{GpuContext, GpuError};

/// What a pass needs to know about the camera. `view_proj` has no
/// translation: positions are made camera-relative per draw, in f64.
#[derive(Clone, Copy, Debug)]
pub struct View {
    pub eye: DVec3,
    pub view_proj: Mat4,
    /// Direction the camera looks (the head light's direction).
    pub forward: Vec3,
}

/// A depth image as read back: row-major, row 0 at the top, reversed-Z
/// (1 at the near plane, 0 = nothing drawn / infinitely far).
#[derive(Clone, Debug, PartialEq)]
pub struct DepthImage {
    pub width: u32,
    pub height: u32,
    pub depth: Vec<f32>,
}

/// A colour image (sRGB RGBA8, row 0 at the top) with its depth.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameImage {
    pub colour: Vec<u8>,
    pub depth: DepthImage,
}

pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Where depth is copied, bit for bit, to be read back on adapters that
/// cannot copy a depth texture to a buffer (GL): integer formats are
/// renderable everywhere, 32-bit floats not on every GLES.
pub(crate) const DEPTH_COPY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;
pub const DEPTH_COPY_WGSL: &str = include_str!("../../../shaders/depth_copy.wgsl");
pub const COLOUR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
/// How RVG draws triangles.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DrawStyle {
    /// Filled, lit by the head light.
    #[default]
    Shaded,
    /// Triangle edges only, in the object's unlit colour. Needs the
    /// adapter's `POLYGON_MODE_LINE` ([`GpuContext::supports_wireframe`]);
    /// without it RVG draws `Shaded` and logs a warning once.
    Wireframe,
}

/// Reversed-Z: clear to 0 (infinitely far), keep the greater depth.
pub(crate) const DEPTH_COMPARE: wgpu::CompareFunction = wgpu::CompareFunction::GreaterEqual;

/// Uniforms, per-draw instance data and the draw loop shared by both passes.
pub(crate) struct Drawer {
    uniforms: wgpu::Buffer,
    pub(crate) bind_group: wgpu::BindGroup,
    pub(crate) layout: wgpu::PipelineLayout,
    instances: wgpu::Buffer,
    /// Instances already used this frame (chunks append).
    used: u64,
    /// Written to `FrameUniforms::params.z` (what shaders that read it
    /// move toward the eye in depth).
    pub(crate) depth_bias: f32,
}

impl Drawer {
    pub(crate) fn new(ctx: &GpuContext, label: &str) -> Drawer {
        let d = &ctx.device;
        let bgl = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(label),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let uniforms = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: std::mem::size_of::<FrameUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout: &bgl,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: uniforms.as_entire_binding(),
            }],
        });
        let layout = d.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: &[Some(&bgl)],
            immediate_size: 0,
        });
        Drawer {
            uniforms,
            bind_group,
            layout,
            instances: instance_buffer(ctx, 1024),
            used: 0,
            depth_bias: 0.0,
        }
    }

    /// `unlit`: draw the object colour without lighting (wireframe).
    pub(crate) fn begin(&mut self, ctx: &GpuContext, view: &View, unlit: bool) {
        let u = FrameUniforms {
            view_proj: view.view_proj.to_cols_array_2d(),
            light_dir: view
                .forward
                .normalize_or(Vec3::NEG_Z)
                .extend(0.0)
                .to_array(),
            params: [0.25, if unlit { 1.0 } else { 0.0 }, self.depth_bias, 0.0],
        };
        ctx.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&u));
        self.used = 0;
    }

    /// Writes this chunk's instance data; returns the draws with their instance index.
    pub(crate) fn prepare(
        &mut self,
        ctx: &GpuContext,
        view: &View,
        residency: &dyn Residency,
        lods: &[u32],
    ) -> Vec<(LodRange, u32)> {
        let draws: Vec<LodRange> = lods.iter().filter_map(|&l| residency.range(l)).collect();
        let size = std::mem::size_of::<DrawInstance>() as u64;
        let needed = self.used + draws.len() as u64;
        if needed * size > self.instances.size() {
            // Earlier chunks keep the old buffer alive until they finish.
            self.instances = instance_buffer(ctx, needed.next_power_of_two().max(1024));
            self.used = 0;
        }
        let data: Vec<DrawInstance> = draws
            .iter()
            .map(|r| DrawInstance {
                offset: (r.origin - view.eye).as_vec3().extend(0.0).to_array(),
            })
            .collect();
        ctx.queue.write_buffer(
            &self.instances,
            self.used * size,
            bytemuck::cast_slice(&data),
        );
        let first = self.used as u32;
        self.used += draws.len() as u64;
        draws
            .into_iter()
            .enumerate()
            .map(|(i, r)| (r, first + i as u32))
            .collect()
    }

    pub(crate) fn record(
        &self,
        pass: &mut wgpu::RenderPass,
        residency: &dyn Residency,
        draws: &[(LodRange, u32)],
    ) {
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_vertex_buffer(1, self.instances.slice(..));
        let mut bound = None;
        for (r, instance) in draws {
            if bound != Some(r.buffer) {
                let (v, i) = residency.buffers(r.buffer);
                pass.set_vertex_buffer(0, v.slice(..));
                pass.set_index_buffer(i.slice(..), wgpu::IndexFormat::Uint32);
                bound = Some(r.buffer);
            }
            pass.draw_indexed(
                r.first_index..r.first_index + r.index_count,
                r.base_vertex,
                *instance..*instance + 1,
            );
        }
    }
}

fn instance_buffer(ctx: &GpuContext, count: u64) -> wgpu::Buffer {
    ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("draw instances"),
        size: count * std::mem::size_of::<DrawInstance>() as u64,
        usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

pub(crate) fn target(
    ctx: &GpuContext,
    label: &str,
    w: u32,
    h: u32,
    format: wgpu::TextureFormat,
) -> wgpu::Texture {
    ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    })
}

pub(crate) fn pipeline(
    ctx: &GpuContext,
    drawer: &Drawer,
    label: &str,
    wgsl: &str,
    colour: Option<wgpu::TextureFormat>,
    polygon_mode: wgpu::PolygonMode,
) -> wgpu::RenderPipeline {
    let module = ctx
        .device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(label),
            source: wgpu::ShaderSource::Wgsl(shader_types::shader_source(wgsl).into()),
        });
    let targets = [colour.map(|format| wgpu::ColorTargetState {
        format,
        blend: None,
        write_mask: wgpu::ColorWrites::ALL,
    })];
    ctx.device
        .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(&drawer.layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[
                    Some(shader_types::vertex_layout()),
                    Some(shader_types::instance_layout()),
                ],
            },
            primitive: wgpu::PrimitiveState {
                // No culling: imported winding is not trusted, and OR must
                // write every occluder's depth.
                cull_mode: None,
                polygon_mode,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(DEPTH_COMPARE),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: colour.map(|_| wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &targets,
            }),
            multiview_mask: None,
            cache: None,
        })
}

/// OR: renders occluders' depth at its own resolution and reads it back.
pub struct DepthPass {
    drawer: Drawer,
    pipeline: wgpu::RenderPipeline,
    depth: wgpu::Texture,
    readback: ReadBack,
    width: u32,
    height: u32,
}

impl DepthPass {
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> DepthPass {
        let drawer = Drawer::new(ctx, "occluder depth");
        let pipeline = pipeline(
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
            pipeline,
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
            pass.set_pipeline(&self.pipeline);
            self.drawer.record(&mut pass, residency, &draws);
        }
        ctx.queue.submit([enc.finish()]);
        self.readback
            .depth(ctx, &self.depth, self.width, self.height)
    }
}

pub(crate) fn depth_attachment(
    view: &wgpu::TextureView,
    clear: bool,
) -> wgpu::RenderPassDepthStencilAttachment<'_> {
    wgpu::RenderPassDepthStencilAttachment {
        view,
        depth_ops: Some(wgpu::Operations {
            load: if clear {
                wgpu::LoadOp::Clear(0.0)
            } else {
                wgpu::LoadOp::Load
            },
            store: wgpu::StoreOp::Store,
        }),
        stencil_ops: None,
    }
}

/// RVG: draws the visible list in chunks as it arrives, to an offscreen
/// colour target (or a caller-provided view, e.g. a window's surface).
pub struct VisiblePass {
    drawer: Drawer,
    pipeline: wgpu::RenderPipeline,
    /// The line-mode pipeline, where the device supports it.
    wire_pipeline: Option<wgpu::RenderPipeline>,
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
                shader_types::VISIBLE_WGSL,
                Some(COLOUR_FORMAT),
                mode,
            )
        };
        let pipeline = visible("visible", wgpu::PolygonMode::Fill);
        let wire_pipeline = ctx
            .supports_wireframe()
            .then(|| visible("visible wireframe", wgpu::PolygonMode::Line));
        VisiblePass {
            wire_pipeline,
            style: DrawStyle::Shaded,
            warned_no_wireframe: false,
            colour: target(ctx, "visible colour", width, height, COLOUR_FORMAT),
            depth: target(ctx, "visible depth", width, height, DEPTH_FORMAT),
            colour_readback: ReadBack::default(),
            depth_readback: ReadBack::default(),
            drawer,
            pipeline,
            width,
            height,
            cleared: false,
            scissor: None,
            view: None,
        }
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

    /// Starts a frame: the next [`VisiblePass::draw`] clears the targets.
    pub fn begin(&mut self, ctx: &GpuContext, view: &View, style: DrawStyle) {
        self.style = match style {
            DrawStyle::Wireframe if self.wire_pipeline.is_none() => {
                if !self.warned_no_wireframe {
                    tracing::warn!(
                        "{}: no POLYGON_MODE_LINE, drawing shaded instead of wireframe",
                        ctx.name
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
            let pipeline = match (self.style, &self.wire_pipeline) {
                (DrawStyle::Wireframe, Some(wire)) => wire,
                _ => &self.pipeline,
            };
            pass.set_pipeline(pipeline);
            if let Some([x, y, w, h]) = self.scissor {
                let (tw, th) = (self.width, self.height);
                let (x, y) = (x.min(tw), y.min(th));
                pass.set_scissor_rect(x, y, w.min(tw - x), h.min(th - y));
            }
            self.drawer.record(&mut pass, residency, &draws);
        }
        self.cleared = true;
        ctx.queue.submit([enc.finish()]);
    }

    /// Ends the frame: waits until the GPU is done and optionally reads
    /// back colour and depth.
    pub fn finish(
        &mut self,
        ctx: &GpuContext,
        read_back: bool,
    ) -> Result<Option<FrameImage>, GpuError> {
        if !self.cleared {
            // An empty frame still clears its targets.
            self.draw(ctx, &NoGeometry, &[]);
        }
        self.view = None;
        if !read_back {
            ctx.device
                .poll(wgpu::PollType::wait_indefinitely())
                .map_err(|e| device_error(ctx, e))?;
            ctx.check()?;
            return Ok(None);
        }
        self.read_back(ctx).map(Some)
    }

    /// Reads back the last finished frame's colour and depth.
    pub fn read_back(&mut self, ctx: &GpuContext) -> Result<FrameImage, GpuError> {
        let colour = self.colour_readback.read(
            ctx,
            &self.colour,
            self.width,
            self.height,
            4,
            wgpu::TextureAspect::All,
        )?;
        let depth = self
            .depth_readback
            .depth(ctx, &self.depth, self.width, self.height)?;
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

/// Maps `slice` for reading and waits until it is (after the submissions
/// that fill it).
pub(crate) fn map_and_wait(ctx: &GpuContext, slice: wgpu::BufferSlice) -> Result<(), GpuError> {
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    ctx.device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| device_error(ctx, e))?;
    ctx.check()?;
    rx.recv()
        .map_err(|e| device_error(ctx, e))?
        .map_err(|e| device_error(ctx, e))
}

pub(crate) fn device_error(ctx: &GpuContext, e: impl std::fmt::Display) -> GpuError {
    GpuError::Device {
        device: ctx.name.clone(),
        message: e.to_string(),
    }
}

/// A mappable buffer that texture read-backs copy into, kept from one
/// read-back to the next: OR reads its depth back every frame, and a new
/// buffer each time would be an allocation (and a driver-side free) per
/// frame. Made on first use, and again if the size changes.
#[derive(Default)]
pub(crate) struct ReadBack {
    buffer: Option<wgpu::Buffer>,
    /// The copy pass for depth, on adapters that need it (made on first use).
    depth_copy: Option<DepthCopy>,
}

impl ReadBack {
    /// Reads a `Depth32Float` texture back as a [`DepthImage`]: copied
    /// directly, or, where the adapter cannot copy depth (GL), drawn bit
    /// for bit into an R32Uint target that is copied.
    fn depth(
        &mut self,
        ctx: &GpuContext,
        tex: &wgpu::Texture,
        w: u32,
        h: u32,
    ) -> Result<DepthImage, GpuError> {
        let depth = if ctx.depth_via_pass {
            let copy = self.depth_copy.get_or_insert_with(|| DepthCopy::new(ctx));
            let target = copy.draw(ctx, tex, w, h);
            let bits: Vec<u32> = self.read(ctx, &target, w, h, 4, wgpu::TextureAspect::All)?;
            bits.into_iter().map(f32::from_bits).collect()
        } else {
            self.read(ctx, tex, w, h, 4, wgpu::TextureAspect::DepthOnly)?
        };
        Ok(DepthImage {
            width: w,
            height: h,
            depth,
        })
    }

    /// Copies a texture of `bpp` bytes per texel into the buffer, waits,
    /// and returns its rows tightly packed (the copy pads rows to 256
    /// bytes) as `T`s.
    pub(crate) fn read<T: bytemuck::Pod>(
        &mut self,
        ctx: &GpuContext,
        tex: &wgpu::Texture,
        w: u32,
        h: u32,
        bpp: u32,
        aspect: wgpu::TextureAspect,
    ) -> Result<Vec<T>, GpuError> {
        let row = w * bpp;
        let padded = row.next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let size = padded as u64 * h as u64;
        // Taken out while in use: a read-back that fails part-way may leave
        // the buffer mapped, so only a finished one is put back.
        let buf = match self.buffer.take().filter(|b| b.size() == size) {
            Some(b) => b,
            None => ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("readback"),
                size,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            }),
        };
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: tex,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buf,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
        ctx.queue.submit([enc.finish()]);
        map_and_wait(ctx, buf.slice(..))?;
        let data = buf.get_mapped_range(..).map_err(|e| device_error(ctx, e))?;
        let mut out = Vec::with_capacity(row as usize * h as usize / std::mem::size_of::<T>());
        for y in 0..h as usize {
            let bytes = &data[y * padded as usize..][..row as usize];
            match bytemuck::try_cast_slice(bytes) {
                Ok(texels) => out.extend_from_slice(texels),
                // Mapped memory is aligned in practice; copy if it is not.
                Err(_) => out.extend(
                    bytes
                        .chunks_exact(std::mem::size_of::<T>())
                        .map(bytemuck::pod_read_unaligned::<T>),
                ),
            }
        }
        drop(data);
        buf.unmap();
        self.buffer = Some(buf);
        Ok(out)
    }
}

/// The depth copy pass (`shaders/depth_copy.wgsl`), with its target and
/// bind group kept while the depth texture and size stay the same.
struct DepthCopy {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    /// The depth texture last copied, its bind group, and the target.
    bound: Option<(wgpu::Texture, wgpu::BindGroup, wgpu::Texture)>,
}

impl DepthCopy {
    fn new(ctx: &GpuContext) -> DepthCopy {
        let d = &ctx.device;
        let layout = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("depth copy"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            }],
        });
        let pipeline = fullscreen_pipeline(
            ctx,
            "depth copy",
            DEPTH_COPY_WGSL,
            &layout,
            DEPTH_COPY_FORMAT,
        );
        DepthCopy {
            pipeline,
            layout,
            bound: None,
        }
    }

    /// Draws `tex`'s depth into the R32Uint target and returns it (the
    /// caller's copy is submitted after this pass, on the same queue).
    fn draw(&mut self, ctx: &GpuContext, tex: &wgpu::Texture, w: u32, h: u32) -> wgpu::Texture {
        let fresh = match &self.bound {
            Some((t, _, target)) => t != tex || target.width() != w || target.height() != h,
            None => true,
        };
        if fresh {
            let view = tex.create_view(&wgpu::TextureViewDescriptor {
                aspect: wgpu::TextureAspect::DepthOnly,
                ..Default::default()
            });
            let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("depth copy"),
                layout: &self.layout,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&view),
                }],
            });
            let target = target(ctx, "depth copy", w, h, DEPTH_COPY_FORMAT);
            self.bound = Some((tex.clone(), bind_group, target));
        }
        let (_, bind_group, target) = self.bound.as_ref().expect("bound above");
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        {
            let view = target.create_view(&Default::default());
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("depth copy"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                ..Default::default()
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, bind_group, &[]);
            pass.draw(0..3, 0..1);
        }
        ctx.queue.submit([enc.finish()]);
        target.clone()
    }
}

/// A pipeline that draws one fullscreen triangle (`vs_main`, no vertex
/// buffers) with `wgsl`'s `fs_main` into one `format` target, reading bind
/// group 0 of `layout`: the blit to a window, the depth copy.
pub(crate) fn fullscreen_pipeline(
    ctx: &GpuContext,
    label: &str,
    wgsl: &str,
    layout: &wgpu::BindGroupLayout,
    format: wgpu::TextureFormat,
) -> wgpu::RenderPipeline {
    let d = &ctx.device;
    let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(wgsl.into()),
    });
    let pipeline_layout = d.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    d.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: Default::default(),
        depth_stencil: None,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}
