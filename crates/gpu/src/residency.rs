//! Geometry residency: where each LOD's vertices and indices live on a
//! device, in a few large buffers with per-LOD ranges (no buffer per node).
//! Two kinds behind the [`Residency`] trait: [`ResidentGeometry`], every
//! LOD loaded at start, and [`GeometryPool`], a fixed amount of device
//! memory that LODs are put into and taken out of while the walk runs
//! (out-of-core streaming; the runtime decides what goes in and out).

use std::ops::Range;

use glam::DVec3;
use range_alloc::RangeAllocator;

use gigawalk_scene::codec::{GridPositions, OctNormals};
use gigawalk_scene::{Colours, LodInfo, LodMesh, ReadAt, ReadError, SceneReader, StoredLod};

use crate::shader_types::{CompactVertex, GpuVertex, VertexLayout};
use crate::{GpuContext, GpuError};

/// Where one LOD lives: which buffer pair, and the ranges inside it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LodRange {
    pub buffer: u32,
    /// In indices of `index_format` from the start of the index buffer.
    pub first_index: u32,
    pub index_count: u32,
    pub base_vertex: i32,
    pub layout: VertexLayout,
    pub index_format: wgpu::IndexFormat,
    /// World point the LOD's position 0 (grid coordinate 0) lies at.
    pub origin: DVec3,
    /// Model units per coordinate on each axis (1 for the wide layout).
    pub scale: [f32; 3],
}

/// What a pass needs to draw a LOD.
pub trait Residency {
    /// The LOD's location, or `None` if it is not resident (it is then
    /// skipped: a streaming residency would request it).
    fn range(&self, lod: u32) -> Option<LodRange>;
    /// The vertex and index buffer of a buffer pair.
    fn buffers(&self, buffer: u32) -> (&wgpu::Buffer, &wgpu::Buffer);
}

/// Bytes of a wide vertex (f32 positions).
pub const VERTEX_BYTES: u64 = VertexLayout::Wide.stride();
/// Bytes of an index of a LOD with more vertices than u16 indices reach.
pub const INDEX_BYTES: u64 = 4;

/// Vertices a LOD may have for u16 indices: index 0xffff is left out, as
/// it restarts primitives where a driver keeps restart on for lists.
const U16_VERTICES: usize = 0xffff;

/// The index format for a LOD of `vertices` vertices.
fn index_format(vertices: usize) -> wgpu::IndexFormat {
    if vertices <= U16_VERTICES {
        wgpu::IndexFormat::Uint16
    } else {
        wgpu::IndexFormat::Uint32
    }
}

/// Device bytes of a LOD's indices (padded to 4 bytes).
fn index_bytes(vertices: usize, indices: usize) -> u64 {
    (indices as u64 * index_format(vertices).byte_size() as u64).next_multiple_of(4)
}

/// Device bytes a LOD of this record takes: its vertices in
/// [`VertexLayout::of`], its indices in u16 when they reach every vertex.
pub fn device_bytes(info: &LodInfo) -> u64 {
    info.vertices as u64 * VertexLayout::of(info).stride()
        + index_bytes(info.vertices as usize, 3 * info.triangles as usize)
}

/// One LOD decoded into a device layout in host memory: what a streaming
/// loader hands to the devices, and what [`HostGeometry`] packs.
#[derive(Clone, Debug, PartialEq)]
pub struct DecodedLod {
    pub layout: VertexLayout,
    /// The vertices in `layout`.
    pub vertices: Vec<u8>,
    pub index_format: wgpu::IndexFormat,
    /// The indices in `index_format`, zero-padded to 4 bytes.
    pub indices: Vec<u8>,
    pub index_count: u32,
    /// World point position 0 (grid coordinate 0) lies at.
    pub origin: DVec3,
    /// Model units per coordinate (1 for the wide layout).
    pub scale: [f32; 3],
}

impl DecodedLod {
    /// A decoded LOD in the wide layout.
    pub fn new(mesh: &LodMesh) -> Self {
        let colour = |i: usize| match &mesh.colours {
            Colours::Uniform(c) => *c,
            Colours::PerVertex(v) => v[i],
        };
        let vertices: Vec<GpuVertex> = mesh
            .positions
            .iter()
            .zip(&mesh.normals)
            .enumerate()
            .map(|(i, (p, n))| GpuVertex {
                position: *p,
                normal: gigawalk_scene::encode_normal(*n),
                colour: colour(i),
            })
            .collect();
        DecodedLod::with_indices(
            VertexLayout::Wide,
            bytemuck::cast_slice(&vertices).to_vec(),
            mesh.positions.len(),
            &mesh.indices,
            mesh.origin,
            [1.0; 3],
        )
    }

