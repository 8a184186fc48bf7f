//! The tile tree: which levels of detail become tiles, each tile's
//! geometric error, and how the tree is cut into tileset files.
//!
//! A node's levels become a chain of tiles refined by REPLACE, coarsest
//! first; its finest level's tile has the node's children's chains as its
//! children, and a leaf's finest level (its full detail) ends the chain.
//! Each tile's geometric error is its level's stored error: a measured
//! bound on the two-sided Hausdorff distance between that level and the
//! full-detail surface it stands for, so it is the error a client incurs
//! drawing the tile instead of refining it to full detail.
//!
//! The scene guarantees errors that never decrease from a node's finest
//! level to its coarsest, nor from a node's finest to its parent's finest,
//! but a child's coarser levels may be coarser than its parent's finest.
//! A tile's error must not be below its children's (a client that
//! refines a tile must not draw something coarser), so a level is a tile
//! only when its error is at most that of the tile above it, and strictly
//! less within a node's chain (a finer level of the same error as a
//! coarser one of the same node is never drawn: the coarser one always
//! passes first). So every tile keeps its level's own measured bound and
//! errors never increase down the tree; the levels left out are counted.

use gigawalk_scene::Skeleton;

/// One tile.
#[derive(Clone, Debug, PartialEq)]
pub struct Tile {
    /// The node whose box the tile takes.
    pub node: u32,
    /// The level it draws; `None` for the empty root of a scene whose root
    /// node has no levels.
    pub lod: Option<u32>,
    /// Its geometric error, model units.
    pub error: f64,
    /// Its children, indices into [`Plan::tiles`].
    pub children: Vec<u32>,
}

/// The tile tree of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Tile 0 is the root; a tile's children come after it.
    pub tiles: Vec<Tile>,
    /// Levels that are no tile (see the module's comment).
    pub levels_left_out: usize,
}

/// The tile tree of `skeleton`.
pub fn plan(skeleton: &Skeleton) -> Plan {
    let mut tiles = Vec::new();
    let root = skeleton.node(0);
    if root.lod_count == 0 {
        // Nothing to draw at the top: an empty tile whose error is the
        // scene's diagonal (drawing nothing is within that of everything)
        // and at least its children's.
        tiles.push(Tile {
            node: 0,
            lod: None,
            error: 0.0,
            children: Vec::new(),
        });
        let mut children = Vec::new();
        for c in root.children() {
            attach(skeleton, c, f32::INFINITY, &mut tiles, &mut children);
        }
        let b = skeleton.node(0).bounds;
        let diagonal = (b.max - b.min).length();
        let top = children
            .iter()
            .map(|&c| tiles[c as usize].error)
            .fold(diagonal, f64::max);
        tiles[0].error = top;
        tiles[0].children = children;
    } else {
        let mut top = Vec::new();
        attach(skeleton, 0, f32::INFINITY, &mut tiles, &mut top);
        debug_assert_eq!(top, [0]);
    }
    let emitted = tiles.iter().filter(|t| t.lod.is_some()).count();
    Plan {
        levels_left_out: skeleton.lods().len() - emitted,
        tiles,
    }
}

/// Appends the tiles of `node`'s subtree whose errors are at most `cap`,
/// pushing the top ones' indices to `out`. A node without levels is drawn
/// through its children, so theirs take its place.
fn attach(skeleton: &Skeleton, node: u32, cap: f32, tiles: &mut Vec<Tile>, out: &mut Vec<u32>) {
    let n = *skeleton.node(node);
    if n.lod_count == 0 {
        for c in n.children() {
            attach(skeleton, c, cap, tiles, out);
        }
        return;
    }
    // Coarsest first.
    let mut chain: Vec<u32> = Vec::new();
    let mut last = cap;
    for l in n.lods().rev() {
        let e = skeleton.lods()[l].error;
        if e <= last && (chain.is_empty() || e < last) {
            chain.push(l as u32);
            last = e;
        }
    }
    if chain.is_empty() {
        // Unreachable for a valid skeleton (a node's finest error is at
        // most its ancestors'), kept so the tree always reaches full detail.
        chain.push(n.first_lod);
        last = skeleton.lods()[n.first_lod as usize].error;
    }
    let mut parent: Option<usize> = None;
    for &l in &chain {
        let i = tiles.len();
        tiles.push(Tile {
            node,
            lod: Some(l),
            error: skeleton.lods()[l as usize].error as f64,
            children: Vec::new(),
        });
        match parent {
            None => out.push(i as u32),
            Some(p) => tiles[p].children.push(i as u32),
        }
        parent = Some(i);
    }
    let finest = parent.expect("a chain has a tile");
    let mut children = Vec::new();
    for c in n.children() {
        attach(skeleton, c, last, tiles, &mut children);
    }
    tiles[finest].children = children;
}

/// Where the tree is cut into files: each file's root tile, the main
/// tileset's first. A tile that roots a file other than the first is
/// referenced from its parent's file by a tile of its own.
#[derive(Clone, Debug, PartialEq)]
pub struct Files {
    pub roots: Vec<u32>,
    /// Per tile: whether it roots a file.
    pub is_root: Vec<bool>,
}

