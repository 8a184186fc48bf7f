//! Object identity end to end, on generated scenes: a pick is the object
//! a brute-force ray cast through the input model's triangles finds,
//! objects Partition-I split and objects clustering merged included; no
//! drawn LOD stands for a hidden object at any tolerance; a hidden object
//! leaves exactly its own pixels and occlusion culling stays conservative
//! (lavapipe or any adapter); in x-ray a hidden object shows faint where
//! it showed, hiding nothing; find matches glTF node names and OBJ groups
//! of several files made one model.

mod common;

use std::collections::{HashMap, HashSet};
use std::path::Path;
use std::sync::Arc;

use common::render;
use gigawalk_cull::{
    default_near, pick, traverse, Camera, CullView, NoOcclusion, NodeShow, Ray, TraversalOptions,
    Viewport, Visibility,
};
use gigawalk_gpu::devices_or_skip;
use gigawalk_import::Model;
use gigawalk_procgen::{generate, Generated, Kind};
use gigawalk_replay::Mode;
use gigawalk_runtime::{CameraRequest, CullMethod, Runtime, RuntimeOptions, Schedule};
use gigawalk_scene::objects::{ObjectTable, Pattern};
use gigawalk_scene::SceneReader;
use glam::DVec3;

const W: u32 = 160;
const H: u32 = 90;

struct Built {
    reader: SceneReader,
    table: ObjectTable,
    model: Model,
    generated: Generated,
}

/// A generated scene preprocessed with `params` into `dir`.
fn build(
    dir: &Path,
    kind: Kind,
    triangles: u64,
    seed: u64,
    params: gigawalk_preprocess::Params,
) -> Built {
    let generated = generate(kind, triangles, seed, 24);
    let model = gigawalk_import::import_glb_bytes(&generated.glb_bytes(), "m.glb").unwrap();
    let reader = common::preprocess(dir, &format!("{kind:?}-{seed}"), &model, params);
    let table = reader.objects().unwrap().expect("a new scene has identity");
    Built {
        reader,
        table,
        model,
        generated,
    }
}

/// The nearest hit of `ray` per object identity (path) of the model:
/// (distance, path) of the nearest, and the nearest distance of any
/// other identity.
fn brute_force(model: &Model, ray: &Ray) -> Option<((f64, String), f64)> {
    let mut per: HashMap<&str, f64> = HashMap::new();
    for o in &model.objects {
        for t in o.indices.chunks_exact(3) {
            let p = |i: u32| o.positions[i as usize];
            if let Some((d, _)) = gigawalk_cull::pick::intersect(ray, p(t[0]), p(t[1]), p(t[2])) {
                let e = per.entry(o.identity.path.as_str()).or_insert(f64::INFINITY);
                *e = e.min(d);
            }
        }
    }
    let mut hits: Vec<(f64, &str)> = per.into_iter().map(|(k, d)| (d, k)).collect();
    hits.sort_by(|a, b| a.0.total_cmp(&b.0));
    let first = hits.first()?;
    let second = hits.get(1).map_or(f64::INFINITY, |h| h.0);
    Some(((first.0, first.1.to_string()), second))
}

/// The pick of `ray` on `b`'s scene, skipping objects `skip` names.
fn pick_in(b: &Built, ray: &Ray, skip: &dyn Fn(u32) -> bool) -> Option<gigawalk_cull::PickHit> {
    let skeleton = b.reader.skeleton();
    pick(
        skeleton,
        Some(&b.table),
        ray,
        &|_| false,
        skip,
        &mut |lod| b.reader.read_lod(lod),
    )
    .unwrap()
    .0
}

