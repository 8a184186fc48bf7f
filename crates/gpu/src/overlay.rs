//! The viewer's overlays, drawn over the RVG image before it is shown:
//! node bounding boxes as coloured lines (drawn / frustum-culled /
//! occlusion-culled, like Figure 13 of Coorg and Teller's paper), lines
//! of a given width in pixels (a measurement), and HUD text in an 8x8
//! bitmap font (public-domain font8x8), each line on a translucent panel
//! so it reads over any scene.

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};

use crate::GpuContext;

/// One box to outline, camera-relative (min/max minus the eye, in f64
/// then rounded, like every other draw), linear RGBA.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OverlayBox {
    pub min: Vec3,
    pub max: Vec3,
    pub colour: [f32; 4],
}

/// A block of text at a pixel position (row 0 at the top).
#[derive(Clone, Debug, PartialEq)]
pub struct OverlayText {
    pub x: f32,
    pub y: f32,
    /// Integer magnification of the 8x8 glyphs.
    pub scale: u32,
    pub lines: Vec<String>,
    pub colour: [f32; 4],
    /// Panel behind the text (alpha < 1 lets the scene show through).
    pub background: [f32; 4],
}

/// A line in pixels (row 0 at the top), `width` pixels wide: a thin
/// quad, drawn under the text (the caller projects and clips its ends).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OverlayLine {
    pub from: [f32; 2],
    pub to: [f32; 2],
    pub width: f32,
    pub colour: [f32; 4],
}

/// What to draw over one frame.
#[derive(Clone, Debug, Default)]
pub struct OverlayFrame {
    /// The camera's projection x rotation, as [`crate::View::view_proj`].
    pub view_proj: Mat4,
    pub boxes: Vec<OverlayBox>,
    pub lines: Vec<OverlayLine>,
    pub text: Vec<OverlayText>,
}

/// Measurement colours: a yellow that reads over the shaded scene, on a
/// dark outline.
const MEASURE_COLOUR: [f32; 4] = [1.0, 0.85, 0.1, 1.0];
const MEASURE_OUTLINE: [f32; 4] = [0.0, 0.0, 0.0, 0.8];

impl OverlayFrame {
    /// A measurement over a `size` image, in pixels (row 0 at the top):
    /// a marker at each of `markers` (a short thick line on it), the
    /// `segment` between the points and `label` (printable ASCII) at its
    /// middle, `scale` times the font's size.
    pub fn push_measurement(
        &mut self,
        markers: &[[f32; 2]],
        segment: Option<([f32; 2], [f32; 2])>,
        label: Option<String>,
        size: (u32, u32),
        scale: u32,
    ) {
        let s = scale as f32;
        for a in markers {
            for (width, colour) in [(9.0 * s, MEASURE_OUTLINE), (5.0 * s, MEASURE_COLOUR)] {
                let half = width * 0.5;
                self.lines.push(OverlayLine {
                    from: [a[0] - half, a[1]],
                    to: [a[0] + half, a[1]],
                    width,
                    colour,
                });
            }
        }
        let Some((from, to)) = segment else {
            return;
        };
        for (width, colour) in [(4.0 * s, MEASURE_OUTLINE), (2.0 * s, MEASURE_COLOUR)] {
            self.lines.push(OverlayLine {
                from,
                to,
                width,
                colour,
            });
        }
        if let Some(label) = label {
            let glyph = GLYPH as f32 * s;
            let mid = [(from[0] + to[0]) * 0.5, (from[1] + to[1]) * 0.5];
            let width = label.len() as f32 * glyph;
            self.text.push(OverlayText {
                // Centred on the middle, just above the line.
                x: (mid[0] - width * 0.5).clamp(glyph, (size.0 as f32 - width - glyph).max(glyph)),
                y: (mid[1] - 2.0 * glyph).clamp(glyph, (size.1 as f32 - 2.0 * glyph).max(glyph)),
                scale,
                lines: vec![label],
                colour: MEASURE_COLOUR,
                background: [0.0, 0.0, 0.0, 0.75],
            });
        }
    }
}

/// Glyph cell size of the font atlas, in texels.
pub const GLYPH: u32 = 8;
/// Atlas: 16 x 8 cells of the 128 ASCII codes; code 127 (DEL) is a solid
/// block used for panels.
const ATLAS_COLUMNS: u32 = 16;
const SOLID: u8 = 127;