    /// A LOD as its blob stores it: an encoded LOD whose layout allows it
    /// ([`VertexLayout::for_grid`]) stays on its grid, in the compact
    /// layout; anything else is decoded into the wide one.
    pub fn from_stored(lod: StoredLod) -> Self {
        let g = match lod {
            StoredLod::Grid(g) => g,
            mesh => return DecodedLod::new(&mesh.into_mesh()),
        };
        // 16-bit grids decode to u16 coordinates and 8-bit normals to
        // snorm8: exactly `VertexLayout::for_grid`'s compact case.
        let s = &g.streams;
        let (GridPositions::U16(p), OctNormals::Snorm8(nm)) = (&s.positions, &s.normals) else {
            return DecodedLod::new(&StoredLod::Grid(g).into_mesh());
        };
        let vertices: Vec<CompactVertex> = p
            .iter()
            .zip(nm)
            .enumerate()
            .map(|(i, (p, n))| CompactVertex {
                position: [p[0], p[1], p[2], CompactVertex::pack_normal(n[0], n[1])],
                colour: g.colour(i),
            })
            .collect();
        DecodedLod::with_indices(
            VertexLayout::Compact,
            bytemuck::cast_slice(&vertices).to_vec(),
            p.len(),
            &s.indices,
            g.origin + glam::Vec3::from(s.origin).as_dvec3(),
            s.step,
        )
    }

    fn with_indices(
        layout: VertexLayout,
        vertices: Vec<u8>,
        vertex_count: usize,
        indices: &[u32],
        origin: DVec3,
        scale: [f32; 3],
    ) -> Self {
        let index_format = index_format(vertex_count);
        let mut bytes: Vec<u8> = match index_format {
            wgpu::IndexFormat::Uint16 => {
                let narrow: Vec<u16> = indices.iter().map(|&i| i as u16).collect();
                bytemuck::cast_slice(&narrow).to_vec()
            }
            wgpu::IndexFormat::Uint32 => bytemuck::cast_slice(indices).to_vec(),
        };
        bytes.resize(bytes.len().next_multiple_of(4), 0);
        DecodedLod {
            layout,
            vertices,
            index_format,
            indices: bytes,
            index_count: indices.len() as u32,
            origin,
            scale,
        }
    }

    /// Reads LOD `lod` of `scene` into its device layout.
    pub fn read<R: ReadAt>(scene: &SceneReader<R>, lod: u32) -> Result<Self, ReadError> {
        scene.read_lod_stored(lod).map(DecodedLod::from_stored)
    }

    pub fn vertex_count(&self) -> u64 {
        self.vertices.len() as u64 / self.layout.stride()
    }

    /// Device bytes the LOD takes.
    pub fn bytes(&self) -> u64 {
        (self.vertices.len() + self.indices.len()) as u64
    }
}

/// All of a scene's geometry decoded into device layouts in host memory,
/// split into chunks that fit a device's buffer limit. Built once,
/// uploaded to each device that draws.
pub struct HostGeometry {
    chunks: Vec<Chunk>,
    ranges: Vec<LodRange>,
}

