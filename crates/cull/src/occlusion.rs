//! The occlusion-test interface traversal uses, and its first implementation:
//! the conservative box-vs-HZB test (GigaWalk Section 5.1.2).

use crate::{BoxProjection, CullView, Hzb, PixelRect, RelBox};

/// Decides whether a box may be visible. Traversal is generic over it, so
/// other culling methods (a lazy occlusion grid, object-space occluders, GPU
/// occlusion queries) plug into the same slot.
///
/// Contract for a conservative implementation: `false` only when no point
/// of the box can show in the image.
pub trait OcclusionTest {
    /// `b` is the box relative to `view.camera.position`, rounded outward.
    fn is_visible(&self, view: &CullView, b: &RelBox) -> bool;
}

/// Culls nothing: the "occlusion off" test.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoOcclusion;

impl OcclusionTest for NoOcclusion {
    fn is_visible(&self, _: &CullView, _: &RelBox) -> bool {
        true
    }
}

/// Relative slack on the depth comparison: a box is occluded only when its
/// nearest depth is below the farthest stored depth by more than this
/// fraction. It absorbs the rasterizer's own depth rounding (a GPU
/// interpolates f32 depth to a few ulps, ~2^-21) and that of the reference
/// rasterizer, so a box lying exactly on an occluder is never culled.
/// Relative, hence the same at every scale and distance.
pub const DEPTH_SLACK: f32 = 1.0 / 65536.0;

/// The conservative box test against a hierarchical Z-buffer.
///
/// A box that crosses the near plane or contains the eye is visible.
/// Otherwise its projection's pixel footprint (every pixel the projected
/// rectangle touches, a superset of the pixels whose centres it covers) is
/// looked up at the finest HZB level where it spans at most 2x2 cells; the
/// box is occluded when its nearest depth is farther than the farthest
/// stored depth of every cell there. A cell that does not hide the box is
/// refined into its children that meet the footprint, down to single
/// pixels ([`Hzb::rect_hides`], at most [`REFINE_CELLS`] cells), so the
/// pixels of a 2x2 cell outside the footprint do not keep the box: the
/// classic 2x2 lookup reads up to 4x the footprint's extent per axis.
/// Ties count as visible.
///
/// A box that does not hide as a whole is split in two across its longest
/// axis, and it hides when both halves do, up to `splits` times deep
/// ([`SPLITS`] by default). One nearest depth stands for the whole box, so
/// a box that runs away from the eye (a pipe along the view, a node deep
/// in view depth) is tested everywhere with the depth of its nearest
/// corner; its far half has a farther nearest depth and a smaller
/// footprint. The halves' union is the box (both share one f32 midpoint),
/// so splitting stays conservative; it only costs tests: a visible box
/// whose nearer half shows pays `splits + 1` footprint tests, and any box
/// at most `2^(splits + 1) - 1`.
///
/// The footprint is computed in the HZB's own pixel grid from NDC, so an HZB
/// built from a lower-resolution depth image (GigaWalk Section 5.3) works
/// unchanged; it is then approximate, as the paper notes.
#[derive(Clone, Copy, Debug)]
pub struct HzbOcclusion<'a> {
    pub hzb: &'a Hzb,
    /// How many times deep a box that does not hide is split (0: never).
    splits: u8,
}

impl<'a> HzbOcclusion<'a> {
    pub fn new(hzb: &'a Hzb) -> Self {
        HzbOcclusion {
            hzb,
            splits: SPLITS,
        }
    }

    /// The same test with boxes split `splits` times deep, at most
    /// [`MAX_SPLITS`] (the tests per box grow as `2^(splits + 1)`).
    pub fn with_splits(self, splits: u8) -> Self {
        HzbOcclusion {
            splits: splits.min(MAX_SPLITS),
            ..self
        }
    }
}

