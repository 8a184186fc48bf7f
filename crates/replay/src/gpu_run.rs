//! `benches/gpu-run.sh`'s results: the script records each step (name,
//! kind, status, seconds) in `steps.tsv` and the run's settings in
//! `run.tsv`; [`collect`] reads those and every replay's `summary.json`
//! and pipeline bench table, and [`GpuRun::write`] writes `results.json`
//! (every figure with its unit) and `summary.md`. Kept in Rust so that the
//! GPU machine needs nothing but the `gigawalk` binary: no python, no jq.
//! docs/results.md ("Real GPU") describes the files.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;
use serde_json::Value;

/// `results.json`'s `format`: bumped when a field changes meaning.
pub const FORMAT: &str = "gigawalk-gpu-run 1";

/// Why the results could not be collected or written. A step's missing or
/// unreadable output is not one of these: it is recorded in the step's
/// `note`, since a failed step must not lose the others' figures.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GpuRunError {
    #[error("{file}: cannot read: {source}")]
    Read {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("{file}:{line}: {why}")]
    Parse {
        file: PathBuf,
        line: usize,
        why: String,
    },
    #[error("{file}: cannot write: {source}")]
    Write {
        file: PathBuf,
        source: std::io::Error,
    },
}

/// One step of the script, as `steps.tsv` records it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Step {
    pub name: String,
    /// `build`, `prepare`, `replay`, `pipeline` (a replay of one schedule),
    /// `bench` (the criterion-free pipeline bench's table), `screenshot`.
    pub kind: String,
    /// `ok`, `failed`, `timeout` (stopped by its time limit; a replay
    /// stopped this way still wrote what it measured) or `skipped`.
    pub status: String,
    pub seconds: f64,
    pub timeout_seconds: f64,
    /// The step's output: a report directory, a file, or empty.
    pub output: String,
    /// Why it failed or was skipped, or what it read.
    pub note: String,
}

/// One measured number.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Figure {
    /// The step that measured it.
    pub step: String,
    /// The run within the step (`och 1px`, `pipelined, 2 devices`), or
    /// `all` for a whole-step figure.
    pub run: String,
    pub name: String,
    /// `null`: not computable (e.g. PSNR of identical images).
    pub value: Option<f64>,
    pub unit: String,
}

/// Everything `results.json` holds.
#[derive(Clone, Debug, Serialize)]
pub struct GpuRun {
    pub format: &'static str,
    /// `run.tsv`: mode, commit, machine, start time, budget, ...
    pub run: BTreeMap<String, String>,
    /// Every distinct adapter the replays ran on.
    pub adapters: Vec<String>,
    pub steps: Vec<Step>,
    pub figures: Vec<Figure>,
}

/// The unit of a summary.json field (docs/report-format.md); names not
/// known yet are read by their suffix (`_ms`, `_fraction`, ...).
pub fn unit_of(field: &str) -> &'static str {
    match field {
        "mean_fps" | "fps" => "frames/s",
        "seconds" => "s",
        "mean_triangles" | "triangles_per_frame" => "triangles/frame",
        "mean_drawn_nodes" | "mean_visited" | "mean_occlusion_culled" => "nodes/frame",
        "wrongly_culled_pixels" => "pixels",
        "psnr_db" => "dB",
        "frames" | "measured_frames" | "accuracy_frames" => "frames",
        "pixel_error" => "px",
        "memory_budget" => "bytes",
        f if f.ends_with("_bytes") => "bytes",
        f if f.ends_with("_ms") => "ms",
        f if f.ends_with("_fraction") => "fraction of compared pixels",
        f if f.contains("speedup") => "x",
        f if f.ends_with("_db") => "dB",
        f if f.ends_with("_pixels") => "pixels",
        _ => "count",
    }
}

