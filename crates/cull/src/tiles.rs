//! Tiled displays (Nirnimesh, Harish and Narayanan, "Culling an Object
//! Hierarchy to a Frustum Hierarchy"): one eye, a viewport split into
//! `cols x rows` tiles, each its own off-axis frustum. Traversal decides
//! occlusion and LODs once for the whole view; this module then sends each
//! drawn item to the tiles it may cover.
//!
//! Ways of doing that, all conservative (a tile's list holds every item
//! whose box meets its frustum):
//! - **naive**: every item against every tile's frustum (O(n m));
//! - **object hierarchy only** ("OH without FH"): for each tile, the
//!   hierarchy of the drawn items (their ancestors in the scene's tree)
//!   culled against its frustum, a subtree wholly inside taken without
//!   more tests;
//! - **frustum hierarchy only** ("FH without OH"): every item down a binary
//!   tree of the tiles, split by planes through the eye along tile
//!   boundaries; an item on one side of a plane skips the other half;
//! - **adaptive** (the paper's Algorithm 2 with its Section 4.2 rules): the
//!   two hierarchies together: an object node on one side of a frustum
//!   node's plane goes down the frustum hierarchy whole; one the plane cuts
//!   is opened into its children (L, C, R), a drawn item the plane cuts
//!   goes to both sides; at a tile, everything below the node is in it.
//!   One change: a child in C is opened again at the same plane, where the
//!   paper's lines 7-8 send it whole to both halves (so at the last split
//!   a cut group of items lands in both tiles though each item lies on
//!   one side). With it a tile's list is exactly per-tile frustum culling's
//!   for boxes in front of the eye, as the tests check;
//! - **binning**: each item's conservative screen rectangle against the
//!   tile grid (a baseline the paper did not compare).
//!
//! Planes through the eye separate the tiles only in front of it: behind
//! the eye their sides swap. So the hierarchical methods may leave a tile
//! out for a box reaching behind the eye that the tile's own frustum
//! (naive) keeps, but never a box that meets the tile's frustum.

use gigawalk_scene::Skeleton;
use glam::{DMat4, DVec3, DVec4};

use crate::{BoxProjection, CullView, DrawItem, Frustum, ALL_PLANES};

/// A tile grid: `cols` across, `rows` down.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct TileGrid {
    pub cols: u32,
    pub rows: u32,
}

impl TileGrid {
    pub fn count(&self) -> usize {
        self.cols as usize * self.rows as usize
    }

    /// Tile `t`'s pixel rectangle `[x, y, w, h]` (rows from the top) in a
    /// `width x height` viewport: the pixels are shared out as evenly as
    /// whole pixels allow. Tile t is column `t % cols`, row `t / cols`.
    pub fn rect(&self, t: usize, width: u32, height: u32) -> [u32; 4] {
        let (c, r) = (t as u64 % self.cols as u64, t as u64 / self.cols as u64);
        let edge = |i: u64, n: u64, size: u32| (i * size as u64 / n) as u32;
        let (x0, x1) = (
            edge(c, self.cols as u64, width),
            edge(c + 1, self.cols as u64, width),
        );
        let (y0, y1) = (
            edge(r, self.rows as u64, height),
            edge(r + 1, self.rows as u64, height),
        );
        [x0, y0, x1 - x0, y1 - y0]
    }
}

impl std::fmt::Display for TileGrid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{}", self.cols, self.rows)
    }
}

impl std::str::FromStr for TileGrid {
    type Err = String;

    /// `"MxN"`: M columns, N rows, each 1..=64.
    fn from_str(s: &str) -> Result<Self, String> {
        let (a, b) = s
            .split_once(['x', 'X'])
            .ok_or_else(|| format!("tiles {s:?}: expected COLSxROWS, e.g. 4x4"))?;
        let n = |v: &str| -> Result<u32, String> {
            match v.trim().parse::<u32>() {
                Ok(n) if (1..=64).contains(&n) => Ok(n),
                _ => Err(format!("tiles {s:?}: {v:?} is not a count from 1 to 64")),
            }
        };
        Ok(TileGrid {
            cols: n(a)?,
            rows: n(b)?,
        })
    }
}

