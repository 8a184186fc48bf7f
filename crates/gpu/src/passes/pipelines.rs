//! Pipeline builders: the scene pipeline that draws LODs through a
//! [`Drawer`]'s layout (OR, RVG, the query prepass) and the fullscreen
//! pipeline that draws one triangle (the blit to a window, the depth copy).

use crate::passes::{Drawer, DEPTH_COMPARE, DEPTH_FORMAT};
use crate::shader_types::{self, VertexLayout};
use crate::GpuContext;

/// A scene pipeline for each vertex layout (the same pass, the entry
/// point that reads that layout), without and with a section (the
/// fragment entry point `fs_section`, which discards what the section
/// removes; kept apart so frames without one keep early depth tests).
pub(crate) struct ScenePipelines {
    plain: [wgpu::RenderPipeline; 2],
    section: [wgpu::RenderPipeline; 2],
}

impl ScenePipelines {
    pub(crate) fn get(&self, layout: VertexLayout, section: bool) -> &wgpu::RenderPipeline {
        if section {
            &self.section[layout as usize]
        } else {
            &self.plain[layout as usize]
        }
    }
}

pub(crate) fn pipeline(
    ctx: &GpuContext,
    drawer: &Drawer,
    label: &str,
    wgsl: &str,
    colour: Option<wgpu::TextureFormat>,
    polygon_mode: wgpu::PolygonMode,
) -> ScenePipelines {
    let module = ctx
        .device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(label),
            source: wgpu::ShaderSource::Wgsl(shader_types::shader_source(wgsl).into()),
        });
    let targets: Vec<_> = colour
        .map(|format| wgpu::ColorTargetState {
            format,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        })
        .into_iter()
        .map(Some)
        .collect();
    // Without a section a depth-only pass has no fragment stage.
    let plain = colour.map(|_| "fs_main");
    let build = |layout: VertexLayout, fragment: Option<&str>| {
        ctx.device
            .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&drawer.layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some(layout.entry_point()),
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
                    depth_write_enabled: Some(true),
                    depth_compare: Some(DEPTH_COMPARE),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: fragment.map(|entry| wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    targets: &targets,
                }),
                multiview_mask: None,
                cache: None,
            })
    };
    ScenePipelines {
        plain: VertexLayout::ALL.map(|layout| build(layout, plain)),
        section: VertexLayout::ALL.map(|layout| build(layout, Some("fs_section"))),
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
