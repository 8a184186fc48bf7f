//! OR's HZB pyramid built on its device from the occluders' depth
//! (`shaders/hzb_downsample.wgsl`): levels 1 to the one read back, each the
//! farthest of 2x2 texels of the one below, so only a small level crosses
//! to the host instead of the whole depth image. Compute passes into one
//! storage buffer where the adapter has compute shaders (the level read
//! back is packed tightly there), fragment passes into a texture a level
//! elsewhere and on GL.

use crate::passes::{draw_fullscreen, fullscreen_pipeline_entry, ReadBack, Rows};
use crate::shader_types::HzbLevelUniforms;
use crate::GpuContext;

pub const HZB_DOWNSAMPLE_WGSL: &str = include_str!("../../../../shaders/hzb_downsample.wgsl");

/// How the pyramid is built on a device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PyramidPath {
    /// Compute passes into one storage buffer.
    Compute,
    /// Fragment passes into a texture a level.
    Fragment,
}

/// The size of level `k` of a `w x h` pyramid: halved `k` times, rounding
/// up (as `gigawalk_cull::level_sizes`).
pub(crate) fn level_size(w: u32, h: u32, k: u32) -> (u32, u32) {
    (0..k).fold((w, h), |(w, h), _| (w.div_ceil(2), h.div_ceil(2)))
}

/// The pipelines of one path, made once per depth pass.
enum Pipelines {
    Compute {
        layout: wgpu::BindGroupLayout,
        from_depth: wgpu::ComputePipeline,
        from_level: wgpu::ComputePipeline,
    },
    Fragment {
        depth_layout: wgpu::BindGroupLayout,
        level_layout: wgpu::BindGroupLayout,
        from_depth: wgpu::RenderPipeline,
        from_level: wgpu::RenderPipeline,
    },
}

/// The levels' storage for one depth texture and one level read back,
/// with a bind group a step.
enum Storage {
    Compute {
        buffer: wgpu::Buffer,
        /// Byte offset of each level from 1 on (index k - 1).
        offsets: Vec<u64>,
    },
    Fragment {
        /// Level k's texture at index k - 1.
        textures: Vec<wgpu::Texture>,
    },
}

/// Builds levels 1 to `level` of a depth texture's pyramid and records the
/// copy of `level` into a [`ReadBack`].
pub(crate) struct Pyramid {
    path: PyramidPath,
    pipelines: Pipelines,
    /// What the storage was made for: the depth texture, its size and
    /// the level read back.
    made_for: Option<(wgpu::Texture, u32, u32, u32)>,
    storage: Option<Storage>,
    /// One uniform buffer and bind group per step (step k makes level k).
    steps: Vec<(wgpu::Buffer, wgpu::BindGroup)>,
    /// Nearest and clamped: the first step reads depth at texel centres.
    nearest: wgpu::Sampler,
}

impl Pyramid {
    /// The path this device takes: compute where its capabilities allow
    /// ([`crate::Capabilities::compute_pyramid`]) and its storage binding
    /// is as large as the pyramid of a `w x h` image needs; else fragment
    /// passes.
    pub(crate) fn path_for(ctx: &GpuContext, w: u32, h: u32) -> PyramidPath {
        let compute = ctx.caps.compute_pyramid;
        // Levels 1 and up hold at most a third of level 0's texels, each
        // texel 4 bytes.
        let bytes = (w as u64 * h as u64).div_ceil(3) * 4 + 64;
        let fits = bytes <= ctx.device.limits().max_storage_buffer_binding_size;
        if compute && fits {
            PyramidPath::Compute
        } else {
            PyramidPath::Fragment
        }
    }

