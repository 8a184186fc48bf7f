//! Replays on a small generated plant (lavapipe or any adapter): the report
//! files are written and parse, every frame is counted, `och` draws fewer
//! triangles than `vfc`, and conservative `occ` and `och` at pixel error 0
//! lose no pixel against the reference.

use std::path::Path;

use gigawalk_gpu::devices_or_skip;
use gigawalk_procgen::{generate, Kind};
use gigawalk_replay::{replay_on, Mode, NoProgress, Progress, ReplayOptions};
use gigawalk_runtime::{Runtime, RuntimeOptions};
use gigawalk_scene::path::CameraPath;
use gigawalk_scene::SceneReader;

/// Small enough for lavapipe on 2 cores (a few hundred thousand triangles
/// drawn over the whole test), big enough that occlusion culls.
const TRIANGLES: u64 = 30_000;
const W: u32 = 128;
const H: u32 = 72;

fn plant(dir: &Path, poses: usize) -> (SceneReader, CameraPath) {
    let g = generate(Kind::Plant, TRIANGLES, 3, poses);
    let model = gigawalk_import::import_glb_bytes(&g.glb_bytes(), "plant").unwrap();
    let file = dir.join("plant.gwk");
    gigawalk_preprocess::preprocess(
        &model,
        &gigawalk_preprocess::Params::default(),
        &file,
        "test plant",
        &gigawalk_preprocess::NoProgress,
    )
    .unwrap();
    (SceneReader::open(&file).unwrap(), g.path)
}

/// Runs `test` on a runtime over `devices` devices and a fresh plant with a
/// `poses`-pose walk (and the plant's temporary directory), or skips it
/// loudly without an adapter.
fn on_plant(
    devices: usize,
    name: &str,
    poses: usize,
    test: impl FnOnce(&Runtime, &CameraPath, &Path),
) {
    let Some(devices) = devices_or_skip(devices, name) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (scene, path) = plant(dir.path(), poses);
    let rt = Runtime::with_devices(&scene, devices).unwrap();
    test(&rt, &path, dir.path());
}

/// Replays `path` on the plant without progress reporting.
fn replay_plant(
    rt: &Runtime,
    path: &CameraPath,
    opts: &ReplayOptions,
) -> Result<gigawalk_replay::Replay, gigawalk_replay::ReplayError> {
    replay_on(
        rt,
        "plant.gwk",
        &path.poses,
        "plant.path",
        opts,
        &mut NoProgress,
    )
}

fn options(pixel_errors: &[f64], frames: usize, every: usize) -> ReplayOptions {
    ReplayOptions {
        modes: Mode::ALL.to_vec(),
        pixel_errors: pixel_errors.to_vec(),
        cullers: vec![Default::default()],
        runtime: RuntimeOptions {
            width: W,
            height: H,
            ..Default::default()
        },
        memory_budget: Default::default(),
        near: None,
        frames: Some(frames),
        accuracy_every: every,
        warmup: 3,
        target: None,
        adapter: None,
        visibility: None,
        section: None,
        look: Default::default(),
        ghosts: None,
    }
}