#[test]
fn a_pick_is_the_object_a_brute_force_ray_cast_through_the_model_finds() {
    let dir = tempfile::tempdir().unwrap();
    for (kind, seed) in [(Kind::Plant, 3), (Kind::Machine, 4)] {
        // Partition-I splits every object of more than 64 triangles.
        let params = gigawalk_preprocess::Params {
            t1: 64,
            ..Default::default()
        };
        let b = build(dir.path(), kind, 12_000, seed, params);
        let skeleton = b.reader.skeleton();
        // Split objects (runs in several leaves) and merged leaves
        // (several objects) are both there.
        let mut leaves_of: HashMap<u32, HashSet<u32>> = HashMap::new();
        let mut merged = 0;
        for (lod, runs) in b.table.lod_runs() {
            let objects: HashSet<u32> = runs.iter().map(|r| r.object).collect();
            merged += usize::from(objects.len() > 1);
            for o in objects {
                leaves_of.entry(o).or_default().insert(lod);
            }
        }
        let split = leaves_of.values().filter(|l| l.len() > 1).count();
        assert!(
            split > 0 && merged > 0,
            "{kind:?}: {split} split, {merged} merged"
        );
        // Quantization moves full detail by at most the leaves' finest
        // stored error: closer calls than that are not the test's.
        let moved = skeleton
            .nodes()
            .iter()
            .filter(|n| n.is_leaf())
            .map(|n| skeleton.lod(n.first_lod).error as f64)
            .fold(0.0, f64::max);
        let near = default_near(&skeleton.bounds());
        let vp = Viewport::new(W, H);
        let (mut compared, mut hits) = (0, 0);
        for pose in [0, 9, 20] {
            let camera = Camera::of_pose(&b.generated.path.poses[pose], vp, near);
            for py in (4..H).step_by(11) {
                for px in (3..W).step_by(13) {
                    let at = |dx: f64, dy: f64| {
                        camera
                            .pixel_ray(vp, px as f64 + 0.5 + dx, py as f64 + 0.5 + dy)
                            .unwrap()
                    };
                    let ray = at(0.0, 0.0);
                    let truth = brute_force(&b.model, &ray);
                    // Robust: the same object a fifth of a pixel away
                    // either way, and no other within the quantization.
                    let robust = [(-0.2, 0.0), (0.2, 0.0), (0.0, -0.2), (0.0, 0.2)]
                        .iter()
                        .all(|&(dx, dy)| {
                            let j = brute_force(&b.model, &at(dx, dy));
                            j.as_ref().map(|j| &j.0 .1) == truth.as_ref().map(|t| &t.0 .1)
                        })
                        && truth.as_ref().is_none_or(|((d, _), second)| {
                            *second - *d > 4.0 * moved + 1e-9 * d.abs()
                        });
                    if !robust {
                        continue;
                    }
                    let hit = pick_in(&b, &ray, &|_| false);
                    compared += 1;
                    match (&truth, hit) {
                        (None, None) => {}
                        (Some(((d, path), _)), Some(h)) => {
                            hits += 1;
                            let o = b.table.object(h.object.unwrap()).unwrap();
                            assert_eq!(&o.path, path, "{kind:?} pose {pose} pixel {px},{py}");
                            assert!(
                                (h.distance - d).abs() <= 50.0 * moved + 1e-9 * d,
                                "{kind:?} pose {pose} pixel {px},{py}: {} against {d}",
                                h.distance
                            );
                        }
                        (t, h) => {
                            panic!("{kind:?} pose {pose} pixel {px},{py}: {t:?} against {h:?}")
                        }
                    }
                }
            }
        }
        assert!(
            compared >= 120 && hits >= 60,
            "{kind:?}: {compared} compared, {hits} hits"
        );
    }
}

