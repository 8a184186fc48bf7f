//! The lazy occlusion grid (Hey, Tobler and Purgathofer, "Real-Time
//! Occlusion Culling With a Lazy Occlusion Grid", the z-buffer variant of
//! their Fig. 3): a grid of cells over a software depth image that STC
//! fills with what it draws, front to back, in the frame it traverses.
//!
//! Each cell keeps the farthest depth of its pixels and an out-of-date
//! flag. Drawing marks the cells under the drawn item out of date; a box
//! test reads a stale cell's old value first (depth only ever comes
//! nearer, so the old farthest depth is never nearer than the new one: if
//! it hides the box, so would the fresh one) and refreshes the cell only
//! when the old value would say "visible". A cell the box covers only
//! partly is decided by the box's own pixels when its value does not hide
//! the box. So a footprint test hides a box exactly when every pixel of
//! its footprint is farther than its nearest depth: the grid answers the
//! brute-force scan, with far fewer pixel reads. A box that does not hide
//! as a whole is split in halves as the HZB test does
//! ([`crate::HzbOcclusion`]), and hides when they do. The eager variant
//! refreshes cells as they are drawn over (same answers; the paper's
//! comparison of the two is in pixel reads).

use std::time::Instant;

use gigawalk_scene::Skeleton;
use glam::{DMat4, DVec3};

use crate::occlusion::{hides_split, occludes, RectTest, SPLITS};
use crate::raster::{PixelRect, SoftDepth};
use crate::{CullView, Culler, DrawItem, RelBox, Verdict};

/// Default cell size in pixels (the paper's).
pub const DEFAULT_GRID_CELL: u32 = 32;

/// What the grid did in a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GridStats {
    /// Footprint tests answered (a box split in halves asks one per part
    /// tested).
    pub tests: u64,
    /// Depth pixels read: refreshing cells and scanning partly covered ones.
    pub pixel_reads: u64,
    /// Cells recomputed from their pixels.
    pub refreshes: u64,
    /// Items rasterized into the software depth, and their triangles.
    pub items_drawn: u64,
    pub triangles_drawn: u64,
    /// Items not rasterized (over the triangle budget, or no triangles to
    /// hand): they occlude nothing, which is conservative.
    pub items_skipped: u64,
    /// Milliseconds rasterizing, and answering box tests.
    pub raster_ms: f64,
    pub test_ms: f64,
}

/// A software depth image and the occlusion grid over it.
#[derive(Clone, Debug)]
pub struct OcclusionGrid {
    cell: u32,
    lazy: bool,
    depth: SoftDepth,
    cols: u32,
    rows: u32,
    /// Farthest depth of each cell's pixels (as of its last refresh).
    far: Vec<f32>,
    stale: Vec<bool>,
    pub stats: GridStats,
}

impl OcclusionGrid {
    /// Cells of `cell x cell` pixels (at least 1); `lazy` false refreshes
    /// cells as they are drawn over.
    pub fn new(cell: u32, lazy: bool) -> Self {
        OcclusionGrid {
            cell: cell.max(1),
            lazy,
            depth: SoftDepth::new(),
            cols: 0,
            rows: 0,
            far: Vec::new(),
            stale: Vec::new(),
            stats: GridStats::default(),
        }
    }

    pub fn cell(&self) -> u32 {
        self.cell
    }

    pub fn is_lazy(&self) -> bool {
        self.lazy
    }

    /// The GPU's absolute depth error, which the software depth leaves room
    /// for ([`SoftDepth::set_absolute_slack`]).
    pub fn set_absolute_slack(&mut self, slack: f64) {
        self.depth.set_absolute_slack(slack);
    }

    /// Clears to an empty `width x height` image; zeroes the stats.
    pub fn reset(&mut self, width: u32, height: u32) {
        self.depth.reset(width, height);
        self.cols = width.div_ceil(self.cell);
        self.rows = height.div_ceil(self.cell);
        let n = self.cols as usize * self.rows as usize;
        self.far.clear();
        self.far.resize(n, 0.0);
        self.stale.clear();
        self.stale.resize(n, false);
        self.stats = GridStats::default();
    }

