//! The camera: an f64 pose with a reversed-Z, infinite-far perspective, and
//! the camera-relative f32 matrices the GPU and the culling tests use.

use gigawalk_scene::Aabb;
use glam::{DMat3, DMat4, DQuat, DVec3, DVec4, Mat4};

/// The default near plane as a fraction of the scene's bounding-box
/// diagonal (see [`default_near`]): 1 mm in a 100 m plant, 1 m in a 100 km
/// city. Depth is reversed-Z f32 with an infinite far plane, `near /
/// distance`: a float keeps 24 bits of relative precision at every
/// magnitude, so depth resolution at distance d is about d * 6e-8
/// whatever the near plane is, and a surface at the far end of the scene
/// still has depth 1e-5, far above f32's smallest normal (1e-38). A small
/// near plane therefore costs no precision; a large one cuts away what is
/// close to the eye. On the generated plants (diagonal 52 m at 50k
/// triangles, 133 m at 400k, growing as the square root of the size) that
/// is 0.5 to a few mm, and their walks draw the same triangles as with the
/// old fixed 0.05 units (checked on the 400k plant's walk); at a person's
/// scale it is far below anything the eye stands next to.
pub const NEAR_FRACTION_OF_SCENE: f64 = 1e-5;

/// The near plane for a scene with bounds `bounds` when none is given:
/// [`NEAR_FRACTION_OF_SCENE`] of its diagonal, so a model in millimetres
/// and the same model in kilometres draw the same pixels from the same
/// (scaled) cameras. One figure for the whole scene rather than one per
/// camera (e.g. a fraction of the distance to the nearest node box): the
/// frustum, HZB and LOD choices of a frame then depend on the camera pose
/// alone, a walk does not see the near plane jump as boxes come and go,
/// and the reference and every mode share it trivially. An empty or
/// degenerate box gets 0.05 (a person's scale in metres); the result is
/// always a positive, normal f32.
pub fn default_near(bounds: &Aabb) -> f64 {
    let diag = (bounds.max - bounds.min).length();
    let near = diag * NEAR_FRACTION_OF_SCENE;
    if near.is_finite() && near >= f32::MIN_POSITIVE as f64 * 1e6 && near <= f32::MAX as f64 * 1e-6
    {
        near
    } else {
        0.05
    }
}

/// Size of the image a camera renders, in pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Viewport {
    pub width: u32,
    pub height: u32,
}

impl Viewport {
    pub fn new(width: u32, height: u32) -> Self {
        Viewport { width, height }
    }

    /// Width over height; 1 for a degenerate (zero-sized) viewport.
    pub fn aspect(&self) -> f64 {
        if self.width == 0 || self.height == 0 {
            1.0
        } else {
            self.width as f64 / self.height as f64
        }
    }
}

/// A perspective camera.
///
/// Conventions (shared by every gigawalk crate): world is right-handed with
/// Y up; the camera looks along its local -Z with local +Y up, and
/// `orientation` rotates camera-local vectors into world. The projection is
/// reversed-Z with an infinite far plane: NDC depth = `near` / (view-space
/// distance along the view axis), 1 at the near plane and tending to 0 at
/// infinity.
///
/// The position stays in f64. Everything that becomes f32 is first made
/// camera-relative (the position is subtracted in f64), so a scene 10^7
/// units from the origin culls and renders like the same scene at the
/// origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: DVec3,
    pub orientation: DQuat,
    /// Vertical field of view in radians, in (0, pi).
    pub fovy: f64,
    /// Width over height of the image.
    pub aspect: f64,
    /// Distance of the near plane along the view axis, > 0.
    pub near: f64,
}

impl Camera {
    /// The camera of a camera-path pose, rendering to `viewport` with its
    /// near plane at `near`.
    pub fn of_pose(pose: &gigawalk_scene::path::Pose, viewport: Viewport, near: f64) -> Self {
        Camera::from_pose(pose.position, pose.orientation, pose.fovy, viewport, near)
    }

    /// A camera from a camera-path pose `(position, orientation, fovy)` and
    /// the viewport it renders to.
    pub fn from_pose(
        position: DVec3,
        orientation: DQuat,
        fovy: f64,
        viewport: Viewport,
        near: f64,
    ) -> Self {
        Camera {
            position,
            orientation,
            fovy,
            aspect: viewport.aspect(),
            near,
        }
    }

    /// A camera at `position` looking at `target` with world +Y as up (or
    /// world +Z when looking straight up or down).
    pub fn look_at(position: DVec3, target: DVec3, fovy: f64, aspect: f64, near: f64) -> Self {
        let forward = (target - position).normalize_or(DVec3::NEG_Z);
        let up_hint = if forward.cross(DVec3::Y).length_squared() < 1e-12 {
            DVec3::Z
        } else {
            DVec3::Y
        };
        let right = forward.cross(up_hint).normalize();
        let up = right.cross(forward);
        let orientation = DQuat::from_mat3(&DMat3::from_cols(right, up, -forward));
        Camera {
            position,
            orientation,
            fovy,
            aspect,
            near,
        }
    }

    /// Unit view direction in world space (camera-local -Z).
    pub fn forward(&self) -> DVec3 {
        self.orientation * DVec3::NEG_Z
    }

    /// Unit camera-local +X in world space.
    pub fn right(&self) -> DVec3 {
        self.orientation * DVec3::X
    }

    /// Unit camera-local +Y in world space.
    pub fn up(&self) -> DVec3 {
        self.orientation * DVec3::Y
    }

