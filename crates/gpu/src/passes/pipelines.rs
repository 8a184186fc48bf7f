//! Pipeline builders: the scene pipeline that draws LODs through a
//! [`Drawer`]'s layout (OR, RVG, the query prepass) and the fullscreen
//! pipeline that draws one triangle (the blit to a window, the depth copy).

use crate::passes::{Drawer, DEPTH_COMPARE, DEPTH_FORMAT};
use crate::shader_types::{self, VertexLayout};
use crate::GpuContext;

/// How a draw clips by the frame's section.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Clipping {
    /// No section.
    None,
    /// The rasterizer clips (clip distances: at most
    /// [`HARDWARE_CLIP_PLANES`] half-spaces, on devices with
    /// `Features::CLIP_DISTANCES`); the fragment stage never discards,
    /// and paints caps only when `caps` (the eye is on some half-space's
    /// removed side; from a kept eye no cut can be looked into).
    Hardware { caps: bool },
    /// The fragment stage discards what the section removes.
    Discard,
}

/// The most half-spaces the rasterizer clips by (WGSL's `clip_distances`
/// holds at most eight).
pub(crate) const HARDWARE_CLIP_PLANES: usize = 8;

/// A scene pipeline for each vertex layout (the same pass, the entry
/// point that reads that layout), for each way of clipping by a section:
/// none (no discard, so frames without a section keep early depth
/// tests), the rasterizer's clip distances where the device has them,
/// and discarding in the fragment stage (`fs_section`) everywhere.
pub(crate) struct ScenePipelines {
    plain: [wgpu::RenderPipeline; 2],
    discard: [wgpu::RenderPipeline; 2],
    /// Clip distances with the plain fragment stage, and with caps
    /// (`fs_cap`; the same pipelines for a pass without colour).
    hardware: Option<[[wgpu::RenderPipeline; 2]; 2]>,
}

impl ScenePipelines {
    pub(crate) fn get(&self, layout: VertexLayout, clipping: Clipping) -> &wgpu::RenderPipeline {
        let set = match clipping {
            Clipping::None => &self.plain,
            Clipping::Hardware { caps } => self
                .hardware
                .as_ref()
                .map_or(&self.discard, |h| &h[caps as usize]),
            Clipping::Discard => &self.discard,
        };
        &set[layout as usize]
    }

    /// How to clip by `half_spaces` of a section (0: none), `caps`
    /// when a cut can be looked into.
    pub(crate) fn clipping(&self, half_spaces: usize, caps: bool) -> Clipping {
        match half_spaces {
            0 => Clipping::None,
            n if n <= HARDWARE_CLIP_PLANES && self.hardware.is_some() => {
                Clipping::Hardware { caps }
            }
            _ => Clipping::Discard,
        }
    }
}

/// What a scene pipeline writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Surface {
    /// Every target and depth, as drawn.
    Opaque,
    /// X-ray's ghosts (the shader's `GHOST` override): blended over the
    /// first target, nothing else written, depth tested but not written.
    Ghost,
}

pub(crate) fn pipeline(
    ctx: &GpuContext,
    drawer: &Drawer,
    label: &str,
    (wgsl, clip_wgsl): (&str, &str),
    colour: &[Option<wgpu::TextureFormat>],
    polygon_mode: wgpu::PolygonMode,
) -> ScenePipelines {
    scene_pipelines(
        ctx,
        drawer,
        label,
        (wgsl, clip_wgsl),
        colour,
        polygon_mode,
        Surface::Opaque,
    )
}

