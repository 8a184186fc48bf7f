//! The look: what the shown image adds to RVG's frame (`shaders/look.wgsl`):
//! a sky and ground behind the model, screen-space ambient occlusion,
//! edges (creases from the normal target, silhouettes from depth) and
//! FXAA. It reads RVG's colour, depth and normal targets and writes an
//! image of its own, so what accuracy reads back stays the geometry as
//! drawn; only the window, screenshots and what they show take the look.

use glam::Mat4;

use crate::passes::{
    draw_fullscreen, fullscreen_pipeline_entry, fullscreen_pipeline_with, target, View,
    COLOUR_FORMAT,
};
use crate::GpuContext;

pub const LOOK_WGSL: &str = include_str!("../../../../shaders/look.wgsl");

/// How the shown image is anti-aliased.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Antialias {
    /// As drawn: one sample a pixel.
    #[default]
    Off,
    /// FXAA over the composed image: edges blended along their direction.
    Fxaa,
}

/// What the shown image adds to the geometry RVG draws. The default is
/// [`Look::PLAIN`]: the frame as drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Look {
    pub aa: Antialias,
    /// Crease edges (normals parting by more than `crease_degrees`) and
    /// silhouettes, drawn dark over the surface.
    pub edges: bool,
    pub crease_degrees: f32,
    /// Screen-space ambient occlusion reaching `ao_radius` model units.
    pub ao: bool,
    pub ao_radius: f32,
    /// A sky and ground gradient behind the model, instead of the flat
    /// background.
    pub sky: bool,
}

impl Default for Look {
    fn default() -> Look {
        Look::PLAIN
    }
}

impl Look {
    /// Nothing added: what is shown is what RVG drew.
    pub const PLAIN: Look = Look {
        aa: Antialias::Off,
        edges: false,
        crease_degrees: 30.0,
        ao: false,
        ao_radius: 0.5,
        sky: false,
    };

    /// The defaults for a device: everything on a GPU; on a CPU
    /// rasterizer (lavapipe, llvmpipe) the sky and edges, and not
    /// ambient occlusion nor FXAA, which cost there a frame's worth of
    /// time or more for what they show (docs/results.md, "The look").
    pub fn auto(cpu_rasterizer: bool) -> Look {
        let gpu = !cpu_rasterizer;
        Look {
            aa: if gpu { Antialias::Fxaa } else { Antialias::Off },
            edges: true,
            ao: gpu,
            sky: true,
            ..Look::PLAIN
        }
    }

    /// Whether nothing is added (no look pass runs).
    pub fn is_plain(&self) -> bool {
        self.aa == Antialias::Off && !self.edges && !self.ao && !self.sky
    }

    /// What it adds, in words ("plain" for nothing).
    pub fn describe(&self) -> String {
        let mut parts = Vec::new();
        if self.sky {
            parts.push("sky".to_string());
        }
        if self.edges {
            parts.push(format!("edges over {} degrees", self.crease_degrees));
        }
        if self.ao {
            parts.push(format!("ambient occlusion within {} units", self.ao_radius));
        }
        if self.aa == Antialias::Fxaa {
            parts.push("FXAA".to_string());
        }
        if parts.is_empty() {
            "plain".to_string()
        } else {
            parts.join(", ")
        }
    }

    /// Whether RVG must write its normal target.
    pub fn needs_normals(&self) -> bool {
        self.edges || self.ao
    }
}

/// A look as asked for: each feature on, off, or left to a default look
/// ([`LookChoice::over`]); the viewer's default is [`Look::auto`] for its
/// device, replay's [`Look::PLAIN`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LookChoice {
    pub aa: Option<Antialias>,
    pub edges: Option<bool>,
    pub ao: Option<bool>,
    pub sky: Option<bool>,
    pub crease_degrees: Option<f32>,
    /// Ambient occlusion's reach in model units.
    pub ao_radius: Option<f32>,
}

impl LookChoice {
    /// `default` with what was asked for in place of its features.
    pub fn over(&self, default: Look) -> Look {
        Look {
            aa: self.aa.unwrap_or(default.aa),
            edges: self.edges.unwrap_or(default.edges),
            crease_degrees: self.crease_degrees.unwrap_or(default.crease_degrees),
            ao: self.ao.unwrap_or(default.ao),
            ao_radius: self.ao_radius.unwrap_or(default.ao_radius),
            sky: self.sky.unwrap_or(default.sky),
        }
    }
}

/// `shaders/look.wgsl`'s `LookUniforms`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct LookUniforms {
    inv_view_proj: [[f32; 4]; 4],
    size: [f32; 4],
    params: [f32; 4],
}