    pub fn depth(&self) -> &SoftDepth {
        &self.depth
    }

    /// Draws a mesh (see [`SoftDepth::draw_mesh`]) and marks the cells it
    /// wrote out of date (lazy) or refreshes them (eager).
    pub fn draw_mesh(
        &mut self,
        view_proj: &DMat4,
        rel_origin: DVec3,
        positions: &[[f32; 3]],
        indices: &[u32],
    ) {
        if let Some(r) = self
            .depth
            .draw_mesh(view_proj, rel_origin, positions, indices)
        {
            self.drawn(r);
        }
    }

    /// Pixels in `r` were drawn over.
    fn drawn(&mut self, r: PixelRect) {
        let c = self.cell;
        for cy in r.y0 / c..=r.y1 / c {
            for cx in r.x0 / c..=r.x1 / c {
                if self.lazy {
                    self.stale[(cy * self.cols + cx) as usize] = true;
                } else {
                    self.refresh(cx, cy);
                }
            }
        }
    }

    /// The pixels of cell `(cx, cy)`.
    fn cell_rect(&self, cx: u32, cy: u32) -> PixelRect {
        let c = self.cell;
        PixelRect {
            x0: cx * c,
            y0: cy * c,
            x1: ((cx + 1) * c).min(self.depth.width()) - 1,
            y1: ((cy + 1) * c).min(self.depth.height()) - 1,
        }
    }

    fn refresh(&mut self, cx: u32, cy: u32) {
        let r = self.cell_rect(cx, cy);
        let far = self.farthest(r);
        let i = (cy * self.cols + cx) as usize;
        self.far[i] = far;
        self.stale[i] = false;
        self.stats.refreshes += 1;
    }

    /// The farthest depth over `r`, counting the reads.
    fn farthest(&mut self, r: PixelRect) -> f32 {
        let (w, d) = (self.depth.width() as usize, self.depth.depth());
        let mut far = f32::INFINITY;
        for y in r.y0..=r.y1 {
            let row = &d[y as usize * w..][r.x0 as usize..=r.x1 as usize];
            far = row.iter().fold(far, |a, &b| if b < a { b } else { a });
        }
        self.stats.pixel_reads += (r.x1 - r.x0 + 1) as u64 * (r.y1 - r.y0 + 1) as u64;
        far
    }

    /// Whether every pixel of `r` (inside the image) is farther than
    /// `nearest` (by [`crate::DEPTH_SLACK`]): the box is hidden.
    pub fn hides(&mut self, r: PixelRect, nearest: f32) -> bool {
        self.stats.tests += 1;
        // Clipped to the image (an empty image hides nothing).
        let (w, h) = (self.depth.width(), self.depth.height());
        if w == 0 || h == 0 || r.x0 > r.x1 || r.y0 > r.y1 || r.x0 >= w || r.y0 >= h {
            return w > 0 && h > 0 && (r.x0 >= w || r.y0 >= h);
        }
        let r = PixelRect {
            x1: r.x1.min(w - 1),
            y1: r.y1.min(h - 1),
            ..r
        };
        let c = self.cell;
        for cy in r.y0 / c..=r.y1 / c {
            for cx in r.x0 / c..=r.x1 / c {
                let i = (cy * self.cols + cx) as usize;
                // A stale value is never nearer than the fresh one.
                if occludes(nearest, self.far[i]) {
                    continue;
                }
                if self.stale[i] {
                    self.refresh(cx, cy);
                    if occludes(nearest, self.far[i]) {
                        continue;
                    }
                }
                let cell = self.cell_rect(cx, cy);
                let part = PixelRect {
                    x0: cell.x0.max(r.x0),
                    y0: cell.y0.max(r.y0),
                    x1: cell.x1.min(r.x1),
                    y1: cell.y1.min(r.y1),
                };
                // The whole cell's farthest pixel does not hide the box;
                // a part of the cell might still.
                if part == cell || !occludes(nearest, self.farthest(part)) {
                    return false;
                }
            }
        }
        true
    }
}