impl OcclusionTest for HzbOcclusion<'_> {
    fn is_visible(&self, view: &CullView, b: &RelBox) -> bool {
        let (w, h) = (self.hzb.width(), self.hzb.height());
        !hides_split(view, b, w, h, self.splits, &mut |r, nearest| {
            let hides = |d| occludes(nearest, d);
            if self
                .hzb
                .rect_hides(r.x0, r.y0, r.x1, r.y1, REFINE_CELLS, hides)
            {
                RectTest::Hides
            } else if self.hzb.rect_shows(r.x0, r.y0, r.x1, r.y1, hides) {
                RectTest::ShowsEverywhere
            } else {
                RectTest::Shows
            }
        })
    }
}

/// What a footprint test found for a box part of some nearest depth.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum RectTest {
    /// Every pixel of the rectangle hides it.
    Hides,
    /// Some pixel may show it.
    Shows,
    /// No pixel of the rectangle hides it: no part of the box with the
    /// same nearest depth hides either, so splitting cannot help.
    ShowsEverywhere,
}

impl RectTest {
    /// Hides, or shows (without saying more).
    pub(crate) fn from_hides(hides: bool) -> RectTest {
        if hides {
            RectTest::Hides
        } else {
            RectTest::Shows
        }
    }
}

/// Whether a box hides in a `w x h` depth image, where `hides(rect,
/// nearest)` tests the pixels of `rect` against a box part whose nearest
/// depth is `nearest` (conservatively): the box as a whole, or else both
/// its [`halves`], up to `splits` times deep. A box crossing the near
/// plane shows (so does any half of it that crosses it); one wholly
/// beside the image hides. A box whose rectangle shows it everywhere is
/// not split: the half holding its nearest corner has the same nearest
/// depth and a footprint inside the rectangle, so it shows too.
pub(crate) fn hides_split(
    view: &CullView,
    b: &RelBox,
    w: u32,
    h: u32,
    splits: u8,
    hides: &mut impl FnMut(PixelRect, f32) -> RectTest,
) -> bool {
    match footprint(view, b, w, h) {
        Footprint::Visible => false,
        Footprint::Beside => true,
        Footprint::Pixels { rect, nearest } => match hides(rect, nearest) {
            RectTest::Hides => true,
            RectTest::ShowsEverywhere => false,
            RectTest::Shows => {
                splits > 0
                    && halves(b)
                        .iter()
                        .all(|half| hides_split(view, half, w, h, splits - 1, hides))
            }
        },
    }
}

/// How many times deep [`HzbOcclusion`] splits a box that does not hide.
/// Measured on the 4M demo and 20M plant walks; see docs/results.md
/// "The HZB: build and box test".
pub const SPLITS: u8 = 2;

/// The most splits [`HzbOcclusion::with_splits`] takes.
pub const MAX_SPLITS: u8 = 8;

/// A camera-relative box cut in two across its longest axis at one f32
/// midpoint (so the halves cover it exactly), the half nearer the eye
/// first: a visible box is then usually settled by its first half.
fn halves(b: &RelBox) -> [RelBox; 2] {
    let e = b.max - b.min;
    let axis = if e.x >= e.y && e.x >= e.z {
        0
    } else if e.y >= e.z {
        1
    } else {
        2
    };
    let mid = (b.min[axis] + b.max[axis]) * 0.5;
    let (mut lo, mut hi) = (*b, *b);
    lo.max[axis] = mid;
    hi.min[axis] = mid;
    // The eye is at the origin: the half on its side of the cut is nearer.
    if mid > 0.0 {
        [lo, hi]
    } else {
        [hi, lo]
    }
}

/// Cells one footprint test may read while refining past its 2x2 cells;
/// past it the box (or the split part of it) counts as visible, so a box
/// split in halves may read this many per part. Measured before boxes
/// were split (640x360, och at 1 px, revision 6 scenes): 16 cells leave 5% (4M plant) and 7% (20M plant) more
/// triangles than an unlimited refinement, 64 and 256 within 0.2%, with
/// traversal time unchanged. See docs/results.md "The HZB: build and box test".
pub const REFINE_CELLS: usize = 256;

/// Where a box lands in a `w x h` depth image.
pub(crate) enum Footprint {
    /// Crosses the near plane, contains the eye, an empty image, or the
    /// math could not decide: visible.
    Visible,
    /// Entirely beside the image: no pixel to show in.
    Beside,
    /// Every pixel its projection touches (a superset of the pixels whose
    /// centres it covers), and its nearest depth.
    Pixels { rect: PixelRect, nearest: f32 },
}

