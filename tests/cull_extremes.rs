//! Numerical extremes: the culling core decides the same for a scene
//! translated by 10^7 or scaled by 10^-3 and 10^4, and stays conservative
//! (never NaN, never a panic) with a 10^-4 near plane, 1 and 170 degree
//! fields of view, the eye inside a box, zero-thickness boxes and a 1x1
//! viewport.

mod cull_common;

use cull_common::{check_no_false_culls, random_scene, Scene};
use gigawalk_cull::{
    BoxProjection, Containment, CullView, DrawItem, Hzb, HzbOcclusion, Reduction, TraversalOptions,
    Viewport, ALL_PLANES,
};
use gigawalk_scene::{Aabb, Node, Provenance, Skeleton, NO_NODE};
use gigawalk_suite::raster::DepthImage;
use gigawalk_suite::scenes::bare_lod;
use glam::DVec3;
use rand::rngs::SmallRng;
use rand::SeedableRng;

const SEEDS: std::ops::Range<u64> = 0..60;

fn plain(seed: u64) -> Scene {
    random_scene(&mut SmallRng::seed_from_u64(seed), 160, 90, 40)
}

/// The same scene and camera mapped by p -> p x scale + offset.
fn transformed(s: &Scene, offset: DVec3, scale: f64) -> Scene {
    let map = |b: &Aabb| Aabb::new(b.min * scale + offset, b.max * scale + offset);
    let mut t = s.clone();
    t.camera.position = s.camera.position * scale + offset;
    t.camera.near = s.camera.near * scale;
    t.occluders = s.occluders.iter().map(map).collect();
    t.tests = s.tests.iter().map(map).collect();
    t
}

/// Per test box: (outside the frustum, visible to the HZB test), after
/// checking the HZB test against brute force.
fn decide(s: &Scene, label: &str) -> Vec<(bool, bool)> {
    let (visible, _) = check_no_false_culls(s, label);
    let view = CullView::new(s.camera, s.viewport);
    s.tests
        .iter()
        .zip(visible)
        .map(|(b, v)| {
            let (min, max) = view.rel_f64(b);
            let outside = view.frustum.test(min, max, ALL_PLANES).0 == Containment::Outside;
            if let BoxProjection::Screen {
                ndc_min,
                ndc_max,
                nearest_depth,
            } = view.project_box(&view.rel_box(b))
            {
                assert!(
                    ndc_min.iter().chain(&ndc_max).all(|x| !x.is_nan())
                        && nearest_depth.is_finite(),
                    "{label}: NaN projecting {b:?}"
                );
            }
            (outside, v)
        })
        .collect()
}

/// Decisions of a variant equal the plain scene's, box by box.
fn check_same(offset: DVec3, scale: f64) {
    let mut boxes = 0;
    for seed in SEEDS {
        let p = plain(seed);
        let want = decide(&p, &format!("seed {seed} plain"));
        let label = format!("seed {seed} offset {offset} scale {scale}");
        let got = decide(&transformed(&p, offset, scale), &label);
        for (i, (w, g)) in want.iter().zip(&got).enumerate() {
            assert_eq!(w, g, "{label}: test box {i} {:?}", p.tests[i]);
        }
        boxes += want.len();
    }
    assert!(boxes > 1000);
}

#[test]
fn translated_by_ten_million_culls_the_same() {
    check_same(DVec3::new(1e7 + 0.37, -1e7, 1e7 - 0.11), 1.0);
}

#[test]
fn scaled_down_by_a_thousand_culls_the_same() {
    check_same(DVec3::ZERO, 1e-3);
}

#[test]
fn scaled_up_by_ten_thousand_culls_the_same() {
    check_same(DVec3::ZERO, 1e4);
}

#[test]
fn tiny_near_plane_culls_the_same_beyond_the_old_near_plane() {
    let mut compared = 0;
    for seed in SEEDS {
        let p = plain(seed);
        let want = decide(&p, &format!("seed {seed} plain"));
        let mut t = p.clone();
        t.camera.near = 1e-4;
        let got = decide(&t, &format!("seed {seed} near 1e-4"));
        let view = CullView::new(p.camera, p.viewport);
        let beyond_near = |b: &Aabb| {
            matches!(
                view.project_box(&view.rel_box(b)),
                BoxProjection::Screen { .. }
            )
        };
        // Depth = near / distance: scaling near scales every depth alike, so
        // only boxes reaching the old near plane may decide otherwise, and
        // occluders reaching it draw more (no longer clipped) and hide more.
        if !p.occluders.iter().all(beyond_near) {
            continue;
        }
        compared += 1;
        for (i, b) in p.tests.iter().enumerate() {
            if beyond_near(b) {
                assert_eq!(want[i], got[i], "seed {seed} box {i}");
            }
        }
    }
    assert!(compared > 10, "only {compared} scenes compared");
}