/// One LOD's triangles for the software rasterizer: f32 positions as
/// offsets from `origin` (world), and triangle indices.
pub struct LodTriangles<'a> {
    pub origin: DVec3,
    pub positions: &'a [[f32; 3]],
    pub indices: &'a [u32],
}

/// Where the grid culler gets the triangles of the LODs it rasterizes
/// (by the LOD's index in `Skeleton::lods`). `None`: not at hand (it is
/// then not drawn into the grid, which only makes culling weaker).
pub trait TriangleSource {
    fn lod_triangles(&mut self, lod: u32) -> Option<LodTriangles<'_>>;
}

/// The lazy occlusion grid as a [`Culler`]: every emitted item is
/// rasterized (nearest first, as traversal emits them, up to a triangle
/// budget a frame) before the next node is tested.
pub struct GridCuller<'a> {
    pub grid: &'a mut OcclusionGrid,
    skeleton: &'a Skeleton,
    source: &'a mut dyn TriangleSource,
    budget: u64,
    used: u64,
    view_proj: DMat4,
    eye: DVec3,
}

impl<'a> GridCuller<'a> {
    /// `budget`: triangles rasterized a frame at most (u64::MAX: all).
    pub fn new(
        grid: &'a mut OcclusionGrid,
        skeleton: &'a Skeleton,
        source: &'a mut dyn TriangleSource,
        budget: u64,
    ) -> Self {
        GridCuller {
            grid,
            skeleton,
            source,
            budget,
            used: 0,
            view_proj: DMat4::IDENTITY,
            eye: DVec3::ZERO,
        }
    }
}

