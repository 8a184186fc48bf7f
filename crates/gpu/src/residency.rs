//! Geometry residency: where each LOD's vertices and indices live on a
//! device. Everything is loaded at start for now, into a few large buffers
//! with per-LOD ranges (no buffer per node); the [`Residency`] trait is the
//! seam where streaming will plug in.

use glam::DVec3;

use gigawalk_scene::{Colours, ReadAt, SceneReader};

use crate::shader_types::GpuVertex;
use crate::{GpuContext, GpuError};

/// Where one LOD lives: which buffer pair, and the ranges inside it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LodRange {
    pub buffer: u32,
    pub first_index: u32,
    pub index_count: u32,
    pub base_vertex: i32,
    /// World point the LOD's positions are relative to.
    pub origin: DVec3,
}

/// What a pass needs to draw a LOD.
pub trait Residency {
    /// The LOD's location, or `None` if it is not resident (it is then
    /// skipped: a streaming residency would request it).
    fn range(&self, lod: u32) -> Option<LodRange>;
    /// The vertex and index buffer of a buffer pair.
    fn buffers(&self, buffer: u32) -> (&wgpu::Buffer, &wgpu::Buffer);
}

/// All of a scene's geometry decoded into GPU layout in host memory, split
/// into chunks that fit a device's buffer limit. Built once, uploaded to
/// each device that draws.
pub struct HostGeometry {
    chunks: Vec<Chunk>,
    ranges: Vec<LodRange>,
}

#[derive(Default)]
struct Chunk {
    vertices: Vec<GpuVertex>,
    indices: Vec<u32>,
}

impl HostGeometry {
    /// Reads every LOD of the scene. `max_chunk_bytes` bounds each vertex
    /// and index buffer (use the smaller of the devices' limits).
    pub fn load<R: ReadAt>(scene: &SceneReader<R>, max_chunk_bytes: u64) -> Result<Self, GpuError> {
        let lods = scene.skeleton().lods.len();
        let mut chunks = vec![Chunk::default()];
        let mut ranges = Vec::with_capacity(lods);
        let vsize = std::mem::size_of::<GpuVertex>() as u64;
        for lod in 0..lods as u32 {
            let mesh = scene.read_lod(lod)?;
            let (nv, ni) = (mesh.positions.len() as u64, mesh.indices.len() as u64);
            if nv * vsize > max_chunk_bytes || ni * 4 > max_chunk_bytes {
                return Err(GpuError::TooLarge {
                    what: format!("LOD {lod}"),
                    needed: (nv * vsize).max(ni * 4),
                    limit: max_chunk_bytes,
                });
            }
            let c = chunks.last().expect("one chunk");
            if (c.vertices.len() as u64 + nv) * vsize > max_chunk_bytes
                || (c.indices.len() as u64 + ni) * 4 > max_chunk_bytes
                || c.vertices.len() as u64 + nv > i32::MAX as u64
            {
                chunks.push(Chunk::default());
            }
            let buffer = chunks.len() as u32 - 1;
            let c = chunks.last_mut().expect("one chunk");
            ranges.push(LodRange {
                buffer,
                first_index: c.indices.len() as u32,
                index_count: ni as u32,
                base_vertex: c.vertices.len() as i32,
                origin: mesh.origin,
            });
            let colour = |i: usize| match &mesh.colours {
                Colours::Uniform(c) => *c,
                Colours::PerVertex(v) => v[i],
            };
            c.vertices
                .extend(
                    mesh.positions
                        .iter()
                        .zip(&mesh.normals)
                        .enumerate()
                        .map(|(i, (p, n))| GpuVertex {
                            position: *p,
                            normal: gigawalk_scene::encode_normal(*n),
                            colour: colour(i),
                        }),
                );
            c.indices.extend_from_slice(&mesh.indices);
        }
        Ok(HostGeometry { chunks, ranges })
    }

    pub fn bytes(&self) -> u64 {
        self.chunks
            .iter()
            .map(|c| {
                (c.vertices.len() * std::mem::size_of::<GpuVertex>() + c.indices.len() * 4) as u64
            })
            .sum()
    }

    /// Uploads everything to one device.
    pub fn upload(&self, ctx: &GpuContext) -> Result<ResidentGeometry, GpuError> {
        let mut buffers = Vec::with_capacity(self.chunks.len());
        for (i, c) in self.chunks.iter().enumerate() {
            let make = |what: &str, bytes: &[u8], usage| {
                // Zero-sized buffers are legal but binding them is not; keep 4 bytes.
                let size = (bytes.len() as u64)
                    .max(4)
                    .next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT);
                let b = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(&format!("{what} chunk {i}")),
                    size,
                    usage: usage | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                ctx.queue.write_buffer(&b, 0, bytes);
                b
            };
            buffers.push((
                make(
                    "vertices",
                    bytemuck::cast_slice(&c.vertices),
                    wgpu::BufferUsages::VERTEX,
                ),
                make(
                    "indices",
                    bytemuck::cast_slice(&c.indices),
                    wgpu::BufferUsages::INDEX,
                ),
            ));
        }
        ctx.queue.submit([]);
        ctx.check()?;
        Ok(ResidentGeometry {
            buffers,
            ranges: self.ranges.clone(),
        })
    }
}

/// A whole scene resident on one device.
pub struct ResidentGeometry {
    buffers: Vec<(wgpu::Buffer, wgpu::Buffer)>,
    ranges: Vec<LodRange>,
}

impl Residency for ResidentGeometry {
    fn range(&self, lod: u32) -> Option<LodRange> {
        self.ranges.get(lod as usize).copied()
    }
    fn buffers(&self, buffer: u32) -> (&wgpu::Buffer, &wgpu::Buffer) {
        let (v, i) = &self.buffers[buffer as usize];
        (v, i)
    }
}
