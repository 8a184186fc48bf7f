//! The tile tree: which stored levels of detail each tile's content
//! unites, each tile's geometric error, and how the tree is cut into
//! tileset files.
//!
//! A tile covers the subtrees of a few hierarchy nodes (its `nodes`) and
//! draws them at one error band `e`: for each node, the coarsest stored
//! level whose error is at most `e`, or, where the node has none, its
//! children's in the same way (a leaf with none draws its full detail).
//! That is gigawalk's own traversal at a uniform error, cut to the
//! tile's subtrees, so a content is exactly a set of stored levels, never
//! re-simplified. Its geometric error is the largest of those levels'
//! stored errors (each a measured bound on the distance to the full
//! detail it stands for), raised where needed to its children's largest
//! so errors never increase down the tree (a bound above a bound is still
//! one).
//!
//! A tile's children draw the same subtrees at a finer band: half the
//! largest error of the tile's levels that are not yet full detail, halved
//! again until the band's triangles are at least twice the tile's and a
//! quarter of the target (so each band is worth its request, and the few
//! coarse levels at the top are one tile, not a chain of tiny ones), and
//! full detail at once when a band would be more than half of full
//! detail's triangles (so a level is not written again and again for a
//! few triangles less). The subtrees are
//! then split into groups of about the target triangles: a node whose
//! band is larger is replaced by its children, and consecutive nodes (the
//! hierarchy keeps neighbours together) are packed until the next would
//! pass the target. A tile whose levels are all full detail ends its
//! branch, so every leaf's full detail is reached.

use std::collections::VecDeque;

use gigawalk_scene::Skeleton;

/// The target a content's triangles are cut to when none is given: a few
/// draw calls' worth for CesiumJS and 3d-tiles-renderer, whose contents
/// are meant to hold thousands to tens of thousands of triangles. Larger
/// contents mean fewer requests to settle a view and more triangles
/// drawn in it (docs/tiles.md measures 5,000 to 50,000); at 30,000
/// CesiumJS settles views of a 10M plant with under a tenth of the
/// requests the per-node tree took.
pub const DEFAULT_CONTENT_TRIANGLES: u64 = 30_000;

/// One stored level a tile draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Part {
    pub node: u32,
    pub lod: u32,
}

/// One tile.
#[derive(Clone, Debug, PartialEq)]
pub struct Tile {
    /// The hierarchy nodes whose subtrees it covers; its box holds theirs.
    pub nodes: Vec<u32>,
    /// The levels its content unites, in hierarchy order; empty for the
    /// root of a scene whose root node has no levels (no content).
    pub parts: Vec<Part>,
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
    /// Stored levels no tile draws (bands skip them).
    pub levels_left_out: usize,
}

/// The band that draws every leaf's full detail (below every error).
const FULL_DETAIL: f32 = -1.0;

/// The tile tree of `skeleton`, contents cut to about `target` triangles.
pub fn plan(skeleton: &Skeleton, target: u64) -> Plan {
    let p = Planner::new(skeleton, target.max(1));
    let mut tiles = Vec::new();
    let root = skeleton.node(0);
    let mut parts = Vec::new();
    if root.lod_count > 0 {
        p.cut(0, f32::INFINITY, &mut parts);
    }
    tiles.push(Tile {
        nodes: vec![0],
        parts,
        error: 0.0,
        children: Vec::new(),
    });
    let mut queue = VecDeque::from([0usize]);
    while let Some(t) = queue.pop_front() {
        let band = if t == 0 && tiles[0].parts.is_empty() {
            // The empty root: its children draw the coarsest there is.
            Some(f32::INFINITY)
        } else {
            p.next_band(&tiles[t].nodes, &tiles[t].parts)
        };
        let Some(e) = band else { continue };
        let mut items = Vec::new();
        for &n in &tiles[t].nodes {
            p.items(n, e, &mut items);
        }
        for nodes in pack(&items, p.target) {
            let mut parts = Vec::new();
            for &n in &nodes {
                p.cut(n, e, &mut parts);
            }
            let i = tiles.len();
            tiles.push(Tile {
                nodes,
                parts,
                error: 0.0,
                children: Vec::new(),
            });
            tiles[t].children.push(i as u32);
            queue.push_back(i);
        }
    }

    // Errors: the parts' largest, then bottom up at least the children's
    // (children come after their parent).
    for t in (0..tiles.len()).rev() {
        let own = tiles[t]
            .parts
            .iter()
            .map(|q| skeleton.lods()[q.lod as usize].error as f64)
            .fold(0.0, f64::max);
        let below = tiles[t]
            .children
            .iter()
            .map(|&c| tiles[c as usize].error)
            .fold(own, f64::max);
        tiles[t].error = below;
    }
    if tiles[0].parts.is_empty() {
        // Drawing nothing is within the scene's diagonal of everything.
        let b = root.bounds;
        tiles[0].error = tiles[0].error.max((b.max - b.min).length());
    }
    let mut drawn = vec![false; skeleton.lods().len()];
    for q in tiles.iter().flat_map(|t| &t.parts) {
        drawn[q.lod as usize] = true;
    }
    Plan {
        levels_left_out: drawn.iter().filter(|&&d| !d).count(),
        tiles,
    }
}

