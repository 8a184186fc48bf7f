//! The fly / walk camera controller: mouse look (yaw and pitch, no roll),
//! WASD/QE movement in the view's frame, Shift for speed, scroll to scale
//! the speed, and a walk mode that keeps the eye level at eye height above
//! the scene's floor. The native viewer and the browser page both drive it.

use std::collections::HashSet;

use gigawalk_cull::Camera;
use gigawalk_scene::Aabb;
use glam::{DQuat, DVec3};

/// Held movement keys.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Movement {
    Forward,
    Back,
    Left,
    Right,
    Down,
    Up,
    Fast,
}

/// Eye height in walk mode, metres: a person's eye. In model units it is
/// this over the model's metres per unit (`--units`; glTF's unit, which
/// the generated plants use, is the metre).
pub const EYE_HEIGHT: f64 = 1.7;
/// Scrolling keeps the speed within this factor of the scene's default
/// speed either way: any scene scale can be crossed, and a runaway scroll
/// stays recoverable.
const SPEED_RANGE: f64 = 1e6;
/// Radians of turn per pixel of mouse drag (a full turn is ~2000 pixels).
pub const LOOK_RADIANS_PER_PIXEL: f64 = 0.003;
/// Shift multiplies the speed by this.
pub const FAST_FACTOR: f64 = 5.0;
/// One scroll notch scales the speed by this.
pub const SCROLL_FACTOR: f64 = 1.25;
/// Pitch stops short of straight up/down, where yaw is undefined.
const MAX_PITCH: f64 = 89.0 * std::f64::consts::PI / 180.0;
/// A frame longer than this (a stall, a restart of the pipeline) moves the
/// camera as if it took this long, so it does not jump.
const MAX_STEP_SECONDS: f64 = 0.1;

/// Position, heading and speed of the viewer's camera.
#[derive(Clone, Debug, PartialEq)]
pub struct FlyController {
    pub position: DVec3,
    /// Turn about world +Y, radians; 0 looks along -Z.
    pub yaw: f64,
    /// Up/down, radians, within +-89 degrees.
    pub pitch: f64,
    /// Model units per second.
    pub speed: f64,
    /// The scene's default speed (crossing its diagonal in 40 s), which
    /// scrolling stays within [`SPEED_RANGE`] of.
    pub base_speed: f64,
    /// Walk mode's eye height above the floor, model units.
    pub eye_height: f64,
    pub fovy: f64,
    /// Walk mode: the floor height the eye stays `eye_height` above.
    pub walk_floor: Option<f64>,
    /// The scene's floor (its bounds' lowest y), where walk mode puts you.
    pub floor: f64,
}

impl FlyController {
    /// A controller at a camera's pose (roll is dropped).
    pub fn from_pose(position: DVec3, orientation: DQuat, fovy: f64, scene: &Aabb) -> Self {
        let f = orientation * DVec3::NEG_Z;
        let mut c = FlyController {
            position,
            yaw: 0.0,
            pitch: 0.0,
            speed: default_speed(scene),
            base_speed: default_speed(scene),
            eye_height: EYE_HEIGHT,
            fovy,
            walk_floor: None,
            floor: if scene.min.y.is_finite() {
                scene.min.y
            } else {
                0.0
            },
        };
        c.look_along(f);
        c
    }

    /// The same controller for a model measured in `metres_per_unit`
    /// (0.001 for millimetres): walk mode's eye height follows; speeds
    /// already follow the scene's size.
    pub fn with_units(mut self, metres_per_unit: f64) -> Self {
        if metres_per_unit.is_finite() && metres_per_unit > 0.0 {
            self.eye_height = EYE_HEIGHT / metres_per_unit;
        }
        self
    }

    /// An overview: outside the scene's bounds, looking at its centre.
    pub fn overview(scene: &Aabb, fovy: f64) -> Self {
        let (centre, diag) = if scene.min.x.is_finite() && scene.max.x >= scene.min.x {
            (
                (scene.min + scene.max) * 0.5,
                (scene.max - scene.min).length().max(1e-3),
            )
        } else {
            (DVec3::ZERO, 10.0)
        };
        let eye = centre + DVec3::new(0.45, 0.3, 0.6).normalize() * diag * 0.75;
        let mut c = FlyController::from_pose(eye, DQuat::IDENTITY, fovy, scene);
        c.look_along(centre - eye);
        c
    }

    /// Puts the eye at a pose (roll is dropped) and leaves walk mode: a
    /// saved view's camera. Speed and eye height stay.
    pub fn set_pose(&mut self, position: DVec3, orientation: DQuat, fovy: f64) {
        self.position = position;
        self.fovy = fovy;
        self.walk_floor = None;
        self.look_along(orientation * DVec3::NEG_Z);
    }

