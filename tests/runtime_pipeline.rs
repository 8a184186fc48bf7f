//! The pipelined runtime on lavapipe (or any adapter), on a hand-built
//! street of boxes: conservative occlusion culling changes no pixel's
//! depth, the pipelined and sequential schedules choose the same nodes,
//! and a failure in any stage ends the run with that error.

use std::time::{Duration, Instant};

use gigawalk_cull::{Camera, TraversalOptions};
use gigawalk_gpu::devices_or_skip;
use gigawalk_runtime::{
    CameraError, CameraList, CameraRequest, DrawStyle, FailureHook, FrameReport, OccluderBudget,
    OccluderSelection, Runtime, RuntimeError, RuntimeOptions, Schedule, Stage, CPU_OCCLUDER_BUDGET,
};
use gigawalk_scene::SceneReader;
use gigawalk_suite::scenes::{street, write_boxes_scene};
use glam::DVec3;

const W: u32 = 96;
const H: u32 = 64;

/// A walk down the street towards and through the wall's gap, looking
/// around; `frames` poses.
fn walk(frames: usize, shift: DVec3, read_back: bool) -> CameraList {
    let cameras = (0..frames)
        .map(|i| {
            let t = i as f64 / frames as f64;
            let eye = shift + DVec3::new(3.0 * t, 1.7, 8.0 - 30.0 * t);
            let yaw = (t * 9.0).sin() * 0.6;
            let target = eye + DVec3::new(yaw.sin(), -0.05, -yaw.cos());
            CameraRequest::new(
                Camera::look_at(eye, target, 60f64.to_radians(), W as f64 / H as f64, 0.05),
                read_back,
            )
        })
        .collect();
    CameraList { cameras }
}

fn options(schedule: Schedule, occlusion: bool, hlod: bool, pixel_error: f64) -> RuntimeOptions {
    RuntimeOptions {
        schedule,
        width: W,
        height: H,
        traversal: TraversalOptions {
            occlusion,
            hlod,
            pixel_error,
        },
        ..Default::default()
    }
}

fn run(
    rt: &Runtime,
    opts: &RuntimeOptions,
    cams: CameraList,
) -> Result<Vec<FrameReport>, RuntimeError> {
    let mut cams = cams;
    let mut out = Vec::new();
    rt.run(opts, &mut cams, &mut |r| {
        out.push(r);
        true
    })?;
    Ok(out)
}

struct Fixture {
    _dir: tempfile::TempDir,
    scene: SceneReader,
}

fn fixture(shift: DVec3) -> Fixture {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("street.gwk");
    write_boxes_scene(&path, &street(400, shift));
    let scene = SceneReader::open(&path).unwrap();
    Fixture { _dir: dir, scene }
}

/// Runs `test` on a runtime over `devices` devices and the street scene
/// shifted by `shift`, or skips it loudly without an adapter.
fn on_street(devices: usize, name: &str, shift: DVec3, test: impl FnOnce(&Runtime)) {
    let Some(devices) = devices_or_skip(devices, name) else {
        return;
    };
    let f = fixture(shift);
    let rt = Runtime::with_devices(&f.scene, devices).unwrap();
    test(&rt);
}

#[test]
fn device_counts_other_than_one_or_two_are_setup_errors() {
    // Checked before any device is opened: no adapter needed.
    let f = fixture(DVec3::ZERO);
    let e = Runtime::with_devices(&f.scene, Vec::new())
        .err()
        .expect("no devices is an error");
    assert!(matches!(e, RuntimeError::DeviceCount { count: 0 }), "{e}");
    assert!(e.to_string().starts_with("setup: 0 devices"), "{e}");
    let e = Runtime::new(&f.scene, 3)
        .err()
        .expect("three devices is an error");
    assert!(matches!(e, RuntimeError::DeviceCount { count: 3 }), "{e}");
}

