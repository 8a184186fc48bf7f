//! Random culling scenes and the brute-force "no false cull" check, shared
//! by the culling integration tests and benches.

#![allow(dead_code)] // each test file uses its own subset

use gigawalk_cull::{Camera, CullView, Hzb, HzbOcclusion, OcclusionTest, Reduction, Viewport};
use gigawalk_scene::Aabb;
use gigawalk_suite::raster::{for_each_box_fragment, DepthImage};
use glam::{DQuat, DVec3, EulerRot};
use rand::rngs::SmallRng;
use rand::RngExt;

/// A camera, occluder boxes drawn into the depth image, and boxes to test.
#[derive(Clone, Debug)]
pub struct Scene {
    pub camera: Camera,
    pub viewport: Viewport,
    pub occluders: Vec<Aabb>,
    pub tests: Vec<Aabb>,
}

/// A random camera looking into a random field of boxes. Occluders sit
/// between 3 x near and 25 units, test boxes anywhere from half the near
/// distance to 80 units, so some test boxes hide behind occluders, some
/// peek around them and some cross the near plane. A tenth of the boxes
/// have zero thickness on some axis.
pub fn random_scene(rng: &mut SmallRng, width: u32, height: u32, tests: usize) -> Scene {
    let viewport = Viewport::new(width, height);
    let orientation = DQuat::from_euler(
        EulerRot::YXZ,
        rng.random_range(0.0..std::f64::consts::TAU),
        rng.random_range(-1.2..1.2),
        rng.random_range(-0.5..0.5),
    );
    let camera = Camera {
        position: DVec3::new(
            rng.random_range(-100.0..100.0),
            rng.random_range(-100.0..100.0),
            rng.random_range(-100.0..100.0),
        ),
        orientation,
        fovy: rng.random_range(20f64..120.0).to_radians(),
        aspect: viewport.aspect(),
        near: rng.random_range(0.05..1.0),
    };
    let n_occ = rng.random_range(1..=8);
    let occluders = (0..n_occ)
        .map(|_| {
            let d = rng.random_range(camera.near * 3.0..25.0);
            random_box(rng, &camera, d, true)
        })
        .collect();
    let mut tests: Vec<Aabb> = (0..tests)
        .map(|_| {
            let d = rng.random_range(camera.near * 0.5..80.0);
            random_box(rng, &camera, d, false)
        })
        .collect();
    // Boxes inside an occluder, flush with one of its faces: exact depth
    // ties with the occluder's surface, which must count as visible.
    for o in &occluders {
        tests.push(flush_sub_box(rng, o));
    }
    Scene {
        camera,
        viewport,
        occluders,
        tests,
    }
}

/// A box centred about `d` units ahead, somewhat beyond the frustum's sides.
fn random_box(rng: &mut SmallRng, camera: &Camera, d: f64, wall: bool) -> Aabb {
    let ty = camera.tan_half_fovy();
    let tx = ty * camera.aspect;
    let local = DVec3::new(
        rng.random_range(-1.2..1.2) * tx * d,
        rng.random_range(-1.2..1.2) * ty * d,
        -d,
    );
    let centre = camera.position + camera.orientation * local;
    let mut half = if wall {
        let mut h = DVec3::new(
            rng.random_range(0.5..8.0),
            rng.random_range(0.5..8.0),
            rng.random_range(0.5..8.0),
        );
        h[rng.random_range(0..3usize)] = rng.random_range(0.0..0.2);
        h
    } else {
        let s = rng.random_range(0.005..3.0);
        DVec3::new(
            s * rng.random_range(0.2..1.0),
            s * rng.random_range(0.2..1.0),
            s * rng.random_range(0.2..1.0),
        )
    };
    if rng.random_range(0..10) == 0 {
        half[rng.random_range(0..3usize)] = 0.0;
    }
    Aabb::new(centre - half, centre + half)
}

/// A random box inside `o` that shares one of its faces.
fn flush_sub_box(rng: &mut SmallRng, o: &Aabb) -> Aabb {
    let e = o.extent();
    let mut min = o.min
        + e * DVec3::new(
            rng.random_range(0.0..0.5),
            rng.random_range(0.0..0.5),
            rng.random_range(0.0..0.5),
        );
    let mut max = o.max
        - e * DVec3::new(
            rng.random_range(0.0..0.5),
            rng.random_range(0.0..0.5),
            rng.random_range(0.0..0.5),
        );
    let axis = rng.random_range(0..3usize);
    if rng.random_range(0..2) == 0 {
        min[axis] = o.min[axis];
    } else {
        max[axis] = o.max[axis];
    }
    Aabb::new(min, max)
}

/// The occluders drawn by the reference rasterizer.
pub fn render_occluders(scene: &Scene) -> DepthImage {
    let mut img = DepthImage::new(scene.viewport.width, scene.viewport.height);
    let vp = scene.camera.view_projection_rel_f64();
    for b in &scene.occluders {
        img.draw_box(&vp, scene.camera.position, b);
    }
    img
}

/// What the HZB test said about one test box.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tally {
    pub tested: usize,
    pub culled: usize,
}

/// Builds the HZB of the scene's occluders, tests every test box, and for
/// every box the test culls, rasterizes it and checks that no fragment is
/// nearer than (or as near as) the stored depth: a culled box must fail
/// the GreaterEqual depth test everywhere. Returns the per-box decisions.
pub fn check_no_false_culls(scene: &Scene, label: &str) -> (Vec<bool>, Tally) {
    check_no_false_culls_split(scene, label, gigawalk_cull::SPLITS)
}

/// [`check_no_false_culls`] with boxes split `splits` times deep.
pub fn check_no_false_culls_split(scene: &Scene, label: &str, splits: u8) -> (Vec<bool>, Tally) {
    let img = render_occluders(scene);
    let hzb = Hzb::build(img.width, img.height, &img.depth, Reduction::Farthest).unwrap();
    let view = CullView::new(scene.camera, scene.viewport);
    let vp = scene.camera.view_projection_rel_f64();
    let test = HzbOcclusion::new(&hzb).with_splits(splits);
    let mut tally = Tally::default();
    let mut decisions = Vec::with_capacity(scene.tests.len());
    for (i, b) in scene.tests.iter().enumerate() {
        let visible = test.is_visible(&view, &view.rel_box(b));
        decisions.push(visible);
        tally.tested += 1;
        if visible {
            continue;
        }
        tally.culled += 1;
        for_each_box_fragment(
            img.width,
            img.height,
            &vp,
            scene.camera.position,
            b,
            |x, y, z| {
                let stored = img.get(x, y);
                assert!(
                    z < stored as f64,
                    "{label}: false cull of test box {i} {b:?}: fragment ({x}, {y}) depth {z} \
                 vs stored {stored}; {}x{} image, camera {:?}",
                    img.width,
                    img.height,
                    scene.camera,
                );
            },
        );
    }
    (decisions, tally)
}