#[test]
fn no_drawn_lod_stands_for_a_hidden_object_at_any_tolerance() {
    let dir = tempfile::tempdir().unwrap();
    let b = build(dir.path(), Kind::Plant, 20_000, 7, Default::default());
    let skeleton = b.reader.skeleton();
    let below = b.table.node_objects(skeleton);
    let n = b.table.objects().len() as u32;
    let hidden: HashSet<u32> = (0..n).filter(|o| o % 5 == 2).collect();
    let vis = Arc::new(Visibility::new(
        skeleton,
        &b.table,
        &|o| hidden.contains(&o),
        &|_| false,
    ));
    let near = default_near(&skeleton.bounds());
    let vp = Viewport::new(W, H);
    let (mut aggregated, mut pieces) = (0, 0);
    for tolerance in [0.0, 1.0, 4.0, 16.0] {
        let opts = TraversalOptions {
            occlusion: false,
            hlod: true,
            pixel_error: tolerance,
        };
        for pose in b.generated.path.poses.iter().step_by(4) {
            let camera = Camera::of_pose(pose, vp, near);
            // Without hiding, HLODs standing for hidden objects are drawn.
            traverse(
                skeleton,
                &CullView::new(camera, vp),
                &NoOcclusion,
                &opts,
                &mut |i: gigawalk_cull::DrawItem| {
                    if !skeleton.node(i.node).is_leaf()
                        && below[i.node as usize].iter().any(|o| hidden.contains(o))
                    {
                        aggregated += 1;
                    }
                },
            );
            let view = CullView::new(camera, vp).with_visibility(Some(vis.clone()));
            let mut drawn_objects = HashSet::new();
            traverse(
                skeleton,
                &view,
                &NoOcclusion,
                &opts,
                &mut |i: gigawalk_cull::DrawItem| {
                    let node = skeleton.node(i.node);
                    match vis.node(i.node) {
                        NodeShow::Whole => {
                            assert!(
                                below[i.node as usize].iter().all(|o| !hidden.contains(o)),
                                "node {} drawn whole stands for a hidden object",
                                i.node
                            );
                            drawn_objects.extend(below[i.node as usize].iter().copied());
                        }
                        NodeShow::Partial => {
                            assert!(node.is_leaf() && i.lod == 0, "a partial node is refined");
                            let lod = node.first_lod;
                            let runs = b.table.runs(lod).unwrap();
                            let drawn = vis.pieces(lod).expect("a partial leaf is drawn in pieces");
                            pieces += 1;
                            // Every run drawn shows, every run shown is drawn.
                            let mut first = 0;
                            for r in runs {
                                let covered = drawn.iter().any(|p| {
                                    p.first_triangle <= first
                                        && first + r.triangles <= p.first_triangle + p.triangles
                                });
                                assert_eq!(covered, !hidden.contains(&r.object), "LOD {lod}");
                                if covered {
                                    drawn_objects.insert(r.object);
                                }
                                first += r.triangles;
                            }
                        }
                        NodeShow::Hidden => panic!("a hidden node is culled"),
                    }
                },
            );
            assert!(drawn_objects.iter().all(|o| !hidden.contains(o)));
        }
    }
    assert!(
        aggregated > 0,
        "no HLOD held a hidden object: the test means little"
    );
    assert!(
        pieces > 0,
        "no leaf was drawn in pieces: the test means little"
    );
}

/// The object nearest in the most pixels of a coarse grid of picks from
/// `camera` (ties: the lowest id).
fn most_seen(b: &Built, camera: &Camera) -> u32 {
    let vp = Viewport::new(W, H);
    let mut seen: HashMap<u32, u32> = HashMap::new();
    for py in (0..H).step_by(6) {
        for px in (0..W).step_by(6) {
            let ray = camera
                .pixel_ray(vp, px as f64 + 0.5, py as f64 + 0.5)
                .unwrap();
            if let Some(o) = pick_in(b, &ray, &|_| false).and_then(|h| h.object) {
                *seen.entry(o).or_default() += 1;
            }
        }
    }
    seen.iter()
        .max_by_key(|(o, n)| (**n, std::cmp::Reverse(**o)))
        .map(|(o, _)| *o)
        .expect("the pose sees something")
}