#[test]
fn a_corrupted_lod_found_while_loading_is_a_setup_error() {
    let Some(devices) = devices_or_skip(1, "corrupted LOD at setup") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("street.gwk");
    write_boxes_scene(&path, &street(20, DVec3::ZERO));
    // Opening reads only the skeleton; the damage is found when the
    // runtime loads the geometry.
    let lods = SceneReader::open(&path).unwrap().skeleton().lods().to_vec();
    let at = lods[lods.len() / 2].offset as usize + 5;
    let mut bytes = std::fs::read(&path).unwrap();
    bytes[at] ^= 0x5a;
    std::fs::write(&path, bytes).unwrap();
    let scene = SceneReader::open(&path).unwrap();
    let e = Runtime::with_devices(&scene, devices)
        .err()
        .expect("a corrupted LOD is an error");
    assert!(matches!(e, RuntimeError::Setup { .. }), "{e}");
    let text = e.to_string();
    assert!(text.starts_with("setup: scene geometry: "), "{text}");
    assert!(!text.contains("OR:"), "not a stage's error: {text}");
}

/// A frame's read-back depth image.
fn depth(r: &FrameReport) -> &[f32] {
    &r.image.as_ref().expect("a read-back frame").depth.depth
}

/// Pixels where the reference is nearer than the result (something that
/// should show is missing). Reversed-Z: nearer = larger. The tolerance
/// covers nothing but f32 noise: both images come from the same rasterizer.
fn wrongly_culled(reference: &[f32], result: &[f32]) -> usize {
    reference
        .iter()
        .zip(result)
        .filter(|(r, x)| **r > **x + 1e-7)
        .count()
}

fn check_conservative(shift: DVec3) {
    on_street(2, "runtime conservativeness", shift, |rt| {
        let frames = 60;
        let occ = run(
            rt,
            &options(Schedule::Pipelined, true, false, 0.0),
            walk(frames, shift, true),
        )
        .unwrap();
        let vfc = run(
            rt,
            &options(Schedule::Sequential, false, false, 0.0),
            walk(frames, shift, true),
        )
        .unwrap();
        assert_eq!((occ.len(), vfc.len()), (frames, frames));
        let mut culled = 0;
        let mut identical = 0;
        for (o, v) in occ.iter().zip(&vfc) {
            assert_eq!(o.frame, v.frame);
            let (od, vd) = (depth(o), depth(v));
            assert_eq!(
                wrongly_culled(vd, od),
                0,
                "frame {}: occlusion culling removed visible pixels",
                o.frame
            );
            identical += (od == vd) as usize;
            culled += o.stats.occlusion_culled;
            assert!(o.stats.drawn_triangles <= v.stats.drawn_triangles);
        }
        // The test means something only if occlusion culled nodes.
        assert!(
            culled > 100,
            "only {culled} nodes occlusion-culled over the walk"
        );
        // Same rasterizer, same triangles for every visible pixel: the depth
        // images are bit-identical (a culled box never wins a pixel).
        assert_eq!(identical, frames);
        assert!(
            occ[0..2].iter().all(|r| !r.occlusion_used),
            "startup bypass"
        );
        assert!(occ[2..].iter().all(|r| r.occlusion_used));
    });
}

#[test]
fn pipelined_occlusion_is_conservative() {
    check_conservative(DVec3::ZERO);
}

#[test]
fn pipelined_occlusion_is_conservative_far_from_origin() {
    check_conservative(DVec3::new(2.0e7, 1.0e6, -3.0e7));
}

#[test]
fn pipelined_and_sequential_choose_the_same_nodes() {
    on_street(2, "pipelined vs sequential", DVec3::ZERO, |rt| {
        for lag in [1, 2] {
            let mut p = options(Schedule::Pipelined, true, true, 2.0);
            p.occluder_lag = lag;
            let s = RuntimeOptions {
                schedule: Schedule::Sequential,
                ..p.clone()
            };
            let a = run(rt, &p, walk(30, DVec3::ZERO, false)).unwrap();
            let b = run(rt, &s, walk(30, DVec3::ZERO, false)).unwrap();
            assert_eq!(a.len(), 30);
            for (x, y) in a.iter().zip(&b) {
                assert_eq!(x.visible, y.visible, "lag {lag}, frame {}", x.frame);
                assert_eq!(x.stats, y.stats);
            }
            assert!(a.iter().any(|r| r.stats.drawn_nodes < r.stats.visited));
        }
    });
}

