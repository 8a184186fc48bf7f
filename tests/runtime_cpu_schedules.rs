//! The schedules (sequential, pipelined, pipelined with asynchronous RVG)
//! run on the CPU: OR and RVG draw with gigawalk-cull's conservative
//! software depth rasterizer instead of a device (`run_on_cpu`), so the
//! occluder lag, frozen culling, culler choice and error handling are
//! tested without an adapter, with the same schedule code.

use std::time::{Duration, Instant};

use gigawalk_cull::{default_near, TraversalOptions, Viewport};
use gigawalk_import::import_glb_bytes;
use gigawalk_preprocess::{preprocess, NoProgress, Params};
use gigawalk_procgen::{generate, Kind};
use gigawalk_runtime::{
    run_on_cpu, CameraList, CullMethod, FailureHook, FrameReport, OccluderBudget, RuntimeError,
    RuntimeOptions, Schedule, Stage,
};
use gigawalk_scene::path::Pose;
use gigawalk_scene::SceneReader;

const W: u32 = 160;
const H: u32 = 90;

fn city(dir: &std::path::Path) -> (SceneReader, Vec<Pose>) {
    let g = generate(Kind::City, 40_000, 3, 24);
    let model = import_glb_bytes(&g.glb_bytes(), "city").unwrap();
    let file = dir.join("city.gwk");
    preprocess(&model, &Params::default(), &file, "city", &NoProgress).unwrap();
    (SceneReader::open(&file).unwrap(), g.path.poses)
}

fn cameras(scene: &SceneReader, poses: &[Pose]) -> CameraList {
    let near = default_near(&scene.skeleton().bounds());
    CameraList::from_poses(poses, Viewport::new(W, H), near)
}

fn options(schedule: Schedule, occlusion: bool, culler: CullMethod) -> RuntimeOptions {
    RuntimeOptions {
        schedule,
        width: W,
        height: H,
        culler,
        traversal: TraversalOptions {
            occlusion,
            hlod: false,
            pixel_error: 0.0,
        },
        ..Default::default()
    }
}

fn run(
    scene: &SceneReader,
    opts: &RuntimeOptions,
    list: &mut CameraList,
) -> Result<Vec<FrameReport>, RuntimeError> {
    let mut frames = Vec::new();
    run_on_cpu(scene.skeleton(), scene, opts, list, &mut |r| {
        frames.push(r);
        true
    })?;
    Ok(frames)
}

/// The walk without occlusion, sequential: the image every conservative
/// run must match.
fn full_detail(scene: &SceneReader, poses: &[Pose]) -> Vec<FrameReport> {
    run(
        scene,
        &options(Schedule::Sequential, false, CullMethod::Hzb),
        &mut cameras(scene, poses),
    )
    .unwrap()
}

fn depth(r: &FrameReport) -> &[f32] {
    &r.image.as_ref().expect("read back").depth.depth
}