/// Uniforms of shaders/overlay.wgsl (`OverlayUniforms`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct OverlayUniforms {
    pub view_proj: [[f32; 4]; 4],
    /// xy: target size in pixels.
    pub screen: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct LineVertex {
    position: [f32; 3],
    colour: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct TextVertex {
    pixel: [f32; 2],
    texel: [f32; 2],
    colour: [f32; 4],
}

pub const OVERLAY_WGSL: &str = include_str!("../../../shaders/overlay.wgsl");

/// The overlay pipelines and their resources on one device.
pub(crate) struct OverlayRenderer {
    uniforms: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    lines: wgpu::RenderPipeline,
    text: wgpu::RenderPipeline,
}

impl OverlayRenderer {
    pub(crate) fn new(ctx: &GpuContext, format: wgpu::TextureFormat) -> OverlayRenderer {
        let d = &ctx.device;
        let bgl = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("overlay"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
            ],
        });
        let uniforms = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("overlay uniforms"),
            size: std::mem::size_of::<OverlayUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let atlas = font_atlas(ctx);
        let atlas_view = atlas.create_view(&Default::default());
        let bind_group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("overlay"),
            layout: &bgl,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniforms.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&atlas_view),
                },
            ],
        });
        let layout = d.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("overlay"),
            bind_group_layouts: &[Some(&bgl)],
            immediate_size: 0,
        });
        let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("overlay"),
            source: wgpu::ShaderSource::Wgsl(OVERLAY_WGSL.into()),
        });
        let line_attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x4];
        let text_attrs = wgpu::vertex_attr_array![0 => Float32x2, 1 => Float32x2, 2 => Float32x4];
        let pipeline = |label: &str,
                        vs: &str,
                        fs: &str,
                        stride: usize,
                        attrs: &[wgpu::VertexAttribute],
                        topology: wgpu::PrimitiveTopology| {
            d.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some(vs),
                    compilation_options: Default::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout {
                        array_stride: stride as u64,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes: attrs,
                    })],
                },
                primitive: wgpu::PrimitiveState {
                    topology,
                    cull_mode: None,
                    ..Default::default()
                },
                // No depth test: culled boxes are mostly behind geometry,
                // and showing them is the point.
                depth_stencil: None,
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend: Some(wgpu::BlendState::ALPHA_BLENDING),
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        OverlayRenderer {
            lines: pipeline(
                "overlay boxes",
                "vs_line",
                "fs_line",
                std::mem::size_of::<LineVertex>(),
                &line_attrs,
                wgpu::PrimitiveTopology::LineList,
            ),
            text: pipeline(
                "overlay text",
                "vs_text",
                "fs_text",
                std::mem::size_of::<TextVertex>(),
                &text_attrs,
                wgpu::PrimitiveTopology::TriangleList,
            ),
            uniforms,
            bind_group,
        }
    }

    /// Records the overlay into `target` (loaded, not cleared).
    pub(crate) fn draw(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        size: (u32, u32),
        frame: &OverlayFrame,
    ) {
        if frame.boxes.is_empty() && frame.lines.is_empty() && frame.text.is_empty() {
            return;
        }
        let u = OverlayUniforms {
            view_proj: frame.view_proj.to_cols_array_2d(),
            screen: [size.0 as f32, size.1 as f32, 0.0, 0.0],
        };
        ctx.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&u));
        let lines = box_lines(&frame.boxes);
        // Lines first, so labels read over them; both are solid-glyph
        // and glyph quads of the text pipeline.
        let mut quads = line_quads(&frame.lines);
        quads.extend(text_quads(&frame.text));
        let vertex_buffer = |label: &str, bytes: &[u8]| {
            let b = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: (bytes.len() as u64).max(16),
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            ctx.queue.write_buffer(&b, 0, bytes);
            b
        };
        let line_buf = vertex_buffer("overlay boxes", bytemuck::cast_slice(&lines));
        let text_buf = vertex_buffer("overlay text", bytemuck::cast_slice(&quads));
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("overlay"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Store,
                },
            })],
            ..Default::default()
        });
        pass.set_bind_group(0, &self.bind_group, &[]);
        if !lines.is_empty() {
            pass.set_pipeline(&self.lines);
            pass.set_vertex_buffer(0, line_buf.slice(..));
            pass.draw(0..lines.len() as u32, 0..1);
        }
        if !quads.is_empty() {
            pass.set_pipeline(&self.text);
            pass.set_vertex_buffer(0, text_buf.slice(..));
            pass.draw(0..quads.len() as u32, 0..1);
        }
    }
}

