//! A tiny deterministic generator for this crate's randomised unit tests
//! (no dependency needed for them), and a tree over boxes to cull.

use gigawalk_scene::{Aabb, IndexFormat, LodInfo, Node, Skeleton, NO_NODE};
use glam::DVec3;

/// A LOD record with only an error and a triangle count (no geometry).
pub(crate) fn lod(error: f32, triangles: u32) -> LodInfo {
    LodInfo {
        error,
        triangles,
        vertices: 3 * triangles,
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

/// A tree over `leaves` built breadth first (children contiguous and
/// after their parent): a node's boxes sorted along x, y, z in turn (by its
/// index) and split into `arity` runs. Every node has one 12-triangle LOD.
pub(crate) fn tree(leaves: &[Aabb], arity: usize) -> Skeleton {
    let mut slots: Vec<(Vec<Aabb>, u32)> = Vec::new();
    let mut queue = std::collections::VecDeque::new();
    queue.push_back((leaves.to_vec(), NO_NODE));
    while let Some((mut boxes, parent)) = queue.pop_front() {
        let me = slots.len() as u32;
        slots.push((boxes.clone(), parent));
        if boxes.len() > 1 {
            let axis = (me % 3) as usize;
            boxes.sort_by(|a, b| a.center()[axis].total_cmp(&b.center()[axis]));
            let per = boxes.len().div_ceil(arity.clamp(2, boxes.len()));
            for chunk in boxes.chunks(per) {
                queue.push_back((chunk.to_vec(), me));
            }
        }
    }
    let mut nodes: Vec<Node> = slots
        .iter()
        .enumerate()
        .map(|(i, (boxes, parent))| Node {
            bounds: boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b)),
            parent: *parent,
            first_child: 0,
            child_count: 0,
            first_lod: i as u32,
            lod_count: 1,
        })
        .collect();
    for i in 1..nodes.len() {
        let p = nodes[i].parent as usize;
        if nodes[p].child_count == 0 {
            nodes[p].first_child = i as u32;
        }
        nodes[p].child_count += 1;
    }
    let lods = (0..nodes.len()).map(|_| lod(0.0, 12)).collect();
    Skeleton::new(
        DVec3::ZERO,
        nodes[0].bounds,
        nodes,
        lods,
        Default::default(),
    )
    .expect("a valid skeleton")
}

pub(crate) struct Lcg(pub u64);

impl Lcg {
    fn step(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.step() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in 0..n (0 for n = 0).
    pub fn upto(&mut self, n: u32) -> u32 {
        ((self.step() >> 33) as u32) % n.max(1)
    }

    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.unit()
    }

    /// Each coordinate uniform in [-r, r).
    pub fn vec(&mut self, r: f64) -> DVec3 {
        DVec3::new(self.range(-r, r), self.range(-r, r), self.range(-r, r))
    }
}
