//! One frame's culling view: a camera and viewport with everything the box
//! tests precompute, camera-relative boxes, and conservative box projection.

use gigawalk_scene::Aabb;
use glam::{DVec3, Mat4, Vec3, Vec4};

use crate::{Camera, Frustum, Viewport};

/// A camera and viewport, prepared for culling one frame.
#[derive(Clone, Debug)]
pub struct CullView {
    pub camera: Camera,
    pub viewport: Viewport,
    /// Camera-relative view-projection in f32 (see [`Camera::view_projection_rel`]).
    pub view_proj: Mat4,
    pub frustum: Frustum,
    /// Viewport height / (2 tan(fovy / 2)), for pixel errors.
    pub pixels_per_radian: f64,
    near: f32,
    /// |row 3| of `view_proj`: bounds the magnitude of the terms summed into
    /// clip w, for the rounding slack of [`CullView::project_box`].
    w_row_abs: Vec4,
}

impl CullView {
    pub fn new(camera: Camera, viewport: Viewport) -> Self {
        let view_proj = camera.view_projection_rel();
        CullView {
            camera,
            viewport,
            view_proj,
            frustum: Frustum::new(&camera),
            pixels_per_radian: camera.pixels_per_radian(viewport),
            near: camera.near as f32,
            w_row_abs: view_proj.row(3).abs(),
        }
    }

    /// The box relative to the camera, in f64 (exact up to one rounding).
    pub fn rel_f64(&self, b: &Aabb) -> (DVec3, DVec3) {
        (b.min - self.camera.position, b.max - self.camera.position)
    }

    /// The box relative to the camera in f32, rounded outward.
    pub fn rel_box(&self, b: &Aabb) -> RelBox {
        let (min, max) = self.rel_f64(b);
        RelBox::from_f64(min, max)
    }

    /// Projects a camera-relative box conservatively: the returned NDC
    /// rectangle contains every point of the box that lies in front of the
    /// near plane, and `nearest_depth` is at least the depth of its nearest
    /// point, whatever f32 rounding did on the way.
    pub fn project_box(&self, b: &RelBox) -> BoxProjection {
        // Eye inside the box: always visible. Projecting it would divide by
        // depths of either sign, and a box around the eye covers the view.
        if b.min.cmple(Vec3::ZERO).all() && b.max.cmpge(Vec3::ZERO).all() {
            return BoxProjection::CrossesNear;
        }
        let m = &self.view_proj;
        let c = (b.min + b.max) * 0.5;
        let e = (b.max - b.min) * 0.5;
        let cc = *m * c.extend(1.0);
        let ax = m.x_axis * e.x;
        let ay = m.y_axis * e.y;
        let az = m.z_axis * e.z;
        // The smallest clip w (view distance) over the box, made smaller by a
        // bound on f32 rounding: 8 ulps of the magnitudes summed.
        let wr = ax.w.abs() + ay.w.abs() + az.w.abs();
        let w_mag = self.w_row_abs.dot(c.abs().extend(1.0)) + wr;
        let min_w = cc.w - wr - W_ROUNDING * w_mag;
        // NaN (from a non-finite box) counts as crossing: visible.
        if min_w.is_nan() || min_w <= self.near {
            return BoxProjection::CrossesNear;
        }
        // Depth is near / w, largest where w is smallest.
        let nearest_depth = self.near / min_w;

        // The 8 corners as two SoA groups of 4 (z half-extent -/+).
        const SA: Vec4 = Vec4::new(1.0, -1.0, 1.0, -1.0);
        const SB: Vec4 = Vec4::new(1.0, 1.0, -1.0, -1.0);
        let xb = Vec4::splat(cc.x) + SA * ax.x + SB * ay.x;
        let yb = Vec4::splat(cc.y) + SA * ax.y + SB * ay.y;
        let wb = Vec4::splat(cc.w) + SA * ax.w + SB * ay.w;
        let (w_lo, w_hi) = (wb - Vec4::splat(az.w), wb + Vec4::splat(az.w));
        // Every corner's w is above min_w > near > 0, but rounding in the
        // SoA sums can differ from min_w's; clamp so no corner divides by
        // a non-positive w.
        let (w_lo, w_hi) = (w_lo.max(Vec4::splat(min_w)), w_hi.max(Vec4::splat(min_w)));
        let (inv_lo, inv_hi) = (w_lo.recip(), w_hi.recip());
        let x_lo = (xb - Vec4::splat(az.x)) * inv_lo;
        let x_hi = (xb + Vec4::splat(az.x)) * inv_hi;
        let y_lo = (yb - Vec4::splat(az.y)) * inv_lo;
        let y_hi = (yb + Vec4::splat(az.y)) * inv_hi;
        BoxProjection::Screen {
            ndc_min: [x_lo.min(x_hi).min_element(), y_lo.min(y_hi).min_element()],
            ndc_max: [x_lo.max(x_hi).max_element(), y_lo.max(y_hi).max_element()],
            nearest_depth,
        }
    }
}

