//! View-frustum culling of camera-relative boxes, with a "fully inside"
//! answer so traversal can skip plane tests below a node.

use glam::DVec3;

use crate::Camera;

/// Where a box lies relative to the frustum.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Containment {
    /// Entirely outside one plane: cull.
    Outside,
    /// Crosses at least one plane that was tested.
    Intersecting,
    /// Inside every plane that was tested.
    Inside,
}

/// Bit set of the frustum planes a box still has to be tested against.
/// A child of a box that was inside a plane is inside it too, so traversal
/// passes the parent's mask down and skips those planes.
pub type PlaneMask = u8;

/// Every plane of [`Frustum`] (near, left, right, bottom, top).
pub const ALL_PLANES: PlaneMask = 0b1_1111;

/// The five planes of a reversed-Z, infinite-far frustum (there is no far
/// plane), in camera-relative world coordinates: a point `p` (already
/// `world - camera position`) is inside a plane when `n . p + d >= 0`.
/// The four side planes pass through the eye, so their `d` is 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frustum {
    normals: [DVec3; 5],
    offsets: [f64; 5],
}

/// Relative slack on "outside": a box is culled only when it is outside a
/// plane by more than this fraction of the magnitudes involved, so f64
/// rounding (about 1e-16 relative) can never cull a box that touches the
/// frustum. Scale-free, so it is the same at 10^-3 and 10^4 model units.
const OUTSIDE_SLACK: f64 = 1e-9;

impl Frustum {
    pub fn new(camera: &Camera) -> Self {
        let f = camera.forward();
        let r = camera.right();
        let u = camera.up();
        let ty = camera.tan_half_fovy();
        let tx = ty * camera.aspect;
        let normals = [
            f,
            (r + f * tx).normalize(),
            (-r + f * tx).normalize(),
            (u + f * ty).normalize(),
            (-u + f * ty).normalize(),
        ];
        let offsets = [-camera.near, 0.0, 0.0, 0.0, 0.0];
        Frustum { normals, offsets }
    }

    /// The frustum of a camera-relative view-projection matrix in the
    /// runtime's convention (reversed Z, infinite far: clip z <= w in
    /// front of the near plane, -w <= x, y <= w inside), for off-axis
    /// frustums such as a tile's (Gribb and Hartmann's plane extraction).
    pub fn from_view_projection(m: &glam::DMat4) -> Self {
        let (x, y, z, w) = (m.row(0), m.row(1), m.row(2), m.row(3));
        let planes = [w - z, w + x, w - x, w + y, w - y];
        let mut normals = [DVec3::ZERO; 5];
        let mut offsets = [0.0; 5];
        for (i, p) in planes.iter().enumerate() {
            let n = p.truncate();
            let len = n.length();
            let len = if len > 0.0 && len.is_finite() {
                len
            } else {
                1.0
            };
            normals[i] = n / len;
            offsets[i] = p.w / len;
        }
        Frustum { normals, offsets }
    }

    /// Tests the camera-relative box `[min, max]` against the planes in
    /// `mask`. Returns the containment and the planes the box's descendants
    /// still have to be tested against (those it crosses).
    pub fn test(&self, min: DVec3, max: DVec3, mask: PlaneMask) -> (Containment, PlaneMask) {
        let c = (min + max) * 0.5;
        let e = (max - min) * 0.5;
        let mut out_mask = 0;
        for i in 0..5 {
            if mask & (1 << i) == 0 {
                continue;
            }
            let n = self.normals[i];
            let s = n.dot(c) + self.offsets[i];
            let r = n.abs().dot(e);
            let slack = OUTSIDE_SLACK * (n.abs().dot(c.abs()) + r + self.offsets[i].abs());
            if s + r < -slack {
                return (Containment::Outside, 0);
            }
            if s - r < slack {
                out_mask |= 1 << i;
            }
        }
        if out_mask == 0 {
            (Containment::Inside, 0)
        } else {
            (Containment::Intersecting, out_mask)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frustum() -> Frustum {
        Frustum::new(&Camera::look_at(
            DVec3::ZERO,
            DVec3::NEG_Z,
            90f64.to_radians(),
            1.0,
            1.0,
        ))
    }

    fn check(min: [f64; 3], max: [f64; 3], expected: Containment) {
        let (got, _) = frustum().test(DVec3::from(min), DVec3::from(max), ALL_PLANES);
        assert_eq!(got, expected, "box {min:?}..{max:?}");
    }

    #[test]
    fn box_in_front_is_inside() {
        check([-1.0, -1.0, -10.0], [1.0, 1.0, -5.0], Containment::Inside);
    }

    #[test]
    fn box_behind_eye_is_outside() {
        check([-1.0, -1.0, 5.0], [1.0, 1.0, 10.0], Containment::Outside);
    }

    #[test]
    fn box_between_eye_and_near_plane_is_outside() {
        check([-0.1, -0.1, -0.9], [0.1, 0.1, -0.2], Containment::Outside);
    }

    #[test]
    fn box_crossing_near_plane_intersects() {
        check(
            [-0.1, -0.1, -2.0],
            [0.1, 0.1, -0.5],
            Containment::Intersecting,
        );
    }

    #[test]
    fn box_left_of_frustum_is_outside() {
        // fovy 90, aspect 1: the left plane is x = z.
        check(
            [-20.0, -1.0, -10.0],
            [-11.0, 1.0, -5.0],
            Containment::Outside,
        );
    }

    #[test]
    fn box_touching_side_plane_is_kept() {
        check(
            [-20.0, -1.0, -10.0],
            [-10.0, 1.0, -10.0],
            Containment::Intersecting,
        );
    }

    #[test]
    fn eye_inside_box_intersects() {
        check([-1.0; 3], [1.0; 3], Containment::Intersecting);
    }

    #[test]
    fn mask_skips_planes_already_passed() {
        let f = frustum();
        let (c, mask) = f.test(
            DVec3::new(-20.0, -1.0, -10.0),
            DVec3::new(0.0, 1.0, -5.0),
            ALL_PLANES,
        );
        assert_eq!(c, Containment::Intersecting);
        assert_eq!(mask, 0b0_0010, "only the left plane is crossed");
        // With the left plane masked off, a box outside only the left plane passes.
        let (c, _) = f.test(
            DVec3::new(-20.0, -1.0, -10.0),
            DVec3::new(-11.0, 1.0, -5.0),
            ALL_PLANES & !0b0_0010,
        );
        assert_eq!(c, Containment::Inside);
    }
}
