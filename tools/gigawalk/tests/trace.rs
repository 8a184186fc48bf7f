//! `gigawalk --trace`: a replay writes a Chrome trace in which OR, STC and
//! RVG run on their own threads and overlap in time (the paper's Figure 6).

use std::collections::HashMap;

mod common;
use common::{gigawalk_ok, s};

#[test]
fn replay_trace_shows_the_stages_overlapping() {
    if gigawalk_gpu::devices_or_skip(2, "gigawalk --trace").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n);
    gigawalk_ok(&[
        "generate",
        "plant",
        "--triangles",
        "30k",
        "--seed",
        "4",
        "-o",
        s(&p("p.glb")),
        "--path",
        s(&p("p.path")),
        "--poses",
        "30",
    ]);
    gigawalk_ok(&["preprocess", s(&p("p.glb")), "-o", s(&p("p.gwk"))]);
    gigawalk_ok(&[
        "--trace",
        s(&p("trace.json")),
        "replay",
        s(&p("p.gwk")),
        "--path",
        s(&p("p.path")),
        "--out",
        s(&p("report")),
        "--modes",
        "och",
        "--width",
        "96",
        "--height",
        "54",
    ]);
    let trace: serde_json::Value =
        serde_json::from_slice(&std::fs::read(p("trace.json")).unwrap()).unwrap();
    let events = trace
        .as_array()
        .or_else(|| trace["traceEvents"].as_array())
        .expect("trace events");
    // (stage, thread) -> [(begin, end)] in microseconds, from B/E pairs.
    let mut open: HashMap<(String, u64), f64> = HashMap::new();
    let mut spans: HashMap<String, Vec<(u64, f64, f64)>> = HashMap::new();
    for e in events {
        let name = e["name"].as_str().unwrap_or_default();
        if !["OR", "STC", "RVG"].contains(&name) {
            continue;
        }
        let (tid, ts) = (e["tid"].as_u64().unwrap(), e["ts"].as_f64().unwrap());
        match e["ph"].as_str() {
            Some("B") => {
                open.insert((name.into(), tid), ts);
            }
            Some("E") => {
                if let Some(b) = open.remove(&(name.to_string(), tid)) {
                    spans.entry(name.into()).or_default().push((tid, b, ts));
                }
            }
            Some("X") => spans.entry(name.into()).or_default().push((
                tid,
                ts,
                ts + e["dur"].as_f64().unwrap(),
            )),
            _ => {}
        }
    }
    for stage in ["OR", "STC", "RVG"] {
        assert!(
            spans.get(stage).is_some_and(|v| v.len() >= 20),
            "too few {stage} spans: {spans:?}"
        );
    }
    // The pipelined run has a thread per stage.
    let thread_of = |stage: &str| {
        spans[stage]
            .iter()
            .map(|s| s.0)
            .collect::<std::collections::BTreeSet<_>>()
    };
    let (or, rvg) = (thread_of("OR"), thread_of("RVG"));
    assert!(
        rvg.iter().any(|t| !or.contains(t)),
        "RVG never ran on its own thread"
    );
    // Some OR span overlaps some RVG span: frame i's occluders are drawn
    // while frame i - 1 or i - 2 is drawn.
    let overlap = spans["OR"].iter().any(|&(ta, a0, a1)| {
        spans["RVG"]
            .iter()
            .any(|&(tb, b0, b1)| ta != tb && a0 < b1 && b0 < a1)
    });
    assert!(overlap, "OR and RVG never overlap in time");
}
