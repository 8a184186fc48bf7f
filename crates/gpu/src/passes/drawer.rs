//! The draw loop both passes (and the query pass's depth prepass) share:
//! a uniform buffer with the frame's view, a per-draw instance buffer with
//! each LOD's origin relative to the eye, and the recording of the draws,
//! rebinding geometry buffers only when they change. Where the device has
//! indirect draws with a first instance (`Capabilities::multi_draw`), each
//! run of draws that share a pipeline and buffers is one
//! `multi_draw_indexed_indirect` over records written beside the instance
//! data (a draw's first instance is its instance slot); elsewhere each
//! draw is a `draw_indexed` of its own. Both draw the same triangles in
//! the same order.

use std::sync::Arc;

use gigawalk_scene::objects::LodPieces;
use glam::Vec3;

use crate::passes::{ScenePipelines, View};
use crate::residency::{LodRange, Residency};
use crate::shader_types::{DrawInstance, FrameUniforms};
use crate::GpuContext;

/// Uniforms, per-draw instance data and the draw loop shared by both passes.
pub(crate) struct Drawer {
    uniforms: wgpu::Buffer,
    pub(crate) bind_group: wgpu::BindGroup,
    pub(crate) layout: wgpu::PipelineLayout,
    instances: wgpu::Buffer,
    /// A `DrawIndexedIndirectArgs` per instance slot, when the device
    /// records runs of draws as multi-draws.
    indirect: Option<wgpu::Buffer>,
    /// Instances already used this frame (chunks append).
    used: u64,
    /// What `prepare` builds each chunk, kept so a chunk allocates none.
    scratch: Scratch,
    /// Written to `FrameUniforms::params.z` (what shaders that read it
    /// move toward the eye in depth).
    pub(crate) depth_bias: f32,
    /// LODs drawn in pieces (hidden or highlighted objects), this frame.
    pieces: Option<Arc<LodPieces>>,
    /// How this frame clips by its view's section: how many half-spaces,
    /// and whether the eye is on one's removed side (a cut can be looked
    /// into, so caps can show).
    clip_planes: usize,
    caps: bool,
    /// Whether draws take a base vertex (`Capabilities::base_vertex`).
    base_vertex: bool,
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
            indirect: indirect_buffer(ctx, 1024),
            used: 0,
            scratch: Scratch::default(),
            depth_bias: 0.0,
            pieces: None,
            clip_planes: 0,
            caps: false,
            base_vertex: ctx.capabilities().base_vertex,
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
            params: [
                0.25,
                if unlit { 1.0 } else { 0.0 },
                self.depth_bias,
                view.clip.count() as f32,
            ],
            clip: view.clip.planes(),
        };
        self.clip_planes = view.clip.count();
        self.caps = view.clip.eye_removed();
        ctx.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&u));
        self.used = 0;
    }

    /// The pieces later draws take, leaving none.
    pub(crate) fn take_pieces(&mut self) -> Option<Arc<LodPieces>> {
        self.pieces.take()
    }

    /// Which LODs later draws take in pieces: only each piece's
    /// triangles, a highlighted piece tinted (`None`: every LOD whole).
    pub(crate) fn set_pieces(&mut self, pieces: Option<Arc<LodPieces>>) {
        self.pieces = pieces;
    }

    /// Writes this chunk's instance data; returns the draws with their instance index.
    pub(crate) fn prepare(
        &mut self,
        ctx: &GpuContext,
        view: &View,
        residency: &dyn Residency,
        lods: &[u32],
    ) -> Vec<(LodRange, u32)> {
        let mut draws: Vec<(LodRange, bool)> = Vec::with_capacity(lods.len());
        for &l in lods {
            let Some(r) = residency.range(l) else {
                continue;
            };
            match self.pieces.as_ref().and_then(|p| p.get(&l)) {
                None => draws.push((r, false)),
                Some(pieces) => {
                    for p in pieces {
                        let piece = LodRange {
                            first_index: r.first_index + 3 * p.first_triangle,
                            index_count: 3 * p.triangles,
                            ..r
                        };
                        // Runs cover the LOD's triangles: never past its range.
                        if 3 * (p.first_triangle + p.triangles) <= r.index_count {
                            draws.push((piece, p.highlight));
                        }
                    }
                }
            }
        }
        // One pipeline switch at most: draws grouped by layout, in the
        // caller's order within each.
        if !draws.is_sorted_by_key(|(r, _)| r.layout as u8) {
            draws.sort_by_key(|(r, _)| r.layout as u8);
        }
        let size = std::mem::size_of::<DrawInstance>() as u64;
        let needed = self.used + draws.len() as u64;
        if needed * size > self.instances.size() {
            // Earlier chunks keep the old buffers alive until they finish.
            let slots = needed.next_power_of_two().max(1024);
            self.instances = instance_buffer(ctx, slots);
            self.indirect = indirect_buffer(ctx, slots);
            self.used = 0;
        }
        let first = self.used as u32;
        // Each draw's instance data and, for multi-draws, its record
        // (DrawIndexedIndirectArgs, field by field), in scratch kept
        // between chunks.
        self.scratch.instances.clear();
        self.scratch.records.clear();
        let records = self.indirect.is_some();
        for (i, (r, highlight)) in draws.iter().enumerate() {
            self.scratch.instances.push(DrawInstance {
                // w: 1 tints the draw (a highlighted object).
                offset: (r.origin - view.eye)
                    .as_vec3()
                    .extend(if *highlight { 1.0 } else { 0.0 })
                    .to_array(),
                scale: [r.scale[0], r.scale[1], r.scale[2], 0.0],
            });
            if records {
                self.scratch.records.extend_from_slice(&[
                    r.index_count,
                    1,
                    r.first_index,
                    r.base_vertex as u32,
                    first + i as u32,
                ]);
            }
        }
        ctx.queue.write_buffer(
            &self.instances,
            self.used * size,
            bytemuck::cast_slice(&self.scratch.instances),
        );
        if let Some(indirect) = &self.indirect {
            ctx.queue.write_buffer(
                indirect,
                self.used * INDIRECT_BYTES,
                bytemuck::cast_slice(&self.scratch.records),
            );
        }
        self.used += draws.len() as u64;
        draws
            .into_iter()
            .enumerate()
            .map(|(i, (r, _))| (r, first + i as u32))
            .collect()
    }

    /// Records `draws` (from [`Drawer::prepare`]) with the pipeline of
    /// each one's vertex layout.
    pub(crate) fn record(
        &self,
        pass: &mut wgpu::RenderPass,
        residency: &dyn Residency,
        draws: &[(LodRange, u32)],
        pipelines: &ScenePipelines,
    ) {
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_vertex_buffer(1, self.instances.slice(..));
        let (mut layout, mut vertices, mut indices) = (None, None, None);
        // The indirect run not yet recorded: its first slot and length.
        let mut run: Option<(u32, u32)> = None;
        let flush = |pass: &mut wgpu::RenderPass, run: &mut Option<(u32, u32)>| {
            if let (Some((first, count)), Some(indirect)) = (run.take(), &self.indirect) {
                pass.multi_draw_indexed_indirect(indirect, first as u64 * INDIRECT_BYTES, count);
            }
        };
        for (r, instance) in draws {
            if layout != Some(r.layout) {
                flush(pass, &mut run);
                pass.set_pipeline(
                    pipelines.get(r.layout, pipelines.clipping(self.clip_planes, self.caps)),
                );
                layout = Some(r.layout);
            }
            if vertices != Some(r.buffer) || indices != Some((r.buffer, r.index_format)) {
                flush(pass, &mut run);
                let (v, i) = residency.buffers(r.buffer);
                if vertices != Some(r.buffer) {
                    pass.set_vertex_buffer(0, v.slice(..));
                    vertices = Some(r.buffer);
                }
                pass.set_index_buffer(i.slice(..), r.index_format);
                indices = Some((r.buffer, r.index_format));
            }
            if !self.base_vertex {
                // No base vertex (WebGL2): the vertex buffer starts at the
                // LOD's first vertex.
                let (v, _) = residency.buffers(r.buffer);
                let at = r.base_vertex as u64 * r.layout.stride();
                pass.set_vertex_buffer(0, v.slice(at..));
                vertices = None;
                pass.draw_indexed(
                    r.first_index..r.first_index + r.index_count,
                    0,
                    *instance..*instance + 1,
                );
                continue;
            }
            if self.indirect.is_none() {
                pass.draw_indexed(
                    r.first_index..r.first_index + r.index_count,
                    r.base_vertex,
                    *instance..*instance + 1,
                );
                continue;
            }
            // Slots are consecutive within a chunk; a gap starts a new run.
            match &mut run {
                Some((first, count)) if *first + *count == *instance => *count += 1,
                _ => {
                    flush(pass, &mut run);
                    run = Some((*instance, 1));
                }
            }
        }
        flush(pass, &mut run);
    }
}

/// A chunk's instance data and draw records, before they are written.
#[derive(Default)]
struct Scratch {
    instances: Vec<DrawInstance>,
    records: Vec<u32>,
}

/// Bytes of one `DrawIndexedIndirectArgs`.
const INDIRECT_BYTES: u64 = std::mem::size_of::<wgpu::util::DrawIndexedIndirectArgs>() as u64;

/// The indirect records of `count` draws, where the device takes them.
fn indirect_buffer(ctx: &GpuContext, count: u64) -> Option<wgpu::Buffer> {
    ctx.capabilities().multi_draw.then(|| {
        ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("draw records"),
            size: count * INDIRECT_BYTES,
            usage: wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    })
}

fn instance_buffer(ctx: &GpuContext, count: u64) -> wgpu::Buffer {
    ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("draw instances"),
        size: count * std::mem::size_of::<DrawInstance>() as u64,
        usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}
