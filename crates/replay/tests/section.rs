//! Sections end to end (lavapipe or any adapter): occlusion culling with a
//! section draws the full-detail, frustum-only reference cut by the same
//! section bit for bit, with every culler, on generated plants, cities
//! and forests at an odd viewport; a section that removes the only wall
//! in front of a hall shows the hall, also when the wall was the last
//! frames' occluder; cut solids show a hatched cap, not a hole; och keeps its
//! pixel-error bound; a distance measured between two picks is the
//! distance between the hit points a brute-force ray cast through the
//! input model's triangles finds.

mod common;

use std::path::Path;
use std::sync::Arc;

use common::{preprocess, render};
use gigawalk_cull::{default_near, pick, Camera, Ray, Section, Viewport};
use gigawalk_gpu::devices_or_skip;
use gigawalk_import::{Model, Object};
use gigawalk_procgen::{generate, Generated, Kind};
use gigawalk_replay::Mode;
use gigawalk_runtime::{CameraRequest, CullMethod, Runtime, RuntimeOptions, Schedule};
use gigawalk_scene::{Aabb, SceneReader};
use glam::{DQuat, DVec3};

/// Odd on purpose: no power of two, no even split of the HZB's levels.
const W: u32 = 157;
const H: u32 = 93;

fn generated(dir: &Path, kind: Kind, triangles: u64, seed: u64) -> (SceneReader, Generated, Model) {
    let g = generate(kind, triangles, seed, 24);
    let model = gigawalk_import::import_glb_bytes(&g.glb_bytes(), "m.glb").unwrap();
    let reader = preprocess(dir, &format!("{kind:?}-{seed}"), &model, Default::default());
    (reader, g, model)
}

fn options(schedule: Schedule, culler: CullMethod, mode: Mode, tolerance: f64) -> RuntimeOptions {
    RuntimeOptions {
        width: W,
        height: H,
        schedule,
        culler,
        traversal: mode.traversal(tolerance),
        ..Default::default()
    }
}

/// A tilted plane through the middle of `b`, a box around its middle
/// third, and that box with three planes (nine half-spaces: more than the
/// rasterizer's clip distances hold, so the fragment stage discards).
fn sections(b: &Aabb) -> Vec<Arc<Section>> {
    let c = b.center();
    let n = DVec3::new(0.3, -0.2, 0.93).normalize();
    let e = b.extent() / 3.0;
    let (lo, hi) = (c - e * 0.5, c + e * 0.5);
    vec![
        Arc::new(
            Section::new(gigawalk_cull::SectionSpec {
                planes: vec![[n.x, n.y, n.z, -n.dot(c)]],
                bbox: None,
            })
            .unwrap(),
        ),
        Arc::new(
            Section::new(gigawalk_cull::SectionSpec {
                planes: vec![],
                bbox: Some([lo.x, lo.y, lo.z, hi.x, hi.y, hi.z]),
            })
            .unwrap(),
        ),
        Arc::new(
            Section::new(gigawalk_cull::SectionSpec {
                planes: vec![
                    [n.x, n.y, n.z, -n.dot(c)],
                    [0.0, -1.0, 0.0, c.y + e.y],
                    [-0.6, 0.0, 0.8, 0.6 * c.x - 0.8 * c.z + e.x],
                ],
                bbox: Some([
                    lo.x - e.x,
                    lo.y - e.y,
                    lo.z - e.z,
                    hi.x + e.x,
                    hi.y + e.y,
                    hi.z + e.z,
                ]),
            })
            .unwrap(),
        ),
    ]
}

fn requests(
    cameras: &[Camera],
    section: &dyn Fn(usize) -> Option<Arc<Section>>,
) -> Vec<CameraRequest> {
    cameras
        .iter()
        .enumerate()
        .map(|(i, c)| CameraRequest {
            section: section(i),
            ..CameraRequest::new(*c, true)
        })
        .collect()
}