impl Culler for GridCuller<'_> {
    type Ctx = ();

    fn begin(&mut self, view: &CullView) {
        self.grid.reset(view.viewport.width, view.viewport.height);
        self.view_proj = view.camera.view_projection_rel_f64();
        self.eye = view.camera.position;
        self.used = 0;
    }

    fn test(&mut self, view: &CullView, _: u32, b: &RelBox, _: &()) -> (Verdict, ()) {
        let t = Instant::now();
        let (w, h) = (self.grid.depth.width(), self.grid.depth.height());
        let grid = &mut *self.grid;
        let hidden = hides_split(view, b, w, h, SPLITS, &mut |rect, nearest| {
            RectTest::from_hides(grid.hides(rect, nearest))
        });
        self.grid.stats.test_ms += t.elapsed().as_secs_f64() * 1e3;
        let v = if hidden {
            Verdict::Occluded
        } else {
            Verdict::Visible
        };
        (v, ())
    }

    fn drawn(&mut self, view: &CullView, item: DrawItem) {
        let t = Instant::now();
        // Traversal's items name the skeleton's own nodes and LODs.
        let lod = self.skeleton.node(item.node).first_lod + item.lod;
        // A leaf drawn in pieces (some of its objects hidden) is no
        // occluder: culling only less, never by a hidden object.
        if view.visibility().is_some_and(|v| v.pieces(lod).is_some()) {
            self.grid.stats.items_skipped += 1;
            return;
        }
        // Nor is an item the section cuts: its removed part must not
        // hide what the cut reveals (one wholly kept occludes whole).
        if view.section().is_some() {
            let (min, max) = view.rel_f64(&self.skeleton.node(item.node).bounds);
            if view.section_side(min, max) != crate::BoxSide::Kept {
                self.grid.stats.items_skipped += 1;
                return;
            }
        }
        let tris = self.skeleton.lod(lod).triangles as u64;
        let mesh = (self.used.saturating_add(tris) <= self.budget)
            .then(|| self.source.lod_triangles(lod))
            .flatten();
        match mesh {
            Some(m) => {
                self.used += tris;
                self.grid.stats.items_drawn += 1;
                self.grid.stats.triangles_drawn += (m.indices.len() / 3) as u64;
                self.grid
                    .draw_mesh(&self.view_proj, m.origin - self.eye, m.positions, m.indices);
            }
            None => self.grid.stats.items_skipped += 1,
        }
        self.grid.stats.raster_ms += t.elapsed().as_secs_f64() * 1e3;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The brute-force answer: every pixel of `r` hides the box.
    fn brute(d: &SoftDepth, r: PixelRect, nearest: f32) -> bool {
        (r.y0..=r.y1).all(|y| (r.x0..=r.x1).all(|x| occludes(nearest, d.get(x, y))))
    }

    /// A tiny deterministic generator (no dependency for a unit test).
    use crate::test_rng::Lcg;

    fn proj() -> DMat4 {
        crate::Camera::look_at(DVec3::ZERO, DVec3::NEG_Z, 90f64.to_radians(), 1.0, 0.5)
            .view_projection_rel_f64()
    }

    #[test]
    fn lazy_and_eager_grids_answer_the_brute_force_scan_exactly() {
        let mut rng = Lcg(7);
        for case in 0..60 {
            let (w, h) = (1 + rng.upto(97), 1 + rng.upto(61));
            let cell = [1, 3, 8, 32, 64][case % 5];
            let mut lazy = OcclusionGrid::new(cell, true);
            let mut eager = OcclusionGrid::new(cell, false);
            lazy.reset(w, h);
            eager.reset(w, h);
            for _ in 0..40 {
                if rng.upto(3) == 0 {
                    // Draw a random quad somewhere in front.
                    let z = -(0.6 + 20.0 * rng.unit()) as f32;
                    let (x, y) = (
                        (rng.unit() * 2.0 - 1.0) * 1.5,
                        (rng.unit() * 2.0 - 1.0) * 1.5,
                    );
                    let s = (rng.unit() * 0.8) as f32;
                    let p = [
                        [x as f32 - s, y as f32 - s, z],
                        [x as f32 + s, y as f32 - s, z * 1.1],
                        [x as f32 + s, y as f32 + s, z],
                        [x as f32 - s, y as f32 + s, z * 0.9],
                    ];
                    for g in [&mut lazy, &mut eager] {
                        g.draw_mesh(&proj(), DVec3::ZERO, &p, &[0, 1, 2, 0, 2, 3]);
                    }
                    assert_eq!(lazy.depth().depth(), eager.depth().depth());
                } else {
                    let (x0, y0) = (rng.upto(w), rng.upto(h));
                    let r = PixelRect {
                        x0,
                        y0,
                        x1: (x0 + rng.upto(w)).min(w - 1),
                        y1: (y0 + rng.upto(h)).min(h - 1),
                    };
                    let nearest = (0.02 + rng.unit()) as f32;
                    let want = brute(lazy.depth(), r, nearest);
                    assert_eq!(lazy.hides(r, nearest), want, "case {case} lazy {r:?}");
                    assert_eq!(eager.hides(r, nearest), want, "case {case} eager {r:?}");
                }
            }
        }
    }

    /// One wall of two triangles, 100 wide at z = -10, for any LOD.
    struct Wall;
    impl TriangleSource for Wall {
        fn lod_triangles(&mut self, _: u32) -> Option<LodTriangles<'_>> {
            const P: [[f32; 3]; 4] = [
                [-100.0, -100.0, -10.0],
                [100.0, -100.0, -10.0],
                [100.0, 100.0, -10.0],
                [-100.0, 100.0, -10.0],
            ];
            Some(LodTriangles {
                origin: DVec3::ZERO,
                positions: &P,
                indices: &[0, 1, 2, 0, 2, 3],
            })
        }
    }

    #[test]
    fn the_grid_culler_hides_boxes_behind_what_was_drawn_and_nothing_else() {
        use gigawalk_scene::{Aabb, Node, NO_NODE};
        let bounds = Aabb {
            min: DVec3::new(-100.0, -100.0, -10.0),
            max: DVec3::new(100.0, 100.0, -10.0),
        };
        let skeleton = Skeleton::new(
            DVec3::ZERO,
            bounds,
            vec![Node {
                bounds,
                parent: NO_NODE,
                first_child: 0,
                child_count: 0,
                first_lod: 0,
                lod_count: 1,
            }],
            vec![crate::test_rng::lod(0.0, 2)],
            Default::default(),
        )
        .expect("a valid skeleton");
        let view = CullView::new(
            crate::Camera::look_at(DVec3::ZERO, DVec3::NEG_Z, 90f64.to_radians(), 1.5, 0.5),
            crate::Viewport::new(33, 22),
        );
        let mut grid = OcclusionGrid::new(8, true);
        let mut wall = Wall;
        let mut c = GridCuller::new(&mut grid, &skeleton, &mut wall, u64::MAX);
        c.begin(&view);
        let test = |c: &mut GridCuller, min: [f64; 3], max: [f64; 3]| {
            let b = RelBox::from_f64(DVec3::from(min), DVec3::from(max));
            c.test(&view, 0, &b, &()).0
        };
        // Nothing drawn yet: everything in view is visible.
        assert_eq!(
            test(&mut c, [-1.0, -1.0, -30.0], [1.0, 1.0, -20.0]),
            Verdict::Visible
        );
        c.drawn(&view, DrawItem { node: 0, lod: 0 });
        assert_eq!(c.grid.stats.items_drawn, 1);
        // Behind the wall: hidden; in front, touching it, crossing the
        // near plane, or around the eye: visible; beside the image: hidden.
        assert_eq!(
            test(&mut c, [-1.0, -1.0, -30.0], [1.0, 1.0, -20.0]),
            Verdict::Occluded
        );
        assert_eq!(
            test(&mut c, [-1.0, -1.0, -8.0], [1.0, 1.0, -5.0]),
            Verdict::Visible
        );
        assert_eq!(
            test(&mut c, [-1.0, -1.0, -20.0], [1.0, 1.0, -10.0]),
            Verdict::Visible
        );
        assert_eq!(
            test(&mut c, [-1.0, -1.0, -30.0], [1.0, 1.0, -0.1]),
            Verdict::Visible
        );
        assert_eq!(test(&mut c, [-1.0; 3], [1.0; 3]), Verdict::Visible);
        assert_eq!(
            test(&mut c, [50.0, -1.0, -3.0], [60.0, 1.0, -2.0]),
            Verdict::Occluded
        );
        // A budget of 0 rasterizes nothing, so nothing is hidden.
        let mut grid = OcclusionGrid::new(8, true);
        let mut c = GridCuller::new(&mut grid, &skeleton, &mut wall, 0);
        c.begin(&view);
        c.drawn(&view, DrawItem { node: 0, lod: 0 });
        assert_eq!(c.grid.stats.items_skipped, 1);
        assert_eq!(
            test(&mut c, [-1.0, -1.0, -30.0], [1.0, 1.0, -20.0]),
            Verdict::Visible
        );
    }

    #[test]
    fn lazy_updates_read_fewer_pixels_than_eager_ones() {
        let (mut lazy, mut eager) = (OcclusionGrid::new(8, true), OcclusionGrid::new(8, false));
        lazy.reset(64, 64);
        eager.reset(64, 64);
        // Many overlapping draws near the eye, then one far test.
        for i in 0..20 {
            let z = -1.0 - i as f32 * 0.01;
            let p = [
                [-2.0, -2.0, z],
                [2.0, -2.0, z],
                [2.0, 2.0, z],
                [-2.0, 2.0, z],
            ];
            for g in [&mut lazy, &mut eager] {
                g.draw_mesh(&proj(), DVec3::ZERO, &p, &[0, 1, 2, 0, 2, 3]);
            }
        }
        let r = PixelRect {
            x0: 10,
            y0: 10,
            x1: 20,
            y1: 20,
        };
        assert!(lazy.hides(r, 0.1) && eager.hides(r, 0.1));
        assert!(
            lazy.stats.pixel_reads * 4 < eager.stats.pixel_reads,
            "{:?} vs {:?}",
            lazy.stats,
            eager.stats
        );
    }
}
