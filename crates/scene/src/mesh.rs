//! One LOD's geometry as the writer takes it and the reader returns it.

use glam::DVec3;

/// Vertex colours of one LOD.
#[derive(Clone, Debug, PartialEq)]
pub enum Colours {
    /// Every vertex has this sRGB-encoded RGBA colour (stored once).
    Uniform([u8; 4]),
    /// One sRGB-encoded RGBA colour per vertex.
    PerVertex(Vec<[u8; 4]>),
}

/// Geometry of one LOD: an indexed triangle list with positions relative
/// to `origin`.
#[derive(Clone, Debug, PartialEq)]
pub struct LodMesh {
    /// World position that `positions` are relative to; the writer
    /// recentres on the LOD's box centre, so any origin is fine here.
    pub origin: DVec3,
    pub positions: Vec<[f32; 3]>,
    /// Unit normals, one per position. Stored octahedrally encoded in
    /// 2 x 16 bits: a normal read back is within 1e-4 of the one written.
    pub normals: Vec<[f32; 3]>,
    pub colours: Colours,
    /// 3 indices per triangle, each `< positions.len()`.
    pub indices: Vec<u32>,
}

impl LodMesh {
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }
}
