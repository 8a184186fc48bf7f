//! Geometry residency: where each LOD's vertices and indices live on a
//! device, in a few large buffers with per-LOD ranges (no buffer per node).
//! Two kinds behind the [`Residency`] trait: [`ResidentGeometry`], every
//! LOD loaded at start, and [`GeometryPool`], a fixed amount of device
//! memory that LODs are put into and taken out of while the walk runs
//! (out-of-core streaming; the runtime decides what goes in and out).

use std::ops::Range;

use glam::DVec3;
use range_alloc::RangeAllocator;

use gigawalk_scene::{Colours, LodMesh, ReadAt, SceneReader};

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

/// A LOD's vertices in the GPU's layout.
fn gpu_vertices(mesh: &LodMesh) -> impl Iterator<Item = GpuVertex> + '_ {
    let colour = move |i: usize| match &mesh.colours {
        Colours::Uniform(c) => *c,
        Colours::PerVertex(v) => v[i],
    };
    mesh.positions
        .iter()
        .zip(&mesh.normals)
        .enumerate()
        .map(move |(i, (p, n))| GpuVertex {
            position: *p,
            normal: gigawalk_scene::encode_normal(*n),
            colour: colour(i),
        })
}

/// Bytes one vertex takes on a device.
pub const VERTEX_BYTES: u64 = std::mem::size_of::<GpuVertex>() as u64;
/// Bytes one index takes on a device.
pub const INDEX_BYTES: u64 = 4;

/// One LOD decoded into the GPU's layout in host memory: what a streaming
/// loader hands to the devices.
#[derive(Clone, Debug, PartialEq)]
pub struct DecodedLod {
    pub vertices: Vec<GpuVertex>,
    pub indices: Vec<u32>,
    /// World point the positions are relative to.
    pub origin: DVec3,
}

impl DecodedLod {
    pub fn new(mesh: &LodMesh) -> Self {
        DecodedLod {
            vertices: gpu_vertices(mesh).collect(),
            indices: mesh.indices.clone(),
            origin: mesh.origin,
        }
    }