#[test]
fn a_failure_in_any_stage_stops_the_run() {
    on_street(2, "failure injection", DVec3::ZERO, |rt| {
        for schedule in [Schedule::Pipelined, Schedule::Sequential] {
            for stage in [Stage::Or, Stage::Stc, Stage::Rvg] {
                let mut o = options(schedule, true, true, 1.0);
                o.inject_failure = FailureHook::at(stage, 5);
                let t = Instant::now();
                let mut seen = 0;
                let mut cams = walk(1000, DVec3::ZERO, false);
                let err = rt.run(&o, &mut cams, &mut |_| {
                    seen += 1;
                    true
                });
                let took = t.elapsed();
                match err {
                    Err(RuntimeError::Injected { stage: s, frame: 5 }) => assert_eq!(s, stage),
                    other => {
                        panic!("{schedule:?} {stage}: expected the injected error, got {other:?}")
                    }
                }
                assert!(
                    seen <= 5,
                    "{stage}: {seen} frames finished after a failure at frame 5"
                );
                // Generous bound for a loaded 2-core CI machine; typically milliseconds.
                assert!(
                    took < Duration::from_secs(10),
                    "{stage}: took {took:?} to stop"
                );
            }
        }
    });
}

#[test]
fn stopping_early_from_the_frame_callback() {
    on_street(2, "early stop", DVec3::ZERO, |rt| {
        let mut cams = walk(1000, DVec3::ZERO, false);
        let mut seen = 0;
        let n = rt
            .run(
                &options(Schedule::Pipelined, true, true, 1.0),
                &mut cams,
                &mut |_| {
                    seen += 1;
                    seen < 7
                },
            )
            .unwrap();
        assert_eq!((n, seen), (7, 7));
    });
}

#[test]
fn bad_options_and_cameras_are_errors() {
    on_street(1, "bad options", DVec3::ZERO, |rt| {
        let mut o = options(Schedule::Pipelined, true, true, 1.0);
        o.occluder_scale = 0.0;
        let e = rt
            .run(&o, &mut walk(3, DVec3::ZERO, false), &mut |_| true)
            .unwrap_err();
        assert!(e.to_string().contains("occluder scale 0"), "{e}");
        let mut cams = walk(3, DVec3::ZERO, false);
        cams.cameras[1].camera.position.x = f64::NAN;
        let e = rt
            .run(
                &options(Schedule::Pipelined, true, true, 1.0),
                &mut cams,
                &mut |_| true,
            )
            .unwrap_err();
        assert!(
            matches!(
                e,
                RuntimeError::Camera(CameraError::Invalid { frame: 1, .. })
            ),
            "{e}"
        );
    });
}

#[test]
fn held_culling_reuses_the_frozen_set_in_every_schedule() {
    on_street(2, "hold culling", DVec3::ZERO, |rt| {
        for (schedule, async_rvg) in [
            (Schedule::Sequential, false),
            (Schedule::Pipelined, false),
            (Schedule::Pipelined, true),
        ] {
            let mut cams = walk(20, DVec3::ZERO, false);
            for c in &mut cams.cameras[10..] {
                c.hold_culling = true;
            }
            let mut o = options(schedule, true, true, 1.0);
            o.async_rvg = async_rvg;
            o.record_culled = true;
            let frames = run(rt, &o, cams).unwrap();
            assert_eq!(frames.len(), 20);
            // Frames 10.. draw exactly what frame 9 drew (with async RVG, frame
            // 9 may itself have drawn an earlier camera's set).
            for r in &frames[10..] {
                assert!(r.reused_visible_set);
                assert_eq!(
                    r.visible, frames[9].visible,
                    "{schedule:?} async {async_rvg}, frame {}",
                    r.frame
                );
            }
            if !async_rvg {
                assert!(frames[..10].iter().all(|r| !r.reused_visible_set));
            }
            for r in &frames {
                assert_eq!(
                    r.culled.len() as u64,
                    r.stats.frustum_culled + r.stats.occlusion_culled
                );
            }
        }
    });
}

#[test]
fn async_rvg_renders_every_camera() {
    on_street(2, "async RVG", DVec3::ZERO, |rt| {
        let mut o = options(Schedule::Pipelined, true, true, 1.0);
        o.async_rvg = true;
        let frames = run(rt, &o, walk(40, DVec3::ZERO, true)).unwrap();
        assert_eq!(frames.len(), 40);
        for (i, r) in frames.iter().enumerate() {
            assert_eq!(r.frame, i as u64);
            assert!(r.image.is_some());
            assert!(!r.visible.is_empty());
        }
        // Failures stop the asynchronous schedule too.
        for stage in [Stage::Or, Stage::Stc, Stage::Rvg] {
            o.inject_failure = FailureHook::at(stage, 3);
            let e = run(rt, &o, walk(1000, DVec3::ZERO, false)).unwrap_err();
            assert!(
                matches!(e, RuntimeError::Injected { stage: s, .. } if s == stage),
                "{e}"
            );
        }
        o.schedule = Schedule::Sequential;
        o.inject_failure = FailureHook::default();
        assert!(run(rt, &o, walk(3, DVec3::ZERO, false))
            .unwrap_err()
            .to_string()
            .contains("pipelined"));
    });
}