#[test]
fn sweep_writes_every_report_file_and_counts_every_frame() {
    on_plant(2, "replay report", 40, |rt, path, dir| {
        let frames = 24;
        let opts = options(&[0.0, 2.0], frames, 4);
        let r = replay_plant(rt, path, &opts).unwrap();
        assert!(r.complete);
        // vfc, hlod 0, hlod 2, occ, och 0, och 2.
        assert_eq!(r.runs.len(), 6);
        for run in &r.runs {
            assert_eq!(run.frames.len(), frames, "{}", run.label());
            let ids: Vec<u64> = run.frames.iter().map(|f| f.frame).collect();
            assert_eq!(ids, (0..frames as u64).collect::<Vec<_>>());
            // Frames 0, 4, ..., 20 are compared.
            assert_eq!(
                run.frames.iter().filter(|f| f.accuracy.is_some()).count(),
                6
            );
        }

        let out = dir.join("report");
        let written = r.write_report(&out).unwrap();
        for name in [
            "summary.md",
            "summary.json",
            "frames.csv",
            "fps.png",
            "tradeoff.png",
        ] {
            assert!(
                written.files.contains(&out.join(name)),
                "{name} not written"
            );
            assert!(
                std::fs::metadata(out.join(name)).unwrap().len() > 0,
                "{name} empty"
            );
        }
        for png in ["fps.png", "tradeoff.png"] {
            let bytes = std::fs::read(out.join(png)).unwrap();
            assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{png}");
        }

        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap())
                .unwrap();
        assert_eq!(json["frames"], frames);
        assert_eq!(
            (json["width"].as_u64(), json["height"].as_u64()),
            (Some(W as u64), Some(H as u64))
        );
        let modes = json["modes"].as_array().unwrap();
        assert_eq!(modes.len(), 6);
        for m in modes {
            for key in [
                "name",
                "pixel_error",
                "mean_fps",
                "median_frame_ms",
                "p95_frame_ms",
                "mean_triangles",
                "speedup_vs_vfc",
                "mean_latency_ms",
                "wrongly_culled_pixels",
                "differing_pixels_fraction",
                "bound_violating_pixels",
                "bound_violating_fraction",
                "bound_exceeding_pixels",
                "bound_exceeding_fraction",
                "psnr_db",
            ] {
                assert!(m.get(key).is_some(), "{key} missing from {m}");
            }
            // Every run was compared, so the bound is measured, not null.
            assert!(m["bound_violating_pixels"].is_u64(), "{m}");
            assert!(m["bound_violating_fraction"].is_f64(), "{m}");
            assert!(
                m["bound_exceeding_pixels"].as_u64() <= m["bound_violating_pixels"].as_u64(),
                "{m}"
            );
            assert!(m["mean_fps"].as_f64().unwrap() > 0.0);
            assert_eq!(m["frames"], frames);
            assert_eq!(m["measured_frames"], frames - 3);
            // Triangles drawn a frame per viewport pixel.
            let per_pixel = m["mean_triangles"].as_f64().unwrap() / f64::from(W * H);
            let got = m["triangles_per_pixel"].as_f64().unwrap();
            assert!((got - per_pixel).abs() <= 1e-12 * per_pixel, "{m}");
        }
        assert_eq!(modes[0]["speedup_vs_vfc"].as_f64(), Some(1.0));
        // vfc against its own reference (the same render in another
        // schedule): nothing breaks the bound.
        assert_eq!(modes[0]["name"], "vfc");
        assert_eq!(modes[0]["bound_violating_pixels"].as_u64(), Some(0));

        let csv = std::fs::read_to_string(out.join("frames.csv")).unwrap();
        let mut lines = csv.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
        assert_eq!(rows.len(), 6 * frames);
        assert!(rows.iter().all(|r| r.len() == header.len()));
        let col = |name: &str| {
            header
                .iter()
                .position(|h| *h == name)
                .unwrap_or_else(|| panic!("no {name} column in frames.csv"))
        };
        // Compared frames have the bound's columns, the others leave them
        // empty.
        for r in &rows {
            let compared = !r[col("accuracy_pixels")].is_empty();
            for c in [
                "bound_violating_pixels",
                "bound_violating_fraction",
                "bound_exceeding_pixels",
                "bound_exceeding_fraction",
            ] {
                assert_eq!(!r[col(c)].is_empty(), compared, "{c} in {r:?}");
            }
        }
        // Frame 0 has no interval; every later frame has one, and they parse.
        for r in &rows {
            let frame: u64 = r[col("frame")].parse().unwrap();
            let ms = r[col("frame_ms")];
            if frame == 0 {
                assert_eq!(ms, "");
            } else {
                assert!(ms.parse::<f64>().unwrap() >= 0.0);
            }
        }
        let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
        assert!(md.contains("| och | 2 |") && md.contains("fps.png"), "{md}");
        assert!(md.contains("bound-violating px"), "{md}");
        assert!(md.contains("beyond the bound px"), "{md}");
    });
}