/// Consecutive items (node, triangles) packed into groups of at most
/// `target` triangles (an item larger than that alone).
fn pack(items: &[(u32, u64)], target: u64) -> Vec<Vec<u32>> {
    let mut groups = Vec::new();
    let mut group = Vec::new();
    let mut sum = 0u64;
    for &(n, t) in items {
        if !group.is_empty() && sum + t > target {
            groups.push(std::mem::take(&mut group));
            sum = 0;
        }
        group.push(n);
        sum += t;
    }
    if !group.is_empty() {
        groups.push(group);
    }
    groups
}

struct Planner<'a> {
    skeleton: &'a Skeleton,
    target: u64,
    /// Full-detail triangles of each node's subtree.
    full: Vec<u64>,
}

impl<'a> Planner<'a> {
    fn new(skeleton: &'a Skeleton, target: u64) -> Self {
        let nodes = skeleton.nodes();
        let mut full = vec![0u64; nodes.len()];
        // Children come after their parent in the node array.
        for i in (0..nodes.len()).rev() {
            let n = &nodes[i];
            full[i] = if n.is_leaf() {
                if n.lod_count > 0 {
                    skeleton.lods()[n.first_lod as usize].triangles as u64
                } else {
                    0
                }
            } else {
                n.children().map(|c| full[c as usize]).sum()
            };
        }
        Planner {
            skeleton,
            target,
            full,
        }
    }

    fn error(&self, lod: u32) -> f32 {
        self.skeleton.lods()[lod as usize].error
    }

    /// A leaf's full detail: no finer level exists.
    fn is_final(&self, q: Part) -> bool {
        let n = self.skeleton.node(q.node);
        n.is_leaf() && q.lod == n.first_lod
    }

    /// The level `node` draws at band `e`, or `None` when its children
    /// draw instead.
    fn level(&self, node: u32, e: f32) -> Option<u32> {
        let n = self.skeleton.node(node);
        if n.lod_count == 0 {
            return None;
        }
        // Coarsest first; errors never decrease with coarseness.
        match n.lods().rev().find(|&l| self.skeleton.lods()[l].error <= e) {
            Some(l) => Some(l as u32),
            None if n.is_leaf() => Some(n.first_lod),
            None => None,
        }
    }

    /// Appends the levels `node`'s subtree draws at band `e`.
    fn cut(&self, node: u32, e: f32, out: &mut Vec<Part>) {
        match self.level(node, e) {
            Some(lod) => out.push(Part { node, lod }),
            None => {
                for c in self.skeleton.node(node).children() {
                    self.cut(c, e, out);
                }
            }
        }
    }

    /// The triangles of [`Self::cut`].
    fn triangles(&self, node: u32, e: f32) -> u64 {
        if e < 0.0 {
            return self.full[node as usize];
        }
        match self.level(node, e) {
            Some(lod) => self.skeleton.lods()[lod as usize].triangles as u64,
            None => self
                .skeleton
                .node(node)
                .children()
                .map(|c| self.triangles(c, e))
                .sum(),
        }
    }

    /// The band the children of a tile over `nodes` drawing `parts` draw
    /// (see the module's comment); `None` when every part is full detail.
    fn next_band(&self, nodes: &[u32], parts: &[Part]) -> Option<f32> {
        let open = parts
            .iter()
            .filter(|&&q| !self.is_final(q))
            .map(|q| self.error(q.lod))
            .reduce(f32::max)?;
        let drawn: u64 = parts
            .iter()
            .map(|q| self.skeleton.lods()[q.lod as usize].triangles as u64)
            .sum();
        let full: u64 = nodes.iter().map(|&n| self.full[n as usize]).sum();
        let mut e = open / 2.0;
        // Past a millionth of the open error the rest is full detail (and
        // a level of error 0 above full detail ends the halving).
        while e > open * 1e-6 {
            let t: u64 = nodes.iter().map(|&n| self.triangles(n, e)).sum();
            if 2 * t > full {
                break;
            }
            if t >= 2 * drawn && 4 * t >= self.target {
                return Some(e);
            }
            e /= 2.0;
        }
        Some(FULL_DETAIL)
    }