#[test]
fn wireframe_frames_change_the_image_not_the_culling() {
    on_street(2, "wireframe style", DVec3::ZERO, |rt| {
        let wireframe = rt.device(0).supports_wireframe() && rt.device(1).supports_wireframe();
        if !wireframe {
            assert!(
                std::env::var_os("GIGAWALK_REQUIRE_ADAPTER").is_none(),
                "the CI adapter must support POLYGON_MODE_LINE"
            );
            eprintln!("!!! SKIPPING wireframe style: no POLYGON_MODE_LINE on this adapter");
            return;
        }
        for (schedule, async_rvg) in [
            (Schedule::Sequential, false),
            (Schedule::Pipelined, false),
            (Schedule::Pipelined, true),
        ] {
            let mut o = options(schedule, true, true, 1.0);
            o.async_rvg = async_rvg;
            let shaded = run(rt, &o, walk(12, DVec3::ZERO, true)).unwrap();
            // Odd frames in wireframe.
            let mut cams = walk(12, DVec3::ZERO, true);
            for c in cams.cameras.iter_mut().skip(1).step_by(2) {
                c.style = DrawStyle::Wireframe;
            }
            let mixed = run(rt, &o, cams).unwrap();
            assert_eq!(mixed.len(), 12);
            for (a, b) in shaded.iter().zip(&mixed) {
                let what = format!("{schedule:?} async {async_rvg}, frame {}", a.frame);
                let (ia, ib) = (a.image.as_ref().unwrap(), b.image.as_ref().unwrap());
                if async_rvg {
                    // Which set a frame draws depends on timing; only the style is checked.
                } else {
                    assert_eq!(a.visible, b.visible, "{what}");
                }
                let differing = ia
                    .colour
                    .chunks(4)
                    .zip(ib.colour.chunks(4))
                    .filter(|(x, y)| x != y)
                    .count();
                if b.frame % 2 == 0 && !async_rvg {
                    assert_eq!(differing, 0, "{what}: a shaded frame changed");
                } else if b.frame % 2 == 1 {
                    // Lines leave most of what faces covered as background.
                    assert!(
                        differing * 10 > ia.colour.len() / 4,
                        "{what}: only {differing} pixels differ in wireframe"
                    );
                }
            }
        }
    });
}