    /// tan(fovy / 2): half the image height at view distance 1.
    pub fn tan_half_fovy(&self) -> f64 {
        (self.fovy * 0.5).tan()
    }

    /// The rotation from camera-relative world vectors (`p - position`) to
    /// view space. There is no translation: it was subtracted in f64.
    pub fn view_rotation(&self) -> DMat4 {
        DMat4::from_quat(self.orientation.inverse())
    }

    /// Reversed-Z perspective with an infinite far plane (see [`Camera`]).
    pub fn projection(&self) -> DMat4 {
        let f = 1.0 / self.tan_half_fovy();
        DMat4::from_cols(
            DVec4::new(f / self.aspect, 0.0, 0.0, 0.0),
            DVec4::new(0.0, f, 0.0, 0.0),
            DVec4::new(0.0, 0.0, 0.0, -1.0),
            DVec4::new(0.0, 0.0, self.near, 0.0),
        )
    }

    /// Camera-relative view-projection in f64: maps `p - position` to clip
    /// space.
    pub fn view_projection_rel_f64(&self) -> DMat4 {
        self.projection() * self.view_rotation()
    }

    /// Camera-relative view matrix for the GPU: maps `p - position` (computed
    /// in f64, then made f32) to view space.
    pub fn view_rel(&self) -> Mat4 {
        self.view_rotation().as_mat4()
    }

    /// Camera-relative view-projection for the GPU: maps `p - position`
    /// (computed in f64, then made f32) to clip space.
    pub fn view_projection_rel(&self) -> Mat4 {
        self.view_projection_rel_f64().as_mat4()
    }

    /// Pixels per unit of object-space error at distance 1:
    /// viewport height / (2 tan(fovy / 2)). Pixel error = object-space error x
    /// this / distance (GigaWalk Section 4.3), the distance being
    /// [`crate::CullView::lod_distance`] (the nearest point's, shortened off
    /// the view axis).
    pub fn pixels_per_radian(&self, viewport: Viewport) -> f64 {
        viewport.height as f64 / (2.0 * self.tan_half_fovy())
    }

    /// True when the parameters describe a usable camera: finite, near > 0,
    /// 0 < fovy < pi, aspect > 0 and a unit-length orientation.
    pub fn is_valid(&self) -> bool {
        self.position.is_finite()
            && self.orientation.is_finite()
            && (self.orientation.length() - 1.0).abs() < 1e-6
            && self.fovy > 0.0
            && self.fovy < std::f64::consts::PI
            && self.aspect.is_finite()
            && self.aspect > 0.0
            && self.near.is_finite()
            && self.near > 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Camera {
        Camera::look_at(DVec3::ZERO, DVec3::NEG_Z, 90f64.to_radians(), 2.0, 0.5)
    }

    fn ndc(m: &DMat4, p: DVec3) -> DVec3 {
        let c = *m * p.extend(1.0);
        c.truncate() / c.w
    }

    #[test]
    fn near_plane_maps_to_depth_one() {
        let c = camera();
        let m = c.view_projection_rel_f64();
        assert!((ndc(&m, DVec3::new(0.0, 0.0, -0.5)).z - 1.0).abs() < 1e-12);
        assert!((ndc(&m, DVec3::new(0.0, 0.0, -5.0)).z - 0.1).abs() < 1e-12);
        assert!(ndc(&m, DVec3::new(0.0, 0.0, -1e12)).z < 1e-12);
    }

    #[test]
    fn frustum_edges_map_to_ndc_edges() {
        let c = camera();
        let m = c.view_projection_rel_f64();
        // fovy 90: top edge at y = distance; aspect 2: right edge at x = 2 distance.
        let p = ndc(&m, DVec3::new(6.0, 3.0, -3.0));
        assert!((p.x - 1.0).abs() < 1e-12 && (p.y - 1.0).abs() < 1e-12);
    }

    #[test]
    fn look_at_orientation_points_forward() {
        let c = Camera::look_at(
            DVec3::new(1.0, 2.0, 3.0),
            DVec3::new(1.0, 2.0, 13.0),
            1.0,
            1.0,
            0.1,
        );
        assert!((c.forward() - DVec3::Z).length() < 1e-12);
        assert!((c.up() - DVec3::Y).length() < 1e-12);
        let down = Camera::look_at(DVec3::ZERO, DVec3::NEG_Y, 1.0, 1.0, 0.1);
        assert!((down.forward() - DVec3::NEG_Y).length() < 1e-12);
        assert!(down.is_valid());
    }

    #[test]
    fn relative_matrices_ignore_translation() {
        let mut a = camera();
        let b = Camera {
            position: DVec3::splat(1e7),
            ..a
        };
        assert_eq!(a.view_projection_rel(), b.view_projection_rel());
        a.near = 0.0;
        assert!(!a.is_valid());
    }

    #[test]
    fn default_near_scales_with_the_scene_and_survives_empty_boxes() {
        let b = |s: f64| Aabb::new(DVec3::ZERO, DVec3::new(3.0, 0.0, 4.0) * s);
        for s in [1e-3, 1.0, 1e3, 1e6] {
            let near = default_near(&b(s));
            assert!((near - 5.0 * s * NEAR_FRACTION_OF_SCENE).abs() <= 1e-12 * near);
        }
        for degenerate in [
            Aabb::EMPTY,
            b(0.0),
            b(1e-40),
            b(f64::INFINITY),
            Aabb::new(DVec3::splat(f64::NAN), DVec3::ZERO),
        ] {
            assert_eq!(default_near(&degenerate), 0.05, "{degenerate:?}");
        }
    }
}