#[test]
fn a_hidden_object_leaves_exactly_its_pixels_and_culling_stays_conservative() {
    let dir = tempfile::tempdir().unwrap();
    let b = build(dir.path(), Kind::Plant, 30_000, 5, Default::default());
    let Some(d) = devices_or_skip(2, "hiding objects on a generated plant") else {
        return;
    };
    let skeleton = b.reader.skeleton();
    let near = default_near(&skeleton.bounds());
    let vp = Viewport::new(W, H);
    let poses: Vec<_> = b.generated.path.poses.iter().take(12).collect();
    let cameras = |v: Option<Arc<Visibility>>| -> Vec<CameraRequest> {
        poses
            .iter()
            .map(|p| CameraRequest {
                visibility: v.clone(),
                ..CameraRequest::new(Camera::of_pose(p, vp, near), true)
            })
            .collect()
    };
    // The object seen most in the middle pose.
    let x = most_seen(&b, &Camera::of_pose(poses[6], vp, near));
    let vis = Arc::new(Visibility::new(skeleton, &b.table, &|o| o == x, &|_| false));
    let rt = Runtime::with_devices(&b.reader, d).unwrap();
    let reference = |v| {
        let opts = RuntimeOptions {
            width: W,
            height: H,
            schedule: Schedule::Sequential,
            traversal: Mode::Vfc.traversal(0.0),
            ..Default::default()
        };
        render(&rt, &opts, cameras(v))
    };
    let all = reference(None);
    let without = reference(Some(vis.clone()));
    // Exactly the pixels where the object was nearest changed.
    let mut changed = 0;
    for (f, ((d0, _), (d1, _))) in all.iter().zip(&without).enumerate() {
        let camera = Camera::of_pose(poses[f], vp, near);
        for (i, (a, b2)) in d0.iter().zip(d1).enumerate() {
            let (px, py) = (i as u32 % W, i as u32 / W);
            // Sampled: a pick per pixel is slow in a debug build.
            if a == b2 && (px + py) % 7 != 0 {
                continue;
            }
            let ray = camera
                .pixel_ray(vp, px as f64 + 0.5, py as f64 + 0.5)
                .unwrap();
            let h = pick_in(&b, &ray, &|_| false);
            let on_x = h.and_then(|h| h.object) == Some(x);
            // Where the object lies on another's surface (a depth tie the
            // rasterizer may break either way), it may be what was drawn.
            let tie = || {
                let only_x = pick_in(&b, &ray, &|o| o != x);
                let tied = match (h, only_x) {
                    (Some(h), Some(hx)) => (hx.distance - h.distance).abs() <= 1e-4 * h.distance,
                    _ => false,
                };
                // Or on the object's silhouette: the rasterizer's f32
                // vertices and the f64 ray part a hair's width either way.
                tied || [(-0.05, 0.0), (0.05, 0.0), (0.0, -0.05), (0.0, 0.05)]
                    .iter()
                    .any(|&(dx, dy)| {
                        let r = camera
                            .pixel_ray(vp, px as f64 + 0.5 + dx, py as f64 + 0.5 + dy)
                            .unwrap();
                        let j = pick_in(&b, &r, &|_| false);
                        j.and_then(|j| j.object) == Some(x)
                    })
            };
            if a != b2 {
                changed += 1;
                assert!(
                    on_x || tie(),
                    "frame {f} pixel {px},{py} changed ({} -> {}), but the object there is {:?}, not the hidden one {x}",
                    f32::from_bits(*a),
                    f32::from_bits(*b2),
                    h.map(|h| (h.object, h.distance, h.node))
                );
            } else if !on_x {
                // Unchanged where another object is nearest.
                assert_eq!(a, b2);
            }
        }
    }
    assert!(
        changed > 20,
        "the hidden object covered {changed} pixels: pick another"
    );
    // Occlusion culling with the object hidden draws that reference, bit
    // for bit, in both schedules and with the HZB and occlusion queries.
    for schedule in [Schedule::Pipelined, Schedule::Sequential] {
        for culler in [CullMethod::Hzb, CullMethod::Oq] {
            for (mode, tolerance) in [(Mode::Occ, 0.0), (Mode::Och, 0.0)] {
                let opts = RuntimeOptions {
                    width: W,
                    height: H,
                    schedule,
                    culler,
                    traversal: mode.traversal(tolerance),
                    ..Default::default()
                };
                let got = render(&rt, &opts, cameras(Some(vis.clone())));
                assert_eq!(got.len(), without.len());
                for (f, (g, r)) in got.iter().zip(&without).enumerate() {
                    assert!(
                        g.0 == r.0 && g.1 == r.1,
                        "{schedule:?} {culler:?} {mode:?} frame {f}: differs from the reference without the object"
                    );
                }
            }
        }
    }
}

