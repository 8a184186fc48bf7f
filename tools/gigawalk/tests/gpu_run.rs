//! `benches/gpu-run.sh --quick` end to end with this build's binary: the
//! run a real GPU gets, on small scenes, must finish with every step
//! recorded and a results.json holding every figure with its unit (so the
//! one GPU run cannot be wasted on a script error). Skips loudly without a
//! GPU adapter, unless GIGAWALK_REQUIRE_ADAPTER is set (CI).

use std::path::Path;
use std::process::Command;

use serde_json::Value;

/// The quick run's viewports (the full run's are 1920x1080 and 640x360).
const HI: &str = "320x180";
const LO: &str = "160x90";
const MODE_RUNS: [&str; 4] = ["vfc", "hlod 1px", "occ", "och 1px"];
/// Per run of every replay: docs/report-format.md's summary.json fields.
const RUN_FIGURES: [&str; 20] = [
    "frames",
    "measured_frames",
    "mean_fps",
    "median_frame_ms",
    "p95_frame_ms",
    "mean_triangles",
    "mean_drawn_nodes",
    "mean_visited",
    "mean_occlusion_culled",
    "speedup_vs_vfc",
    "median_speedup_vs_vfc",
    "mean_latency_ms",
    "median_or_ms",
    "median_hzb_ms",
    "median_stc_ms",
    "median_rvg_ms",
    "accuracy_frames",
    "wrongly_culled_pixels",
    "wrongly_culled_fraction",
    "differing_pixels_fraction",
];

fn figure<'a>(results: &'a Value, step: &str, run: &str, name: &str) -> Option<&'a Value> {
    results["figures"]
        .as_array()?
        .iter()
        .find(|f| f["step"] == step && f["run"] == run && f["name"] == name)
}

#[test]
fn quick_gpu_run_records_every_step_and_figure() {
    if gigawalk_gpu::devices_or_skip(2, "benches/gpu-run.sh --quick").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../benches/gpu-run.sh");
    let run = Command::new("bash")
        .arg(&script)
        .arg(&out)
        .arg("--quick")
        .env("GIGAWALK_BIN", env!("CARGO_BIN_EXE_gigawalk"))
        .env("GIGAWALK_GPU_RUN_CACHE", dir.path().join("cache"))
        .output()
        .unwrap();
    let log = format!(
        "{}\n{}",
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(run.status.success(), "gpu-run.sh --quick failed:\n{log}");
    let text = std::fs::read_to_string(out.join("results.json")).unwrap();
    let results: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(results["format"], "gigawalk-gpu-run 1");
    assert_eq!(results["run"]["mode"], "quick");
    for key in ["commit", "cpus", "os", "total_s", "budget_s", "gigawalk"] {
        assert!(results["run"][key].is_string(), "run.{key} missing:\n{log}");
    }
    assert!(
        !results["adapters"].as_array().unwrap().is_empty(),
        "no adapter names:\n{log}"
    );

    let steps = results["steps"].as_array().unwrap();
    let status = |name: &str| {
        steps
            .iter()
            .find(|s| s["name"] == name)
            .unwrap_or_else(|| panic!("step {name} not recorded:\n{log}"))["status"]
            .as_str()
            .unwrap()
            .to_string()
    };
    assert_eq!(status("build"), "skipped");
    assert_eq!(status("bench-pipeline"), "skipped");
    let replays = [
        format!("replay-demo-{HI}"),
        format!("replay-demo-{LO}"),
        format!("replay-big-{HI}"),
        format!("replay-big-{LO}"),
    ];
    let pipeline = ["pipeline-sequential", "pipeline-1dev", "pipeline-2dev"];
    for name in ["prepare-demo", "prepare-big"]
        .iter()
        .map(|s| s.to_string())
        .chain(replays.iter().cloned())
        .chain(pipeline.iter().map(|s| s.to_string()))
    {
        assert_eq!(status(&name), "ok", "step {name}:\n{log}");
    }
    // Streamed under a budget: its memory figures, in bytes.
    let stream = format!("replay-big-stream-{LO}");
    assert_eq!(status(&stream), "ok", "step {stream}:\n{log}");
    let peak = figure(&results, &stream, "och 1px", "peak_resident_bytes")
        .unwrap_or_else(|| panic!("{stream}: no peak_resident_bytes:\n{log}"));
    assert_eq!(peak["unit"], "bytes");
    assert!(peak["value"].as_f64().is_some_and(|v| v > 0.0), "{peak}");
    // Under CI there is Xvfb; elsewhere the step may skip, never fail.
    let viewer = status("viewer");
    assert!(
        viewer == "ok" || viewer == "skipped",
        "viewer {viewer}:\n{log}"
    );
    if viewer == "ok" {
        assert!(out.join("viewer.png").is_file());
    }
    for s in steps {
        for key in ["name", "kind", "status", "output", "note"] {
            assert!(s[key].is_string(), "step field {key}: {s}");
        }
        for key in ["seconds", "timeout_seconds"] {
            assert!(s[key].is_number(), "step field {key}: {s}");
        }
    }

    for f in results["figures"].as_array().unwrap() {
        assert!(
            f["unit"].as_str().is_some_and(|u| !u.is_empty()),
            "figure without a unit: {f}"
        );
        assert!(f["value"].is_number() || f["value"].is_null(), "{f}");
    }
    for step in &replays {
        for run in MODE_RUNS {
            for name in RUN_FIGURES {
                let f = figure(&results, step, run, name)
                    .unwrap_or_else(|| panic!("{step} {run} {name} missing"));
                assert!(f["value"].is_number(), "{step} {run} {name}: {f}");
            }
            // Null when the images are identical.
            assert!(figure(&results, step, run, "psnr_db").is_some());
        }
        let tri = figure(&results, step, "och 1px", "mean_triangles").unwrap();
        assert!(tri["value"].as_f64().unwrap() > 0.0);
        assert_eq!(tri["unit"], "triangles/frame");
    }
    for step in pipeline {
        let f = figure(&results, step, "och 1px", "median_frame_ms").unwrap();
        assert_eq!(f["unit"], "ms");
        assert!(f["value"].as_f64().unwrap() > 0.0);
    }
    for step in ["pipeline-1dev", "pipeline-2dev"] {
        let f = figure(&results, step, "all", "speedup_vs_sequential").unwrap();
        assert!(f["value"].as_f64().unwrap() > 0.0 && f["unit"] == "x");
    }
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    for name in replays.iter().map(String::as_str).chain(pipeline) {
        assert!(summary.contains(name), "summary.md lacks {name}");
    }
}