/// The four side planes and the near plane of the camera-relative frustum
/// of NDC rectangle `[x0, x1] x [y0, y1]` of `view_proj`.
fn sub_frustum(view_proj: &DMat4, x0: f64, x1: f64, y0: f64, y1: f64) -> Frustum {
    let (r0, r1, r3) = (view_proj.row(0), view_proj.row(1), view_proj.row(3));
    // Clip x' = (2 x - (x0 + x1) w) / (x1 - x0) maps [x0, x1] to [-1, 1].
    let x = (r0 * 2.0 - r3 * (x0 + x1)) / (x1 - x0);
    let y = (r1 * 2.0 - r3 * (y0 + y1)) / (y1 - y0);
    let m = DMat4::from_cols(x, y, view_proj.row(2), r3).transpose();
    Frustum::from_view_projection(&m)
}

/// A plane through the eye (camera-relative): `n . p >= 0` is its positive
/// side.
#[derive(Clone, Copy, Debug)]
struct Bisector {
    n: DVec3,
}

/// Which side of a plane a box is on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Side {
    Neg,
    Pos,
    Cut,
}

/// Relative slack, as in [`Frustum::test`]: a box touching the plane cuts it.
const SIDE_SLACK: f64 = 1e-9;

impl Bisector {
    /// The plane through the eye along NDC `x = at` (`axis` 0) or `y = at`
    /// (`axis` 1), positive where the NDC coordinate is larger.
    fn new(view_proj: &DMat4, axis: usize, at: f64) -> Self {
        let p: DVec4 = view_proj.row(axis) - view_proj.row(3) * at;
        Bisector {
            n: p.truncate().normalize_or_zero(),
        }
    }

    fn side(&self, min: DVec3, max: DVec3) -> Side {
        let c = (min + max) * 0.5;
        let e = (max - min) * 0.5;
        let s = self.n.dot(c);
        let r = self.n.abs().dot(e);
        let slack = SIDE_SLACK * (self.n.abs().dot(c.abs()) + r);
        if s + r < -slack {
            Side::Neg
        } else if s - r > slack {
            Side::Pos
        } else {
            Side::Cut
        }
    }
}

/// A node of the frustum hierarchy: a block of tiles.
#[derive(Clone, Copy, Debug)]
enum FhNode {
    /// Tiles on the negative side of `plane` go to `first`, the rest to
    /// `first + 1`.
    Split {
        plane: Bisector,
        first: u32,
    },
    Tile(u32),
}

/// One frame's tiles: their frustums, their hierarchy and rectangles.
#[derive(Clone, Debug)]
pub struct TileFrustums {
    pub grid: TileGrid,
    /// Per tile, its frustum (camera-relative, like [`CullView::frustum`]).
    pub frustums: Vec<Frustum>,
    /// NDC rectangles `[x0, y0, x1, y1]` (y up) per tile.
    ndc: Vec<[f64; 4]>,
    fh: Vec<FhNode>,
}