    /// `node`'s subtree at band `e` as items (node, triangles) of at most
    /// the target each where the hierarchy allows, in hierarchy order;
    /// subtrees that draw nothing are left out.
    fn items(&self, node: u32, e: f32, out: &mut Vec<(u32, u64)>) {
        let t = self.triangles(node, e);
        if t == 0 {
            return;
        }
        let n = self.skeleton.node(node);
        if t <= self.target || n.child_count == 0 {
            out.push((node, t));
            return;
        }
        for c in n.children() {
            self.items(c, e, out);
        }
    }
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

    /// Levels (error, triangles), finest first.
    type Levels = Vec<(f32, u32)>;

    /// A tree given breadth first: per node its child count and levels.
    fn skeleton(spec: &[(u32, Levels)]) -> Skeleton {
        let b = Aabb::new(DVec3::ZERO, DVec3::ONE);
        let mut nodes = Vec::new();
        let mut lods = Vec::new();
        let mut next_child = 1u32;
        for (children, levels) in spec {
            nodes.push(Node {
                bounds: b,
                parent: NO_NODE,
                first_child: if *children > 0 { next_child } else { 0 },
                child_count: *children,
                first_lod: lods.len() as u32,
                lod_count: levels.len() as u32,
            });
            next_child += children;
            lods.extend(levels.iter().map(|&(e, t)| {
                let mut l = LodInfo::placeholder(e);
                l.triangles = t;
                l
            }));
        }
        for i in 0..nodes.len() {
            for c in nodes[i].children() {
                nodes[c as usize].parent = i as u32;
            }
        }
        Skeleton::new(DVec3::ZERO, b, nodes, lods, Provenance::default()).unwrap()
    }

    /// Leaves under `node`, in order.
    fn leaves(s: &Skeleton, node: u32, out: &mut Vec<u32>) {
        let n = s.node(node);
        if n.is_leaf() {
            out.push(node);
        }
        for c in n.children() {
            leaves(s, c, out);
        }
    }

    /// What every plan must be, checked by brute force: errors bound
    /// their parts and never increase down the tree; a tile's parts cover
    /// each leaf of its nodes exactly once; children cover exactly their
    /// parent's leaves; a tile ends its branch exactly when it draws only
    /// full detail; every leaf's full detail is drawn.
    fn check(s: &Skeleton, p: &Plan) {
        let mut finest_drawn = vec![false; s.nodes().len()];
        for (t, tile) in p.tiles.iter().enumerate() {
            let mut covered = Vec::new();
            for &n in &tile.nodes {
                leaves(s, n, &mut covered);
            }
            covered.sort_unstable();
            let mut drawn = Vec::new();
            let mut all_final = true;
            for q in &tile.parts {
                let n = s.node(q.node);
                assert!(n.lods().contains(&(q.lod as usize)), "tile {t}: {q:?}");
                assert!(s.lods()[q.lod as usize].error as f64 <= tile.error);
                leaves(s, q.node, &mut drawn);
                let fin = n.is_leaf() && q.lod == n.first_lod;
                all_final &= fin;
                if fin {
                    finest_drawn[q.node as usize] = true;
                }
            }
            drawn.sort_unstable();
            if !(t == 0 && tile.parts.is_empty()) {
                assert_eq!(drawn, covered, "tile {t} draws each leaf once: {p:?}");
            }
            assert_eq!(
                tile.children.is_empty(),
                all_final && !tile.parts.is_empty(),
                "tile {t}: {p:?}"
            );
            let mut below = Vec::new();
            for &c in &tile.children {
                assert!(c as usize > t);
                let child = &p.tiles[c as usize];
                assert!(child.error <= tile.error, "{p:?}");
                for &n in &child.nodes {
                    leaves(s, n, &mut below);
                }
            }
            below.sort_unstable();
            if !tile.children.is_empty() {
                assert_eq!(below, covered, "tile {t}'s children cover it: {p:?}");
            }
        }
        for l in s.leaves() {
            assert!(finest_drawn[l as usize], "leaf {l}'s full detail: {p:?}");
        }
    }

    #[test]
    fn one_small_scene_is_a_chain_of_bands() {
        // A root over two leaves; everything fits one content.
        let s = skeleton(&[
            (2, vec![(0.5, 40), (1.0, 10), (2.0, 2)]),
            (0, vec![(0.0, 200), (0.25, 60)]),
            (0, vec![(0.0, 100)]),
        ]);
        let p = plan(&s, 1000);
        check(&s, &p);
        let parts: Vec<Vec<u32>> = p
            .tiles
            .iter()
            .map(|t| t.parts.iter().map(|q| q.lod).collect())
            .collect();
        // The root's coarsest (2 triangles), then full detail (300): the
        // bands of 10 and 40 are under a quarter of the target, and the
        // 0.25 band, 160, is over half of full detail.
        assert_eq!(parts, [vec![2], vec![3, 5]]);
        let errors: Vec<f64> = p.tiles.iter().map(|t| t.error).collect();
        assert_eq!(errors, [2.0, 0.0]);
        assert_eq!(p.levels_left_out, 3);
        // A smaller target keeps the bands.
        let p = plan(&s, 40);
        check(&s, &p);
        let parts: Vec<Vec<u32>> = p
            .tiles
            .iter()
            .map(|t| t.parts.iter().map(|q| q.lod).collect())
            .collect();
        assert_eq!(parts, [vec![2], vec![1], vec![0], vec![3], vec![5]]);
    }

