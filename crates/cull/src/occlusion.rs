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
/// The footprint is computed in the HZB's own pixel grid from NDC, so an HZB
/// built from a lower-resolution depth image (GigaWalk Section 5.3) works
/// unchanged; it is then approximate, as the paper notes.
#[derive(Clone, Copy, Debug)]
pub struct HzbOcclusion<'a> {
    pub hzb: &'a Hzb,
}

impl<'a> HzbOcclusion<'a> {
    pub fn new(hzb: &'a Hzb) -> Self {
        HzbOcclusion { hzb }
    }
}

impl OcclusionTest for HzbOcclusion<'_> {
    fn is_visible(&self, view: &CullView, b: &RelBox) -> bool {
        match footprint(view, b, self.hzb.width(), self.hzb.height()) {
            Footprint::Visible => true,
            Footprint::Beside => false,
            Footprint::Pixels { rect: r, nearest } => {
                !self
                    .hzb
                    .rect_hides(r.x0, r.y0, r.x1, r.y1, REFINE_CELLS, |d| {
                        occludes(nearest, d)
                    })
            }
        }
    }
}

/// Cells one box test may read while refining past its 2x2 cells; past
/// it the box counts as visible. Measured (640x360, och at 1 px, revision
/// 6 scenes): 16 cells leave 5% (4M plant) and 7% (20M plant) more
/// triangles than an unlimited refinement, 64 and 256 within 0.2%, with
/// traversal time unchanged. See docs/PERFORMANCE.md "HZB refinement".
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
    use glam::DVec3;

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
    fn empty_hzb_culls_nothing() {
        check(&Hzb::new(), [-1.0, -1.0, -30.0], [1.0, 1.0, -20.0], true);
    }

    #[test]
    fn box_beside_the_image_is_not_visible() {
        check(&wall(10.0), [50.0, -1.0, -3.0], [60.0, 1.0, -2.0], false);
    }
}