#[test]
fn every_schedule_and_culler_on_the_cpu_loses_no_pixel_and_pipelined_culls_as_sequential() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, poses) = city(dir.path());
    let reference = full_detail(&scene, &poses);
    assert_eq!(reference.len(), poses.len());
    // Occlusion queries need a device.
    let e = run(
        &scene,
        &options(Schedule::Sequential, true, CullMethod::Oq),
        &mut cameras(&scene, &poses),
    )
    .unwrap_err();
    assert!(matches!(e, RuntimeError::CullerUnavailable { .. }), "{e}");
    for culler in [CullMethod::Hzb, CullMethod::Grid, CullMethod::Ct] {
        let seq = run(
            &scene,
            &options(Schedule::Sequential, true, culler),
            &mut cameras(&scene, &poses),
        )
        .unwrap();
        let pip = run(
            &scene,
            &options(Schedule::Pipelined, true, culler),
            &mut cameras(&scene, &poses),
        )
        .unwrap();
        let mut culled = 0;
        for ((s, p), r) in seq.iter().zip(&pip).zip(&reference) {
            // Same occluders (frame i - lag's), same culling.
            assert_eq!(s.visible, p.visible, "{culler} frame {}", s.frame);
            assert_eq!(s.occlusion_used, p.occlusion_used);
            // Conservative: the full-detail image, depth for depth.
            assert_eq!(
                depth(s),
                depth(r),
                "{culler} frame {}: lost a pixel",
                s.frame
            );
            assert_eq!(depth(p), depth(r), "{culler} frame {}", p.frame);
            culled += s.stats.occlusion_culled;
            // The startup bypass is the HZB's; the grid culls from frame 0.
            let bypass = culler == CullMethod::Hzb && s.frame < 2;
            assert_eq!(s.occlusion_used, !bypass, "{culler} frame {}", s.frame);
            // Every culler but the HZB reports its own work.
            let work = s.culler_work.map(|w| w.culler());
            assert_eq!(work, (culler != CullMethod::Hzb).then_some(culler));
            if culler != CullMethod::Hzb {
                assert_eq!(s.occluder_items, 0, "OR draws nothing for the grid");
            }
        }
        assert!(culled > 0, "{culler} culled nothing on the city walk");
        // Asynchronous RVG: every camera drawn, each with a finished set.
        let mut o = options(Schedule::Pipelined, true, culler);
        o.async_rvg = true;
        let asy = run(&scene, &o, &mut cameras(&scene, &poses)).unwrap();
        assert_eq!(asy.len(), poses.len());
        assert!(asy.iter().all(|r| r.image.is_some()));
    }
}

#[test]
fn an_adaptive_occluder_budget_probes_and_loses_no_pixel_in_every_cpu_schedule() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, poses) = city(dir.path());
    let reference = full_detail(&scene, &poses);
    for (schedule, async_rvg) in [
        (Schedule::Sequential, false),
        (Schedule::Pipelined, false),
        (Schedule::Pipelined, true),
    ] {
        let what = format!("{schedule:?}, async {async_rvg}");
        let mut o = options(schedule, true, CullMethod::Hzb);
        o.occluder_budget = OccluderBudget::Adaptive;
        o.async_rvg = async_rvg;
        let frames = run(&scene, &o, &mut cameras(&scene, &poses)).unwrap();
        assert_eq!(frames.len(), poses.len(), "{what}");
        let mut probed = false;
        for f in &frames {
            let r = &reference[f.frame as usize];
            // A set culled for this frame's camera is the full-detail
            // image at whatever budget it chose.
            if !f.reused_visible_set {
                assert_eq!(
                    depth(f),
                    depth(r),
                    "{what}, frame {}: lost a pixel",
                    f.frame
                );
                if let Some(limit) = f.occluder_limit {
                    probed = true;
                    assert!(f.occluder_triangles <= limit, "{what}, frame {}", f.frame);
                }
            }
            assert!(f.occluder_triangles <= f.occluder_candidates, "{what}");
        }
        // It starts with all occluders and probes a smaller budget within
        // the walk's 24 frames. (Asynchronous RVG draws most sets with a
        // newer camera; the controller hears only frames drawn with their
        // own set, too few here to probe.)
        assert!(probed || async_rvg, "{what}: no frame drew with a budget");
        assert!(
            frames[..4].iter().all(|f| f.occluder_limit.is_none()),
            "{what}"
        );
    }
}

#[test]
fn occluder_lag_and_frozen_culling_on_the_cpu() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, poses) = city(dir.path());
    for schedule in [Schedule::Sequential, Schedule::Pipelined] {
        let mut o = options(schedule, true, CullMethod::Hzb);
        o.occluder_lag = 1;
        let f = run(&scene, &o, &mut cameras(&scene, &poses)).unwrap();
        assert!(
            !f[0].occlusion_used && f[1].occlusion_used,
            "{schedule:?} lag 1"
        );
        // Frozen: frames 10.. hold frame 9's set while the camera moves on.
        let mut list = cameras(&scene, &poses);
        for c in &mut list.cameras[10..] {
            c.hold_culling = true;
        }
        let f = run(
            &scene,
            &options(schedule, true, CullMethod::Grid),
            &mut list,
        )
        .unwrap();
        for r in &f[10..] {
            assert!(r.reused_visible_set, "{schedule:?} frame {}", r.frame);
            assert_eq!(r.visible, f[9].visible, "{schedule:?} frame {}", r.frame);
        }
        assert!(!f[9].reused_visible_set);
    }
}

