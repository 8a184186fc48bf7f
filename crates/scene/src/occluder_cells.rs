//! The optional OCVC section: Coorg and Teller's view cells (their
//! Section 3.1). A kD-tree over the space the eye moves in; each leaf
//! lists, for each of a few view directions, the occluders (indices into
//! the OCCL section) most likely to hide much from a viewpoint in it, best
//! first. The `ct` culler looks up the eye's leaf and the direction
//! nearest its view direction, so it scores a few dozen occluders a frame
//! instead of all of them.
//!
//! Layout (little-endian): u32 version (1), u32 k (most occluders per
//! list), u32 direction count D, D unit f64x3 directions, u32 node count,
//! then per node: u32 kind (0, 1, 2: split across that axis; 3: leaf), f64
//! split coordinate (0 for a leaf), u32 child (a split's first child, its
//! second is the next node, both after it; a leaf's index); then u32 leaf
//! count L and L x D lists: u32 length (<= k), that many u32 occluder
//! indices. Node 0 is the root and covers all space: a point below a split
//! goes to the first child, at or above it to the second.

use glam::DVec3;

use crate::format::Put;
use crate::{ReadAt, ReadError, SceneReader};

pub const TAG_OCCLUDER_CELLS: [u8; 4] = *b"OCVC";
pub const OCCLUDER_CELLS_VERSION: u32 = 1;
/// Most directions and entries per list a file may hold.
pub const MAX_CELL_DIRECTIONS: usize = 64;
pub const MAX_CELL_OCCLUDERS: usize = 1024;

/// One node of the view-cell tree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CellNode {
    /// Points with coordinate `axis` below `at` go to `first`, the rest to
    /// `first + 1`.
    Split {
        axis: u8,
        at: f64,
        first: u32,
    },
    Leaf(u32),
}

/// The view cells and their occluder lists.
#[derive(Clone, Debug, PartialEq)]
pub struct OccluderCells {
    pub nodes: Vec<CellNode>,
    /// Unit view directions.
    pub directions: Vec<DVec3>,
    /// Most occluders per list.
    pub k: u32,
    /// `lists[leaf * directions.len() + d]`: occluder indices, best first.
    pub lists: Vec<Vec<u32>>,
}

impl OccluderCells {
    pub fn leaves(&self) -> usize {
        self.lists.len() / self.directions.len().max(1)
    }

    /// The leaf whose cell holds `p` (a non-finite coordinate goes to the
    /// second child).
    pub fn leaf(&self, p: DVec3) -> u32 {
        let mut at = 0usize;
        loop {
            match self.nodes.get(at) {
                Some(CellNode::Split { axis, at: s, first }) => {
                    let below = p[*axis as usize] < *s;
                    at = *first as usize + usize::from(!below);
                }
                Some(CellNode::Leaf(l)) => return *l,
                None => return 0,
            }
        }
    }

    /// The stored direction nearest `v` (largest dot product; ties to the
    /// first).
    pub fn direction(&self, v: DVec3) -> usize {
        let mut best = (f64::NEG_INFINITY, 0);
        for (i, d) in self.directions.iter().enumerate() {
            let s = d.dot(v);
            if s > best.0 {
                best = (s, i);
            }
        }
        best.1
    }

    /// The list of `leaf` for direction `d` (empty when out of range).
    pub fn list(&self, leaf: u32, d: usize) -> &[u32] {
        self.lists
            .get(leaf as usize * self.directions.len() + d)
            .map_or(&[], |l| l.as_slice())
    }

    /// The occluders listed for an eye at `eye` looking along `forward`.
    pub fn lookup(&self, eye: DVec3, forward: DVec3) -> &[u32] {
        self.list(self.leaf(eye), self.direction(forward))
    }
}