impl TileFrustums {
    pub fn new(view: &CullView, grid: TileGrid) -> Self {
        let vp = view.camera.view_projection_rel_f64();
        let (w, h) = (view.viewport.width, view.viewport.height);
        let ndc: Vec<[f64; 4]> = (0..grid.count())
            .map(|t| {
                let [x, y, tw, th] = grid.rect(t, w, h);
                let nx = |px: u32| 2.0 * px as f64 / w as f64 - 1.0;
                let ny = |py: u32| 1.0 - 2.0 * py as f64 / h as f64;
                [nx(x), ny(y + th), nx(x + tw), ny(y)]
            })
            .collect();
        let frustums = ndc
            .iter()
            .map(|&[x0, y0, x1, y1]| sub_frustum(&vp, x0, x1, y0, y1))
            .collect();
        // The hierarchy: split the longer side of a block of tiles (in
        // tiles) at its middle, breadth-first so children are adjacent.
        let mut fh = vec![FhNode::Tile(0)];
        let mut work = vec![(0usize, 0u32, grid.cols, 0u32, grid.rows)];
        while let Some((at, c0, c1, r0, r1)) = work.pop() {
            if c1 - c0 == 1 && r1 - r0 == 1 {
                fh[at] = FhNode::Tile(r0 * grid.cols + c0);
                continue;
            }
            let first = fh.len();
            fh.extend([FhNode::Tile(0), FhNode::Tile(0)]);
            let plane = if c1 - c0 >= r1 - r0 {
                let m = (c0 + c1) / 2;
                // Column m's left edge: x grows to the right.
                let [x, ..] = grid.rect(m as usize, w, h);
                work.push((first, c0, m, r0, r1));
                work.push((first + 1, m, c1, r0, r1));
                Bisector::new(&vp, 0, 2.0 * x as f64 / w as f64 - 1.0)
            } else {
                let m = (r0 + r1) / 2;
                // Row m's top edge: NDC y grows upward, so rows below m
                // (larger r) are on the negative side.
                let [_, y, ..] = grid.rect((m * grid.cols) as usize, w, h);
                work.push((first + 1, c0, c1, r0, m));
                work.push((first, c0, c1, m, r1));
                Bisector::new(&vp, 1, 1.0 - 2.0 * y as f64 / h as f64)
            };
            fh[at] = FhNode::Split {
                plane,
                first: first as u32,
            };
        }
        TileFrustums {
            grid,
            frustums,
            ndc,
            fh,
        }
    }
}

/// How items are sent to tiles.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TileMethod {
    Naive,
    ObjectHierarchy,
    FrustumHierarchy,
    Adaptive,
    Binning,
}

impl TileMethod {
    pub const ALL: [TileMethod; 5] = [
        TileMethod::Naive,
        TileMethod::ObjectHierarchy,
        TileMethod::FrustumHierarchy,
        TileMethod::Adaptive,
        TileMethod::Binning,
    ];

    pub fn name(self) -> &'static str {
        match self {
            TileMethod::Naive => "naive",
            TileMethod::ObjectHierarchy => "object-hierarchy",
            TileMethod::FrustumHierarchy => "frustum-hierarchy",
            TileMethod::Adaptive => "adaptive",
            TileMethod::Binning => "binning",
        }
    }
}

impl std::str::FromStr for TileMethod {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        TileMethod::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                format!(
                    "tile culling {s:?} is not one of {}",
                    TileMethod::ALL.map(|m| m.name()).join(", ")
                )
            })
    }
}

/// Per tile, the indices (into the frame's items) of what it draws, in
/// the items' order; and how many box tests it took.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TileLists {
    pub lists: Vec<Vec<u32>>,
    pub tests: u64,
}

/// The drawn items' part of the scene's tree: each node that is an item or
/// has one below it. The items are numbered in depth-first order of that
/// tree, so the items below a node are one range of `order`.
struct ItemTree {
    /// Per skeleton node: the range of `order` below it (empty when the
    /// node is not on the tree).
    range: Vec<(u32, u32)>,
    /// Per skeleton node: the item index when drawn, else u32::MAX.
    item: Vec<u32>,
    /// Item indices in depth-first order.
    order: Vec<u32>,
}