pub(crate) fn scene_pipelines(
    ctx: &GpuContext,
    drawer: &Drawer,
    label: &str,
    (wgsl, clip_wgsl): (&str, &str),
    colour: &[Option<wgpu::TextureFormat>],
    polygon_mode: wgpu::PolygonMode,
    surface: Surface,
) -> ScenePipelines {
    let ghost = surface == Surface::Ghost;
    let module = ctx
        .device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(label),
            source: wgpu::ShaderSource::Wgsl(shader_types::shader_source(wgsl).into()),
        });
    let clip_module = ctx.supports_clip_distances().then(|| {
        ctx.device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(
                    shader_types::clip_shader_source(wgsl, clip_wgsl).into(),
                ),
            })
    });
    // `colour`: the pass's colour targets by location (none: depth only;
    // a `None` slot drops what the shader writes there).
    let targets: Vec<_> = colour
        .iter()
        .enumerate()
        .map(|(i, f)| {
            f.map(|format| wgpu::ColorTargetState {
                format,
                blend: (ghost && i == 0).then_some(wgpu::BlendState::ALPHA_BLENDING),
                write_mask: if ghost && i > 0 {
                    wgpu::ColorWrites::empty()
                } else {
                    wgpu::ColorWrites::ALL
                },
            })
        })
        .collect();
    let constants: &[(&str, f64)] = if ghost { &[("GHOST", 1.0)] } else { &[] };
    let has_colour = !colour.is_empty();
    // Without a section a depth-only pass has no fragment stage.
    let plain = has_colour.then_some("fs_main");
    // `suffix`: "" for the plain entry points, "_clip" for those writing
    // clip distances.
    let build = |module: &wgpu::ShaderModule,
                 layout: VertexLayout,
                 suffix: &str,
                 fragment: Option<&str>| {
        let vertex = format!("{}{suffix}", layout.entry_point());
        ctx.device
            .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&drawer.layout),
                vertex: wgpu::VertexState {
                    module,
                    entry_point: Some(&vertex),
                    compilation_options: Default::default(),
                    buffers: &[
                        Some(layout.buffer_layout()),
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
                    depth_write_enabled: Some(!ghost),
                    depth_compare: Some(DEPTH_COMPARE),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: fragment.map(|entry| wgpu::FragmentState {
                    module,
                    entry_point: Some(entry),
                    compilation_options: wgpu::PipelineCompilationOptions {
                        constants,
                        ..Default::default()
                    },
                    targets: &targets,
                }),
                multiview_mask: None,
                cache: None,
            })
    };
    ScenePipelines {
        plain: VertexLayout::ALL.map(|l| build(&module, l, "", plain)),
        discard: VertexLayout::ALL.map(|l| build(&module, l, "", Some("fs_section"))),
        hardware: clip_module.map(|m| {
            [plain, has_colour.then_some("fs_cap")]
                .map(|fragment| VertexLayout::ALL.map(|l| build(&m, l, "_clip", fragment)))
        }),
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
    fullscreen_pipeline_entry(ctx, label, wgsl, layout, format, "fs_main")
}

/// Records on `enc` one fullscreen triangle of `pipeline` (bind group 0:
/// `bind_group`) into `target`, cleared first.
pub(crate) fn draw_fullscreen(
    enc: &mut wgpu::CommandEncoder,
    label: &str,
    target: &wgpu::Texture,
    pipeline: &wgpu::RenderPipeline,
    bind_group: &wgpu::BindGroup,
) {
    let view = target.create_view(&Default::default());
    let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
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
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, bind_group, &[]);
    pass.draw(0..3, 0..1);
}

/// [`fullscreen_pipeline`] with the fragment entry point `fragment`.
pub(crate) fn fullscreen_pipeline_entry(
    ctx: &GpuContext,
    label: &str,
    wgsl: &str,
    layout: &wgpu::BindGroupLayout,
    format: wgpu::TextureFormat,
    fragment: &str,
) -> wgpu::RenderPipeline {
    fullscreen_pipeline_with(ctx, label, wgsl, layout, (format, fragment), &[])
}

/// [`fullscreen_pipeline_entry`] with the fragment stage's overridable
/// constants set.
pub(crate) fn fullscreen_pipeline_with(
    ctx: &GpuContext,
    label: &str,
    wgsl: &str,
    layout: &wgpu::BindGroupLayout,
    (format, fragment): (wgpu::TextureFormat, &str),
    constants: &[(&str, f64)],
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
            entry_point: Some(fragment),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants,
                ..Default::default()
            },
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

/// A bind group layout of one 2D texture (binding 0) and a sampler
/// (binding 1) that a fragment shader reads it through: a filtering
/// sampler of a filterable float texture, or with `filterable` false a
/// non-filtering one of an unfilterable float texture (depth read as
/// float).
pub(crate) fn sampled_texture_layout(
    ctx: &GpuContext,
    label: &str,
    filterable: bool,
) -> wgpu::BindGroupLayout {
    let sampler = if filterable {
        wgpu::SamplerBindingType::Filtering
    } else {
        wgpu::SamplerBindingType::NonFiltering
    };
    ctx.device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(label),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(sampler),
                    count: None,
                },
            ],
        })
}