#[test]
fn och_draws_less_and_conservative_modes_lose_no_pixel() {
    on_plant(2, "replay accuracy", 40, |rt, path, _| {
        let mut opts = options(&[0.0, 1.0], 30, 3);
        (opts.runtime.width, opts.runtime.height) = (4 * W, 4 * H);
        let r = replay_plant(rt, path, &opts).unwrap();
        let s = r.summary();
        let get = |name: &str, px: f64| {
            s.modes
                .iter()
                .find(|m| m.name == name && m.pixel_error == px)
                .unwrap_or_else(|| panic!("no {name} {px}px run"))
        };
        let vfc = get("vfc", 0.0);
        let och = get("och", 1.0);
        assert!(
            och.mean_triangles < vfc.mean_triangles,
            "och {} vs vfc {} triangles",
            och.mean_triangles,
            vfc.mean_triangles
        );
        // The reference is vfc itself (other schedule, same rasterizer): identical.
        assert_eq!(vfc.wrongly_culled_pixels, Some(0));
        assert_eq!(vfc.differing_pixels_fraction, Some(0.0));
        assert_eq!(vfc.bound_violating_pixels, Some(0));
        for m in [get("occ", 0.0), get("och", 0.0)] {
            assert_eq!(m.accuracy_frames, 10, "{}", m.name);
            assert_eq!(
                m.wrongly_culled_pixels,
                Some(0),
                "{} at 0px lost pixels",
                m.name
            );
            // Full detail, only hidden nodes culled: the same depth.
            assert_eq!(
                m.bound_violating_pixels,
                Some(0),
                "{} at 0px breaks the bound",
                m.name
            );
        }
        // At 1 px the LODs' errors are measured bounds, so surfaces stay
        // within a pixel of the reference. What the metric may still count:
        // a surface moved along the view ray by up to a pixel's worth is
        // beyond its 0.1% depth match wherever no neighbour matches. A
        // pixel's worth is 1/ppr of the distance (ppr = pixels per radian,
        // H / (2 tan(fovy/2))): at 128x72 that is 16x the match and the
        // fraction measured 1.0%; at this 512x288 viewport 4x, measured
        // 0.05% (on the 4M plant at 1920x1080, where a pixel is the match,
        // 0.006%). Before honest errors 1 px lost whole surfaces: 8-11% of
        // pixels on the 5M plant. 0.2% is the measured figure with room
        // for rasterizer differences, far below a vanished surface's share.
        for name in ["hlod", "och"] {
            let m = get(name, 1.0);
            let f = m.bound_violating_fraction.unwrap_or(1.0);
            assert!(f <= 2e-3, "{name} at 1px: bound-violating fraction {f}");
            // With the depth match scaled to the tolerance (1e-3 + 1/ppr),
            // what is left is where the image departs from the reference by
            // more than the bound allows: measured 0.005% here (72 pixels
            // of 1.47M, against 0.079% bound-violating), not traced yet; a
            // likely source is surfaces seen edge-on, where a pixel
            // centre's depth differs from the displaced point's by more
            // than the match's 1e-3 allowance. 5e-4 leaves room for rasterizer differences
            // and is far below a vanished surface's share.
            let e = m.bound_exceeding_fraction.unwrap_or(1.0);
            assert!(e <= 5e-4, "{name} at 1px: beyond-the-bound fraction {e}");
        }
        // ...and the 1 px runs did use coarser levels.
        let (t1, t0) = (
            get("och", 1.0).mean_triangles,
            get("och", 0.0).mean_triangles,
        );
        assert!(t1 < t0, "och draws {t1} triangles at 1 px, {t0} at 0 px");
        // Occlusion culled something, or the check above means little.
        let occ_culled: u64 = r
            .runs
            .iter()
            .filter(|x| x.mode == Mode::Occ)
            .flat_map(|x| &x.frames)
            .map(|f| f.occlusion_culled)
            .sum();
        assert!(occ_culled > 0, "occlusion culled nothing on the walk");
    });
}