impl ItemTree {
    fn new(skeleton: &Skeleton, items: &[DrawItem]) -> Self {
        let n = skeleton.nodes().len();
        let mut item = vec![u32::MAX; n];
        let mut on = vec![false; n];
        for (i, it) in items.iter().enumerate() {
            let Some(slot) = item.get_mut(it.node as usize) else {
                continue;
            };
            *slot = i as u32;
            let mut at = it.node;
            while (at as usize) < n && !on[at as usize] {
                on[at as usize] = true;
                at = skeleton.nodes()[at as usize].parent;
            }
        }
        let mut range = vec![(0u32, 0u32); n];
        let mut order = Vec::with_capacity(items.len());
        if n > 0 && on[0] {
            // Depth-first; a node's range closes when its subtree is done.
            let mut stack = vec![(0u32, false)];
            while let Some((at, done)) = stack.pop() {
                if done {
                    range[at as usize].1 = order.len() as u32;
                    continue;
                }
                range[at as usize].0 = order.len() as u32;
                if item[at as usize] != u32::MAX {
                    order.push(item[at as usize]);
                }
                stack.push((at, true));
                let nd = &skeleton.nodes()[at as usize];
                for c in (nd.first_child..nd.first_child + nd.child_count).rev() {
                    if on.get(c as usize) == Some(&true) {
                        stack.push((c, false));
                    }
                }
            }
        }
        ItemTree { range, item, order }
    }

    fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    fn on(&self, node: u32) -> bool {
        let (a, b) = self.range[node as usize];
        b > a
    }

    fn children<'s>(&'s self, skeleton: &'s Skeleton, node: u32) -> impl Iterator<Item = u32> + 's {
        let n = &skeleton.nodes()[node as usize];
        (n.first_child..n.first_child + n.child_count).filter(|&c| self.on(c))
    }

    /// Every item at or below `node`.
    fn below(&self, node: u32) -> &[u32] {
        let (a, b) = self.range[node as usize];
        &self.order[a as usize..b as usize]
    }
}