/// Reads `dir/steps.tsv`, `dir/run.tsv` and every step's output.
pub fn collect(dir: &Path) -> Result<GpuRun, GpuRunError> {
    let run = read_run(&dir.join("run.tsv"))?;
    let mut steps = read_steps(&dir.join("steps.tsv"))?;
    let mut figures = Vec::new();
    let mut adapters: Vec<String> = Vec::new();
    for step in &mut steps {
        figures.push(Figure {
            step: step.name.clone(),
            run: "all".into(),
            name: "step_seconds".into(),
            value: Some(step.seconds),
            unit: "s".into(),
        });
        let out = dir.join(&step.output);
        match step.kind.as_str() {
            "replay" | "pipeline" if !step.output.is_empty() => {
                match read_summary(&out.join("summary.json")) {
                    Ok(summary) => {
                        for d in summary["devices"].as_array().into_iter().flatten() {
                            if let Some(d) = d.as_str() {
                                if !adapters.iter().any(|a| a == d) {
                                    adapters.push(d.to_string());
                                }
                            }
                        }
                        summary_figures(&step.name, &summary, &mut figures);
                    }
                    Err(why) => append_note(step, &why),
                }
            }
            "bench" if !step.output.is_empty() => match std::fs::read_to_string(&out) {
                Ok(text) => bench_figures(&step.name, &text, &mut figures),
                Err(e) => append_note(step, &format!("{}: {e}", out.display())),
            },
            _ => {}
        }
    }
    pipeline_speedups(&steps, &mut figures);
    Ok(GpuRun {
        format: FORMAT,
        run,
        adapters,
        steps,
        figures,
    })
}

fn append_note(step: &mut Step, why: &str) {
    if !step.note.is_empty() {
        step.note.push_str("; ");
    }
    step.note.push_str(why);
}

fn read_text(file: &Path) -> Result<String, GpuRunError> {
    std::fs::read_to_string(file).map_err(|source| GpuRunError::Read {
        file: file.to_owned(),
        source,
    })
}

fn read_run(file: &Path) -> Result<BTreeMap<String, String>, GpuRunError> {
    let text = read_text(file)?;
    let mut run = BTreeMap::new();
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        let (k, v) = line.split_once('\t').unwrap_or((line, ""));
        run.insert(k.to_string(), v.to_string());
    }
    Ok(run)
}

fn read_steps(file: &Path) -> Result<Vec<Step>, GpuRunError> {
    let text = read_text(file)?;
    let mut steps = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let bad = |why: String| GpuRunError::Parse {
            file: file.to_owned(),
            line: i + 1,
            why,
        };
        let f: Vec<&str> = line.splitn(7, '\t').collect();
        if f.len() < 6 {
            return Err(bad(format!(
                "a step needs name, kind, status, seconds, timeout, output and a note; got {} fields",
                f.len()
            )));
        }
        let number = |s: &str, what: &str| {
            s.parse::<f64>()
                .map_err(|_| bad(format!("{what} {s:?} is not a number")))
        };
        steps.push(Step {
            name: f[0].to_string(),
            kind: f[1].to_string(),
            status: f[2].to_string(),
            seconds: number(f[3], "seconds")?,
            timeout_seconds: number(f[4], "timeout")?,
            output: f[5].to_string(),
            note: f.get(6).unwrap_or(&"").to_string(),
        });
    }
    Ok(steps)
}

fn read_summary(file: &Path) -> Result<Value, String> {
    let text = std::fs::read_to_string(file).map_err(|e| format!("{}: {e}", file.display()))?;
    serde_json::from_str(&text).map_err(|e| format!("{}: {e}", file.display()))
}

/// Every number of a replay's summary.json, per run; unknown fields are
/// kept too (their unit from [`unit_of`]), so a figure added to the
/// summary later reaches results.json without a change here.
fn summary_figures(step: &str, summary: &Value, out: &mut Vec<Figure>) {
    let mut push = |run: &str, name: &str, v: &Value| {
        if v.is_number() || v.is_null() {
            out.push(Figure {
                step: step.to_string(),
                run: run.to_string(),
                name: name.to_string(),
                value: v.as_f64(),
                unit: unit_of(name).to_string(),
            });
        }
    };
    for (k, v) in summary.as_object().into_iter().flatten() {
        // Settings, not figures.
        if !matches!(
            k.as_str(),
            "width"
                | "height"
                | "warmup_frames"
                | "accuracy_every"
                | "occluder_lag"
                | "occluder_scale"
                | "occluder_budget"
        ) && v.is_number()
        {
            push("all", k, v);
        }
    }
    for m in summary["modes"].as_array().into_iter().flatten() {
        let name = m["name"].as_str().unwrap_or("?");
        let pe = m["pixel_error"].as_f64().unwrap_or(0.0);
        let run = if matches!(name, "hlod" | "och") {
            format!("{name} {pe}px")
        } else {
            name.to_string()
        };
        for (k, v) in m.as_object().into_iter().flatten() {
            if k != "name" && k != "pixel_error" {
                push(&run, k, v);
            }
        }
    }
}