#[derive(Default)]
struct Chunk {
    vertices: Vec<u8>,
    indices: Vec<u8>,
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
        for lod in 0..lods as u32 {
            let d = DecodedLod::read(scene, lod)?;
            let stride = d.layout.stride() as usize;
            let (nv, ni) = (d.vertices.len() as u64, d.indices.len() as u64);
            if nv + stride as u64 > max_chunk_bytes || ni > max_chunk_bytes {
                return Err(GpuError::TooLarge {
                    what: format!("LOD {lod}"),
                    needed: nv.max(ni),
                    limit: max_chunk_bytes,
                });
            }
            let c = chunks.last().expect("one chunk");
            let at = c.vertices.len().next_multiple_of(stride);
            if (at as u64 + nv) > max_chunk_bytes
                || c.indices.len() as u64 + ni > max_chunk_bytes
                || (at + d.vertices.len()) / stride > i32::MAX as usize
            {
                chunks.push(Chunk::default());
            }
            let buffer = chunks.len() as u32 - 1;
            let c = chunks.last_mut().expect("one chunk");
            // Each LOD's vertices start on a whole vertex of its layout.
            c.vertices
                .resize(c.vertices.len().next_multiple_of(stride), 0);
            ranges.push(LodRange {
                buffer,
                first_index: (c.indices.len() as u64 / d.index_format.byte_size() as u64) as u32,
                index_count: d.index_count,
                base_vertex: (c.vertices.len() / stride) as i32,
                layout: d.layout,
                index_format: d.index_format,
                origin: d.origin,
                scale: d.scale,
            });
            c.vertices.extend_from_slice(&d.vertices);
            c.indices.extend_from_slice(&d.indices);
            progress(lod as u64 + 1, lods as u64);
        }
        Ok(HostGeometry { chunks, ranges })
    }

    /// Device bytes the geometry takes (what each device that draws holds).
    pub fn bytes(&self) -> u64 {
        self.chunks
            .iter()
            .map(|c| (c.vertices.len() + c.indices.len()) as u64)
            .sum()
    }

    /// LODs in each vertex layout, in [`VertexLayout::ALL`]'s order.
    pub fn layout_counts(&self) -> [usize; 2] {
        let mut n = [0; 2];
        self.ranges.iter().for_each(|r| n[r.layout as usize] += 1);
        n
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
                make("vertices", &c.vertices, wgpu::BufferUsages::VERTEX),
                make("indices", &c.indices, wgpu::BufferUsages::INDEX),
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

/// Bytes of the pool's allocation unit: every write to a buffer is a
/// multiple of 4 bytes at a multiple of 4.
const UNIT_BYTES: u64 = 4;

/// One pool buffer (bound as both the vertex and the index buffer) and
/// what of it is taken, in units.
struct Page {
    buffer: wgpu::Buffer,
    free: RangeAllocator<u32>,
    /// Where one buffer may not be both vertex and index buffer
    /// (`Capabilities::shared_buffers`; WebGL2): `buffer` holds vertices
    /// and this one indices, each half the page.
    indices: Option<(wgpu::Buffer, RangeAllocator<u32>)>,
}

/// Where a resident LOD sits in the pool.
#[derive(Clone, Debug)]
struct Slot {
    range: LodRange,
    units: Range<u32>,
    /// Its indices' units in the page's index buffer, where it has one.
    index_units: Option<Range<u32>>,
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
/// Vertices start on a whole vertex of their layout (a draw names them by
/// `base_vertex`): a range has room for that, at most a vertex less 4
/// bytes more than the LOD's own bytes.
///
/// Where the device may not bind one buffer as both (WebGL2), each page
/// is a vertex buffer and an index buffer of half its bytes each, and a
/// LOD takes a range in both; one that finds no room in either is
/// refused, as a LOD that finds no room is.
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

/// Units `lod` takes in a pool (room to align its vertices, then
/// vertices and indices), if a `u32` range can hold them.
fn pool_units(lod: &DecodedLod) -> Option<u32> {
    let bytes = lod.layout.stride() - UNIT_BYTES + lod.bytes();
    u32::try_from(bytes / UNIT_BYTES).ok()
}

/// Units `lod` takes in a split page's vertex buffer (room to align its
/// vertices, then its vertices) and index buffer, if `u32`s hold them.
fn split_units(lod: &DecodedLod) -> Option<(u32, u32)> {
    let v = (lod.layout.stride() - UNIT_BYTES + lod.vertices.len() as u64) / UNIT_BYTES;
    let i = (lod.indices.len() as u64).div_ceil(UNIT_BYTES);
    Some((u32::try_from(v).ok()?, u32::try_from(i).ok()?))
}

impl GeometryPool {
    /// A pool for a scene of `lods` LODs with room for `bytes` of
    /// geometry (rounded down to whole units of 4 bytes), split into
    /// buffers of at most `max_buffer_bytes`.
    pub fn new(
        ctx: &GpuContext,
        lods: usize,
        bytes: u64,
        max_buffer_bytes: u64,
    ) -> Result<Self, GpuError> {
        // Units a buffer can address: a u32 unit offset; the first index
        // (a u32, two a unit at most) and the base vertex (an i32) then
        // fit as well.
        let max = (max_buffer_bytes / UNIT_BYTES).min(u32::MAX as u64 / 2);
        if max < VERTEX_BYTES / UNIT_BYTES {
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
        let split = !ctx.capabilities().shared_buffers;
        for p in 0..pages {
            out.push(if split {
                let vertex_units = per / 2;
                let index_units = per - vertex_units;
                Page {
                    buffer: geometry_buffer(
                        ctx,
                        &format!("pool {p} vertices"),
                        vertex_units * UNIT_BYTES,
                        wgpu::BufferUsages::VERTEX,
                    ),
                    free: RangeAllocator::new(0..vertex_units as u32),
                    indices: Some((
                        geometry_buffer(
                            ctx,
                            &format!("pool {p} indices"),
                            index_units * UNIT_BYTES,
                            wgpu::BufferUsages::INDEX,
                        ),
                        RangeAllocator::new(0..index_units as u32),
                    )),
                }
            } else {
                Page {
                    buffer: geometry_buffer(
                        ctx,
                        &format!("pool {p}"),
                        per * UNIT_BYTES,
                        wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::INDEX,
                    ),
                    free: RangeAllocator::new(0..per as u32),
                    indices: None,
                }
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

    /// Device bytes the resident LODs take (each with its room to align:
    /// at most a vertex less 4 bytes more than its vertices and indices).
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
        self.pages.iter().any(|p| match &p.indices {
            None => pool_units(lod).is_some_and(|u| p.free.initial_range().len() >= u as usize),
            Some((_, ifree)) => split_units(lod).is_some_and(|(v, i)| {
                p.free.initial_range().len() >= v as usize
                    && ifree.initial_range().len() >= i as usize
            }),
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
        let stride = lod.layout.stride();
        let split = split_units(lod);
        for (b, page) in self.pages.iter_mut().enumerate() {
            let want = match (&page.indices, split) {
                (None, _) => units,
                (Some(_), Some((v, _))) => v,
                (Some(_), None) => return false,
            };
            let Ok(r) = page.free.allocate_range(want.max(1)) else {
                continue;
            };
            let vertices_at = (r.start as u64 * UNIT_BYTES).next_multiple_of(stride);
            let (index_units, indices_at) = match (&mut page.indices, split) {
                (Some((ibuf, ifree)), Some((_, i))) => {
                    let Ok(ir) = ifree.allocate_range(i.max(1)) else {
                        page.free.free_range(r);
                        continue;
                    };
                    let at = ir.start as u64 * UNIT_BYTES;
                    if !lod.indices.is_empty() {
                        ctx.queue.write_buffer(ibuf, at, &lod.indices);
                    }
                    (Some(ir), at)
                }
                _ => {
                    let at = vertices_at + lod.vertices.len() as u64;
                    if !lod.indices.is_empty() {
                        ctx.queue.write_buffer(&page.buffer, at, &lod.indices);
                    }
                    (None, at)
                }
            };
            if !lod.vertices.is_empty() {
                ctx.queue
                    .write_buffer(&page.buffer, vertices_at, &lod.vertices);
            }
            let bytes = (r.len() + index_units.as_ref().map_or(0, |i| i.len())) as u64 * UNIT_BYTES;
            self.slots[id as usize] = Some(Slot {
                range: LodRange {
                    buffer: b as u32,
                    first_index: (indices_at / lod.index_format.byte_size() as u64) as u32,
                    index_count: lod.index_count,
                    base_vertex: (vertices_at / stride) as i32,
                    layout: lod.layout,
                    index_format: lod.index_format,
                    origin: lod.origin,
                    scale: lod.scale,
                },
                units: r,
                index_units,
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
        let page = &mut self.pages[slot.range.buffer as usize];
        page.free.free_range(slot.units);
        if let (Some((_, ifree)), Some(i)) = (&mut page.indices, slot.index_units) {
            ifree.free_range(i);
        }
    }
}

impl Residency for GeometryPool {
    fn range(&self, lod: u32) -> Option<LodRange> {
        self.slots.get(lod as usize)?.as_ref().map(|s| s.range)
    }
    fn buffers(&self, buffer: u32) -> (&wgpu::Buffer, &wgpu::Buffer) {
        let p = &self.pages[buffer as usize];
        (&p.buffer, p.indices.as_ref().map_or(&p.buffer, |(i, _)| i))
    }
}