/// Sends `items` (drawn for `view`) to the tiles of `tiles` by `method`.
pub fn assign(
    skeleton: &Skeleton,
    view: &CullView,
    tiles: &TileFrustums,
    items: &[DrawItem],
    method: TileMethod,
) -> TileLists {
    let m = tiles.grid.count();
    let mut lists = vec![Vec::new(); m];
    let mut tests = 0u64;
    let rel = |node: u32| view.rel_f64(&skeleton.nodes()[node as usize].bounds);
    match method {
        TileMethod::Naive => {
            for (i, it) in items.iter().enumerate() {
                let (lo, hi) = rel(it.node);
                for (t, f) in tiles.frustums.iter().enumerate() {
                    tests += 1;
                    if f.test(lo, hi, ALL_PLANES).0 != crate::Containment::Outside {
                        lists[t].push(i as u32);
                    }
                }
            }
        }
        TileMethod::FrustumHierarchy => {
            let mut stack = Vec::new();
            for (i, it) in items.iter().enumerate() {
                let (lo, hi) = rel(it.node);
                stack.push(0u32);
                while let Some(at) = stack.pop() {
                    match tiles.fh[at as usize] {
                        FhNode::Tile(t) => lists[t as usize].push(i as u32),
                        FhNode::Split { plane, first } => {
                            tests += 1;
                            match plane.side(lo, hi) {
                                Side::Neg => stack.push(first),
                                Side::Pos => stack.push(first + 1),
                                Side::Cut => stack.extend([first + 1, first]),
                            }
                        }
                    }
                }
            }
        }
        TileMethod::ObjectHierarchy => {
            let tree = ItemTree::new(skeleton, items);
            if !tree.is_empty() {
                for (t, f) in tiles.frustums.iter().enumerate() {
                    let mut stack = vec![(0u32, ALL_PLANES)];
                    while let Some((at, mask)) = stack.pop() {
                        let (lo, hi) = rel(at);
                        tests += 1;
                        let (c, mask) = f.test(lo, hi, mask);
                        match c {
                            crate::Containment::Outside => {}
                            crate::Containment::Inside => {
                                lists[t].extend_from_slice(tree.below(at))
                            }
                            crate::Containment::Intersecting => {
                                let i = tree.item[at as usize];
                                if i != u32::MAX {
                                    lists[t].push(i);
                                }
                                stack.extend(tree.children(skeleton, at).map(|c| (c, mask)));
                            }
                        }
                    }
                }
            }
        }
        TileMethod::Adaptive => {
            let tree = ItemTree::new(skeleton, items);
            if !tree.is_empty() {
                // (object node, frustum node, whether the node is already
                // known to cut that frustum node's plane).
                let mut stack = vec![(0u32, 0u32, false)];
                while let Some((oh, fh, known_cut)) = stack.pop() {
                    let (plane, first) = match tiles.fh[fh as usize] {
                        FhNode::Tile(t) => {
                            lists[t as usize].extend_from_slice(tree.below(oh));
                            continue;
                        }
                        FhNode::Split { plane, first } => (plane, first),
                    };
                    let side = if known_cut {
                        Side::Cut
                    } else {
                        tests += 1;
                        let (lo, hi) = rel(oh);
                        plane.side(lo, hi)
                    };
                    match side {
                        // Not cut: down the frustum hierarchy whole.
                        Side::Neg => stack.push((oh, first, false)),
                        Side::Pos => stack.push((oh, first + 1, false)),
                        // A drawn item the plane cuts: both sides.
                        Side::Cut if tree.item[oh as usize] != u32::MAX => {
                            stack.extend([(oh, first + 1, false), (oh, first, false)]);
                        }
                        // Cut: open the node into L, C and R; L and R go
                        // down, C is opened again at this plane.
                        Side::Cut => {
                            for c in tree.children(skeleton, oh) {
                                let (lo, hi) = rel(c);
                                tests += 1;
                                match plane.side(lo, hi) {
                                    Side::Neg => stack.push((c, first, false)),
                                    Side::Pos => stack.push((c, first + 1, false)),
                                    Side::Cut => stack.push((c, fh, true)),
                                }
                            }
                        }
                    }
                }
            }
        }
        TileMethod::Binning => {
            let (cols, rows) = (tiles.grid.cols as usize, tiles.grid.rows as usize);
            // Tile column / row edges in NDC.
            let xs: Vec<f64> = (0..cols).map(|c| tiles.ndc[c][0]).collect();
            let ys: Vec<f64> = (0..rows).map(|r| tiles.ndc[r * cols][3]).collect();
            for (i, it) in items.iter().enumerate() {
                tests += 1;
                let b = view.rel_box(&skeleton.nodes()[it.node as usize].bounds);
                let (c0, c1, r0, r1) = match view.project_box(&b) {
                    BoxProjection::CrossesNear => (0, cols - 1, 0, rows - 1),
                    BoxProjection::Screen {
                        ndc_min, ndc_max, ..
                    } => {
                        // Columns whose left edge is left of the box's right,
                        // from the last whose left edge is left of its left.
                        let col = |x: f64| xs.iter().rposition(|&e| e <= x).unwrap_or(0);
                        // Rows (top down) whose top edge is above the box's
                        // bottom, from the last whose top is above its top.
                        let row = |y: f64| ys.iter().rposition(|&e| e >= y).unwrap_or(0);
                        let (x0, x1) = (ndc_min[0] as f64, ndc_max[0] as f64);
                        let (y0, y1) = (ndc_min[1] as f64, ndc_max[1] as f64);
                        if x1 < -1.0 || x0 > 1.0 || y1 < -1.0 || y0 > 1.0 {
                            continue;
                        }
                        (col(x0), col(x1), row(y1), row(y0))
                    }
                };
                for r in r0..=r1 {
                    for c in c0..=c1 {
                        lists[r * cols + c].push(i as u32);
                    }
                }
            }
        }
    }
    for l in &mut lists {
        l.sort_unstable();
        l.dedup();
    }
    TileLists { lists, tests }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::Lcg;
    use crate::{Camera, Containment, Viewport};
    use gigawalk_scene::{Aabb, NO_NODE};

    /// A random tree: 4-ary over `n` random boxes around the origin, each
    /// node with one LOD; returns the skeleton and its leaves.
    fn scene(rng: &mut Lcg, n: usize, spread: f64) -> Skeleton {
        let leaves: Vec<Aabb> = (0..n)
            .map(|_| {
                let c = rng.vec(spread);
                let e = DVec3::new(
                    rng.range(0.05, 3.0),
                    rng.range(0.05, 3.0),
                    rng.range(0.05, 3.0),
                );
                Aabb::new(c - e, c + e)
            })
            .collect();
        crate::test_rng::tree(&leaves, 4)
    }

    /// Whether some sampled point of the box lies strictly inside the NDC
    /// rectangle `r` of the view, in front of the near plane.
    fn meets(view: &CullView, b: &Aabb, r: [f64; 4]) -> bool {
        let vp = view.camera.view_projection_rel_f64();
        let n = 6;
        for i in 0..=n {
            for j in 0..=n {
                for k in 0..=n {
                    let t = DVec3::new(i as f64, j as f64, k as f64) / n as f64;
                    let p = b.min + (b.max - b.min) * t - view.camera.position;
                    let c = vp * p.extend(1.0);
                    if c.w <= view.camera.near {
                        continue;
                    }
                    let (x, y) = (c.x / c.w, c.y / c.w);
                    let e = 1e-9;
                    if x > r[0] + e && x < r[2] - e && y > r[1] + e && y < r[3] - e {
                        return true;
                    }
                }
            }
        }
        false
    }

    #[test]
    fn every_method_keeps_what_meets_a_tile_and_the_hierarchies_equal_naive_in_front() {
        let mut rng = Lcg(17);
        let grids = [(1, 1), (2, 2), (3, 2), (4, 4), (5, 3), (16, 16)];
        for case in 0..24 {
            let sk = scene(&mut rng, 300, 40.0);
            let eye = rng.vec(30.0);
            let target = eye + rng.vec(1.0);
            let cam = Camera::look_at(eye, target, rng.range(0.5, 1.8), rng.range(0.6, 2.0), 0.5);
            let view = CullView::new(cam, Viewport::new(97 + case * 13, 61 + case * 7));
            // Every leaf is an item (as traversal at full detail would
            // draw, frustum culling aside); some cases draw inner nodes.
            let items: Vec<DrawItem> = sk
                .nodes()
                .iter()
                .enumerate()
                .filter(|(i, n)| {
                    if case % 3 == 0 {
                        n.parent != NO_NODE && sk.nodes()[n.parent as usize].parent == NO_NODE
                    } else {
                        n.child_count == 0 && *i > 0
                    }
                })
                .map(|(i, _)| DrawItem {
                    node: i as u32,
                    lod: i as u32,
                })
                // What traversal would emit: in the view's frustum.
                .filter(|it| {
                    let (lo, hi) = view.rel_f64(&sk.nodes()[it.node as usize].bounds);
                    view.frustum.test(lo, hi, ALL_PLANES).0 != Containment::Outside
                })
                .collect();
            for &(c, r) in &grids {
                let grid = TileGrid { cols: c, rows: r };
                let tiles = TileFrustums::new(&view, grid);
                let got: Vec<TileLists> = TileMethod::ALL
                    .iter()
                    .map(|&m| assign(&sk, &view, &tiles, &items, m))
                    .collect();
                let naive = &got[0].lists;
                for (t, naive_t) in naive.iter().enumerate() {
                    for (i, it) in items.iter().enumerate() {
                        let b = sk.nodes()[it.node as usize].bounds;
                        let i = i as u32;
                        let exact = meets(&view, &b, tiles.ndc[t]);
                        let (lo, hi) = view.rel_f64(&b);
                        let in_front = (0..8).all(|k| {
                            let p = DVec3::new(
                                if k & 1 == 0 { lo.x } else { hi.x },
                                if k & 2 == 0 { lo.y } else { hi.y },
                                if k & 4 == 0 { lo.z } else { hi.z },
                            );
                            p.dot(view.camera.forward()) > 0.0
                        });
                        for (m, l) in TileMethod::ALL.iter().zip(&got) {
                            let has = l.lists[t].binary_search(&i).is_ok();
                            assert!(
                                has || !exact,
                                "{} left out item {i} meeting tile {t} of {grid} (case {case})",
                                m.name()
                            );
                            if matches!(
                                m,
                                TileMethod::ObjectHierarchy
                                    | TileMethod::FrustumHierarchy
                                    | TileMethod::Adaptive
                            ) {
                                let naive_has = naive_t.binary_search(&i).is_ok();

                                assert!(
                                    !has || naive_has,
                                    "{} kept item {i} (node {}) in tile {t} of {grid}, naive did not (case {case}, in front {in_front}, fh {})",
                                    m.name(),
                                    it.node,
                                    got[2].lists[t].binary_search(&i).is_ok()
                                );

                                if in_front && *m != TileMethod::ObjectHierarchy {
                                    assert_eq!(
                                        has,
                                        naive_has,
                                        "{} in front (case {case})",
                                        m.name()
                                    );
                                }
                            }
                        }
                    }
                }
                // The object hierarchy tests the same frustums as naive.
                assert_eq!(got[1].lists, got[0].lists);
            }
        }
    }

    #[test]
    fn a_frustum_from_the_view_projection_is_the_camera_frustum() {
        let mut rng = Lcg(3);
        for _ in 0..50 {
            let cam = Camera::look_at(
                rng.vec(1e7),
                rng.vec(1e7),
                rng.range(0.3, 2.5),
                rng.range(0.3, 3.0),
                rng.range(0.01, 10.0),
            );
            let a = Frustum::new(&cam);
            let b = Frustum::from_view_projection(&cam.view_projection_rel_f64());
            for _ in 0..200 {
                let c = rng.vec(50.0);
                let e = DVec3::new(
                    rng.range(0.0, 5.0),
                    rng.range(0.0, 5.0),
                    rng.range(0.0, 5.0),
                );
                let (ta, _) = a.test(c - e, c + e, ALL_PLANES);
                let (tb, _) = b.test(c - e, c + e, ALL_PLANES);
                if ta != tb {
                    // Only boxes touching a plane within rounding may differ.
                    assert!(
                        a.test(c - e * 1.001, c + e * 1.001, ALL_PLANES).0 != Containment::Outside
                            && a.test(c - e * 0.999, c + e * 0.999, ALL_PLANES).0
                                != Containment::Inside,
                        "{ta:?} vs {tb:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn tile_rectangles_cover_the_viewport_once_and_grids_parse() {
        for (c, r, w, h) in [
            (3, 2, 100, 50),
            (16, 16, 641, 359),
            (1, 1, 7, 9),
            (5, 7, 5, 7),
        ] {
            let g = TileGrid { cols: c, rows: r };
            let mut hit = vec![0u8; (w * h) as usize];
            for t in 0..g.count() {
                let [x, y, tw, th] = g.rect(t, w, h);
                for yy in y..y + th {
                    for xx in x..x + tw {
                        hit[(yy * w + xx) as usize] += 1;
                    }
                }
            }
            assert!(hit.iter().all(|&k| k == 1));
        }
        assert_eq!(
            "4x3".parse::<TileGrid>().unwrap(),
            TileGrid { cols: 4, rows: 3 }
        );
        assert_eq!("4x3".parse::<TileGrid>().unwrap().to_string(), "4x3");
        for bad in ["4", "0x2", "65x1", "ax2", "", "3x"] {
            assert!(bad.parse::<TileGrid>().is_err(), "{bad}");
        }
    }
}