/// Every occlusion culler the runtime can run on this scene, in both
/// schedules for the HZB, draws `reference` bit for bit at pixel error 0.
fn assert_conservative(
    rt: &Runtime,
    what: &str,
    cameras: &[CameraRequest],
    reference: &[(Vec<u32>, Vec<u8>)],
) {
    let mut runs = vec![
        (Schedule::Sequential, CullMethod::Hzb),
        (Schedule::Pipelined, CullMethod::Hzb),
    ];
    for culler in [CullMethod::Oq, CullMethod::Grid, CullMethod::Ct] {
        if rt.check_culler(culler).is_ok() {
            runs.push((Schedule::Pipelined, culler));
        }
    }
    for (schedule, culler) in runs {
        for (mode, tolerance) in [(Mode::Occ, 0.0), (Mode::Och, 0.0)] {
            let got = render(
                rt,
                &options(schedule, culler, mode, tolerance),
                cameras.to_vec(),
            );
            assert_eq!(got.len(), reference.len());
            for (f, (g, r)) in got.iter().zip(reference).enumerate() {
                let differing = g.0.iter().zip(&r.0).filter(|(a, b)| a != b).count();
                assert!(
                    g.0 == r.0 && g.1 == r.1,
                    "{what}: {schedule:?} {culler:?} {mode:?} frame {f}: {differing} depth pixels differ from the reference cut by the same section"
                );
            }
        }
    }
}

fn drawn_pixels(frame: &(Vec<u32>, Vec<u8>)) -> usize {
    frame.0.iter().filter(|&&d| d != 0).count()
}

#[test]
fn occlusion_culling_with_a_section_draws_the_cut_reference_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    for (kind, seed) in [(Kind::Plant, 5), (Kind::City, 2), (Kind::Forest, 3)] {
        let (reader, g, _) = generated(dir.path(), kind, 30_000, seed);
        let Some(d) = devices_or_skip(2, "sections on generated scenes") else {
            return;
        };
        let rt = Runtime::with_devices(&reader, d).unwrap();
        let bounds = reader.skeleton().bounds();
        let near = default_near(&bounds);
        let vp = Viewport::new(W, H);
        let cameras: Vec<Camera> = g
            .path
            .poses
            .iter()
            .take(10)
            .map(|p| Camera::of_pose(p, vp, near))
            .collect();
        let reference_of = |c: &[CameraRequest]| {
            render(
                &rt,
                &options(Schedule::Sequential, CullMethod::Hzb, Mode::Vfc, 0.0),
                c.to_vec(),
            )
        };
        let uncut = reference_of(&requests(&cameras, &|_| None));
        for (k, section) in sections(&bounds).into_iter().enumerate() {
            let what = format!("{kind:?} section {k} ({})", section.describe());
            let cut = requests(&cameras, &|_| Some(section.clone()));
            let reference = reference_of(&cut);
            // The section changes the image and leaves something in it.
            assert!(reference != uncut, "{what}: the section changed nothing");
            assert!(
                reference.iter().any(|f| drawn_pixels(f) > 0),
                "{what}: nothing left"
            );
            assert_conservative(&rt, &what, &cut, &reference);
        }
    }
}

/// A closed box with every triangle wound counter-clockwise seen from
/// outside (glTF's convention), in `colour`.
fn solid_box(name: &str, min: DVec3, max: DVec3, colour: [f32; 4]) -> Object {
    let p: Vec<DVec3> = (0..8)
        .map(|i| {
            DVec3::new(
                if i & 1 == 0 { min.x } else { max.x },
                if i & 2 == 0 { min.y } else { max.y },
                if i & 4 == 0 { min.z } else { max.z },
            )
        })
        .collect();
    let faces: [[u32; 4]; 6] = [
        [0, 2, 6, 4],
        [1, 5, 7, 3],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 1, 3, 2],
        [4, 6, 7, 5],
    ];
    let centre = (min + max) * 0.5;
    let mut indices = Vec::new();
    for f in faces {
        for t in [[f[0], f[1], f[2]], [f[0], f[2], f[3]]] {
            let (a, b, c) = (p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]);
            let outward = (b - a).cross(c - a).dot((a + b + c) / 3.0 - centre) > 0.0;
            indices.extend(if outward { t } else { [t[0], t[2], t[1]] });
        }
    }
    let normals = p
        .iter()
        .map(|q| (*q - centre).normalize().as_vec3())
        .collect();
    Object {
        name: name.into(),
        positions: p,
        normals,
        indices,
        colour,
        vertex_colours: None,
        identity: gigawalk_import::Identity {
            name: name.into(),
            path: name.into(),
            ..Default::default()
        },
    }
}