/// The pixel footprint of a box in a `w x h` image of the view (any
/// resolution: computed from NDC in the image's own pixel grid).
pub(crate) fn footprint(view: &CullView, b: &RelBox, w: u32, h: u32) -> Footprint {
    if w == 0 || h == 0 {
        return Footprint::Visible;
    }
    let BoxProjection::Screen {
        ndc_min,
        ndc_max,
        nearest_depth,
    } = view.project_box(b)
    else {
        return Footprint::Visible;
    };
    let (wf, hf) = (w as f32, h as f32);
    // NDC -> pixels; y flips because row 0 is the top.
    let px_min = (ndc_min[0] * 0.5 + 0.5) * wf;
    let px_max = (ndc_max[0] * 0.5 + 0.5) * wf;
    let py_min = (0.5 - ndc_max[1] * 0.5) * hf;
    let py_max = (0.5 - ndc_min[1] * 0.5) * hf;
    // NaN anywhere fails these comparisons: visible.
    if !(px_min <= px_max && py_min <= py_max && nearest_depth.is_finite()) {
        return Footprint::Visible;
    }
    if px_max < 0.0 || py_max < 0.0 || px_min >= wf || py_min >= hf {
        return Footprint::Beside;
    }
    // Saturating float -> int casts; the clamps keep the rectangle inside.
    Footprint::Pixels {
        rect: PixelRect {
            x0: (px_min.floor() as i64).max(0) as u32,
            y0: (py_min.floor() as i64).max(0) as u32,
            x1: (px_max.floor() as i64).min(w as i64 - 1) as u32,
            y1: (py_max.floor() as i64).min(h as i64 - 1) as u32,
        },
        nearest: nearest_depth,
    }
}

/// Whether a box whose nearest depth is `nearest` hides behind stored
/// depth `farthest` (with [`DEPTH_SLACK`]; NaN and ties: not hidden).
#[inline]
pub(crate) fn occludes(nearest: f32, farthest: f32) -> bool {
    nearest * (1.0 + DEPTH_SLACK) < farthest
}

#[cfg(test)]
mod tests {
    use glam::{DVec3, Vec3};

    use super::*;
    use crate::{Camera, Reduction, Viewport};

    /// 90 degree square camera at the origin looking down -Z, near 1.
    fn view() -> CullView {
        CullView::new(
            Camera::look_at(DVec3::ZERO, DVec3::NEG_Z, 90f64.to_radians(), 1.0, 1.0),
            Viewport::new(16, 16),
        )
    }

    /// A 16x16 HZB whose every pixel is a wall at view distance `dist`.
    fn wall(dist: f32) -> Hzb {
        Hzb::build(16, 16, &[1.0 / dist; 256], Reduction::Farthest).unwrap()
    }

    fn check(hzb: &Hzb, min: [f64; 3], max: [f64; 3], expected: bool) {
        let b = RelBox::from_f64(DVec3::from(min), DVec3::from(max));
        assert_eq!(
            HzbOcclusion::new(hzb).is_visible(&view(), &b),
            expected,
            "box {min:?}..{max:?}"
        );
    }

    #[test]
    fn box_behind_wall_is_occluded() {
        check(&wall(10.0), [-1.0, -1.0, -30.0], [1.0, 1.0, -20.0], false);
    }

    #[test]
    fn box_in_front_of_wall_is_visible() {
        check(&wall(10.0), [-1.0, -1.0, -8.0], [1.0, 1.0, -5.0], true);
    }

    #[test]
    fn box_touching_wall_is_visible() {
        check(&wall(10.0), [-1.0, -1.0, -20.0], [1.0, 1.0, -10.0], true);
    }

    #[test]
    fn box_crossing_near_plane_is_visible() {
        check(&wall(2.0), [-1.0, -1.0, -30.0], [1.0, 1.0, -0.5], true);
    }

    #[test]
    fn eye_inside_box_is_visible() {
        check(&wall(2.0), [-100.0; 3], [100.0; 3], true);
    }