    fn look_along(&mut self, dir: DVec3) {
        let f = dir.normalize_or(DVec3::NEG_Z);
        self.yaw = (-f.x).atan2(-f.z);
        self.pitch = f.y.clamp(-1.0, 1.0).asin().clamp(-MAX_PITCH, MAX_PITCH);
    }

    pub fn orientation(&self) -> DQuat {
        DQuat::from_rotation_y(self.yaw) * DQuat::from_rotation_x(self.pitch)
    }

    pub fn camera(&self, aspect: f64, near: f64) -> Camera {
        Camera {
            position: self.position,
            orientation: self.orientation(),
            fovy: self.fovy,
            aspect,
            near,
        }
    }

    /// Mouse drag by (dx, dy) pixels: right turns right, down looks down.
    pub fn look(&mut self, dx: f64, dy: f64) {
        self.yaw -= dx * LOOK_RADIANS_PER_PIXEL;
        self.pitch = (self.pitch - dy * LOOK_RADIANS_PER_PIXEL).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Scroll by `notches` (positive = away from the user = faster).
    pub fn scroll(&mut self, notches: f64) {
        self.speed = (self.speed * SCROLL_FACTOR.powf(notches))
            .clamp(self.base_speed / SPEED_RANGE, self.base_speed * SPEED_RANGE);
    }

    pub fn walking(&self) -> bool {
        self.walk_floor.is_some()
    }

    /// Walk mode on (eye level at eye height above the floor) or off.
    pub fn toggle_walk(&mut self) {
        if self.walk_floor.take().is_none() {
            self.walk_floor = Some(self.floor);
            self.pitch = 0.0;
            self.position.y = self.floor + self.eye_height;
        }
    }

    /// Moves for `dt` seconds with the given keys held.
    pub fn update(&mut self, dt: f64, held: &HashSet<Movement>) {
        let dt = dt.clamp(0.0, MAX_STEP_SECONDS);
        let q = self.orientation();
        let (forward, right) = if self.walking() {
            // Walking stays level: forward is the heading on the ground.
            let yaw = DQuat::from_rotation_y(self.yaw);
            (yaw * DVec3::NEG_Z, yaw * DVec3::X)
        } else {
            (q * DVec3::NEG_Z, q * DVec3::X)
        };
        let axis = |plus: Movement, minus: Movement| {
            held.contains(&plus) as i32 as f64 - held.contains(&minus) as i32 as f64
        };
        let mut dir = forward * axis(Movement::Forward, Movement::Back)
            + right * axis(Movement::Right, Movement::Left);
        if !self.walking() {
            dir += DVec3::Y * axis(Movement::Up, Movement::Down);
        }
        let mut v = self.speed;
        if held.contains(&Movement::Fast) {
            v *= FAST_FACTOR;
        }
        self.position += dir.normalize_or_zero() * v * dt;
        if let Some(floor) = self.walk_floor {
            self.position.y = floor + self.eye_height;
        }
    }
}

/// Crossing the scene's diagonal takes 40 s: slow enough to see culling
/// change, fast enough to get anywhere in a huge model (then scroll or Shift).
fn default_speed(scene: &Aabb) -> f64 {
    let d = (scene.max - scene.min).length();
    if d.is_finite() && d > 0.0 {
        d / 40.0
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene() -> Aabb {
        Aabb::new(DVec3::new(-10.0, 0.0, -10.0), DVec3::new(10.0, 5.0, 10.0))
    }

    fn held(keys: &[Movement]) -> HashSet<Movement> {
        keys.iter().copied().collect()
    }

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).length() < 1e-9
    }

    #[test]
    fn forward_at_rest_moves_along_minus_z() {
        let mut c = FlyController::from_pose(DVec3::ZERO, DQuat::IDENTITY, 1.0, &scene());
        c.speed = 2.0;
        c.update(0.05, &held(&[Movement::Forward]));
        assert!(
            close(c.position, DVec3::new(0.0, 0.0, -0.1)),
            "{:?}",
            c.position
        );
    }

    #[test]
    fn shift_is_five_times_faster_and_diagonals_are_not() {
        let mut c = FlyController::from_pose(DVec3::ZERO, DQuat::IDENTITY, 1.0, &scene());
        c.speed = 1.0;
        c.update(
            0.1,
            &held(&[Movement::Forward, Movement::Right, Movement::Fast]),
        );
        assert!((c.position.length() - 0.5).abs() < 1e-9);
    }

    #[test]
    fn a_stall_does_not_teleport() {
        let mut c = FlyController::from_pose(DVec3::ZERO, DQuat::IDENTITY, 1.0, &scene());
        c.speed = 1.0;
        c.update(5.0, &held(&[Movement::Up]));
        assert!(close(c.position, DVec3::new(0.0, MAX_STEP_SECONDS, 0.0)));
    }