fn model(objects: Vec<Object>) -> Model {
    Model {
        objects,
        stats: Default::default(),
    }
}

/// An eye at `eye` looking along -Z.
fn camera_at(eye: DVec3, near: f64) -> Camera {
    Camera::from_pose(
        eye,
        DQuat::IDENTITY,
        60f64.to_radians(),
        Viewport::new(W, H),
        near,
    )
}

#[test]
fn a_section_that_removes_the_only_wall_shows_the_hall_behind_it() {
    let dir = tempfile::tempdir().unwrap();
    // A wall at z = 0 filling the view, one object with the floor of the
    // hall behind it (so the section cuts its leaf rather than removing
    // it whole, and OR's clipping is what keeps the wall out of the
    // HZB), and on the floor 400 crates.
    let mut shell = solid_box(
        "shell",
        DVec3::new(-60.0, -30.0, -0.3),
        DVec3::new(60.0, 30.0, 0.3),
        [0.8, 0.8, 0.8, 1.0],
    );
    let floor = solid_box(
        "floor",
        DVec3::new(-60.0, -1.4, -46.0),
        DVec3::new(60.0, -1.0, 0.3),
        [0.8, 0.8, 0.8, 1.0],
    );
    let base = shell.positions.len() as u32;
    shell.positions.extend(floor.positions);
    shell.normals.extend(floor.normals);
    shell.indices.extend(floor.indices.iter().map(|i| i + base));
    let mut objects = vec![shell];
    for i in 0..20 {
        for j in 0..20 {
            let c = DVec3::new(-19.0 + 2.0 * i as f64, 0.0, -4.0 - 2.0 * j as f64);
            objects.push(solid_box(
                &format!("crate-{i}-{j}"),
                c - DVec3::new(0.6, 1.0, 0.6),
                c + DVec3::new(0.6, 1.0, 0.6),
                [0.2, 0.5, 0.9, 1.0],
            ));
        }
    }
    let reader = preprocess(dir.path(), "hall", &model(objects), Default::default());
    assert!(
        reader.skeleton().nodes().len() > 3,
        "the hall and the wall share one leaf"
    );
    let Some(d) = devices_or_skip(2, "a section revealing a hall") else {
        return;
    };
    let rt = Runtime::with_devices(&reader, d).unwrap();
    let near = default_near(&reader.skeleton().bounds());
    // Walking toward the wall; from frame 4 on a plane keeps z <= -1
    // (removing the wall, keeping the hall), so for two frames the HZB's
    // occluders are the wall's last visible set.
    let cameras: Vec<Camera> = (0..10)
        .map(|i| camera_at(DVec3::new(0.0, 1.0, 14.0 - 0.3 * i as f64), near))
        .collect();
    let plane = Arc::new(Section::parse(&["0 0 -1 -1".into()], None).unwrap());
    let from_4 = |i: usize| (i >= 4).then(|| plane.clone());
    let cut = requests(&cameras, &from_4);
    let reference = render(
        &rt,
        &options(Schedule::Sequential, CullMethod::Hzb, Mode::Vfc, 0.0),
        cut.clone(),
    );
    let uncut = render(
        &rt,
        &options(Schedule::Sequential, CullMethod::Hzb, Mode::Vfc, 0.0),
        requests(&cameras, &|_| None),
    );
    // Before the cut the wall fills the image; after it the hall shows,
    // with background between the crates.
    for (f, (frame, whole)) in reference.iter().zip(&uncut).enumerate() {
        let drawn = drawn_pixels(frame);
        if f < 4 {
            assert_eq!(
                drawn,
                (W * H) as usize,
                "frame {f}: the wall fills the view"
            );
        } else {
            assert!(
                drawn > 500 && drawn < (W * H) as usize * 9 / 10,
                "frame {f}: {drawn} pixels drawn"
            );
            assert!(frame != whole);
        }
    }
    // What the reference shows is what a pick cut by the section hits.
    let vp = Viewport::new(W, H);
    let table = reader.objects().unwrap().unwrap();
    for f in [4, 9] {
        let c = cameras[f];
        let mut checked = 0;
        for py in (2..H).step_by(7) {
            for px in (1..W).step_by(9) {
                let hit_at = |dx: f64, dy: f64| {
                    let ray = c
                        .pixel_ray(vp, px as f64 + 0.5 + dx, py as f64 + 0.5 + dy)
                        .unwrap();
                    let ray = ray.clipped(Some(&plane)).unwrap();
                    pick(
                        reader.skeleton(),
                        Some(&table),
                        &ray,
                        &|_| false,
                        &|_| false,
                        &mut |l| reader.read_lod(l),
                    )
                    .unwrap()
                    .0
                    .is_some()
                };
                let hit = hit_at(0.0, 0.0);
                // Away from silhouettes.
                if [(-0.6, 0.0), (0.6, 0.0), (0.0, -0.6), (0.0, 0.6)]
                    .iter()
                    .any(|&(dx, dy)| hit_at(dx, dy) != hit)
                {
                    continue;
                }
                checked += 1;
                let depth = reference[f].0[(py * W + px) as usize];
                assert_eq!(depth != 0, hit, "frame {f} pixel {px},{py}");
            }
        }
        assert!(checked > 150, "{checked} pixels checked");
    }
    assert_conservative(&rt, "the hall", &cut, &reference);
}