/// The pipeline bench's table rows (`| schedule | median frame ms | fps |
/// OR ms | STC ms (HZB) | RVG ms | latency ms | triangles/frame |`).
fn bench_figures(step: &str, text: &str, out: &mut Vec<Figure>) {
    const COLUMNS: [(&str, &str); 7] = [
        ("median_frame_ms", "ms"),
        ("fps", "frames/s"),
        ("median_or_ms", "ms"),
        ("median_stc_ms", "ms"),
        ("median_rvg_ms", "ms"),
        ("median_latency_ms", "ms"),
        ("triangles_per_frame", "triangles/frame"),
    ];
    for line in text.lines() {
        let cells: Vec<&str> = line
            .trim()
            .trim_matches('|')
            .split('|')
            .map(str::trim)
            .collect();
        if cells.len() != 8 || cells[1].parse::<f64>().is_err() {
            continue;
        }
        for (i, (name, unit)) in COLUMNS.iter().enumerate() {
            // "0.6 (0.5)": STC with the HZB build in brackets.
            let cell = cells[i + 1];
            let first = cell.split_whitespace().next().unwrap_or("");
            out.push(Figure {
                step: step.to_string(),
                run: cells[0].to_string(),
                name: name.to_string(),
                value: first.replace(',', "").parse().ok(),
                unit: unit.to_string(),
            });
        }
    }
}

/// The pipelined schedules' speed-up over the sequential one, from the
/// `pipeline` steps' median frame times (`och`).
fn pipeline_speedups(steps: &[Step], figures: &mut Vec<Figure>) {
    let median = |step: &str| {
        figures
            .iter()
            .find(|f| f.step == step && f.run != "all" && f.name == "median_frame_ms")
            .and_then(|f| f.value)
    };
    let pipeline: Vec<&Step> = steps.iter().filter(|s| s.kind == "pipeline").collect();
    let Some(seq) = pipeline.iter().find(|s| s.name.ends_with("sequential")) else {
        return;
    };
    let base = median(&seq.name);
    let mut add = Vec::new();
    for s in pipeline.iter().filter(|s| s.name != seq.name) {
        add.push(Figure {
            step: s.name.clone(),
            run: "all".into(),
            name: "speedup_vs_sequential".into(),
            value: match (base, median(&s.name)) {
                (Some(b), Some(p)) if p > 0.0 => Some(b / p),
                _ => None,
            },
            unit: "x".into(),
        });
    }
    figures.extend(add);
}

impl GpuRun {
    /// The figure `name` of `step`'s `run`, if measured.
    pub fn figure(&self, step: &str, run: &str, name: &str) -> Option<f64> {
        self.figures
            .iter()
            .find(|f| f.step == step && f.run == run && f.name == name)
            .and_then(|f| f.value)
    }

    /// Writes `results.json` and `summary.md` into `dir`.
    pub fn write(&self, dir: &Path) -> Result<Vec<PathBuf>, GpuRunError> {
        let json = serde_json::to_string_pretty(self).expect("results serialise") + "\n";
        let mut written = Vec::new();
        for (name, bytes) in [("results.json", json), ("summary.md", self.markdown())] {
            let file = dir.join(name);
            gigawalk_scene::write_atomic(&file, bytes.as_bytes()).map_err(|source| {
                GpuRunError::Write {
                    file: file.clone(),
                    source,
                }
            })?;
            written.push(file);
        }
        Ok(written)
    }

