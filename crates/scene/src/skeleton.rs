//! The scene skeleton: the AABB hierarchy and per-node LOD table that a
//! reader loads eagerly. Geometry stays on disk until asked for.

use std::ops::Range;

use glam::DVec3;

pub use crate::validate::SkeletonError;
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
    /// Whether the blob is quantized and meshopt-encoded (format 2's
    /// default; docs/scene-format.md), else raw f32 positions.
    pub encoded: bool,
    /// An encoded LOD's grid and normal bits, as its record states them
    /// (format 2.1; `None` for raw LODs and in 2.0 files, whose blobs
    /// alone say). A renderer sizes the LOD's device layout from this
    /// without reading the blob.
    pub grid: Option<GridBits>,
    /// Whether the encoded blob is zstd-compressed after meshopt's codecs,
    /// with the file's dictionary when it has one (format 2.1, section
    /// ZDIC).
    pub compressed: bool,
    /// Byte offset of the geometry blob from the start of the file.
    pub offset: u64,
    pub len: u64,
    /// CRC-32 of the geometry blob, checked when the LOD is read.
    pub checksum: u32,
}

impl LodInfo {
    /// A level that stands only for its error: one triangle, no geometry
    /// stored (raw, u16 indices, per-vertex colours, at offset 0). For
    /// building skeletons where only the tree and its errors matter, as
    /// the tests of code that plans over them do.
    pub fn placeholder(error: f32) -> LodInfo {
        LodInfo {
            error,
            triangles: 1,
            vertices: 3,
            origin: DVec3::ZERO,
            index_format: IndexFormat::U16,
            uniform_colour: None,
            encoded: false,
            grid: None,
            compressed: false,
            offset: 0,
            len: 0,
            checksum: 0,
        }
    }
}

/// The bits of an encoded LOD: grid positions per axis
/// ([`codec::POSITION_BITS`](crate::codec::POSITION_BITS)) and octahedral
/// normals ([`codec::NORMAL_BITS`](crate::codec::NORMAL_BITS)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GridBits {
    pub position: u8,
    pub normal: u8,
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
///
/// Valid by construction: [`Skeleton::new`] is the only way to make one,
/// and it checks every invariant of docs/scene-format.md that does not
/// depend on where the geometry lies in a file (the reader checks those
/// too). So code that walks a skeleton may index it without checking:
/// node 0 is the root; a node's parent is an earlier node and lists it
/// among its children; its children are later nodes and its LODs are in
/// the table; each LOD belongs to exactly one node; boxes are finite and
/// nest; errors do not decrease from a node's finest LOD to its coarsest,
/// nor from child to parent.
#[derive(Clone, Debug, PartialEq)]
pub struct Skeleton {
    origin: DVec3,
    bounds: Aabb,
    nodes: Vec<Node>,
    lods: Vec<LodInfo>,
    provenance: Provenance,
    /// The node each LOD belongs to.
    owner: Vec<u32>,
}

impl Skeleton {
    /// A skeleton from its parts, when they are valid (see [`Skeleton`]);
    /// otherwise what is wrong and where.
    pub fn new(
        origin: DVec3,
        bounds: Aabb,
        nodes: Vec<Node>,
        lods: Vec<LodInfo>,
        provenance: Provenance,
    ) -> Result<Skeleton, SkeletonError> {
        let owner = crate::validate::check_tree(origin, &bounds, &nodes, &lods)?;
        Ok(Skeleton {
            origin,
            bounds,
            nodes,
            lods,
            provenance,
            owner,
        })
    }

    /// The parts [`Skeleton::new`] took, to change and check again.
    pub fn into_parts(self) -> (DVec3, Aabb, Vec<Node>, Vec<LodInfo>, Provenance) {
        (
            self.origin,
            self.bounds,
            self.nodes,
            self.lods,
            self.provenance,
        )
    }

    /// A point near the scene's centre, for camera-relative work.
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// Contains every node's box.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The hierarchy, root first; children after their parent.
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// The LOD table; each node's LODs are a contiguous run, finest first.
    pub fn lods(&self) -> &[LodInfo] {
        &self.lods
    }

    pub fn provenance(&self) -> &Provenance {
        &self.provenance
    }