#[test]
fn a_cut_solid_shows_its_cap_not_a_hole() {
    let dir = tempfile::tempdir().unwrap();
    let objects = vec![
        solid_box(
            "a",
            DVec3::new(-3.0, -1.0, -1.0),
            DVec3::new(-1.0, 1.0, 1.0),
            [0.9, 0.3, 0.2, 1.0],
        ),
        solid_box(
            "b",
            DVec3::new(1.0, -1.5, -2.0),
            DVec3::new(3.0, 1.5, 0.5),
            [0.3, 0.8, 0.3, 1.0],
        ),
    ];
    let reader = preprocess(dir.path(), "solids", &model(objects), Default::default());
    let Some(d) = devices_or_skip(2, "caps on cut solids") else {
        return;
    };
    let rt = Runtime::with_devices(&reader, d).unwrap();
    // Looking down -Z from z = 8 at a slant, a plane keeps z <= 0: both
    // boxes are cut, the eye is on the removed side.
    let rot = DQuat::from_rotation_x(-0.35);
    let camera = Camera::from_pose(
        DVec3::new(0.0, 3.0, 8.0),
        rot,
        60f64.to_radians(),
        Viewport::new(W, H),
        0.05,
    );
    let plane = Arc::new(Section::parse(&["0 0 -1 0".into()], None).unwrap());
    let opts = options(Schedule::Sequential, CullMethod::Hzb, Mode::Vfc, 0.0);
    let cut = render(&rt, &opts, requests(&[camera], &|_| Some(plane.clone())));
    let whole = render(&rt, &opts, requests(&[camera], &|_| None));
    let vp = Viewport::new(W, H);
    let mut inside = 0;
    // Each cap's brightest and darkest sample: caps are hatched.
    let mut shades = [(u32::MAX, 0u32); 2];
    // Points well inside each cut face (z = 0), projected to pixels.
    for (lo, hi) in [((-3.0, -1.0), (-1.0, 1.0)), ((1.0, -1.5), (3.0, 1.5))] {
        for i in 1..8 {
            for j in 1..8 {
                let x = lo.0 + (hi.0 - lo.0) * (0.1 + 0.8 * i as f64 / 8.0);
                let y = lo.1 + (hi.1 - lo.1) * (0.1 + 0.8 * j as f64 / 8.0);
                let p = DVec3::new(x, y, 0.0) - camera.position;
                let clip = camera.view_projection_rel_f64() * p.extend(1.0);
                let (nx, ny) = (clip.x / clip.w, clip.y / clip.w);
                let px = ((nx + 1.0) * 0.5 * vp.width as f64) as u32;
                let py = ((1.0 - ny) * 0.5 * vp.height as f64) as u32;
                let k = (py * W + px) as usize;
                assert_ne!(
                    cut[0].0[k], 0,
                    "background inside the cut at {px},{py}: a hole"
                );
                // The cap: the object's colour at most half as bright
                // (the uncut box's lit face there is brighter than that).
                let colour = if lo.0 < 0.0 {
                    [0.9, 0.3, 0.2]
                } else {
                    [0.3, 0.8, 0.3]
                };
                let c = &cut[0].1[4 * k..4 * k + 3];
                let w = &whole[0].1[4 * k..4 * k + 3];
                for ch in 0..3 {
                    let most = srgb(0.5 * colour[ch]);
                    assert!(
                        c[ch] <= most + 2,
                        "pixel {px},{py}: {c:?} is no cap (at most {most} in channel {ch}; the uncut face is {w:?})"
                    );
                }
                assert!(
                    w.iter().zip(c).any(|(w, c)| w > c),
                    "pixel {px},{py}: {w:?} against {c:?}"
                );
                let sum = c.iter().map(|&v| v as u32).sum::<u32>();
                let s = &mut shades[(lo.0 > 0.0) as usize];
                *s = (s.0.min(sum), s.1.max(sum));
                inside += 1;
            }
        }
    }
    assert_eq!(inside, 98);
    // The hatching's lines are under 0.7 of the cap's plain shade.
    for (dark, light) in shades {
        assert!(dark * 10 < light * 7, "no hatching: {dark} against {light}");
    }
}