    /// summary.md: steps, adapters, one table per replay, the pipeline.
    pub fn markdown(&self) -> String {
        let mut m = String::new();
        let get = |k: &str| self.run.get(k).map_or("?", String::as_str);
        let _ = writeln!(m, "# gigawalk GPU run ({})\n", get("mode"));
        for (k, v) in &self.run {
            let _ = writeln!(m, "- {k}: {v}");
        }
        let _ = writeln!(
            m,
            "- adapters: {}\n",
            if self.adapters.is_empty() {
                "none recorded".to_string()
            } else {
                self.adapters.join("; ")
            }
        );
        let _ = writeln!(m, "| step | status | seconds | limit s | note |");
        let _ = writeln!(m, "|---|---|---:|---:|---|");
        for s in &self.steps {
            let _ = writeln!(
                m,
                "| {} | {} | {:.1} | {:.0} | {} |",
                s.name,
                s.status,
                s.seconds,
                s.timeout_seconds,
                s.note.replace('|', "/")
            );
        }
        let fmt = |v: Option<f64>, digits: usize| match v {
            Some(v) => format!("{v:.digits$}"),
            None => "-".into(),
        };
        for s in self
            .steps
            .iter()
            .filter(|s| s.kind == "replay" || s.kind == "pipeline")
        {
            let runs: Vec<&str> = {
                let mut r: Vec<&str> = Vec::new();
                for f in self
                    .figures
                    .iter()
                    .filter(|f| f.step == s.name && f.run != "all")
                {
                    if !r.contains(&f.run.as_str()) {
                        r.push(&f.run);
                    }
                }
                r
            };
            if runs.is_empty() {
                continue;
            }
            let _ = writeln!(m, "\n## {} ({})\n", s.name, s.output);
            let _ = writeln!(
                m,
                "| run | mean fps | median ms | p95 ms | mean triangles | speed-up vs vfc | OR ms | STC ms | RVG ms | differing px | wrongly culled px | PSNR dB |"
            );
            let _ = writeln!(
                m,
                "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
            );
            for r in runs {
                let f = |n: &str| self.figure(&s.name, r, n);
                let _ = writeln!(
                    m,
                    "| {r} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                    fmt(f("mean_fps"), 2),
                    fmt(f("median_frame_ms"), 2),
                    fmt(f("p95_frame_ms"), 2),
                    fmt(f("mean_triangles"), 0),
                    fmt(f("speedup_vs_vfc"), 2),
                    fmt(f("median_or_ms"), 2),
                    fmt(f("median_stc_ms"), 2),
                    fmt(f("median_rvg_ms"), 2),
                    f("differing_pixels_fraction")
                        .map_or("-".into(), |v| format!("{:.2}%", v * 100.0)),
                    fmt(f("wrongly_culled_pixels"), 0),
                    fmt(f("psnr_db"), 1),
                );
            }
        }
        let speedups: Vec<&Figure> = self
            .figures
            .iter()
            .filter(|f| f.name == "speedup_vs_sequential")
            .collect();
        if !speedups.is_empty() {
            let _ = writeln!(m, "\n## Pipelined vs sequential (median frame time, och)\n");
            for f in speedups {
                let v = f
                    .value
                    .map_or("not measured".into(), |v| format!("{v:.2}x"));
                let _ = writeln!(m, "- {}: {v}", f.step);
            }
        }
        let bench: Vec<&Figure> = self
            .figures
            .iter()
            .filter(|f| {
                f.name == "median_frame_ms"
                    && self
                        .steps
                        .iter()
                        .any(|s| s.name == f.step && s.kind == "bench")
            })
            .collect();
        if !bench.is_empty() {
            let _ = writeln!(m, "\n## Pipeline bench (benches/pipeline.rs)\n");
            for f in bench {
                let _ = writeln!(m, "- {}: median frame {} ms", f.run, fmt(f.value, 2));
            }
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_of_known_and_future_fields() {
        for (field, unit) in [
            ("mean_fps", "frames/s"),
            ("median_rvg_ms", "ms"),
            ("psnr_db", "dB"),
            ("bound_violating_fraction", "fraction of compared pixels"),
            ("median_speedup_vs_vfc", "x"),
            ("mean_triangles", "triangles/frame"),
        ] {
            assert_eq!(unit_of(field), unit, "{field}");
        }
    }

    #[test]
    fn missing_summary_is_a_note_and_the_rest_is_kept() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::write(d.join("run.tsv"), "mode\tquick\n").unwrap();
        std::fs::write(
            d.join("steps.tsv"),
            "build\tbuild\tskipped\t0\t240\t\tGIGAWALK_BIN given\n\
             demo-640x360\treplay\tok\t3.5\t60\tdemo-640x360\t\n\
             gone\treplay\tfailed\t1\t60\tgone\texit 1\n\
             pipeline-sequential\tpipeline\tok\t1\t30\tseq\t\n\
             pipeline-2dev\tpipeline\tok\t1\t30\tp2\t\n\
             bench\tbench\tok\t9\t60\tbench.txt\t\n",
        )
        .unwrap();
        let summary = |ms: f64| {
            format!(
                r#"{{"devices": ["GPU A", "GPU B"], "seconds": 2.0, "width": 640,
                   "modes": [{{"name": "och", "pixel_error": 1.0, "mean_fps": 100.0,
                   "median_frame_ms": {ms}, "psnr_db": null, "bound_violating_fraction": 0.5}}]}}"#
            )
        };
        for (sub, ms) in [("demo-640x360", 10.0), ("seq", 20.0), ("p2", 8.0)] {
            std::fs::create_dir(d.join(sub)).unwrap();
            std::fs::write(d.join(sub).join("summary.json"), summary(ms)).unwrap();
        }
        std::fs::write(
            d.join("bench.txt"),
            "| schedule | median frame ms | fps | OR ms | STC ms (HZB) | RVG ms | latency ms | triangles/frame |\n\
             |---|---|---|---|---|---|---|---|\n\
             | sequential (1 thread, 1 device) | 64.9 | 15.4 | 28.7 | 0.4 (0.2) | 35.3 | 64.6 | 269499 |\n",
        )
        .unwrap();
        let r = collect(d).unwrap();
        assert_eq!(r.adapters, ["GPU A", "GPU B"]);
        assert_eq!(r.figure("demo-640x360", "och 1px", "mean_fps"), Some(100.0));
        assert_eq!(r.figure("demo-640x360", "all", "seconds"), Some(2.0));
        assert_eq!(r.figure("demo-640x360", "all", "width"), None);
        let psnr = r.figures.iter().find(|f| f.name == "psnr_db").unwrap();
        assert_eq!((psnr.value, psnr.unit.as_str()), (None, "dB"));
        assert_eq!(
            r.figure("demo-640x360", "och 1px", "bound_violating_fraction"),
            Some(0.5)
        );
        assert_eq!(
            r.figure("pipeline-2dev", "all", "speedup_vs_sequential"),
            Some(2.5)
        );
        assert_eq!(
            r.figure("bench", "sequential (1 thread, 1 device)", "median_stc_ms"),
            Some(0.4)
        );
        assert!(r.steps[2].note.contains("summary.json"), "{:?}", r.steps[2]);
        let written = r.write(d).unwrap();
        let back: Value =
            serde_json::from_str(&std::fs::read_to_string(&written[0]).unwrap()).unwrap();
        assert_eq!(back["format"], FORMAT);
        assert!(std::fs::read_to_string(&written[1])
            .unwrap()
            .contains("| och 1px | 100.00 |"));
    }

    #[test]
    fn malformed_steps_line_names_the_line() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("run.tsv"), "").unwrap();
        std::fs::write(dir.path().join("steps.tsv"), "ok\n").unwrap();
        let e = collect(dir.path()).unwrap_err().to_string();
        assert!(e.contains("steps.tsv:1:"), "{e}");
        std::fs::write(dir.path().join("steps.tsv"), "a\tb\tok\tfast\t1\t\n").unwrap();
        let e = collect(dir.path()).unwrap_err().to_string();
        assert!(e.contains("seconds \"fast\""), "{e}");
    }
}