/// Stops after a few frames, as Ctrl-C does.
struct StopAfter(usize);
impl Progress for StopAfter {
    fn frame(&mut self) {
        self.0 = self.0.saturating_sub(1);
    }
    fn keep_going(&self) -> bool {
        self.0 > 0
    }
}

#[test]
fn stopping_keeps_what_was_measured() {
    on_plant(2, "replay stop", 20, |rt, path, dir| {
        // Reference: 0, 5, 10, 15 and the frame after each (popping: 8
        // frames); then vfc stops after 3 frames.
        let opts = options(&[1.0], 20, 5);
        let r = replay_on(rt, "s", &path.poses, "p", &opts, &mut StopAfter(11)).unwrap();
        assert!(!r.complete);
        assert_eq!(r.reference_frames, 8);
        assert_eq!(r.runs.len(), 1);
        assert_eq!(r.runs[0].frames.len(), 3);
        let out = dir.join("partial");
        r.write_report(&out).unwrap();
        let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
        assert!(md.contains("Stopped early"), "{md}");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap())
                .unwrap();
        assert_eq!(json["complete"], false);
    });
}

#[test]
fn bad_options_are_errors() {
    on_plant(1, "replay options", 5, |rt, path, _| {
        let mut o = options(&[-1.0], 5, 0);
        let e = replay_on(rt, "s", &path.poses, "p", &o, &mut NoProgress).unwrap_err();
        assert!(e.to_string().contains("pixel error -1"), "{e}");
        o.pixel_errors = vec![1.0];
        o.modes.clear();
        let e = replay_on(rt, "s", &path.poses, "p", &o, &mut NoProgress).unwrap_err();
        assert!(e.to_string().contains("no modes"), "{e}");
        let o = options(&[1.0], 5, 0);
        let e = replay_on(rt, "s", &[], "p", &o, &mut NoProgress).unwrap_err();
        assert!(e.to_string().contains("no poses"), "{e}");
    });
}

/// Every runtime knob replays with accuracy checks (the reference always
/// runs sequentially at full detail, whatever the runs use).
#[test]
fn every_runtime_knob_replays_with_accuracy() {
    on_plant(2, "replay knobs", 12, |rt, path, _| {
        let base = RuntimeOptions {
            width: W,
            height: H,
            ..Default::default()
        };
        let knobs = [
            RuntimeOptions {
                async_rvg: true,
                ..base.clone()
            },
            RuntimeOptions {
                occluder_scale: 0.25,
                ..base.clone()
            },
            RuntimeOptions {
                hzb_reduction: gigawalk_cull::Reduction::NthFarthest(3),
                ..base.clone()
            },
            RuntimeOptions {
                occluder_lag: 1,
                ..base.clone()
            },
            RuntimeOptions {
                occluder_budget: gigawalk_runtime::OccluderBudget::Triangles(500),
                ..base.clone()
            },
        ];
        for runtime in knobs {
            let opts = ReplayOptions {
                modes: vec![Mode::Occ, Mode::Och],
                pixel_errors: vec![1.0],
                // Every knob with every culler.
                cullers: gigawalk_runtime::CullMethod::ALL.to_vec(),
                runtime: runtime.clone(),
                memory_budget: Default::default(),
                near: None,
                frames: Some(12),
                accuracy_every: 4,
                warmup: 2,
                target: None,
                adapter: None,
                visibility: None,
                section: None,
                look: Default::default(),
                ghosts: None,
            };
            let r = replay_plant(rt, path, &opts).unwrap_or_else(|e| panic!("{runtime:?}: {e}"));
            // Frames 0, 4, 8 and the frame after each.
            assert_eq!(r.reference_frames, 6, "{runtime:?}");
            for m in r.summary().modes {
                assert_eq!(m.frames, 12, "{runtime:?} {}", m.name);
                assert_eq!(m.accuracy_frames, 3, "{runtime:?} {}", m.name);
            }
        }
    });
}