    #[test]
    fn contents_are_cut_to_the_target() {
        // A root over four leaves of 100 triangles at full detail.
        let leaf = || (0, vec![(0.0, 100), (1.0, 20)]);
        let s = skeleton(&[(4, vec![(4.0, 30)]), leaf(), leaf(), leaf(), leaf()]);
        let p = plan(&s, 200);
        check(&s, &p);
        // Root (30), the leaves' coarse levels (80: one content), then
        // their full detail in two contents of 200.
        let sizes: Vec<u64> = p
            .tiles
            .iter()
            .map(|t| {
                t.parts
                    .iter()
                    .map(|q| s.lods()[q.lod as usize].triangles as u64)
                    .sum()
            })
            .collect();
        assert_eq!(sizes, [30, 80, 200, 200]);
        assert_eq!(p.tiles[1].children, [2, 3]);
        assert_eq!(p.tiles[2].nodes, [1, 2]);
    }

    #[test]
    fn a_root_without_levels_is_an_empty_tile_over_its_children() {
        let s = skeleton(&[
            (2, vec![]),
            (0, vec![(0.0, 10), (2.0, 1)]),
            (0, vec![(0.0, 10)]),
        ]);
        let p = plan(&s, 1000);
        check(&s, &p);
        assert!(p.tiles[0].parts.is_empty());
        // At least the diagonal of the unit cube and the children's errors.
        assert_eq!(p.tiles[0].error, 2.0);
        assert_eq!(p.tiles[0].children, [1]);
    }

    #[test]
    fn child_levels_coarser_than_the_parent_raise_no_error() {
        // The leaf's coarse level (3.0) is coarser than the root's finest.
        let s = skeleton(&[
            (1, vec![(0.5, 4), (1.0, 2)]),
            (0, vec![(0.0, 100), (0.25, 20), (3.0, 1)]),
        ]);
        let p = plan(&s, 1000);
        check(&s, &p);
        assert!(p.tiles.iter().all(|t| t.parts.iter().all(|q| q.lod != 4)));
    }

    #[test]
    fn generated_hierarchies_keep_every_rule() {
        // Deterministic pseudo-random trees: errors double per level and
        // an inner node's finest is at least its children's coarsest
        // finest, as preprocessing makes them.
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = |m: u32| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % m as u64) as u32
        };
        for _ in 0..30 {
            // Breadth first: the root, then levels of up to 3 children.
            let mut spec: Vec<(u32, Levels)> = Vec::new();
            let mut depth = vec![0u32];
            let mut i = 0;
            while i < depth.len() {
                let children = if depth[i] < 3 && depth.len() < 40 {
                    next(4)
                } else {
                    0
                };
                for _ in 0..children {
                    depth.push(depth[i] + 1);
                }
                spec.push((children, Vec::new()));
                i += 1;
            }
            // Levels: leaves from 0, inner nodes above their deepest leaf.
            for i in (0..spec.len()).rev() {
                let lo = if spec[i].0 == 0 {
                    0.0
                } else {
                    2f32.powi(4 - depth[i] as i32)
                };
                let count = 1 + next(4);
                let mut tri = 50 + next(400);
                let mut levels = Vec::new();
                for k in 0..count {
                    let e = if k == 0 {
                        lo
                    } else {
                        lo.max(0.1) * 2f32.powi(k as i32)
                    };
                    levels.push((e, tri.max(1)));
                    tri /= 3;
                }
                if spec[i].0 > 0 && next(3) == 0 {
                    levels.clear();
                }
                spec[i].1 = levels;
            }
            let s = skeleton(&spec);
            for target in [1, 100, 300, 100_000] {
                check(&s, &plan(&s, target));
            }
        }
    }

    #[test]
    fn files_hold_at_most_their_tiles_and_depth() {
        let leaf = || (0, vec![(0.0, 100), (1.0, 20)]);
        let s = skeleton(&[(4, vec![(4.0, 30)]), leaf(), leaf(), leaf(), leaf()]);
        let p = plan(&s, 200);
        // Tiles: 0 -> 1 -> (2, 3).
        let f = files(&p, 3, 100);
        assert_eq!(f.roots, [0, 3]);
        let f = files(&p, 100, 2);
        assert_eq!(f.roots, [0, 2, 3]);
        let f = files(&p, 100, 100);
        assert_eq!(f.roots, [0]);
    }
}
