//! The scene skeleton: the AABB hierarchy and per-node LOD table that a
//! reader loads eagerly. Geometry stays on disk until asked for.

use std::ops::Range;

use glam::DVec3;

use crate::Aabb;

/// Marks "no node": the root's parent.
pub const NO_NODE: u32 = u32::MAX;

/// One node of the AABB hierarchy. Node 0 is the root. A node's children
/// are the contiguous nodes `first_child .. first_child + child_count`, and
/// its LODs the contiguous entries `first_lod .. first_lod + lod_count` of
/// [`Skeleton::lods`], finest first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    /// Contains the node's own geometry (every LOD) and every child's box.
    pub bounds: Aabb,
    pub parent: u32,
    pub first_child: u32,
    pub child_count: u32,
    pub first_lod: u32,
    pub lod_count: u32,
}

impl Node {
    pub fn is_leaf(&self) -> bool {
        self.child_count == 0
    }
    pub fn children(&self) -> Range<u32> {
        self.first_child..self.first_child + self.child_count
    }
    pub fn lods(&self) -> Range<usize> {
        self.first_lod as usize..(self.first_lod + self.lod_count) as usize
    }
}

/// Width of the stored triangle indices of one LOD.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IndexFormat {
    U16,
    U32,
}

impl IndexFormat {
    pub fn bytes(self) -> u64 {
        match self {
            IndexFormat::U16 => 2,
            IndexFormat::U32 => 4,
        }
    }
    /// The narrowest format that can index `vertices` vertices.
    pub fn for_vertex_count(vertices: u32) -> Self {
        if vertices <= 1 << 16 {
            IndexFormat::U16
        } else {
            IndexFormat::U32
        }
    }
}

/// One level of detail of one node: where its geometry is and how coarse it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LodInfo {
    /// Object-space geometric error in model units: 0 for the original
    /// geometry, larger for coarser levels. Pixel error = `error` x
    /// (viewport height / (2 tan(fovy / 2))) / distance.
    pub error: f32,
    pub triangles: u32,
    pub vertices: u32,
    /// Positions are stored as f32 offsets from this point (the LOD's box
    /// centre), so geometry far from the world origin keeps full precision.
    pub origin: DVec3,
    pub index_format: IndexFormat,
    /// `Some(rgba)` when every vertex has this colour (no per-vertex colours
    /// stored); `None` when the LOD stores one colour per vertex.
    pub uniform_colour: Option<[u8; 4]>,
    /// Byte offset of the geometry blob from the start of the file.
    pub offset: u64,
    pub len: u64,
    /// CRC-32 of the geometry blob, checked when the LOD is read.
    pub checksum: u32,
}

/// Provenance: where a scene came from and how it was made. Stored as JSON.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Provenance {
    /// The model file(s) the scene was built from.
    pub source: String,
    /// Name and version of the tool that wrote the file.
    pub tool: String,
    /// Every parameter that shaped the scene, by name.
    pub parameters: serde_json::Map<String, serde_json::Value>,
}

/// Everything a reader loads when it opens a scene: bounds, origin,
/// hierarchy, LOD table and provenance.
#[derive(Clone, Debug, PartialEq)]
pub struct Skeleton {
    /// A point near the scene's centre, for camera-relative work.
    pub origin: DVec3,
    pub bounds: Aabb,
    pub nodes: Vec<Node>,
    pub lods: Vec<LodInfo>,
    pub provenance: Provenance,
}

impl Skeleton {
    pub fn root(&self) -> &Node {
        &self.nodes[0]
    }

    pub fn node_lods(&self, node: u32) -> &[LodInfo] {
        &self.lods[self.nodes[node as usize].lods()]
    }

    /// Number of levels on the longest root-to-leaf path (1 for a lone root).
    pub fn depth(&self) -> u32 {
        // Children always have larger indices than their parent (validated),
        // so one forward pass computes every node's depth.
        let mut depth = vec![0u32; self.nodes.len()];
        let mut max = 0;
        for (i, n) in self.nodes.iter().enumerate() {
            let d = if n.parent == NO_NODE {
                1
            } else {
                depth[n.parent as usize] + 1
            };
            depth[i] = d;
            max = max.max(d);
        }
        max
    }

    pub fn leaves(&self) -> impl Iterator<Item = u32> + '_ {
        (0..self.nodes.len() as u32).filter(|&i| self.nodes[i as usize].is_leaf())
    }

    /// Triangles of the original geometry: the sum of every leaf's finest LOD.
    pub fn finest_triangles(&self) -> u64 {
        self.leaves()
            .filter_map(|i| self.node_lods(i).first())
            .map(|l| l.triangles as u64)
            .sum()
    }
}