/// A linear channel as the sRGB target stores it.
fn srgb(linear: f64) -> u8 {
    let v = if linear <= 0.0031308 {
        12.92 * linear
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    };
    (v * 255.0).round() as u8
}

#[test]
fn och_keeps_its_bound_with_a_section() {
    let dir = tempfile::tempdir().unwrap();
    let (reader, g, _) = generated(dir.path(), Kind::Plant, 60_000, 7);
    if devices_or_skip(2, "och's bound with a section").is_none() {
        return;
    }
    let bounds = reader.skeleton().bounds();
    let section = sections(&bounds).remove(0);
    let run = |section: Option<Arc<Section>>| {
        let opts = gigawalk_replay::ReplayOptions {
            modes: vec![Mode::Och],
            pixel_errors: vec![1.0],
            frames: Some(24),
            accuracy_every: 3,
            warmup: 2,
            section,
            ..Default::default()
        };
        let r = gigawalk_replay::replay(
            &reader,
            "plant",
            &g.path.poses,
            "walk",
            &opts,
            &mut gigawalk_replay::NoProgress,
        )
        .unwrap();
        let m = r.summary().modes.remove(0);
        (
            m.bound_exceeding_fraction.unwrap(),
            m.mean_triangles,
            m.mean_section_culled,
        )
    };
    let (uncut, uncut_tris, none_culled) = run(None);
    let (cut, cut_tris, culled) = run(Some(section));
    assert_eq!(none_culled, 0.0);
    assert!(culled > 0.0, "the section dropped no node");
    assert!(
        cut_tris < uncut_tris,
        "{cut_tris} triangles cut against {uncut_tris}"
    );
    assert!(
        cut <= uncut.max(0.0) + 0.001,
        "beyond the bound: {cut} with the section, {uncut} without"
    );
}