#[test]
fn a_failing_stage_ends_every_cpu_schedule_with_its_error() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, poses) = city(dir.path());
    for (schedule, async_rvg) in [
        (Schedule::Sequential, false),
        (Schedule::Pipelined, false),
        (Schedule::Pipelined, true),
    ] {
        for stage in [Stage::Or, Stage::Stc, Stage::Rvg] {
            let mut o = options(schedule, true, CullMethod::Hzb);
            o.async_rvg = async_rvg;
            o.inject_failure = FailureHook::at(stage, 5);
            // Asynchronous RVG does not wait for OR and STC once it has a
            // set: on a loaded machine it could draw the whole walk before
            // they reach frame 5, so it gets a walk long enough not to.
            let walk: Vec<Pose> = match async_rvg {
                true => poses
                    .iter()
                    .cycle()
                    .take(poses.len() * 20)
                    .cloned()
                    .collect(),
                false => poses.clone(),
            };
            let t = Instant::now();
            let e = match run(&scene, &o, &mut cameras(&scene, &walk)) {
                Ok(f) => panic!(
                    "{schedule:?} async {async_rvg} {stage}: {} frames and no injected error",
                    f.len()
                ),
                Err(e) => e,
            };
            assert!(
                matches!(e, RuntimeError::Injected { stage: s, .. } if s == stage),
                "{schedule:?} async {async_rvg} {stage}: {e}"
            );
            assert!(t.elapsed() < Duration::from_secs(5), "{schedule:?} {stage}");
        }
    }
}

#[test]
fn speculative_rvg_draws_the_last_set_while_stc_is_late_and_the_real_frames_stay_exact() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, poses) = city(dir.path());
    let mut base = options(Schedule::Pipelined, true, CullMethod::Hzb);
    base.stc_delay_ms = 40.0;
    let plain = run(&scene, &base, &mut cameras(&scene, &poses)).unwrap();
    let spec_opts = RuntimeOptions {
        speculative_rvg: true,
        ..base.clone()
    };
    let spec = run(&scene, &spec_opts, &mut cameras(&scene, &poses)).unwrap();
    let (extra, real): (Vec<&FrameReport>, Vec<&FrameReport>) =
        spec.iter().partition(|r| r.speculative);
    assert_eq!(real.len(), poses.len());
    assert!(
        !extra.is_empty(),
        "STC sleeps 40 ms a frame: RVG should speculate"
    );
    // A speculative frame comes before the real frame of its camera, at
    // most one per frame, drawn from an older set without a read-back.
    for (i, r) in spec.iter().enumerate() {
        if r.speculative {
            let next = &spec[i + 1];
            assert!(!next.speculative && next.frame == r.frame, "{i}");
            assert!(r.reused_visible_set && r.image.is_none());
        }
    }
    // The real frames are those of the run without speculation.
    for (p, s) in plain.iter().zip(&real) {
        assert_eq!(p.frame, s.frame);
        assert_eq!(p.visible, s.visible);
        assert_eq!(depth(p), depth(s), "frame {}", p.frame);
    }
    // RVG waited for the slow STC without speculation.
    let waited: f64 = plain.iter().skip(2).map(|r| r.rvg_wait_ms).sum();
    assert!(
        waited > 20.0 * (plain.len() - 2) as f64,
        "RVG waited {waited} ms in all"
    );
    // Refused where it has no meaning.
    let bad = RuntimeOptions {
        speculative_rvg: true,
        schedule: Schedule::Sequential,
        ..base
    };
    assert!(bad.validate().is_err());
}