/// Cuts the tree into files of at most `max_tiles` tiles (the references
/// to other files included) and `max_depth` tiles from a file's root to
/// its deepest tile, filling each file breadth first from its root, so
/// the upper levels of the tree share a file and no file's JSON grows
/// past a few MB or nests too deep for a parser.
pub fn files(plan: &Plan, max_tiles: usize, max_depth: usize) -> Files {
    let max_tiles = max_tiles.max(2);
    let max_depth = max_depth.max(2);
    let mut is_root = vec![false; plan.tiles.len()];
    let mut roots = vec![0u32];
    is_root[0] = true;
    let mut next = 0;
    while next < roots.len() {
        let root = roots[next];
        next += 1;
        let mut queue = std::collections::VecDeque::from([(root, 1usize)]);
        let mut admitted = 1;
        while let Some((t, depth)) = queue.pop_front() {
            for &c in &plan.tiles[t as usize].children {
                if admitted < max_tiles && depth < max_depth {
                    admitted += 1;
                    queue.push_back((c, depth + 1));
                } else {
                    is_root[c as usize] = true;
                    roots.push(c);
                }
            }
        }
    }
    Files { roots, is_root }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gigawalk_scene::{Aabb, LodInfo, Node, Provenance, NO_NODE};
    use glam::DVec3;

    /// A root with `root_errors` and two leaves with `leaf_errors` each.
    fn skeleton(root_errors: &[f32], leaf_errors: &[&[f32]]) -> Skeleton {
        let b = Aabb::new(DVec3::ZERO, DVec3::ONE);
        let mut lods: Vec<LodInfo> = root_errors
            .iter()
            .map(|&e| LodInfo::placeholder(e))
            .collect();
        let mut nodes = vec![Node {
            bounds: b,
            parent: NO_NODE,
            first_child: 1,
            child_count: leaf_errors.len() as u32,
            first_lod: 0,
            lod_count: root_errors.len() as u32,
        }];
        for errors in leaf_errors {
            nodes.push(Node {
                bounds: b,
                parent: 0,
                first_child: 0,
                child_count: 0,
                first_lod: lods.len() as u32,
                lod_count: errors.len() as u32,
            });
            lods.extend(errors.iter().map(|&e| LodInfo::placeholder(e)));
        }
        Skeleton::new(DVec3::ZERO, b, nodes, lods, Provenance::default()).unwrap()
    }

    fn check_monotone(p: &Plan) {
        for t in &p.tiles {
            for &c in &t.children {
                assert!(p.tiles[c as usize].error <= t.error, "{p:?}");
            }
        }
    }

    #[test]
    fn a_chain_then_its_children() {
        let s = skeleton(&[0.5, 1.0, 2.0], &[&[0.0, 0.25], &[0.0]]);
        let p = plan(&s);
        check_monotone(&p);
        let lods: Vec<Option<u32>> = p.tiles.iter().map(|t| t.lod).collect();
        // Root coarsest to finest, then each leaf coarsest to finest.
        assert_eq!(
            lods,
            [Some(2), Some(1), Some(0), Some(4), Some(3), Some(5)].to_vec()
        );
        assert_eq!(p.tiles[2].children, [3, 5]);
        assert_eq!(p.tiles[3].children, [4]);
        assert_eq!(p.levels_left_out, 0);
    }

    #[test]
    fn child_levels_coarser_than_the_parent_are_left_out() {
        let s = skeleton(&[0.5, 1.0], &[&[0.0, 0.25, 0.75, 3.0]]);
        let p = plan(&s);
        check_monotone(&p);
        let errors: Vec<f64> = p.tiles.iter().map(|t| t.error).collect();
        assert_eq!(errors, [1.0, 0.5, 0.25, 0.0]);
        assert_eq!(p.levels_left_out, 2);
    }

    #[test]
    fn equal_errors_in_a_chain_keep_the_coarser() {
        let s = skeleton(&[0.5, 0.5], &[&[0.0, 0.5]]);
        let p = plan(&s);
        let lods: Vec<Option<u32>> = p.tiles.iter().map(|t| t.lod).collect();
        // Root: LOD 1 only; the leaf's 0.5 equals its parent's: kept.
        assert_eq!(lods, [Some(1), Some(3), Some(2)].to_vec());
    }

    #[test]
    fn a_root_without_levels_is_an_empty_tile_over_its_children() {
        let s = skeleton(&[], &[&[0.0, 2.0], &[0.0]]);
        let p = plan(&s);
        check_monotone(&p);
        assert_eq!(p.tiles[0].lod, None);
        // At least the diagonal of the unit cube and the children's errors.
        assert_eq!(p.tiles[0].error, 2.0);
        assert_eq!(p.tiles[0].children.len(), 2);
    }

    #[test]
    fn files_hold_at_most_their_tiles_and_depth() {
        let s = skeleton(&[0.5, 1.0, 2.0], &[&[0.0, 0.25], &[0.0]]);
        let p = plan(&s);
        let f = files(&p, 3, 100);
        assert_eq!(f.roots, [0, 3, 5]);
        let f = files(&p, 100, 2);
        // Depths: 0 (1), 1 (2), 2 (3, 5): 2 deep per file.
        assert_eq!(f.roots, [0, 2, 4]);
        let f = files(&p, 100, 100);
        assert_eq!(f.roots, [0]);
    }
}