#[test]
fn extreme_fields_of_view_stay_conservative() {
    for fovy in [1f64, 170.0] {
        let mut culled = 0;
        for seed in SEEDS {
            let mut s = plain(seed);
            s.camera.fovy = fovy.to_radians();
            let (v, _) = check_no_false_culls(&s, &format!("seed {seed} fovy {fovy}"));
            decide(&s, &format!("seed {seed} fovy {fovy}"));
            culled += v.iter().filter(|v| !**v).count();
        }
        assert!(culled > 0, "fovy {fovy}: nothing culled");
    }
}

#[test]
fn one_pixel_viewport_stays_conservative() {
    for seed in SEEDS {
        let mut s = plain(seed);
        s.viewport = Viewport::new(1, 1);
        s.camera.aspect = 1.0;
        decide(&s, &format!("seed {seed} 1x1"));
    }
}

#[test]
fn eye_inside_a_box() {
    for seed in SEEDS {
        let mut s = plain(seed);
        let eye = s.camera.position;
        let around = Aabb::new(eye - DVec3::splat(0.5), eye + DVec3::new(2.0, 0.5, 0.5));
        // As a test box it is visible; as an occluder it hides everything
        // outside it, and the brute-force check agrees.
        s.tests.push(around);
        let d = decide(&s, &format!("seed {seed} eye in test box"));
        assert!(
            d.last().unwrap().1,
            "seed {seed}: box around the eye culled"
        );
        s.occluders.push(around);
        s.tests.pop();
        decide(&s, &format!("seed {seed} eye in occluder"));
    }
}

#[test]
fn zero_thickness_boxes_face_on_and_edge_on() {
    for seed in SEEDS {
        let mut s = plain(seed);
        let f = s.camera.forward();
        let c = s.camera.position + f * 10.0;
        // A flat square facing the camera's dominant axis, and a point box.
        let axis = f.abs().max_position();
        let mut half = DVec3::splat(2.0);
        half[axis] = 0.0;
        s.occluders.push(Aabb::new(c - half, c + half));
        s.tests.push(Aabb::new(c + f * 5.0, c + f * 5.0));
        s.tests.push(Aabb::new(c - half * 0.5, c + half * 0.5));
        decide(&s, &format!("seed {seed} zero thickness"));
    }
}

/// A root over one leaf per box, LOD errors proportional to `scale`.
fn flat_skeleton(boxes: &[Aabb], scale: f64) -> Skeleton {
    let lod = |error: f64, triangles| bare_lod(error as f32, triangles);
    let bounds = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
    let mut nodes = vec![Node {
        bounds,
        parent: NO_NODE,
        first_child: 1,
        child_count: boxes.len() as u32,
        first_lod: 0,
        lod_count: 0,
    }];
    let mut lods = Vec::new();
    for (i, b) in boxes.iter().enumerate() {
        nodes.push(Node {
            bounds: *b,
            parent: 0,
            first_child: 0,
            child_count: 0,
            first_lod: lods.len() as u32,
            lod_count: 3,
        });
        let e = 0.001 * (1 + i % 7) as f64 * scale;
        lods.extend([lod(0.0, 1000), lod(e, 100), lod(10.0 * e, 10)]);
    }
    Skeleton::new(bounds.center(), bounds, nodes, lods, Provenance::default())
        .expect("a valid skeleton")
}

fn traverse_scene(s: &Scene, scale: f64) -> Vec<DrawItem> {
    let mut img = DepthImage::new(s.viewport.width, s.viewport.height);
    let vp = s.camera.view_projection_rel_f64();
    for b in &s.occluders {
        img.draw_box(&vp, s.camera.position, b);
    }
    let hzb = Hzb::build(img.width, img.height, &img.depth, Reduction::Farthest).unwrap();
    let view = CullView::new(s.camera, s.viewport);
    let mut items = Vec::new();
    gigawalk_cull::traverse(
        &flat_skeleton(&s.tests, scale),
        &view,
        &HzbOcclusion::new(&hzb),
        &TraversalOptions::default(),
        &mut |i| items.push(i),
    );
    items
}

#[test]
fn traversal_is_the_same_translated_and_scaled() {
    for seed in SEEDS {
        let p = plain(seed);
        let want = traverse_scene(&p, 1.0);
        assert!(!want.is_empty());
        for (offset, scale) in [
            (DVec3::splat(1e7), 1.0),
            (DVec3::ZERO, 1e-3),
            (DVec3::ZERO, 1e4),
        ] {
            let got = traverse_scene(&transformed(&p, offset, scale), scale);
            assert_eq!(got, want, "seed {seed} offset {offset} scale {scale}");
        }
    }
}