    /// Node `i` (an index from this skeleton: a child, a parent, a draw
    /// item's node).
    pub fn node(&self, i: u32) -> &Node {
        debug_assert!(
            (i as usize) < self.nodes.len(),
            "node {i} of {}",
            self.nodes.len()
        );
        &self.nodes[i as usize]
    }

    /// LOD `i` of the table.
    pub fn lod(&self, i: u32) -> &LodInfo {
        debug_assert!(
            (i as usize) < self.lods.len(),
            "LOD {i} of {}",
            self.lods.len()
        );
        &self.lods[i as usize]
    }

    /// The node LOD `lod` belongs to.
    pub fn owner(&self, lod: u32) -> u32 {
        self.owner[lod as usize]
    }

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

#[cfg(test)]
mod tests {
    use super::*;

    fn lod(error: f32) -> LodInfo {
        LodInfo::placeholder(error)
    }

    /// A root over two leaves, each with two LODs; the root has one.
    fn parts() -> (Vec<Node>, Vec<LodInfo>) {
        let b = |x: f64| Aabb::new(DVec3::new(x, 0.0, 0.0), DVec3::new(x + 1.0, 1.0, 1.0));
        let node = |bounds, parent, first_child, child_count, first_lod, lod_count| Node {
            bounds,
            parent,
            first_child,
            child_count,
            first_lod,
            lod_count,
        };
        let root = Aabb::new(DVec3::ZERO, DVec3::new(3.0, 1.0, 1.0));
        (
            vec![
                node(root, NO_NODE, 1, 2, 4, 1),
                node(b(0.0), 0, 0, 0, 0, 2),
                node(b(2.0), 0, 0, 0, 2, 2),
            ],
            vec![lod(0.0), lod(0.5), lod(0.0), lod(0.5), lod(1.0)],
        )
    }

    fn make(nodes: Vec<Node>, lods: Vec<LodInfo>) -> Result<Skeleton, SkeletonError> {
        let bounds = Aabb::new(DVec3::ZERO, DVec3::new(3.0, 1.0, 1.0));
        Skeleton::new(DVec3::ZERO, bounds, nodes, lods, Provenance::default())
    }

    #[test]
    fn a_valid_skeleton_is_made_and_indexed() {
        let (nodes, lods) = parts();
        let s = make(nodes.clone(), lods.clone()).unwrap();
        assert_eq!(s.nodes(), &nodes[..]);
        assert_eq!(s.lods(), &lods[..]);
        assert_eq!(s.node(2).first_lod, 2);
        assert_eq!((s.owner(0), s.owner(3), s.owner(4)), (1, 2, 0));
        assert_eq!(s.lod(4).error, 1.0);
        let (o, b, n, l, p) = s.clone().into_parts();
        assert_eq!(Skeleton::new(o, b, n, l, p).unwrap(), s);
    }

    #[test]
    fn malformed_parts_are_refused_with_where_and_why() {
        // What code walking a skeleton would otherwise have to check.
        type Break = fn(&mut Vec<Node>, &mut Vec<LodInfo>);
        let cases: [(Break, &str); 9] = [
            (|n, _| n.clear(), "scene: the scene has no nodes"),
            (|n, _| n[0].child_count = 7, "node 0: children 1..8"),
            (|n, _| n[1].lod_count = 99, "node 1: LODs 0..99 are beyond"),
            (
                |n, _| {
                    n[2].first_child = 0;
                    n[2].child_count = 1;
                },
                "node 2: children 0..1 must be later nodes",
            ),
            (|n, _| n[0].parent = 0, "node 0: the root has a parent"),
            (
                |n, _| n[2].parent = 1,
                "node 2: is a child of 0 but names parent 1",
            ),
            (|n, _| n[1].first_lod = 2, "LOD 2 already belongs to node 1"),
            (
                |_, l| l.push(lod(0.0)),
                "LOD 5 of node 4294967295: belongs to no node",
            ),
            (|_, l| l[1].error = -1.0, "LOD 1 of node 1: error -1"),
        ];
        for (f, want) in cases {
            let (mut nodes, mut lods) = parts();
            f(&mut nodes, &mut lods);
            let e = make(nodes, lods).unwrap_err().to_string();
            assert!(e.contains(want), "{e} (wanted {want})");
        }
    }
}