#[test]
fn a_streamed_replay_reports_its_memory_and_stand_ins_against_a_settled_reference() {
    let Some(devices) = devices_or_skip(2, "streamed replay") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (scene, path) = plant(dir.path(), 30);
    let total = gigawalk_runtime::scene_device_bytes(scene.skeleton());
    let budget = total / 3;
    let rt = Runtime::streaming(&scene, devices, budget).unwrap();
    assert!(rt.is_streaming());
    let mut opts = options(&[1.0], 20, 5);
    opts.modes = vec![Mode::Occ, Mode::Och];
    let r = replay_plant(&rt, &path, &opts).unwrap();
    assert!(r.complete);
    let s = r.summary();
    assert!(
        s.memory_budget.is_some_and(|b| b <= budget),
        "{:?}",
        s.memory_budget
    );
    // Each reference camera was held until it drew no stand-in.
    assert_eq!(s.unsettled_reference_frames, 0);
    assert_eq!(r.reference_frames, 8);
    for m in &s.modes {
        assert!(
            m.peak_resident_bytes > 0 && m.peak_resident_bytes <= budget,
            "{m:?}"
        );
        assert_eq!(m.missing_draws, 0, "{}", m.name);
        assert!(m.accuracy_frames > 0);
    }
    // The first run starts from the pinned set: it loads and substitutes.
    let occ = &s.modes[0];
    assert!(occ.loaded_bytes > 0 && occ.requests > 0, "{occ:?}");
    assert!(
        occ.substituted_draws > 0 && occ.substituted_frames > 0,
        "{occ:?}"
    );
    // Report files carry the streaming figures.
    let out = dir.path().join("report");
    r.write_report(&out).unwrap();
    let csv = std::fs::read_to_string(out.join("frames.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    for col in [
        "resident_bytes",
        "loaded_bytes",
        "requests",
        "substituted_draws",
        "missing_draws",
    ] {
        assert!(
            header.split(',').any(|c| c == col),
            "{col} missing: {header}"
        );
    }
    let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(md.contains("## Streaming (out of core)"), "{md}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert!(json["memory_budget"].as_u64().is_some());
    assert!(json["modes"][0]["substituted_draws"].as_u64().unwrap() > 0);
}

#[test]
fn a_target_frame_rate_steers_the_tolerance_and_the_report_says_what_it_chose() {
    on_plant(2, "target frame rate", 30, |rt, path, dir| {
        // An unreachable target (0.1 ms a frame): the controller raises the
        // tolerance to its maximum; modes without a pixel error ignore it.
        let opts = ReplayOptions {
            modes: vec![Mode::Vfc, Mode::Och],
            target: Some(gigawalk_replay::TargetFps {
                ms: 0.1,
                max_pixel_error: 6.0,
            }),
            ..options(&[1.0], 30, 5)
        };
        let r = replay_plant(rt, path, &opts).unwrap();
        // och runs at its fixed pixel error and once held to the target.
        assert_eq!(r.runs.len(), 3);
        let fixed = r
            .runs
            .iter()
            .find(|r| r.mode == Mode::Och && !r.target)
            .unwrap();
        assert!(fixed.frames.iter().all(|f| f.pixel_error_used == 1.0));
        let och = r.runs.iter().find(|r| r.target).unwrap();
        assert_eq!(och.label(), "och target");
        let used: Vec<f64> = och.frames.iter().map(|f| f.pixel_error_used).collect();
        assert_eq!(used[0], 1.0, "starts at --pixel-error");
        assert!(used.iter().all(|&p| (0.125..=6.0).contains(&p)), "{used:?}");
        assert_eq!(*used.last().unwrap(), 6.0, "{used:?}");
        let vfc = r.runs.iter().find(|r| r.mode == Mode::Vfc).unwrap();
        assert!(vfc.frames.iter().all(|f| f.pixel_error_used == 0.0));
        let s = r.summary();
        let m = s.modes.iter().find(|m| m.target_fps.is_some()).unwrap();
        assert_eq!(m.target_fps, Some(10_000.0));
        assert!(m.mean_pixel_error_used.unwrap() > 3.0);
        assert!(m.mean_controller_us.is_some());
        // Each compared frame's bound is its own tolerance.
        assert!(och.frames.iter().any(|f| f.accuracy.is_some()));
        let v = s.modes.iter().find(|m| m.name == "vfc").unwrap();
        assert_eq!(v.target_fps, None);
        let csv = r.csv();
        assert!(csv
            .lines()
            .next()
            .unwrap()
            .contains(",pixel_error_used,popping,"));
        let w = r.write_report(&dir.join("target")).unwrap();
        for f in ["pixel_error.png", "tradeoff.png"] {
            assert!(w.files.iter().any(|p| p.ends_with(f)), "{f}");
        }
        let md = std::fs::read_to_string(dir.join("target/summary.md")).unwrap();
        assert!(
            md.contains("## Target frame rate") && md.contains("och target"),
            "{md}"
        );
    });
}

#[test]
fn popping_is_zero_for_what_draws_the_reference_and_above_zero_for_lod_switches() {
    on_plant(2, "popping", 40, |rt, path, dir| {
        let opts = ReplayOptions {
            modes: vec![Mode::Vfc, Mode::Occ, Mode::Och],
            ..options(&[4.0], 40, 2)
        };
        let r = replay_plant(rt, path, &opts).unwrap();
        let s = r.summary();
        let by = |name: &str| s.modes.iter().find(|m| m.name == name).unwrap();
        // Full detail, frustum or conservative culling: the reference's
        // image every frame, so nothing pops.
        assert_eq!(by("vfc").popping, Some(0.0));
        assert_eq!(by("occ").popping, Some(0.0));
        // Coarse LODs switching as the camera walks: some pixels pop.
        let och = by("och").popping.unwrap();
        assert!(och > 0.0 && och < 0.5, "och popping {och}");
        let w = r.write_report(&dir.join("popping")).unwrap();
        assert!(w.files.iter().all(|f| !f.ends_with("pixel_error.png")));
        let md = std::fs::read_to_string(dir.join("popping/summary.md")).unwrap();
        assert!(md.contains("Popping"), "{md}");
    });
}

#[test]
fn speculative_rvg_covers_a_slow_stc_with_extra_frames_and_keeps_every_real_one() {
    on_plant(2, "speculative RVG", 16, |rt, path, _| {
        let mut opts = ReplayOptions {
            modes: vec![Mode::Occ],
            ..options(&[1.0], 16, 4)
        };
        opts.runtime.stc_delay_ms = 60.0;
        let plain = replay_plant(rt, path, &opts).unwrap();
        opts.runtime.speculative_rvg = true;
        let spec = replay_plant(rt, path, &opts).unwrap();
        for r in [&plain, &spec] {
            assert!(r.complete);
            assert_eq!(r.runs[0].frames.len(), 16);
        }
        let (p, s) = (plain.summary(), spec.summary());
        assert_eq!(p.modes[0].speculative_frames, 0);
        assert!(
            s.modes[0].speculative_frames > 0,
            "no speculative frame with a 60 ms STC"
        );
        // Without speculation RVG waits for the slow STC.
        assert!(
            p.modes[0].median_rvg_wait_ms > 20.0,
            "{}",
            p.modes[0].median_rvg_wait_ms
        );
        // The real frames are still exact (occ is conservative).
        assert_eq!(s.modes[0].wrongly_culled_pixels, Some(0));
        let csv = spec.csv();
        assert!(csv.lines().next().unwrap().contains(
            ",speculative_before,rvg_wait_ms,bound_exceeding_pixels,bound_exceeding_fraction,occluder_triangles,occluder_limit,"
        ));
    });
}