    /// Device bytes the LOD takes.
    pub fn bytes(&self) -> u64 {
        self.vertices.len() as u64 * VERTEX_BYTES + self.indices.len() as u64 * INDEX_BYTES
    }
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
        Self::load_reporting(scene, max_chunk_bytes, &mut |_, _| {})
    }

    /// Like [`HostGeometry::load`], telling `progress` (LODs read, LODs in
    /// all) after every LOD.
    pub fn load_reporting<R: ReadAt>(
        scene: &SceneReader<R>,
        max_chunk_bytes: u64,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<Self, GpuError> {
        let lods = scene.skeleton().lods().len();
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
            c.vertices.extend(gpu_vertices(&mesh));
            c.indices.extend_from_slice(&mesh.indices);
            progress(lod as u64 + 1, lods as u64);
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
                let b =
                    geometry_buffer(ctx, &format!("{what} chunk {i}"), bytes.len() as u64, usage);
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

/// A vertex or index buffer of `bytes` that geometry is written into.
fn geometry_buffer(
    ctx: &GpuContext,
    label: &str,
    bytes: u64,
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        // Zero-sized buffers are legal but binding them is not; keep 4 bytes.
        size: bytes.max(4).next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT),
        usage: usage | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
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

/// Bytes of the pool's allocation unit: one vertex, or five indices. A
/// LOD takes whole units (its indices padded to a unit), so every LOD's
/// vertices start on a whole `base_vertex` of the buffer.
const UNIT_BYTES: u64 = VERTEX_BYTES;
/// Indices in a unit.
const UNIT_INDICES: u32 = (UNIT_BYTES / INDEX_BYTES) as u32;
const _: () = assert!(UNIT_BYTES.is_multiple_of(INDEX_BYTES));

/// One pool buffer (bound as both the vertex and the index buffer) and
/// what of it is taken, in units.
struct Page {
    buffer: wgpu::Buffer,
    free: RangeAllocator<u32>,
}

/// Where a resident LOD sits in the pool.
#[derive(Clone, Debug)]
struct Slot {
    range: LodRange,
    units: Range<u32>,
    bytes: u64,
}

/// A fixed amount of one device's memory for geometry (buffers made once,
/// at most the device's buffer limit each), that LODs are put into and
/// taken out of one by one. It keeps no policy: the caller chooses what to
/// insert and what to remove (the runtime's memory budget, least recently
/// drawn first).
///
/// A LOD's vertices and indices lie side by side in one range of one
/// buffer, so any LOD fits wherever its bytes are free in one piece: with
/// separate vertex and index buffers split in the scene's proportions, a
/// working set richer in vertices than the scene ran out of vertex room
/// with a fifth of the pool free (a held camera then never settled).
///
/// Overwriting a removed LOD's range is safe while earlier frames still
/// draw from it on the GPU: `Queue::write_buffer` takes effect at the next
/// submission, after every command already submitted on the queue.
pub struct GeometryPool {
    pages: Vec<Page>,
    slots: Vec<Option<Slot>>,
    used_bytes: u64,
    capacity_bytes: u64,
}

/// Units `lod` takes in a pool (vertices, then indices), if a `u32` range
/// can hold them.
fn pool_units(lod: &DecodedLod) -> Option<u32> {
    let units =
        lod.vertices.len() as u64 + lod.indices.len().div_ceil(UNIT_INDICES as usize) as u64;
    u32::try_from(units.max(1)).ok()
}

impl GeometryPool {
    /// A pool for a scene of `lods` LODs with room for `bytes` of
    /// geometry (rounded down to whole units of 20 bytes), split into
    /// buffers of at most `max_buffer_bytes`.
    pub fn new(
        ctx: &GpuContext,
        lods: usize,
        bytes: u64,
        max_buffer_bytes: u64,
    ) -> Result<Self, GpuError> {
        // Units a buffer can address: the first index (five a unit) is a
        // u32, the base vertex (one a unit) an i32.
        let max = (max_buffer_bytes / UNIT_BYTES).min(u32::MAX as u64 / UNIT_INDICES as u64);
        if max == 0 {
            return Err(GpuError::TooLarge {
                what: "a geometry pool buffer".into(),
                needed: VERTEX_BYTES,
                limit: max_buffer_bytes,
            });
        }
        let units = bytes / UNIT_BYTES;
        let pages = units.div_ceil(max).max(1);
        let per = units / pages;
        let mut out = Vec::with_capacity(pages as usize);
        for p in 0..pages {
            out.push(Page {
                buffer: geometry_buffer(
                    ctx,
                    &format!("pool {p}"),
                    per * UNIT_BYTES,
                    wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::INDEX,
                ),
                free: RangeAllocator::new(0..per as u32),
            });
        }
        ctx.check()?;
        Ok(GeometryPool {
            pages: out,
            slots: vec![None; lods],
            used_bytes: 0,
            capacity_bytes: pages * per * UNIT_BYTES,
        })
    }

    /// Device bytes the pool's buffers take, resident LODs or not.
    pub fn capacity_bytes(&self) -> u64 {
        self.capacity_bytes
    }

    /// Device bytes the resident LODs take (each rounded up to whole
    /// units: at most 16 bytes more than its vertices and indices).
    pub fn used_bytes(&self) -> u64 {
        self.used_bytes
    }

    pub fn contains(&self, lod: u32) -> bool {
        matches!(self.slots.get(lod as usize), Some(Some(_)))
    }

    /// Device bytes `lod` takes (0 when it is not resident).
    pub fn bytes_of(&self, lod: u32) -> u64 {
        match self.slots.get(lod as usize) {
            Some(Some(s)) => s.bytes,
            _ => 0,
        }
    }

    /// Whether `lod` could fit in an empty pool.
    pub fn could_hold(&self, lod: &DecodedLod) -> bool {
        pool_units(lod).is_some_and(|u| {
            self.pages
                .iter()
                .any(|p| p.free.initial_range().len() >= u as usize)
        })
    }

    /// Puts `lod` (id `id`) in the pool and writes it to the device; false
    /// when no page has room for it in one piece (nothing changes then). A
    /// LOD already resident stays where it is.
    pub fn insert(&mut self, ctx: &GpuContext, id: u32, lod: &DecodedLod) -> bool {
        if self.contains(id) {
            return true;
        }
        let Some(units) = pool_units(lod) else {
            return false;
        };
        if id as usize >= self.slots.len() {
            return false;
        }
        for (b, page) in self.pages.iter_mut().enumerate() {
            let Ok(r) = page.free.allocate_range(units) else {
                continue;
            };
            let indices_at = r.start + lod.vertices.len() as u32;
            for (at, data) in [
                (r.start, bytemuck::cast_slice::<_, u8>(&lod.vertices)),
                (indices_at, bytemuck::cast_slice(&lod.indices)),
            ] {
                if !data.is_empty() {
                    ctx.queue
                        .write_buffer(&page.buffer, at as u64 * UNIT_BYTES, data);
                }
            }
            let bytes = r.len() as u64 * UNIT_BYTES;
            self.slots[id as usize] = Some(Slot {
                range: LodRange {
                    buffer: b as u32,
                    first_index: indices_at * UNIT_INDICES,
                    index_count: lod.indices.len() as u32,
                    base_vertex: r.start as i32,
                    origin: lod.origin,
                },
                units: r,
                bytes,
            });
            self.used_bytes += bytes;
            return true;
        }
        false
    }

    /// Takes `id` out of the pool (its memory is free for the next insert).
    pub fn remove(&mut self, id: u32) {
        let Some(slot) = self.slots.get_mut(id as usize).and_then(Option::take) else {
            return;
        };
        self.used_bytes -= slot.bytes;
        self.pages[slot.range.buffer as usize]
            .free
            .free_range(slot.units);
    }
}

impl Residency for GeometryPool {
    fn range(&self, lod: u32) -> Option<LodRange> {
        self.slots.get(lod as usize)?.as_ref().map(|s| s.range)
    }
    fn buffers(&self, buffer: u32) -> (&wgpu::Buffer, &wgpu::Buffer) {
        let p = &self.pages[buffer as usize].buffer;
        (p, p)
    }
}