    #[test]
    fn box_seen_through_hole_is_visible() {
        let mut d = [0.1f32; 256];
        d[8 * 16 + 8] = 0.0; // one pixel of sky just right of and below centre
        let hzb = Hzb::build(16, 16, &d, Reduction::Farthest).unwrap();
        // A small far box around the view axis covers pixels 7..=8.
        check(&hzb, [-1.0, -1.0, -101.0], [1.0, 1.0, -100.0], true);
        // Far to the upper left it is hidden.
        check(&hzb, [-60.0, 40.0, -101.0], [-58.0, 42.0, -100.0], false);
    }

    #[test]
    fn halves_cover_the_box_nearer_half_first() {
        let b = RelBox {
            min: Vec3::new(-1.0, 2.0, -30.0),
            max: Vec3::new(1.0, 3.0, -10.0),
        };
        let [near, far] = halves(&b);
        // Cut across z, the longest axis, at one shared value.
        assert_eq!(near.min, Vec3::new(-1.0, 2.0, -20.0));
        assert_eq!(near.max, b.max);
        assert_eq!(far.min, b.min);
        assert_eq!(far.max.z, near.min.z);
        // A box on the other side of the eye: the nearer half flips.
        let b = RelBox {
            min: Vec3::new(4.0, -1.0, -1.0),
            max: Vec3::new(9.0, 1.0, 1.0),
        };
        let [near, far] = halves(&b);
        assert_eq!((near.min.x, near.max.x, far.min.x), (4.0, 6.5, 6.5));
    }

    #[test]
    fn a_box_running_away_hides_only_when_split() {
        // 512x512, 90 degrees: pixel column c starts at ndc x (c - 256) /
        // 256. Columns below 259 (ndc x < 0.0117) are a far wall at 40,
        // the rest a near wall at 10. The box x 1..2, depth 10.5..100:
        // a point of it at depth w has ndc x >= 1 / w, so it reaches the
        // far wall's columns only beyond depth 85 (behind 40), and
        // everywhere else it is beyond 10: hidden. As a whole its nearest
        // depth 10.5 is tested against the far wall's columns too.
        const N: usize = 512;
        let d: Vec<f32> = (0..N * N)
            .map(|i| if i % N < 259 { 1.0 / 40.0 } else { 1.0 / 10.0 })
            .collect();
        let hzb = Hzb::build(N as u32, N as u32, &d, Reduction::Farthest).unwrap();
        let view = CullView::new(
            Camera::look_at(DVec3::ZERO, DVec3::NEG_Z, 90f64.to_radians(), 1.0, 1.0),
            Viewport::new(N as u32, N as u32),
        );
        let b = RelBox::from_f64(DVec3::new(1.0, -0.5, -100.0), DVec3::new(2.0, 0.5, -10.5));
        let test = HzbOcclusion::new(&hzb);
        assert!(test.with_splits(0).is_visible(&view, &b));
        // Split once at depth 55.25: the far half is behind 40, the near
        // half (ndc x >= 0.018) lies on the near wall's columns.
        assert!(!test.with_splits(1).is_visible(&view, &b));
        assert!(!test.is_visible(&view, &b));
        // Brought nearer than the near wall, it shows however split.
        let b = RelBox::from_f64(DVec3::new(1.0, -0.5, -100.0), DVec3::new(2.0, 0.5, -9.5));
        assert!(test.with_splits(6).is_visible(&view, &b));
    }

    #[test]
    fn splits_are_capped() {
        let hzb = wall(10.0);
        assert_eq!(HzbOcclusion::new(&hzb).splits, SPLITS);
        assert_eq!(HzbOcclusion::new(&hzb).with_splits(255).splits, MAX_SPLITS);
        assert_eq!(HzbOcclusion::new(&hzb).with_splits(0).splits, 0);
    }

    #[test]
    fn empty_hzb_culls_nothing() {
        check(&Hzb::new(), [-1.0, -1.0, -30.0], [1.0, 1.0, -20.0], true);
    }

    #[test]
    fn box_beside_the_image_is_not_visible() {
        check(&wall(10.0), [50.0, -1.0, -3.0], [60.0, 1.0, -2.0], false);
    }
}