/// The 12 edges of each box as a line list.
fn box_lines(boxes: &[OverlayBox]) -> Vec<LineVertex> {
    const EDGES: [(usize, usize); 12] = [
        (0, 1),
        (2, 3),
        (4, 5),
        (6, 7),
        (0, 2),
        (1, 3),
        (4, 6),
        (5, 7),
        (0, 4),
        (1, 5),
        (2, 6),
        (3, 7),
    ];
    let mut out = Vec::with_capacity(boxes.len() * 24);
    for b in boxes {
        // Corner k takes max on axis i when bit i of k is set.
        let corner = |k: usize| {
            Vec3::new(
                if k & 1 != 0 { b.max.x } else { b.min.x },
                if k & 2 != 0 { b.max.y } else { b.min.y },
                if k & 4 != 0 { b.max.z } else { b.min.z },
            )
        };
        for (a, c) in EDGES {
            for k in [a, c] {
                out.push(LineVertex {
                    position: corner(k).to_array(),
                    colour: b.colour,
                });
            }
        }
    }
    out
}

/// Two triangles per line, a quad `width` wide around it sampling the
/// solid glyph; a line of no length draws nothing.
fn line_quads(lines: &[OverlayLine]) -> Vec<TextVertex> {
    let mut out = Vec::with_capacity(lines.len() * 6);
    let cell = [
        (SOLID as u32 % ATLAS_COLUMNS * GLYPH) as f32 + 0.5 * GLYPH as f32,
        (SOLID as u32 / ATLAS_COLUMNS * GLYPH) as f32 + 0.5 * GLYPH as f32,
    ];
    for l in lines {
        let (dx, dy) = (l.to[0] - l.from[0], l.to[1] - l.from[1]);
        let len = (dx * dx + dy * dy).sqrt();
        if !(len > 0.0 && len.is_finite()) {
            continue;
        }
        // Half the width along the line's normal.
        let h = 0.5 * l.width.max(1.0);
        let (nx, ny) = (-dy / len * h, dx / len * h);
        let v = |x: f32, y: f32| TextVertex {
            pixel: [x, y],
            texel: cell,
            colour: l.colour,
        };
        let (a, b) = (l.from, l.to);
        out.extend([
            v(a[0] + nx, a[1] + ny),
            v(b[0] + nx, b[1] + ny),
            v(a[0] - nx, a[1] - ny),
            v(a[0] - nx, a[1] - ny),
            v(b[0] + nx, b[1] + ny),
            v(b[0] - nx, b[1] - ny),
        ]);
    }
    out
}

/// Two triangles per glyph plus one panel per text block, in pixels.
fn text_quads(text: &[OverlayText]) -> Vec<TextVertex> {
    let mut out = Vec::new();
    for t in text {
        let s = (t.scale.max(1) * GLYPH) as f32;
        let columns = t.lines.iter().map(|l| l.chars().count()).max().unwrap_or(0);
        if columns == 0 {
            continue;
        }
        // The panel: one glyph-size margin around the block.
        let pad = s * 0.5;
        quad(
            &mut out,
            [t.x - pad, t.y - pad],
            [
                columns as f32 * s + 2.0 * pad,
                t.lines.len() as f32 * s + 2.0 * pad,
            ],
            SOLID,
            t.background,
        );
        for (row, line) in t.lines.iter().enumerate() {
            for (col, ch) in line.chars().enumerate() {
                let code = if ch.is_ascii() { ch as u8 } else { b'?' };
                if code == b' ' {
                    continue;
                }
                quad(
                    &mut out,
                    [t.x + col as f32 * s, t.y + row as f32 * s],
                    [s, s],
                    code,
                    t.colour,
                );
            }
        }
    }
    out
}

fn quad(out: &mut Vec<TextVertex>, at: [f32; 2], size: [f32; 2], code: u8, colour: [f32; 4]) {
    let cell = [
        (code as u32 % ATLAS_COLUMNS * GLYPH) as f32,
        (code as u32 / ATLAS_COLUMNS * GLYPH) as f32,
    ];
    let g = GLYPH as f32;
    let v = |dx: f32, dy: f32| TextVertex {
        pixel: [at[0] + dx * size[0], at[1] + dy * size[1]],
        // Half-texel inset keeps floor() inside the cell at the far edge.
        texel: [cell[0] + dx * (g - 0.01), cell[1] + dy * (g - 0.01)],
        colour,
    };
    out.extend([
        v(0.0, 0.0),
        v(1.0, 0.0),
        v(0.0, 1.0),
        v(0.0, 1.0),
        v(1.0, 0.0),
        v(1.0, 1.0),
    ]);
}