/// Relative f32 rounding bound on clip w: 8 ulps of the summed magnitudes
/// covers the f64 -> f32 matrix rounding, the 4-term dot product and the
/// extent sums (each a few half-ulps). Relative, so scale-free.
const W_ROUNDING: f32 = 8.0 * f32::EPSILON;

/// Where a box lands on screen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BoxProjection {
    /// The box reaches the near plane (or contains the eye, or the math
    /// could not decide): treat as visible.
    CrossesNear,
    /// The box is entirely beyond the near plane.
    Screen {
        /// NDC rectangle (x right, y up) holding the box's projection; may
        /// reach beyond [-1, 1].
        ndc_min: [f32; 2],
        ndc_max: [f32; 2],
        /// Reversed-Z NDC depth of the box's nearest point, rounded up.
        nearest_depth: f32,
    },
}

/// An axis-aligned box relative to the camera position, in f32, rounded
/// outward from the f64 difference so it always contains the true box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RelBox {
    pub min: Vec3,
    pub max: Vec3,
}

impl RelBox {
    pub fn from_f64(min: DVec3, max: DVec3) -> Self {
        RelBox {
            min: Vec3::new(round_down(min.x), round_down(min.y), round_down(min.z)),
            max: Vec3::new(round_up(max.x), round_up(max.y), round_up(max.z)),
        }
    }
}

/// The largest f32 not above `x` (or near it: one ulp below at worst).
fn round_down(x: f64) -> f32 {
    let r = x as f32;
    if (r as f64) > x {
        r - (r.abs() * f32::EPSILON).max(f32::MIN_POSITIVE)
    } else {
        r
    }
}

/// The smallest f32 not below `x` (or near it: one ulp above at worst).
fn round_up(x: f64) -> f32 {
    -round_down(-x)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn view() -> CullView {
        CullView::new(
            Camera::look_at(DVec3::ZERO, DVec3::NEG_Z, 90f64.to_radians(), 1.0, 1.0),
            Viewport::new(100, 100),
        )
    }

    #[test]
    fn rounding_is_outward() {
        for x in [0.1f64, -0.1, 1e7 + 0.3, -1e-30, 3.0] {
            assert!(round_down(x) as f64 <= x, "{x}");
            assert!(round_up(x) as f64 >= x, "{x}");
        }
        assert_eq!(round_down(3.0), 3.0);
    }

    #[test]
    fn box_straight_ahead_projects_around_centre() {
        let b = RelBox::from_f64(DVec3::new(-1.0, -1.0, -10.0), DVec3::new(1.0, 1.0, -5.0));
        let BoxProjection::Screen {
            ndc_min,
            ndc_max,
            nearest_depth,
        } = view().project_box(&b)
        else {
            panic!("box in front must project");
        };
        // Nearest face at distance 5 spans +-1/5 in NDC; depth = near/5.
        assert!((ndc_min[0] + 0.2).abs() < 1e-5 && (ndc_max[1] - 0.2).abs() < 1e-5);
        assert!((0.2..0.2 + 1e-5).contains(&nearest_depth));
    }

    #[test]
    fn box_crossing_near_plane_is_flagged() {
        let b = RelBox::from_f64(DVec3::new(-1.0, -1.0, -10.0), DVec3::new(1.0, 1.0, -0.5));
        assert_eq!(view().project_box(&b), BoxProjection::CrossesNear);
    }

    #[test]
    fn eye_inside_box_is_flagged() {
        let b = RelBox::from_f64(DVec3::splat(-1.0), DVec3::splat(1.0));
        assert_eq!(view().project_box(&b), BoxProjection::CrossesNear);
    }

    #[test]
    fn nan_box_is_flagged() {
        let b = RelBox::from_f64(DVec3::splat(f64::NAN), DVec3::splat(1.0));
        assert_eq!(view().project_box(&b), BoxProjection::CrossesNear);
    }
}