/// The section's bytes.
pub fn encode_occluder_cells(c: &OccluderCells) -> Vec<u8> {
    let mut p = Put::default();
    p.u32(OCCLUDER_CELLS_VERSION);
    p.u32(c.k);
    p.u32(c.directions.len() as u32);
    for d in &c.directions {
        p.dvec3(*d);
    }
    p.u32(c.nodes.len() as u32);
    for n in &c.nodes {
        match *n {
            CellNode::Split { axis, at, first } => {
                p.u32(axis as u32);
                p.f64(at);
                p.u32(first);
            }
            CellNode::Leaf(l) => {
                p.u32(3);
                p.f64(0.0);
                p.u32(l);
            }
        }
    }
    p.u32(c.leaves() as u32);
    for l in &c.lists {
        p.u32(l.len() as u32);
        for &o in l {
            p.u32(o);
        }
    }
    p.0
}

/// A bounds-checked little-endian reader.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self, what: &str) -> Result<[u8; N], (u64, String)> {
        let b = self
            .bytes
            .get(self.at..self.at + N)
            .ok_or_else(|| (self.at as u64, format!("ends inside {what}")))?;
        self.at += N;
        Ok(b.try_into().expect("N bytes"))
    }
    fn u32(&mut self, what: &str) -> Result<u32, (u64, String)> {
        self.take::<4>(what).map(u32::from_le_bytes)
    }
    fn f64(&mut self, what: &str) -> Result<f64, (u64, String)> {
        self.take::<8>(what).map(f64::from_le_bytes)
    }
}

/// Parses the section, checking it against a scene with `occluders`
/// occluders; the error says what is wrong and at which byte.
pub fn decode_occluder_cells(
    bytes: &[u8],
    occluders: usize,
) -> Result<OccluderCells, (u64, String)> {
    let mut r = Reader { bytes, at: 0 };
    let bad = |at: usize, s: String| Err((at as u64, s));
    let version = r.u32("the header")?;
    if version != OCCLUDER_CELLS_VERSION {
        return bad(
            0,
            format!("version {version}; this gigawalk reads {OCCLUDER_CELLS_VERSION}"),
        );
    }
    let k = r.u32("the header")?;
    let dirs = r.u32("the header")? as usize;
    if !(1..=MAX_CELL_DIRECTIONS).contains(&dirs) || k as usize > MAX_CELL_OCCLUDERS {
        return bad(4, format!("{dirs} directions, k = {k} (1..=64, <= 1024)"));
    }
    let mut directions = Vec::with_capacity(dirs);
    for i in 0..dirs {
        let at = r.at;
        let d = DVec3::new(
            r.f64("a direction")?,
            r.f64("a direction")?,
            r.f64("a direction")?,
        );
        if !(d.is_finite() && (d.length() - 1.0).abs() < 1e-6) {
            return bad(at, format!("direction {i} is not a unit vector: {d}"));
        }
        directions.push(d);
    }
    let count = r.u32("the node count")? as usize;
    if count == 0 || count > bytes.len() / 16 {
        return bad(r.at - 4, format!("{count} nodes in {} bytes", bytes.len()));
    }
    let mut nodes = Vec::with_capacity(count);
    let mut leaves = 0u32;
    for i in 0..count {
        let at = r.at;
        let kind = r.u32("a node")?;
        let split = r.f64("a node")?;
        let child = r.u32("a node")?;
        let node = match kind {
            0..=2 => {
                // Children after the parent: the tree has no cycles.
                if !(split.is_finite() && child as usize > i && (child as usize) + 1 < count) {
                    return bad(at, format!("node {i}: split {split}, children {child}"));
                }
                CellNode::Split {
                    axis: kind as u8,
                    at: split,
                    first: child,
                }
            }
            3 => {
                if child != leaves {
                    return bad(at, format!("node {i}: leaf {child}, expected {leaves}"));
                }
                leaves += 1;
                CellNode::Leaf(child)
            }
            _ => return bad(at, format!("node {i} has kind {kind}")),
        };
        nodes.push(node);
    }
    let at = r.at;
    let stored = r.u32("the leaf count")?;
    if stored != leaves {
        return bad(at, format!("{stored} leaves listed, the tree has {leaves}"));
    }
    let mut lists = Vec::with_capacity(leaves as usize * dirs);
    for i in 0..leaves as usize * dirs {
        let at = r.at;
        let n = r.u32("a list")?;
        if n > k {
            return bad(at, format!("list {i} has {n} occluders, more than k = {k}"));
        }
        let mut l = Vec::with_capacity(n as usize);
        for _ in 0..n {
            let o = r.u32("a list")?;
            if o as usize >= occluders {
                return bad(at, format!("list {i} names occluder {o} of {occluders}"));
            }
            l.push(o);
        }
        lists.push(l);
    }
    if r.at != bytes.len() {
        return bad(
            r.at,
            format!("{} bytes after the last list", bytes.len() - r.at),
        );
    }
    Ok(OccluderCells {
        nodes,
        directions,
        k,
        lists,
    })
}