    pub(crate) fn new(ctx: &GpuContext, path: PyramidPath) -> Pyramid {
        let d = &ctx.device;
        let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("hzb downsample"),
            source: wgpu::ShaderSource::Wgsl(HZB_DOWNSAMPLE_WGSL.into()),
        });
        let depth_entry = |visibility| wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: false },
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        };
        let sampler_entry = |visibility| wgpu::BindGroupLayoutEntry {
            binding: 4,
            visibility,
            ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::NonFiltering),
            count: None,
        };
        let uniform_entry = |visibility| wgpu::BindGroupLayoutEntry {
            binding: 1,
            visibility,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let pipelines = match path {
            PyramidPath::Compute => {
                let cs = wgpu::ShaderStages::COMPUTE;
                let layout = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some("hzb downsample"),
                    entries: &[
                        depth_entry(cs),
                        sampler_entry(cs),
                        uniform_entry(cs),
                        wgpu::BindGroupLayoutEntry {
                            binding: 2,
                            visibility: cs,
                            ty: wgpu::BindingType::Buffer {
                                ty: wgpu::BufferBindingType::Storage { read_only: false },
                                has_dynamic_offset: false,
                                min_binding_size: None,
                            },
                            count: None,
                        },
                    ],
                });
                let pipeline_layout = d.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some("hzb downsample"),
                    bind_group_layouts: &[Some(&layout)],
                    immediate_size: 0,
                });
                let compute = |entry| {
                    d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                        label: Some(entry),
                        layout: Some(&pipeline_layout),
                        module: &module,
                        entry_point: Some(entry),
                        compilation_options: Default::default(),
                        cache: None,
                    })
                };
                Pipelines::Compute {
                    from_depth: compute("cs_from_depth"),
                    from_level: compute("cs_from_level"),
                    layout,
                }
            }
            PyramidPath::Fragment => {
                let fs = wgpu::ShaderStages::FRAGMENT;
                let depth_layout = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some("hzb downsample from depth"),
                    entries: &[depth_entry(fs), sampler_entry(fs), uniform_entry(fs)],
                });
                let level_layout = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some("hzb downsample from a level"),
                    entries: &[
                        uniform_entry(fs),
                        wgpu::BindGroupLayoutEntry {
                            binding: 3,
                            visibility: fs,
                            ty: wgpu::BindingType::Texture {
                                sample_type: wgpu::TextureSampleType::Uint,
                                view_dimension: wgpu::TextureViewDimension::D2,
                                multisampled: false,
                            },
                            count: None,
                        },
                    ],
                });
                let format = PYRAMID_FORMAT;
                let src = HZB_DOWNSAMPLE_WGSL;
                Pipelines::Fragment {
                    from_depth: fullscreen_pipeline_entry(
                        ctx,
                        "hzb from depth",
                        src,
                        &depth_layout,
                        format,
                        "fs_from_depth",
                    ),
                    from_level: fullscreen_pipeline_entry(
                        ctx,
                        "hzb from a level",
                        src,
                        &level_layout,
                        format,
                        "fs_from_level",
                    ),
                    depth_layout,
                    level_layout,
                }
            }
        };
        Pyramid {
            path,
            pipelines,
            made_for: None,
            storage: None,
            steps: Vec::new(),
            nearest: d.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("hzb depth"),
                ..Default::default()
            }),
        }
    }

    pub(crate) fn path(&self) -> PyramidPath {
        self.path
    }

    /// Records on `enc` the steps that make levels 1 to `level` (>= 1) of
    /// `depth`'s (`w x h`) pyramid, and the copy of `level` into
    /// `readback`; returns where its rows lie there.
    pub(crate) fn record(
        &mut self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        depth: &wgpu::Texture,
        (w, h): (u32, u32),
        level: u32,
        readback: &mut ReadBack,
    ) -> Rows {
        debug_assert!(level >= 1);
        let fresh = self
            .made_for
            .as_ref()
            .is_none_or(|(t, mw, mh, ml)| t != depth || (*mw, *mh, *ml) != (w, h, level));
        if fresh {
            self.make(ctx, depth, (w, h), level);
        }
        let storage = self.storage.as_ref().expect("made above");
        for k in 1..=level {
            let (dw, dh) = level_size(w, h, k);
            let (_, bind_group) = &self.steps[k as usize - 1];
            match (&self.pipelines, storage) {
                (
                    Pipelines::Compute {
                        from_depth,
                        from_level,
                        ..
                    },
                    Storage::Compute { .. },
                ) => {
                    let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("hzb downsample"),
                        timestamp_writes: None,
                    });
                    pass.set_pipeline(if k == 1 { from_depth } else { from_level });
                    pass.set_bind_group(0, bind_group, &[]);
                    pass.dispatch_workgroups(dw.div_ceil(8), dh.div_ceil(8), 1);
                }
                (
                    Pipelines::Fragment {
                        from_depth,
                        from_level,
                        ..
                    },
                    Storage::Fragment { textures },
                ) => {
                    let pipeline = if k == 1 { from_depth } else { from_level };
                    let target = &textures[k as usize - 1];
                    draw_fullscreen(enc, "hzb downsample", target, pipeline, bind_group);
                }
                _ => unreachable!("storage is made for the pipelines' path"),
            }
        }
        let (lw, lh) = level_size(w, h, level);
        match storage {
            Storage::Compute { buffer, offsets } => readback.record_buffer(
                ctx,
                enc,
                buffer,
                offsets[level as usize - 1],
                Rows::packed(lw * 4, lh),
            ),
            Storage::Fragment { textures } => readback.record_texture(
                ctx,
                enc,
                &textures[level as usize - 1],
                lw,
                lh,
                4,
                wgpu::TextureAspect::All,
            ),
        }
    }

    /// Makes the storage, uniforms and bind groups for `depth` and `level`.
    fn make(&mut self, ctx: &GpuContext, depth: &wgpu::Texture, (w, h): (u32, u32), level: u32) {
        let d = &ctx.device;
        let depth_view = depth.create_view(&wgpu::TextureViewDescriptor {
            aspect: wgpu::TextureAspect::DepthOnly,
            ..Default::default()
        });
        let sizes: Vec<(u32, u32)> = (0..=level).map(|k| level_size(w, h, k)).collect();
        let storage = match self.path {
            PyramidPath::Compute => {
                let mut offsets = Vec::with_capacity(level as usize);
                let mut end = 0u64;
                for &(lw, lh) in &sizes[1..] {
                    offsets.push(end);
                    // Copies between buffers start at multiples of 4 bytes,
                    // which every level's u32s are.
                    end += lw as u64 * lh as u64 * 4;
                }
                let buffer = d.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("hzb pyramid"),
                    size: end.max(4),
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                });
                Storage::Compute { buffer, offsets }
            }
            PyramidPath::Fragment => Storage::Fragment {
                textures: sizes[1..]
                    .iter()
                    .map(|&(lw, lh)| {
                        d.create_texture(&wgpu::TextureDescriptor {
                            label: Some("hzb level"),
                            size: wgpu::Extent3d {
                                width: lw,
                                height: lh,
                                depth_or_array_layers: 1,
                            },
                            mip_level_count: 1,
                            sample_count: 1,
                            dimension: wgpu::TextureDimension::D2,
                            format: PYRAMID_FORMAT,
                            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                                | wgpu::TextureUsages::TEXTURE_BINDING
                                | wgpu::TextureUsages::COPY_SRC,
                            view_formats: &[],
                        })
                    })
                    .collect(),
            },
        };
        let mut steps = Vec::with_capacity(level as usize);
        for k in 1..=level as usize {
            let offset = |k: usize| match &storage {
                Storage::Compute { offsets, .. } if k >= 1 => offsets[k - 1] as u32 / 4,
                _ => 0,
            };
            let u = HzbLevelUniforms {
                src_size: [sizes[k - 1].0, sizes[k - 1].1],
                dst_size: [sizes[k].0, sizes[k].1],
                src_offset: offset(k - 1),
                dst_offset: offset(k),
                _pad: [0; 2],
            };
            let uniforms = d.create_buffer(&wgpu::BufferDescriptor {
                label: Some("hzb level"),
                size: std::mem::size_of::<HzbLevelUniforms>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            ctx.queue.write_buffer(&uniforms, 0, bytemuck::bytes_of(&u));
            let uniform = wgpu::BindGroupEntry {
                binding: 1,
                resource: uniforms.as_entire_binding(),
            };
            let depth_entry = wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&depth_view),
            };
            let sampler_entry = wgpu::BindGroupEntry {
                binding: 4,
                resource: wgpu::BindingResource::Sampler(&self.nearest),
            };
            let bind_group = match (&self.pipelines, &storage) {
                (Pipelines::Compute { layout, .. }, Storage::Compute { buffer, .. }) => d
                    .create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("hzb level"),
                        layout,
                        entries: &[
                            depth_entry,
                            sampler_entry,
                            uniform,
                            wgpu::BindGroupEntry {
                                binding: 2,
                                resource: buffer.as_entire_binding(),
                            },
                        ],
                    }),
                (Pipelines::Fragment { depth_layout, .. }, Storage::Fragment { .. }) if k == 1 => d
                    .create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("hzb level"),
                        layout: depth_layout,
                        entries: &[depth_entry, sampler_entry, uniform],
                    }),
                (Pipelines::Fragment { level_layout, .. }, Storage::Fragment { textures }) => {
                    let src = textures[k - 2].create_view(&Default::default());
                    d.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("hzb level"),
                        layout: level_layout,
                        entries: &[
                            uniform,
                            wgpu::BindGroupEntry {
                                binding: 3,
                                resource: wgpu::BindingResource::TextureView(&src),
                            },
                        ],
                    })
                }
                _ => unreachable!("storage is made for the pipelines' path"),
            };
            steps.push((uniforms, bind_group));
        }
        self.storage = Some(storage);
        self.steps = steps;
        self.made_for = Some((depth.clone(), w, h, level));
    }
}

/// The levels' texel format on the fragment path: depth's f32 bits as
/// u32 (renderable everywhere, unlike R32Float on some GL).
const PYRAMID_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;
