//! One frame's culling view: a camera and viewport with everything the box
//! tests precompute, camera-relative boxes, and conservative box projection.

use gigawalk_scene::section::{BoxSide, HalfSpace, Section};
use gigawalk_scene::Aabb;

/// Relative slack of [`CullView::section_side`]: the GPU's clip test
/// rounds a relative plane's offset and a position's coordinates to f32
/// (2^-24 each) and sums three products; 1e-6 of their magnitude is
/// several times that.
pub const SECTION_REL_SLACK: f64 = 1e-6;
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
    /// Unit view direction, and the cosine of the angle between it and an
    /// image corner (the widest angle at which anything shows).
    forward: DVec3,
    cos_corner: f64,
    near: f32,
    /// |row 3| of `view_proj`: bounds the magnitude of the terms summed into
    /// clip w, for the rounding slack of [`CullView::project_box`].
    w_row_abs: Vec4,
    /// Hidden and highlighted objects (`None`: every object shows whole).
    visibility: Option<std::sync::Arc<crate::Visibility>>,
    /// X-ray: the hidden objects as a visibility of their own
    /// ([`crate::Visibility::ghosts`]), drawn as faint ghosts.
    ghosts: Option<std::sync::Arc<crate::Visibility>>,
    /// Section planes and box (`None`: nothing is cut), and their
    /// half-spaces relative to the eye in f64.
    section: Option<std::sync::Arc<Section>>,
    section_rel: Vec<HalfSpace>,
    /// The largest |offset| of `section_rel` (the eye's distance from the
    /// farthest plane), for the slack of [`CullView::section_side`].
    section_offset: f64,
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
            forward: camera.forward(),
            cos_corner: {
                let ty = camera.tan_half_fovy();
                let tx = ty * viewport.aspect();
                1.0 / (1.0 + tx * tx + ty * ty).sqrt()
            },
            near: camera.near as f32,
            w_row_abs: view_proj.row(3).abs(),
            visibility: None,
            ghosts: None,
            section: None,
            section_rel: Vec::new(),
            section_offset: 0.0,
        }
    }

    /// This view cut by `section`: traversal drops what lies wholly on
    /// its removed side and the passes clip every fragment by it.
    pub fn with_section(mut self, section: Option<std::sync::Arc<Section>>) -> Self {
        self.section = section.filter(|s| !s.is_empty());
        self.section_rel = match &self.section {
            Some(s) => s
                .half_spaces()
                .iter()
                .map(|h| h.relative_to(self.camera.position))
                .collect(),
            None => Vec::new(),
        };
        self.section_offset = self
            .section_rel
            .iter()
            .fold(0.0f64, |m, h| m.max(h.d.abs()));
        self
    }

    /// The view's section, when one cuts.
    pub fn section(&self) -> Option<&std::sync::Arc<Section>> {
        self.section.as_ref()
    }

    /// Where a camera-relative box lies against the section (`Kept` when
    /// there is none). `Removed` is certain: the slack covers the f32
    /// rounding of the GPU's per-fragment test (relative half-spaces and
    /// positions rounded once each), so no fragment of the box can pass it.
    pub fn section_side(&self, min: DVec3, max: DVec3) -> BoxSide {
        if self.section_rel.is_empty() {
            return BoxSide::Kept;
        }
        let extent = min.abs().max(max.abs()).max_element();
        let slack = SECTION_REL_SLACK * (extent + self.section_offset);
        crate::section_classify(&self.section_rel, min, max, slack)
    }

    /// This view with `v`'s hidden and highlighted objects: traversal
    /// culls hidden subtrees and refines partial nodes
    /// ([`crate::visibility`]).
    pub fn with_visibility(mut self, v: Option<std::sync::Arc<crate::Visibility>>) -> Self {
        self.visibility = v.filter(|v| !v.is_all());
        self
    }

    /// The view's hidden and highlighted objects, when any.
    pub fn visibility(&self) -> Option<&std::sync::Arc<crate::Visibility>> {
        self.visibility.as_ref()
    }

    /// This view with x-ray's ghosts: `g` shows what the view's own
    /// visibility hides ([`crate::Visibility::ghosts`]); `None`: no ghosts.
    pub fn with_ghosts(mut self, g: Option<std::sync::Arc<crate::Visibility>>) -> Self {
        self.ghosts = g;
        self
    }

    /// X-ray's ghosts, when any.
    pub fn ghosts(&self) -> Option<&std::sync::Arc<crate::Visibility>> {
        self.ghosts.as_ref()
    }

    /// The view that draws the ghosts: their visibility in place of the
    /// view's own, the same camera and section.
    pub fn ghost_view(&self) -> Option<CullView> {
        let g = self.ghosts.clone()?;
        let mut v = self.clone();
        v.ghosts = None;
        Some(v.with_visibility(Some(g)))
    }

    /// What of `node`'s subtree shows.
    pub fn show(&self, node: u32) -> crate::NodeShow {
        match &self.visibility {
            Some(v) => v.node(node),
            None => crate::NodeShow::Whole,
        }
    }

    /// The box relative to the camera, in f64 (exact up to one rounding).
    pub fn rel_f64(&self, b: &Aabb) -> (DVec3, DVec3) {
        (b.min - self.camera.position, b.max - self.camera.position)
    }

    /// The distance at which a camera-relative box's object-space LOD
    /// error is projected to pixels (error x `pixels_per_radian` / this):
    /// the distance to its nearest point, shortened for where it sits off
    /// the view axis, so the pixel error bounds how far on screen a surface
    /// can move, not only at the image centre.
    ///
    /// A point at distance r seen at angle a off the view axis projects
    /// with a Jacobian of norm f / (r cos^2 a) (f = `pixels_per_radian`):
    /// moving it by e moves its image by up to e f / (r cos^2 a), 1.33x
    /// the on-axis figure at 30 degrees and 2.39x at the corners of a
    /// 60-degree 16:9 image. So this is the nearest distance times cos^2
    /// of the widest angle at which a point of the box can show: that of
    /// its bounding sphere's far side, at most the image corner's.
    pub fn lod_distance(&self, min: DVec3, max: DVec3) -> f64 {
        let d = crate::lod::distance_to_rel_box(min, max);
        let c = (min + max) * 0.5;
        let (dc2, r2) = (c.length_squared(), ((max - min) * 0.5).length_squared());
        let cos = if dc2 > r2 {
            // cos(angle of the centre + half-angle of the sphere), with
            // dc the centre's distance, cf its component along the view
            // and r the sphere's radius: (cf sqrt(dc^2 - r^2) -
            // sqrt(dc^2 - cf^2) r) / dc^2, a square root fewer than the
            // angles' sines and cosines.
            let cf = c.dot(self.forward);
            let far_side = cf * (dc2 - r2).sqrt() - (dc2 - cf * cf).max(0.0).sqrt() * r2.sqrt();
            (far_side / dc2).max(self.cos_corner)
        } else {
            self.cos_corner
        };
        d * cos * cos
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

    /// Pixel position of a camera-relative point (x right, y up), or None
    /// behind the near plane.
    fn pixel(v: &CullView, p: DVec3) -> Option<(f64, f64)> {
        let q = v.camera.orientation.inverse() * p;
        let z = -q.z;
        (z >= v.camera.near).then(|| {
            let f = v.pixels_per_radian;
            (f * q.x / z, f * q.y / z)
        })
    }

    #[test]
    fn lod_distance_bounds_how_far_a_moved_point_moves_on_screen() {
        // Random cameras (fovy 20-120 degrees, aspect 0.5-2.5), boxes near
        // and far, on and off axis, and points of them that show; moving a
        // point by e in any direction must move its image by at most
        // e x ppr / lod_distance (to first order: e is 1e-6 of the box).
        let mut rng = crate::test_rng::Lcg(7);
        let mut worst_on_axis: f64 = 0.0;
        let mut tested = 0;
        for _ in 0..400 {
            let fovy = rng.range(20.0, 120.0).to_radians();
            let aspect = rng.range(0.5, 2.5);
            let target = rng.vec(1.0) + DVec3::NEG_Z;
            let cam = Camera::look_at(DVec3::ZERO, target, fovy, aspect, 0.01);
            let v = CullView::new(cam, Viewport::new(400, (400.0 / aspect) as u32));
            let c = rng.vec(50.0);
            let half = DVec3::new(
                rng.range(0.01, 5.0),
                rng.range(0.01, 5.0),
                rng.range(0.01, 5.0),
            );
            let (min, max) = (c - half, c + half);
            let ld = v.lod_distance(min, max);
            let d = crate::lod::distance_to_rel_box(min, max);
            assert!(ld <= d, "never longer than the nearest distance");
            let e = 1e-6 * half.length();
            for _ in 0..50 {
                let p = min + (max - min) * DVec3::new(rng.unit(), rng.unit(), rng.unit());
                let Some(a) = pixel(&v, p) else { continue };
                let on_screen = a.0.abs() <= v.viewport.width as f64 / 2.0
                    && a.1.abs() <= v.viewport.height as f64 / 2.0;
                if !on_screen {
                    continue;
                }
                let dir = rng.vec(1.0).normalize_or(DVec3::X);
                let Some(b) = pixel(&v, p + dir * e) else {
                    continue;
                };
                let moved = ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt();
                let bound = e * v.pixels_per_radian / ld;
                assert!(
                    moved <= bound * (1.0 + 1e-3),
                    "moved {moved} px, bound {bound}"
                );
                tested += 1;
                let on_axis = e * v.pixels_per_radian / d;
                worst_on_axis = worst_on_axis.max(moved / on_axis);
            }
        }
        assert!(tested > 1000, "{tested} points tested");
        // The on-axis formula alone (error x ppr / nearest distance) is
        // exceeded off axis: what this corrects.
        assert!(worst_on_axis > 1.5, "worst off-axis ratio {worst_on_axis}");
    }

    #[test]
    fn lod_distance_is_the_distance_straight_ahead() {
        let v = view();
        let (min, max) = (DVec3::new(-0.1, -0.1, -100.1), DVec3::new(0.1, 0.1, -99.9));
        let ld = v.lod_distance(min, max);
        assert!(ld <= 99.9 && ld > 99.9 * 0.999, "{ld}");
        // Around the eye: the image corner's factor (90 degrees, square:
        // 1 + 1 + 1 = 3).
        let ld = v.lod_distance(DVec3::splat(-1.0), DVec3::splat(1.0));
        assert_eq!(ld, 0.0);
        // Beside the eye, its sphere around it: distance 2, factor 3.
        let ld = v.lod_distance(DVec3::new(2.0, -1.0, -3.0), DVec3::new(4.0, 1.0, 3.0));
        assert!((ld - 2.0 / 3.0).abs() < 1e-12, "{ld}");
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