/// The nearest hit of `ray` on the model's triangles.
fn brute_force(model: &Model, ray: &Ray) -> Option<f64> {
    let mut best: Option<f64> = None;
    for o in &model.objects {
        for t in o.indices.chunks_exact(3) {
            let p = |i: u32| o.positions[i as usize];
            if let Some((d, _)) = gigawalk_cull::pick::intersect(ray, p(t[0]), p(t[1]), p(t[2])) {
                best = Some(best.map_or(d, |b: f64| b.min(d)));
            }
        }
    }
    best
}

#[test]
fn a_measured_distance_is_the_distance_between_the_models_hit_points() {
    let dir = tempfile::tempdir().unwrap();
    let g = generate(Kind::Plant, 12_000, 3, 24);
    let model = gigawalk_import::import_glb_bytes(&g.glb_bytes(), "m.glb").unwrap();
    let mut worst = Vec::new();
    for (name, bits) in [
        ("f32", gigawalk_preprocess::PositionBits::F32),
        ("grid", gigawalk_preprocess::Params::default().position_bits),
    ] {
        let params = gigawalk_preprocess::Params {
            position_bits: bits,
            ..Default::default()
        };
        let reader = preprocess(dir.path(), name, &model, params);
        let table = reader.objects().unwrap().unwrap();
        let skeleton = reader.skeleton();
        let bounds = skeleton.bounds();
        let diagonal = bounds.extent().length();
        let section = sections(&bounds).remove(0);
        let near = default_near(&bounds);
        let vp = Viewport::new(W, H);
        let mut errors = Vec::new();
        for pose in [0, 9, 20] {
            let camera = Camera::of_pose(&g.path.poses[pose], vp, near);
            let ray = |px: u32, py: u32| {
                camera
                    .pixel_ray(vp, px as f64 + 0.5, py as f64 + 0.5)
                    .unwrap()
                    .clipped(Some(&section))
            };
            let picked = |r: &Ray| {
                pick(
                    skeleton,
                    Some(&table),
                    r,
                    &|_| false,
                    &|_| false,
                    &mut |l| reader.read_lod(l),
                )
                .unwrap()
                .0
                .map(|h| h.point)
            };
            let truth = |r: &Ray| brute_force(&model, r).map(|t| r.origin + r.dir * t);
            let points: Vec<(DVec3, DVec3)> = (0..12)
                .filter_map(|k| {
                    let r = ray(7 + 13 * k, 5 + 7 * k)?;
                    Some((picked(&r)?, truth(&r)?))
                })
                .collect();
            for pair in points.windows(2) {
                let measured = pair[0].0.distance(pair[1].0);
                let exact = pair[0].1.distance(pair[1].1);
                // Only where both picks hit the surface the model's ray cast hits (not a
                // surface just behind another, which quantization can swap).
                if pair.iter().all(|(p, t)| p.distance(*t) < 1e-3 * diagonal) {
                    errors.push((measured - exact).abs() / diagonal);
                }
            }
        }
        assert!(
            errors.len() >= 10,
            "{name}: {} pairs measured",
            errors.len()
        );
        let max = errors.iter().copied().fold(0.0, f64::max);
        worst.push((name, max));
    }
    eprintln!("largest measurement error over the diagonal: {worst:?}");
    // Full-precision positions: exact to 1e-6 of the diagonal. The
    // default grid moves each point by its leaf's quantization (further
    // along a grazing ray): a few millionths.
    assert!(worst[0].1 <= 1e-6, "{worst:?}");
    assert!(worst[1].1 <= 1e-4, "{worst:?}");
}