#[test]
fn an_occluder_budget_culls_less_but_never_wrongly() {
    on_street(2, "occluder budget", DVec3::ZERO, |rt| {
        let frames = 40;
        let vfc = run(
            rt,
            &options(Schedule::Sequential, false, false, 0.0),
            walk(frames, DVec3::ZERO, true),
        )
        .unwrap();
        let mut culled_by_budget = Vec::new();
        for budget in [
            OccluderBudget::All,
            OccluderBudget::Triangles(2_000),
            OccluderBudget::Triangles(200),
            OccluderBudget::Triangles(0),
            OccluderBudget::Adaptive,
        ] {
            let mut o = options(Schedule::Pipelined, true, false, 0.0);
            o.occluder_budget = budget;
            let occ = run(rt, &o, walk(frames, DVec3::ZERO, true)).unwrap();
            assert_eq!(occ.len(), frames);
            // Every frame reports the budget it drew with, and keeps to it.
            for r in &occ {
                assert!(r.occluder_triangles <= r.occluder_candidates, "{budget:?}");
                if let Some(limit) = r.occluder_limit {
                    assert!(r.occluder_triangles <= limit, "{budget:?}: {limit}");
                }
                match budget {
                    OccluderBudget::Triangles(t) if r.occluder_candidates > 0 => {
                        assert_eq!(r.occluder_limit, Some(t))
                    }
                    OccluderBudget::All => assert_eq!(r.occluder_limit, None),
                    _ => {}
                }
            }
            if budget == OccluderBudget::Adaptive {
                // It probed: some frames drew with a budget, the first ones
                // with all occluders.
                assert!(occ.iter().any(|r| r.occluder_limit.is_some()));
                assert!(occ[..4].iter().all(|r| r.occluder_limit.is_none()));
            }
            let mut culled = 0;
            for (r, v) in occ.iter().zip(&vfc) {
                let (rd, vd) = (depth(r), depth(v));
                assert_eq!(
                    wrongly_culled(vd, rd),
                    0,
                    "budget {budget:?}, frame {}: visible pixels removed",
                    r.frame
                );
                assert_eq!(rd, vd, "budget {budget:?}, frame {}", r.frame);
                culled += r.stats.occlusion_culled;
            }
            culled_by_budget.push((budget, culled));
        }
        // No occluders, no occlusion culling; a sensible budget still culls.
        // (Totals need not shrink with the budget: each run's later occluders
        // come from its own visible sets, and culling a parent counts once
        // where culling its children counts each.)
        assert!(culled_by_budget[0].1 > 0, "{culled_by_budget:?}");
        assert_eq!(culled_by_budget[3].1, 0, "{culled_by_budget:?}");
        assert!(culled_by_budget[1].1 > 0, "{culled_by_budget:?}");
        // Auto: the CPU budget on a CPU rasterizer (lavapipe in CI), else all.
        let cpu = rt.device(0).is_cpu() || rt.device(1).is_cpu();
        assert_eq!(
            rt.occluder_selection(OccluderBudget::Auto),
            if cpu {
                OccluderSelection::Triangles(CPU_OCCLUDER_BUDGET)
            } else {
                OccluderSelection::All
            }
        );
        assert_eq!(
            rt.occluder_selection(OccluderBudget::All),
            OccluderSelection::All
        );
    });
}

#[test]
fn a_replay_asking_for_a_culler_the_scene_cannot_run_fails_before_any_frame() {
    let Some(devices) = devices_or_skip(2, "replay culler checks") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("boxes.gwk");
    // A scene written without the occluder sections.
    write_boxes_scene(&path, &street(20, DVec3::ZERO));
    let scene = SceneReader::open(&path).unwrap();
    let poses: Vec<gigawalk_scene::path::Pose> = (0..4)
        .map(|i| gigawalk_scene::path::Pose {
            time: i as f64,
            position: DVec3::new(0.0, 1.7, -(i as f64)),
            orientation: glam::DQuat::IDENTITY,
            fovy: 1.0,
        })
        .collect();
    let opts = |cullers: Vec<gigawalk_runtime::CullMethod>| gigawalk_replay::ReplayOptions {
        modes: vec![gigawalk_replay::Mode::Occ],
        cullers,
        frames: Some(4),
        accuracy_every: 2,
        ..Default::default()
    };
    let rt = Runtime::with_devices(&scene, devices).unwrap();
    let e = gigawalk_replay::replay_on(
        &rt,
        "boxes.gwk",
        &poses,
        "p",
        &opts(vec![gigawalk_runtime::CullMethod::Ct]),
        &mut gigawalk_replay::NoProgress,
    )
    .unwrap_err();
    assert!(
        matches!(&e, gigawalk_replay::ReplayError::Culler(_))
            && e.to_string().contains("preprocess it again"),
        "{e}"
    );
    drop(rt);
    // Occlusion queries need the whole scene on the device.
    let Some(devices) = devices_or_skip(2, "replay culler checks") else {
        return;
    };
    let big = dir.path().join("big.gwk");
    write_boxes_scene(&big, &street(3000, DVec3::ZERO));
    let scene = SceneReader::open(&big).unwrap();
    let budget = (gigawalk_runtime::scene_device_bytes(scene.skeleton()) / 3)
        .max(gigawalk_runtime::MIN_MEMORY_BUDGET);
    let streamed = Runtime::streaming(&scene, devices, budget).unwrap();
    assert!(streamed.is_streaming(), "budget {budget}");
    let e = gigawalk_replay::replay_on(
        &streamed,
        "boxes.gwk",
        &poses,
        "p",
        &opts(vec![gigawalk_runtime::CullMethod::Oq]),
        &mut gigawalk_replay::NoProgress,
    )
    .unwrap_err();
    assert!(
        matches!(&e, gigawalk_replay::ReplayError::Culler(_))
            && e.to_string().contains("--memory-budget"),
        "{e}"
    );
}