/// The normal target's format: 8 bits a component hold a direction to
/// well under a degree, far finer than any crease angle.
pub(crate) const NORMAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
const AO_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R8Unorm;

/// The look's passes and targets for one size of RVG's targets.
pub(crate) struct LookPass {
    uniforms: wgpu::Buffer,
    ao_pipeline: wgpu::RenderPipeline,
    /// The composition for each set of its parts (sky, occlusion,
    /// edges), made when first used.
    compose_pipelines: [Option<wgpu::RenderPipeline>; 8],
    compose_layout: wgpu::BindGroupLayout,
    fxaa_pipeline: wgpu::RenderPipeline,
    ao_group: wgpu::BindGroup,
    compose_group: wgpu::BindGroup,
    fxaa_group: wgpu::BindGroup,
    /// FXAA straight from RVG's colour, when nothing is composed.
    fxaa_colour_group: wgpu::BindGroup,
    /// Which image the last frame's passes ended in (`None`: none ran,
    /// RVG's colour is shown).
    last: Option<Shown>,
    ao: wgpu::Texture,
    composed: wgpu::Texture,
    shown: wgpu::Texture,
    size: (u32, u32),
}

/// One binding of the look's layouts.
#[derive(Clone, Copy)]
enum Slot {
    Uniforms,
    /// A texture read with `textureLoad` or the nearest sampler only
    /// (depth as unfilterable float).
    Unfiltered,
    Filtered,
    Sampler,
    /// The nearest sampler depth is read through (`depth_at`).
    Nearest,
}

fn layout(ctx: &GpuContext, label: &str, slots: &[(u32, Slot)]) -> wgpu::BindGroupLayout {
    let entries: Vec<_> = slots
        .iter()
        .map(|&(binding, slot)| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: match slot {
                Slot::Uniforms => wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                Slot::Unfiltered | Slot::Filtered => wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float {
                        filterable: matches!(slot, Slot::Filtered),
                    },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                Slot::Sampler => wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                Slot::Nearest => wgpu::BindingType::Sampler(wgpu::SamplerBindingType::NonFiltering),
            },
            count: None,
        })
        .collect();
    ctx.device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(label),
            entries: &entries,
        })
}

