//! `gigawalk replay` end to end: bad path and scene files are clear errors
//! with a non-zero exit code; a small generated plant replays into a report.

use std::path::{Path, PathBuf};

mod common;
use common::{gigawalk, s};

/// `gigawalk replay SCENE --path PATH --out OUT` with `more` flags.
fn replay(gwk: &Path, path: &Path, out: &Path, more: &[&str]) -> (bool, String, String) {
    let mut args = vec!["replay", s(gwk), "--path", s(path), "--out", s(out)];
    args.extend_from_slice(more);
    gigawalk(&args)
}

/// A generated plant of `triangles` with a 12-pose walk, preprocessed in
/// `dir`: its path and scene files, and a report directory.
fn plant(dir: &Path, triangles: &str) -> (PathBuf, PathBuf, PathBuf) {
    let (path, gwk) = common::plant(dir, triangles);
    (path, gwk, dir.join("report"))
}

const ONE_POSE: &str = "0 0 1.7 5 0 0 0 1 60\n";

#[test]
fn missing_path_file() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("none.gwk");
    std::fs::write(&scene, b"").unwrap();
    let path = dir.path().join("missing.path");
    let (ok, _, err) = gigawalk(&["replay", s(&scene), "--path", s(&path)]);
    assert!(!ok);
    assert!(
        err.contains("missing.path") && err.contains("camera path"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn malformed_path_file_names_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("none.gwk");
    std::fs::write(&scene, b"").unwrap();
    let path = dir.path().join("bad.path");
    std::fs::write(&path, format!("{ONE_POSE}1 0 1.7 oops 0 0 0 1 60\n")).unwrap();
    let (ok, _, err) = gigawalk(&["replay", s(&scene), "--path", s(&path)]);
    assert!(!ok);
    assert!(err.contains("bad.path") && err.contains("line 2"), "{err}");
}

#[test]
fn garbage_scene_file() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("garbage.gwk");
    std::fs::write(&scene, b"this is not a scene file at all, just some bytes").unwrap();
    let path = dir.path().join("ok.path");
    std::fs::write(&path, ONE_POSE).unwrap();
    let (ok, _, err) = gigawalk(&["replay", s(&scene), "--path", s(&path)]);
    assert!(!ok);
    assert!(err.contains("garbage.gwk"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn unknown_mode_is_rejected() {
    let (ok, _, err) = gigawalk(&["replay", "x.gwk", "--path", "x.path", "--modes", "vfc,fast"]);
    assert!(!ok);
    assert!(err.contains("unknown mode \"fast\""), "{err}");
}

#[test]
fn bad_occluder_budget_and_prefetch_are_rejected() {
    for (flag, bad, says) in [
        ("occluder-budget", "lots", "occluder budget"),
        ("occluder-budget", "-3", "occluder budget"),
        ("occluder-budget", "1e19", "occluder budget"),
        ("prefetch", "on", "off, band, ring or both"),
        ("target-fps", "0", "a target must be"),
        ("target-ms", "-5", "a target must be"),
        ("pixel-error-max", "-1", "--pixel-error-max"),
        ("tiles", "0x3", "not a count from 1 to 64"),
        ("tile-culling", "fast", "tile culling \"fast\""),
        ("tile-size", "1920", "expected WIDTHxHEIGHT"),
    ] {
        let flag = format!("--{flag}={bad}");
        let (ok, _, err) = gigawalk(&["replay", "x.gwk", "--path", "x.path", &flag]);
        assert!(!ok);
        assert!(err.contains(says), "{bad}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn small_plant_replays_into_a_report() {
    if gigawalk_gpu::devices_or_skip(2, "gigawalk replay CLI").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (path, gwk, out) = plant(dir.path(), "20k");
    let (ok, stdout, err) = replay(
        &gwk,
        &path,
        &out,
        &[
            "--width",
            "96",
            "--height",
            "54",
            "--accuracy-every",
            "4",
            "--warmup",
            "2",
            "--modes",
            "vfc,och",
        ],
    );
    assert!(ok, "{err}");
    // Loading the whole scene before the first frame is reported too.
    assert!(err.contains("LODs before the first frame"), "{err}");
    assert!(stdout.contains("| och |"), "{stdout}");
    for f in ["summary.md", "summary.json", "frames.csv", "fps.png"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    assert!(
        !out.join("tradeoff.png").exists(),
        "no sweep, no tradeoff plot"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(json["frames"], 12);
    // The default budget is adaptive (no fixed budget: null), on any
    // device, and frames.csv has each frame's choice.
    assert_eq!(json["occluder_budget"], serde_json::Value::Null);
    assert_eq!(json["occluder_selection"], "adaptive");
    assert_eq!(json["modes"].as_array().unwrap().len(), 2);
    let rows = std::fs::read_to_string(out.join("frames.csv"))
        .unwrap()
        .lines()
        .count();
    assert_eq!(rows, 1 + 2 * 12);
}

/// `--adapter null` needs no GPU: every GPU operation is free, so the
/// report is what the CPU can feed, and says so. Nothing is drawn, so
/// accuracy is not measured; depth reads back as zeros, so occlusion
/// culls nothing; OR reads back the small level of its pyramid, not the
/// whole image, unless `--hzb cpu` asks for it.
#[test]
fn a_null_adapter_replay_reports_the_cpu_ceiling() {
    let dir = tempfile::tempdir().unwrap();
    let (path, gwk, out) = plant(dir.path(), "20k");
    let (w, h) = (1280u64, 720u64);
    let run = |out: &Path, hzb: &str| {
        let (ok, stdout, err) = replay(
            &gwk,
            &path,
            out,
            &[
                "--adapter",
                "null",
                "--width",
                "1280",
                "--height",
                "720",
                "--warmup",
                "2",
                "--modes",
                "vfc,hlod,och",
                "--hzb",
                hzb,
            ],
        );
        assert!(ok, "{err}");
        assert!(stdout.contains("| och |"), "{stdout}");
        let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
        assert!(md.contains("**Null adapter"), "{md}");
        assert!(
            md.contains("accuracy: not measured (the null adapter"),
            "{md}"
        );
        assert!(md.contains("## CPU time a frame"), "{md}");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap())
                .unwrap();
        assert_eq!(json["null_adapter"], true);
        assert_eq!(json["accuracy_every"], 0);
        let modes = json["modes"].as_array().unwrap().clone();
        assert_eq!(modes.len(), 3);
        for m in &modes {
            assert_eq!(m["accuracy_frames"], 0, "{m}");
            assert_eq!(m["mean_occlusion_culled"], 0.0, "nothing occluded: {m}");
            assert!(m["mean_triangles"].as_f64().unwrap() > 0.0, "{m}");
        }
        modes[2].clone()
    };
    let gpu = run(&out, "gpu");
    let cpu = run(&dir.path().join("cpu"), "cpu");
    // 1280x720 reads level 2 (320x180), 16 times fewer bytes than the
    // whole image; both draw the same (nothing is occluded either way).
    assert_eq!(gpu["cpu"]["median_hzb_level"], 2.0);
    assert_eq!(cpu["cpu"]["median_hzb_level"], 0.0);
    let read = |m: &serde_json::Value| m["cpu"]["mean_or_read_bytes"].as_f64().unwrap();
    assert!(read(&cpu) >= (w * h * 4) as f64, "{cpu}");
    assert!(read(&gpu) <= (w * h * 4 / 16) as f64 + 4096.0, "{gpu}");
    assert_eq!(gpu["mean_triangles"], cpu["mean_triangles"]);
    // frames.csv has the split of each frame's CPU time.
    let csv = std::fs::read_to_string(out.join("frames.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    for col in [
        "or_wait_ms",
        "traversal_ms",
        "cull_test_ms",
        "rvg_encode_ms",
        "or_read_bytes",
    ] {
        assert!(
            header.split(',').any(|c| c == col),
            "{col} missing: {header}"
        );
    }
    // The look and x-ray run every frame and the report says so; x-ray
    // needs something hidden.
    let looked = dir.path().join("look");
    let (ok, _, err) = replay(
        &gwk,
        &path,
        &looked,
        &[
            "--adapter",
            "null",
            "--modes",
            "och",
            "--sky",
            "on",
            "--edges",
            "on",
            "--aa",
            "fxaa",
            "--hide",
            "*pipes*",
            "--xray",
        ],
    );
    assert!(ok, "{err}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(looked.join("summary.json")).unwrap())
            .unwrap();
    assert_eq!(json["look"], "sky, edges over 30 degrees, FXAA");
    assert_eq!(json["xray"], true);
    let md = std::fs::read_to_string(looked.join("summary.md")).unwrap();
    assert!(
        md.contains("**Look: sky") && md.contains("**X-ray:"),
        "{md}"
    );
    let (ok, _, err) = replay(&gwk, &path, &looked, &["--adapter", "null", "--xray"]);
    assert!(
        !ok && err.contains("--xray") && err.contains("--hide"),
        "{err}"
    );
    // A window cannot be shown on it.
    let (ok, _, err) = gigawalk(&["view", s(&gwk), "--adapter", "null"]);
    assert!(
        !ok && err.contains("the null adapter draws nothing"),
        "{err}"
    );
}

#[test]
fn a_corrupted_lod_found_while_streaming_ends_the_replay_with_a_partial_report() {
    if gigawalk_gpu::devices_or_skip(2, "gigawalk replay CLI, streaming").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (path, gwk, out) = plant(dir.path(), "60k");
    // Corrupt the full-detail LOD of every leaf with coarser ones (never
    // pinned, which would fail the start instead); the first
    // frames at full detail ask for some of them.
    let mut bytes = std::fs::read(&gwk).unwrap();
    {
        let scene = gigawalk_scene::SceneReader::open(&gwk).unwrap();
        let sk = scene.skeleton();
        for n in sk.nodes().iter().filter(|n| n.is_leaf() && n.lod_count > 1) {
            let l = &sk.lods()[n.first_lod as usize];
            bytes[(l.offset + l.len / 2) as usize] ^= 0x5a;
        }
    }
    std::fs::write(&gwk, &bytes).unwrap();
    let (ok, _, err) = replay(
        &gwk,
        &path,
        &out,
        &[
            "--width",
            "96",
            "--height",
            "54",
            "--accuracy-every",
            "0",
            "--modes",
            "occ",
            "--memory-budget",
            "256k",
        ],
    );
    assert!(!ok, "a corrupted LOD must fail the replay");
    // Progress while the pinned set loads (one line each way off a terminal).
    assert!(err.contains("LODs before the first frame"), "{err}");
    assert!(err.contains("loading done in"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(err.contains("p.gwk") && err.contains("LOD "), "{err}");
    assert!(err.contains("loader"), "{err}");
    // The report of what was measured before the error.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(json["complete"], false);
}

#[test]
fn a_damaged_occluder_section_is_an_error_naming_it_not_none() {
    if gigawalk_gpu::devices_or_skip(2, "gigawalk replay --cullers ct, damaged OCCL/OCVC").is_none()
    {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (path, gwk, out) = plant(dir.path(), "20k");
    let good = std::fs::read(&gwk).unwrap();
    let sections = gigawalk_scene::SceneReader::open(&gwk)
        .unwrap()
        .sections()
        .to_vec();
    for tag in ["OCCL", "OCVC"] {
        let s = sections.iter().find(|s| s.name == tag).unwrap();
        let mut bytes = good.clone();
        bytes[(s.offset + s.len / 2) as usize] ^= 0x10;
        std::fs::write(&gwk, &bytes).unwrap();
        let (ok, _, err) = replay(
            &gwk,
            &path,
            &out,
            &[
                "--width",
                "96",
                "--height",
                "54",
                "--accuracy-every",
                "0",
                "--modes",
                "occ",
                "--cullers",
                "ct",
            ],
        );
        assert!(!ok, "{tag}: a damaged section must fail the replay");
        assert!(
            err.contains("p.gwk") && err.contains(&format!("checksum mismatch in {tag}")),
            "{tag}: {err}"
        );
        assert!(!err.contains("stores none"), "{tag}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn a_tiled_replay_sizes_the_view_from_its_tiles() {
    if gigawalk_gpu::devices_or_skip(2, "gigawalk replay --tiles").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (path, gwk, out) = plant(dir.path(), "20k");
    let (ok, _, err) = replay(
        &gwk,
        &path,
        &out,
        &[
            "--modes",
            "vfc,occ",
            "--frames",
            "4",
            "--accuracy-every",
            "2",
            "--tiles",
            "3x2",
            "--tile-size",
            "40x30",
            "--tile-culling",
            "frustum-hierarchy",
        ],
    );
    assert!(ok, "{err}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(
        (summary["width"].as_u64(), summary["height"].as_u64()),
        (Some(120), Some(60))
    );
    for m in summary["modes"].as_array().unwrap() {
        assert_eq!(m["tiles"], "3x2");
        assert_eq!(m["tile_culling"], "frustum-hierarchy");
        assert_eq!(m["wrongly_culled_pixels"], 0, "{m}");
    }
}