    #[test]
    fn drag_right_turns_right_and_pitch_stops_at_89_degrees() {
        let mut c = FlyController::from_pose(DVec3::ZERO, DQuat::IDENTITY, 1.0, &scene());
        c.look(100.0, 0.0);
        let f = c.camera(1.0, 0.1).forward();
        assert!(f.x > 0.0, "looking right of -Z means +x: {f:?}");
        c.look(0.0, 1e6);
        assert!((c.pitch + MAX_PITCH).abs() < 1e-12);
    }

    #[test]
    fn pose_round_trips_through_yaw_and_pitch() {
        let cam = Camera::look_at(
            DVec3::new(1.0, 2.0, 3.0),
            DVec3::new(-4.0, 0.0, 1.0),
            1.0,
            1.0,
            0.1,
        );
        let c = FlyController::from_pose(cam.position, cam.orientation, 1.0, &scene());
        assert!(close(c.camera(1.0, 0.1).forward(), cam.forward()));
        assert!(close(c.camera(1.0, 0.1).up(), cam.up()));
    }

    #[test]
    fn walk_mode_keeps_eye_height_and_ignores_up_down() {
        let mut c = FlyController::from_pose(
            DVec3::new(0.0, 4.0, 0.0),
            DQuat::from_rotation_x(-0.5),
            1.0,
            &scene(),
        );
        c.toggle_walk();
        assert_eq!(c.position.y, EYE_HEIGHT);
        c.pitch = -0.7;
        c.update(0.1, &held(&[Movement::Forward, Movement::Up]));
        assert_eq!(c.position.y, EYE_HEIGHT);
        assert!(c.position.z < 0.0);
        c.toggle_walk();
        assert!(!c.walking());
    }

    #[test]
    fn set_pose_keeps_the_speed_and_leaves_walk_mode() {
        let mut c = FlyController::from_pose(DVec3::ZERO, DQuat::IDENTITY, 1.0, &scene());
        c.scroll(2.0);
        c.toggle_walk();
        let speed = c.speed;
        let q = DQuat::from_rotation_y(0.7) * DQuat::from_rotation_x(-0.2);
        c.set_pose(DVec3::new(3.0, 9.0, -1.0), q, 0.5);
        assert!(!c.walking());
        assert_eq!(
            (c.position, c.fovy, c.speed),
            (DVec3::new(3.0, 9.0, -1.0), 0.5, speed)
        );
        assert!(close(c.camera(1.0, 0.1).forward(), q * DVec3::NEG_Z));
    }

    #[test]
    fn scroll_scales_speed_and_back() {
        let mut c = FlyController::from_pose(DVec3::ZERO, DQuat::IDENTITY, 1.0, &scene());
        let s = c.speed;
        c.scroll(3.0);
        c.scroll(-3.0);
        assert!((c.speed - s).abs() < 1e-9 * s);
    }

    #[test]
    fn overview_looks_at_the_centre_from_outside() {
        let s = scene();
        let c = FlyController::overview(&s, 1.0);
        let centre = (s.min + s.max) * 0.5;
        let to_centre = (centre - c.position).normalize();
        assert!(c.camera(1.0, 0.1).forward().dot(to_centre) > 0.999);
        assert!(c.position.z > s.max.z);
    }

    #[test]
    fn empty_scene_gives_a_usable_controller() {
        let c = FlyController::overview(&Aabb::EMPTY, 1.0);
        assert!(c.position.is_finite() && c.speed > 0.0 && c.floor == 0.0);
    }

    #[test]
    fn millimetre_model_walks_at_1700_units_and_scrolls_in_its_own_range() {
        let mm = |b: Aabb| Aabb::new(b.min * 1e3, b.max * 1e3);
        let mut m = FlyController::from_pose(DVec3::ZERO, DQuat::IDENTITY, 1.0, &scene());
        let mut c = FlyController::from_pose(DVec3::ZERO, DQuat::IDENTITY, 1.0, &mm(scene()))
            .with_units(1e-3);
        assert!((c.speed - 1e3 * m.speed).abs() < 1e-9 * c.speed);
        c.toggle_walk();
        m.toggle_walk();
        assert!((c.position.y - 1e3 * m.position.y).abs() < 1e-9);
        assert!((c.position.y - 1700.0).abs() < 1e-9);
        for ctl in [&mut m, &mut c] {
            let base = ctl.base_speed;
            ctl.scroll(1e4);
            assert!((ctl.speed - base * SPEED_RANGE).abs() < 1e-6 * ctl.speed);
            ctl.scroll(-1e4);
            assert!((ctl.speed - base / SPEED_RANGE).abs() < 1e-6 * ctl.speed);
        }
    }

    #[test]
    fn bad_units_keep_metres() {
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let c = FlyController::overview(&scene(), 1.0).with_units(bad);
            assert_eq!(c.eye_height, EYE_HEIGHT);
        }
    }
}