impl LookPass {
    /// The look over RVG's `colour`, `depth` and `normal` targets.
    pub(crate) fn new(
        ctx: &GpuContext,
        colour: &wgpu::Texture,
        depth: &wgpu::Texture,
        normal: &wgpu::Texture,
    ) -> LookPass {
        let d = &ctx.device;
        let (w, h) = (colour.width(), colour.height());
        let uniforms = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("look"),
            size: std::mem::size_of::<LookUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let ao = target(ctx, "look occlusion", w, h, AO_FORMAT);
        let composed = target(ctx, "look composed", w, h, COLOUR_FORMAT);
        let shown = target(ctx, "look shown", w, h, COLOUR_FORMAT);
        let sampler = d.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("look"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        // Nearest is the default filter.
        let nearest = d.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("look depth"),
            ..Default::default()
        });
        use Slot::*;
        let ao_layout = layout(
            ctx,
            "look occlusion",
            &[(0, Uniforms), (1, Unfiltered), (2, Filtered), (6, Nearest)],
        );
        let compose_layout = layout(
            ctx,
            "look compose",
            &[
                (0, Uniforms),
                (1, Unfiltered),
                (2, Filtered),
                (3, Filtered),
                (4, Filtered),
                (6, Nearest),
            ],
        );
        let fxaa_layout = layout(
            ctx,
            "look fxaa",
            &[(0, Uniforms), (3, Filtered), (5, Sampler)],
        );
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        // A group of the uniforms, `textures` at their bindings and, for
        // FXAA, the sampler at binding 5; else the nearest one at 6 (depth
        // is read through it).
        let group = |label,
                     layout: &wgpu::BindGroupLayout,
                     textures: &[(u32, &wgpu::Texture)],
                     sampled: bool| {
            let views: Vec<_> = textures.iter().map(|(b, t)| (*b, view(t))).collect();
            let mut entries = vec![wgpu::BindGroupEntry {
                binding: 0,
                resource: uniforms.as_entire_binding(),
            }];
            entries.extend(views.iter().map(|(b, v)| wgpu::BindGroupEntry {
                binding: *b,
                resource: wgpu::BindingResource::TextureView(v),
            }));
            entries.push(match sampled {
                true => wgpu::BindGroupEntry {
                    binding: 5,
                    resource: wgpu::BindingResource::Sampler(&sampler),
                },
                false => wgpu::BindGroupEntry {
                    binding: 6,
                    resource: wgpu::BindingResource::Sampler(&nearest),
                },
            });
            d.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout,
                entries: &entries,
            })
        };
        let ao_group = group(
            "look occlusion",
            &ao_layout,
            &[(1, depth), (2, normal)],
            false,
        );
        let compose_group = group(
            "look compose",
            &compose_layout,
            &[(1, depth), (2, normal), (3, colour), (4, &ao)],
            false,
        );
        let fxaa_group = group("look fxaa", &fxaa_layout, &[(3, &composed)], true);
        let fxaa_colour_group = group("look fxaa", &fxaa_layout, &[(3, colour)], true);
        let pipeline = |label, layout, format, entry| {
            fullscreen_pipeline_entry(ctx, label, LOOK_WGSL, layout, format, entry)
        };
        LookPass {
            ao_pipeline: pipeline("look occlusion", &ao_layout, AO_FORMAT, "fs_ao"),
            compose_pipelines: Default::default(),
            fxaa_pipeline: pipeline("look fxaa", &fxaa_layout, COLOUR_FORMAT, "fs_fxaa"),
            compose_layout,
            uniforms,
            ao_group,
            compose_group,
            fxaa_group,
            fxaa_colour_group,
            last: None,
            ao,
            composed,
            shown,
            size: (w, h),
        }
    }

    /// The image the last [`LookPass::record`] ended in (`None`: RVG's
    /// colour, nothing ran).
    pub(crate) fn shown(&self) -> Option<&wgpu::Texture> {
        match self.last? {
            Shown::Composed => Some(&self.composed),
            Shown::Fxaa => Some(&self.shown),
        }
    }

    /// Nothing ran for the last frame (its look was plain): RVG's colour
    /// is what it shows.
    pub(crate) fn skip(&mut self) {
        self.last = None;
    }

    /// Records the look's passes for a frame drawn with `view`; `shaded`:
    /// false for a wireframe frame, which takes no occlusion or edges.
    pub(crate) fn record(
        &mut self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        view: &View,
        look: &Look,
        shaded: bool,
    ) {
        let (w, h) = self.size;
        // Rows of (projection x rotation): the rotation keeps each row's
        // length, so the second row's is the projection's y scale.
        let m = view.view_proj;
        let y_scale = glam::Vec3::new(m.x_axis.y, m.y_axis.y, m.z_axis.y).length();
        let (edges, ao) = (shaded && look.edges, shaded && look.ao);
        let u = LookUniforms {
            inv_view_proj: inverse(m).to_cols_array_2d(),
            size: [w as f32, h as f32, look.ao_radius, 0.5 * h as f32 * y_scale],
            params: [look.crease_degrees.to_radians().cos(), 0.0, 0.0, 0.0],
        };
        ctx.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&u));
        if ao {
            draw_fullscreen(
                enc,
                "look occlusion",
                &self.ao,
                &self.ao_pipeline,
                &self.ao_group,
            );
        }
        let compose = edges || ao || look.sky;
        if compose {
            let key = (look.sky as usize) | (ao as usize) << 1 | (edges as usize) << 2;
            let layout = &self.compose_layout;
            let pipeline = self.compose_pipelines[key].get_or_insert_with(|| {
                let flag = |on: bool| if on { 1.0 } else { 0.0 };
                fullscreen_pipeline_with(
                    ctx,
                    "look compose",
                    LOOK_WGSL,
                    layout,
                    (COLOUR_FORMAT, "fs_compose"),
                    &[
                        ("SKY", flag(look.sky)),
                        ("AO", flag(ao)),
                        ("EDGES", flag(edges)),
                    ],
                )
            });
            draw_fullscreen(
                enc,
                "look compose",
                &self.composed,
                pipeline,
                &self.compose_group,
            );
        }
        self.last = compose.then_some(Shown::Composed);
        if look.aa == Antialias::Fxaa {
            let group = if compose {
                &self.fxaa_group
            } else {
                &self.fxaa_colour_group
            };
            draw_fullscreen(enc, "look fxaa", &self.shown, &self.fxaa_pipeline, group);
            self.last = Some(Shown::Fxaa);
        }
    }
}

/// Which of the look's images a frame ended in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Shown {
    Composed,
    Fxaa,
}

/// The inverse of a frame's projection x rotation; a singular one (a
/// degenerate camera) gives the identity, which only misplaces the sky.
fn inverse(m: Mat4) -> Mat4 {
    let inv = m.inverse();
    if inv.is_finite() {
        inv
    } else {
        Mat4::IDENTITY
    }
}