/// The 128 ASCII glyphs of font8x8 (bit 0 = leftmost pixel) in a 128 x 64
/// R8 texture; code 127 is solid.
fn font_atlas_texels() -> Vec<u8> {
    let w = ATLAS_COLUMNS * GLYPH;
    let h = 128 / ATLAS_COLUMNS * GLYPH;
    let mut texels = vec![0u8; (w * h) as usize];
    for code in 0..128u32 {
        let rows = if code == SOLID as u32 {
            [0xff; 8]
        } else {
            font8x8::legacy::BASIC_LEGACY[code as usize]
        };
        let (cx, cy) = (code % ATLAS_COLUMNS * GLYPH, code / ATLAS_COLUMNS * GLYPH);
        for (y, bits) in rows.iter().enumerate() {
            for x in 0..GLYPH {
                if bits & (1 << x) != 0 {
                    texels[((cy + y as u32) * w + cx + x) as usize] = 255;
                }
            }
        }
    }
    texels
}

fn font_atlas(ctx: &GpuContext) -> wgpu::Texture {
    let w = ATLAS_COLUMNS * GLYPH;
    let h = 128 / ATLAS_COLUMNS * GLYPH;
    let size = wgpu::Extent3d {
        width: w,
        height: h,
        depth_or_array_layers: 1,
    };
    let tex = ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("font atlas"),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::R8Unorm,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    ctx.queue.write_texture(
        wgpu::TexelCopyTextureInfo {
            texture: &tex,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        &font_atlas_texels(),
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(w),
            rows_per_image: Some(h),
        },
        size,
    );
    tex
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_box_is_twelve_edges() {
        let b = OverlayBox {
            min: Vec3::ZERO,
            max: Vec3::ONE,
            colour: [1.0; 4],
        };
        let lines = box_lines(&[b]);
        assert_eq!(lines.len(), 24);
        // Every edge joins corners that differ on exactly one axis.
        for pair in lines.chunks(2) {
            let d = Vec3::from(pair[0].position) - Vec3::from(pair[1].position);
            assert_eq!(d.abs().element_sum(), 1.0);
        }
    }

    #[test]
    fn text_is_one_panel_and_a_quad_per_visible_glyph() {
        let t = OverlayText {
            x: 10.0,
            y: 20.0,
            scale: 2,
            lines: vec!["a b".into(), "".into()],
            colour: [1.0; 4],
            background: [0.0, 0.0, 0.0, 0.5],
        };
        let q = text_quads(&[t]);
        assert_eq!(q.len(), 6 * 3);
        // Second glyph ('b') starts two 16-pixel cells to the right.
        assert_eq!(q[12].pixel, [10.0 + 32.0, 20.0]);
    }

    #[test]
    fn a_line_is_one_quad_of_its_width_on_the_solid_glyph() {
        let l = OverlayLine {
            from: [10.0, 20.0],
            to: [30.0, 20.0],
            width: 4.0,
            colour: [1.0; 4],
        };
        let q = line_quads(&[l]);
        assert_eq!(q.len(), 6);
        let ys: Vec<f32> = q.iter().map(|v| v.pixel[1]).collect();
        assert!(ys.iter().all(|&y| y == 18.0 || y == 22.0), "{ys:?}");
        let xs: Vec<f32> = q.iter().map(|v| v.pixel[0]).collect();
        assert!(xs.iter().all(|&x| x == 10.0 || x == 30.0), "{xs:?}");
        // Every vertex samples inside the solid block (code 127).
        let t = q[0].texel;
        assert_eq!(((t[0] / 8.0) as u32, (t[1] / 8.0) as u32), (15, 7));
        let dot = OverlayLine { to: l.from, ..l };
        assert!(line_quads(&[dot]).is_empty());
    }

    #[test]
    fn empty_text_draws_nothing() {
        let t = OverlayText {
            x: 0.0,
            y: 0.0,
            scale: 1,
            lines: vec![],
            colour: [1.0; 4],
            background: [0.0; 4],
        };
        assert!(text_quads(&[t]).is_empty());
    }

    #[test]
    fn atlas_has_solid_block_and_glyphs() {
        let t = font_atlas_texels();
        let w = (ATLAS_COLUMNS * GLYPH) as usize;
        let cell_sum = |code: usize| -> usize {
            let (cx, cy) = (code % 16 * 8, code / 16 * 8);
            (0..8)
                .flat_map(|y| (0..8).map(move |x| (x, y)))
                .filter(|&(x, y)| t[(cy + y) * w + cx + x] != 0)
                .count()
        };
        assert_eq!(cell_sum(127), 64);
        assert_eq!(cell_sum(b' ' as usize), 0);
        assert!(cell_sum(b'A' as usize) > 10);
    }
}
