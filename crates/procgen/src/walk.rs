//! Camera paths that walk a scene's corridor grid (plant aisles, city
//! streets, forest trails) as a person would: eye height, walking speed,
//! smooth turns, stops to look around, and now and then a fast move.

use glam::{DQuat, DVec3, EulerRot};

use gigawalk_scene::path::{CameraPath, Pose};

use crate::rng::Rng;

/// Eye height of a standing adult, in metres (model units are metres).
pub const EYE_HEIGHT: f64 = 1.7;
/// Comfortable walking speed, m/s.
const WALK_SPEED: f64 = 1.4;
/// Fast moves (a user flying down a corridor), m/s.
const FAST_SPEED: (f64, f64) = (6.0, 12.0);
/// Sample interval: 10 poses a second, so the default 600 poses are a
/// one-minute walk.
pub const DT: f64 = 0.1;
/// Head turn rates, rad/s: a walker turns a corner in about a second; a
/// fast move whips around.
const TURN_RATE: f64 = 1.6;
const FAST_TURN_RATE: f64 = 6.0;
/// Vertical field of view of every pose.
const FOVY_DEG: f64 = 60.0;

/// Walkable corridor centre lines: x = `xs[i]` for every i and z = `zs[j]`
/// for every j, meeting at intersections.
pub struct Grid {
    pub xs: Vec<f64>,
    pub zs: Vec<f64>,
    /// Height of the walking surface.
    pub floor: f64,
}

/// A walk of `poses` poses (at [`DT`] intervals) along the grid.
pub fn walk(grid: &Grid, rng: &mut Rng, poses: usize) -> CameraPath {
    let (nx, nz) = (grid.xs.len(), grid.zs.len());
    let node_pos =
        |(i, j): (usize, usize)| DVec3::new(grid.xs[i], grid.floor + EYE_HEIGHT, grid.zs[j]);
    let mut at = (rng.below(nx), rng.below(nz));
    let mut prev = at;
    let mut pos = node_pos(at);
    let mut target = next_node(at, prev, nx, nz, rng);
    let mut speed = WALK_SPEED * rng.range(0.85, 1.15);
    let d = node_pos(target) - pos;
    let mut yaw = heading(d).unwrap_or(0.0);
    let mut pause = 0.0f64;
    let mut look_phase = 0.0f64;
    let mut out = Vec::with_capacity(poses);
    for k in 0..poses {
        let t = k as f64 * DT;
        let (look_yaw, pitch);
        if pause > 0.0 {
            // Looking around: a slow sweep left and right, glancing up at
            // what hangs overhead.
            pause -= DT;
            look_phase += DT;
            look_yaw = 1.4 * (look_phase * 0.9).sin();
            pitch = 0.35 * (look_phase * 0.6).sin().max(-0.3);
        } else {
            let to = node_pos(target) - pos;
            let dist = to.length();
            let step = speed * DT;
            if dist <= step {
                pos = node_pos(target);
                prev = at;
                at = target;
                target = next_node(at, prev, nx, nz, rng);
                if rng.chance(0.25) {
                    pause = rng.range(2.0, 4.0);
                    look_phase = 0.0;
                }
                speed = if rng.chance(0.15) {
                    rng.range(FAST_SPEED.0, FAST_SPEED.1)
                } else {
                    WALK_SPEED * rng.range(0.85, 1.15)
                };
            } else {
                pos += to / dist * step;
            }
            look_yaw = 0.25 * (t * 0.7).sin();
            pitch = 0.08 * (t * 0.5).sin();
        }
        if let Some(want) = heading(node_pos(target) - pos) {
            let rate = if speed > WALK_SPEED * 2.0 {
                FAST_TURN_RATE
            } else {
                TURN_RATE
            };
            let diff = wrap(want - yaw);
            yaw += diff.clamp(-rate * DT, rate * DT);
        }
        out.push(Pose {
            time: t,
            position: pos,
            orientation: DQuat::from_euler(EulerRot::YXZ, yaw + look_yaw, pitch, 0.0),
            fovy: FOVY_DEG.to_radians(),
        });
    }
    CameraPath { poses: out }
}

/// The yaw that looks along `d` in the XZ plane (a camera looks down its
/// local -Z, so yaw 0 looks down world -Z).
fn heading(d: DVec3) -> Option<f64> {
    (d.x * d.x + d.z * d.z > 1e-12).then(|| (-d.x).atan2(-d.z))
}

fn wrap(a: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    (a + std::f64::consts::PI).rem_euclid(tau) - std::f64::consts::PI
}

/// A random neighbour of `at`, not going straight back unless it must.
fn next_node(
    at: (usize, usize),
    prev: (usize, usize),
    nx: usize,
    nz: usize,
    rng: &mut Rng,
) -> (usize, usize) {
    let (i, j) = at;
    let mut options = Vec::with_capacity(4);
    if i > 0 {
        options.push((i - 1, j));
    }
    if i + 1 < nx {
        options.push((i + 1, j));
    }
    if j > 0 {
        options.push((i, j - 1));
    }
    if j + 1 < nz {
        options.push((i, j + 1));
    }
    if options.len() > 1 {
        options.retain(|&o| o != prev);
    }
    if options.is_empty() {
        return at;
    }
    options[rng.below(options.len())]
}