impl<R: ReadAt> SceneReader<R> {
    /// The scene's view cells, checked against its `occluders` occluders;
    /// `None` only when the table of contents lists no OCVC section
    /// (written before it existed). A stored section that fails its
    /// checksum or its checks is an error naming the file and OCVC, never
    /// `None`.
    pub fn occluder_cells(&self, occluders: usize) -> Result<Option<OccluderCells>, ReadError> {
        self.decode_optional(TAG_OCCLUDER_CELLS, |b| decode_occluder_cells(b, occluders))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cells() -> OccluderCells {
        OccluderCells {
            nodes: vec![
                CellNode::Split {
                    axis: 0,
                    at: 1.5,
                    first: 1,
                },
                CellNode::Leaf(0),
                CellNode::Split {
                    axis: 2,
                    at: -1e7,
                    first: 3,
                },
                CellNode::Leaf(1),
                CellNode::Leaf(2),
            ],
            directions: vec![DVec3::X, DVec3::NEG_X],
            k: 3,
            lists: vec![vec![0, 1], vec![], vec![2], vec![2, 1, 0], vec![1], vec![0]],
        }
    }

    #[test]
    fn cells_round_trip_and_every_truncation_is_an_error() {
        let c = cells();
        let bytes = encode_occluder_cells(&c);
        assert_eq!(decode_occluder_cells(&bytes, 3).unwrap(), c);
        for cut in 0..bytes.len() {
            assert!(
                decode_occluder_cells(&bytes[..cut], 3).is_err(),
                "cut {cut}"
            );
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(decode_occluder_cells(&longer, 3).is_err());
        // An index past the scene's occluders.
        assert!(decode_occluder_cells(&bytes, 2)
            .unwrap_err()
            .1
            .contains("names occluder 2"));
        let mut bad = bytes.clone();
        bad[0] = 7;
        assert!(decode_occluder_cells(&bad, 3)
            .unwrap_err()
            .1
            .contains("version"));
        // A child pointing back at its parent would loop.
        let mut looped = c.clone();
        looped.nodes[2] = CellNode::Split {
            axis: 2,
            at: 0.0,
            first: 1,
        };
        assert!(decode_occluder_cells(&encode_occluder_cells(&looped), 3).is_err());
    }

    #[test]
    fn the_eye_finds_its_cell_and_direction() {
        let c = cells();
        assert_eq!(c.leaves(), 3);
        assert_eq!(c.leaf(DVec3::new(0.0, 5.0, 0.0)), 0);
        assert_eq!(c.leaf(DVec3::new(1.5, 0.0, 0.0)), 2);
        assert_eq!(c.leaf(DVec3::new(9.0, 0.0, -2e7)), 1);
        assert_eq!(c.leaf(DVec3::NAN), 2);
        assert_eq!(c.direction(DVec3::new(-0.9, 0.4, 0.0)), 1);
        assert_eq!(c.lookup(DVec3::new(9.0, 0.0, -2e7), DVec3::X), &[2]);
        assert_eq!(
            c.lookup(DVec3::new(9.0, 0.0, -2e7), DVec3::NEG_X),
            &[2, 1, 0]
        );
        assert_eq!(c.lookup(DVec3::ZERO, DVec3::NEG_X), &[] as &[u32]);
    }
}