#[test]
fn in_x_ray_a_hidden_object_shows_faint_where_it_showed_and_hides_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let b = build(dir.path(), Kind::Plant, 30_000, 5, Default::default());
    let Some(d) = devices_or_skip(2, "x-ray on a generated plant") else {
        return;
    };
    let skeleton = b.reader.skeleton();
    let near = default_near(&skeleton.bounds());
    let vp = Viewport::new(W, H);
    let poses: Vec<_> = b.generated.path.poses.iter().skip(4).take(6).collect();
    // The object nearest in the most pixels of the first pose.
    let x = most_seen(&b, &Camera::of_pose(poses[0], vp, near));
    let hidden = |o: u32| o == x;
    let vis = Arc::new(Visibility::new(skeleton, &b.table, &hidden, &|_| false));
    let ghosts = Visibility::ghosts(skeleton, &b.table, &hidden).map(Arc::new);
    assert!(ghosts.is_some());
    assert!(Visibility::ghosts(skeleton, &b.table, &|_| false).is_none());
    let rt = Runtime::with_devices(&b.reader, d).unwrap();
    let opts = RuntimeOptions {
        width: W,
        height: H,
        traversal: Mode::Och.traversal(1.0),
        ..Default::default()
    };
    let frames = |v: Option<Arc<Visibility>>, g: Option<Arc<Visibility>>| {
        let cameras = poses
            .iter()
            .map(|p| CameraRequest {
                visibility: v.clone(),
                ghosts: g.clone(),
                ..CameraRequest::new(Camera::of_pose(p, vp, near), true)
            })
            .collect();
        render(&rt, &opts, cameras)
    };
    let shown = frames(None, None);
    let without = frames(Some(vis.clone()), None);
    let xray = frames(Some(vis), ghosts);
    let (mut on_x, mut ghost, mut elsewhere, mut moved) = (0, 0, 0, 0);
    for f in 0..shown.len() {
        // Ghosts write no depth: the depth is the frame's without them.
        assert_eq!(xray[f].0, without[f].0, "frame {f}: a ghost hid something");
        let px = |img: &[u8], i: usize| [img[4 * i], img[4 * i + 1], img[4 * i + 2]];
        for i in 0..(W * H) as usize {
            let (s, w, g) = (px(&shown[f].1, i), px(&without[f].1, i), px(&xray[f].1, i));
            if shown[f].0[i] != without[f].0[i] {
                // Where the object showed: its ghost, over what is
                // behind it, not the object drawn solid.
                on_x += 1;
                if g != w && g != s {
                    ghost += 1;
                }
            } else {
                elsewhere += 1;
                if g != w {
                    moved += 1;
                }
            }
        }
    }
    assert!(on_x > 50, "the object showed in {on_x} pixels");
    assert!(
        ghost * 10 >= on_x * 9,
        "{ghost} of {on_x} pixels show the ghost"
    );
    // Elsewhere the ghost lies behind what is drawn (depth ties aside).
    assert!(
        moved * 200 <= elsewhere,
        "{moved} of {elsewhere} other pixels changed"
    );
    // With x-ray off the hidden object is simply absent.
    assert_eq!(
        frames(Some(vis_again(skeleton, &b.table, x)), None),
        without
    );
}

fn vis_again(skeleton: &gigawalk_scene::Skeleton, table: &ObjectTable, x: u32) -> Arc<Visibility> {
    Arc::new(Visibility::new(skeleton, table, &|o| o == x, &|_| false))
}

#[test]
fn find_matches_gltf_node_names_and_obj_groups_of_several_files() {
    let dir = tempfile::tempdir().unwrap();
    let glb = dir.path().join("plant.glb");
    let g = generate(Kind::Plant, 5_000, 2, 2);
    std::fs::write(&glb, g.glb_bytes()).unwrap();
    let obj = dir.path().join("skid.obj");
    std::fs::write(
        &obj,
        "o Valve_101\nv 0 0 40\nv 1 0 40\nv 0 1 40\nf 1 2 3\n\
         g Pump_7\nv 5 0 40\nv 6 0 40\nv 5 1 40\nf 4 5 6\n",
    )
    .unwrap();
    let model =
        gigawalk_import::import_all(&[glb.clone(), obj.clone()], &mut |_, _, _| {}).unwrap();
    let table = common::preprocess(dir.path(), "both", &model, Default::default())
        .objects()
        .unwrap()
        .unwrap();
    let names = |p: &str| -> Vec<String> {
        table
            .find(&Pattern::new(p).unwrap())
            .iter()
            .map(|&i| table.object(i).unwrap().full_path())
            .collect()
    };
    let obj_name = obj.display().to_string();
    assert_eq!(names("valve_1"), vec![format!("{obj_name}/Valve_101")]);
    assert_eq!(names("PUMP"), vec![format!("{obj_name}/Pump_7")]);
    assert_eq!(names("skid.obj/").len(), 2, "a file's objects by its name");
    assert_eq!(names("p?mp_*"), vec![format!("{obj_name}/Pump_7")]);
    // glTF node names, and their parents' names in the path.
    let pipes = names("pipe");
    assert!(!pipes.is_empty());
    assert!(pipes
        .iter()
        .all(|p| p.starts_with(&glb.display().to_string())));
    let under_pipes = names("pipes/*");
    assert!(
        !under_pipes.is_empty(),
        "a parent's name finds its children"
    );
    // The boxes are the objects' own.
    let v = table.find(&Pattern::new("Valve_101").unwrap())[0];
    let b = table.object(v).unwrap().bounds;
    assert_eq!(
        (b.min, b.max),
        (DVec3::new(0.0, 0.0, 40.0), DVec3::new(1.0, 1.0, 40.0))
    );
    assert!(names("no such thing").is_empty());
}
