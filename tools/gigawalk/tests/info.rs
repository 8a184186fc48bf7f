//! `gigawalk info` end to end: text, JSON, --verify, and bad input.

use std::process::Command;

use gigawalk_scene::{Aabb, Colours, LodMesh, Node, Provenance, SceneWriter, NO_NODE};
use glam::DVec3;

mod common;
use common::gigawalk;

/// Root with two leaf triangles; each leaf has LODs of 2 and 1 triangles.
fn write_scene(path: &std::path::Path) {
    write_scene_with(path, Vec::new());
}

/// [`write_scene`] with optional sections (tag, bytes) added.
fn write_scene_with(path: &std::path::Path, optional: Vec<([u8; 4], Vec<u8>)>) {
    let tri = |x: f32, n: usize| LodMesh {
        origin: DVec3::ZERO,
        positions: (0..n + 2)
            .map(|i| [x + i as f32, (i % 2) as f32, 0.0])
            .collect(),
        normals: vec![[0.0, 0.0, 1.0]; n + 2],
        colours: Colours::Uniform([200, 10, 10, 255]),
        indices: (0..n as u32).flat_map(|i| [i, i + 1, i + 2]).collect(),
    };
    let mut w = SceneWriter::create(path).unwrap();
    for (tag, bytes) in optional {
        w.add_optional_section(tag, bytes);
    }
    // Raw f32 positions: the figures below are exact (quantized, each
    // error would grow by a millionth of its box).
    w.set_position_bits(None).unwrap();
    w.add_lod(&tri(0.0, 1), 3.0).unwrap(); // root HLOD
    w.add_lod(&tri(0.0, 2), 0.0).unwrap();
    w.add_lod(&tri(0.0, 1), 1.0).unwrap();
    w.add_lod(&tri(10.0, 2), 0.0).unwrap();
    w.add_lod(&tri(10.0, 1), 1.0).unwrap();
    let b = |x: f64| Aabb::new(DVec3::new(x, 0.0, 0.0), DVec3::new(x + 3.0, 1.0, 0.0));
    let nodes = vec![
        Node {
            bounds: b(0.0).union(&b(10.0)),
            parent: NO_NODE,
            first_child: 1,
            child_count: 2,
            first_lod: 0,
            lod_count: 1,
        },
        Node {
            bounds: b(0.0),
            parent: 0,
            first_child: 0,
            child_count: 0,
            first_lod: 1,
            lod_count: 2,
        },
        Node {
            bounds: b(10.0),
            parent: 0,
            first_child: 0,
            child_count: 0,
            first_lod: 3,
            lod_count: 2,
        },
    ];
    let mut p = Provenance {
        source: "hand.glb".into(),
        tool: "test".into(),
        ..Default::default()
    };
    p.parameters.insert("t1".into(), 1000.into());
    w.finish(nodes, p).unwrap();
}

#[test]
fn info_text_and_json() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.gwk");
    write_scene(&path);
    let (ok, out, err) = gigawalk(&["info", path.to_str().unwrap(), "--verify"]);
    assert!(ok, "{err}");
    assert!(out.contains("positions   raw f32 (5 LODs)\n"), "{out}");
    assert!(out.contains("triangles   4\n"), "{out}");
    assert!(
        out.contains("nodes       3 (2 leaves, depth 2, up to 2 LODs per node)"),
        "{out}"
    );
    assert!(out.contains("source    hand.glb"), "{out}");
    assert!(out.contains("HLOD levels per tree depth"), "{out}");
    assert!(out.contains("whole-scene triangles at one error"), "{out}");
    // Each leaf's coarsest level is 1 triangle; the root's 1-triangle
    // HLOD at error 3 switches to the leaves' 1 + 1.
    assert!(
        out.contains("  leaf floor     2 triangles (every leaf at its coarsest LOD)\n"),
        "{out}"
    );
    assert!(
        out.contains(
            "  switch         median 2.00  p90 2.00  p99 2.00  max 2.00  (1 inner nodes with LODs)\n"
        ),
        "{out}"
    );
    assert!(out.contains("  switch above   2: 0  4: 0  8: 0\n"), "{out}");
    assert!(
        out.contains("  worst switch   node 0 (depth 0): 1 triangles at error 3.0000e0 (box diagonal 1.3038e1); children 2 (2.00x)\n"),
        "{out}"
    );

    let (ok, out, err) = gigawalk(&["info", path.to_str().unwrap(), "--json"]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["nodes"], 3);
    assert_eq!(v["triangles"], 4);
    assert_eq!(v["leaf_triangles_per_level"], serde_json::json!([4, 2]));
    assert_eq!(v["hlod_triangles_per_depth"], serde_json::json!([1, 4]));
    // The root: one inner node with one HLOD of 1 triangle, error 3 over a
    // box diagonal of sqrt(13^2 + 1); depth 1: two leaves, no inner node.
    let d = &v["hlod_levels_per_depth"];
    assert_eq!(d[0]["inner_nodes"], 1);
    assert_eq!(d[0]["levels_median"], 1);
    assert_eq!(d[0]["finest_triangles_median"], 1);
    let e = d[0]["finest_error_median"].as_f64().unwrap();
    assert!((e - 3.0 / 170f64.sqrt()).abs() < 1e-9, "{e}");
    // Within the root's error 3 each leaf draws its 1-triangle level.
    assert_eq!(d[0]["switch_factor_median"], 2.0);
    assert_eq!(d[0]["switch_factor_max"], 2.0);
    // Diagonal sqrt(170) = 13.04: error 6.5 and 3.3 take the root's
    // 1-triangle HLOD, 1.6 the leaves' 1-triangle levels, below 1 the
    // leaves' 2 triangles each.
    let at: Vec<(f64, u64)> = serde_json::from_value(v["triangles_at_error"].clone()).unwrap();
    assert_eq!(at.len(), 16);
    assert!((at[0].0 - 170f64.sqrt() / 2.0).abs() < 1e-9, "{at:?}");
    assert_eq!(
        at.iter().map(|x| x.1).take(4).collect::<Vec<_>>(),
        [1, 1, 2, 4]
    );
    assert!(at.iter().skip(3).all(|x| x.1 == 4), "{at:?}");
    assert_eq!(
        (d[1]["inner_nodes"].clone(), d[1]["leaves"].clone()),
        (0.into(), 2.into())
    );
    assert_eq!(v["leaf_floor_triangles"], 2);
    let f = &v["switch_factors"];
    assert_eq!(
        (f["count"].clone(), f["median"].clone(), f["max"].clone()),
        (1.into(), 2.0.into(), 2.0.into())
    );
    assert_eq!(
        (f["over_2"].clone(), f["over_8"].clone()),
        (0.into(), 0.into())
    );
    let w = &f["worst"];
    assert_eq!(
        (w["node"].clone(), w["depth"].clone()),
        (0.into(), 0.into())
    );
    assert_eq!(
        (w["triangles"].clone(), w["children_triangles"].clone()),
        (1.into(), 2.into())
    );
    assert_eq!(w["error"], 3.0);
    assert!(
        (w["diagonal"].as_f64().unwrap() - 170f64.sqrt()).abs() < 1e-9,
        "{w}"
    );
    assert_eq!(v["provenance"]["parameters"]["t1"], 1000);
    let bpt = v["bytes_per_triangle"].as_f64().unwrap();
    assert_eq!(bpt, std::fs::metadata(&path).unwrap().len() as f64 / 4.0);
}

/// A generated and preprocessed scene: `info` and `preprocess` (its table
/// and `--stats` JSON) report the same leaf floor and switch factors.
#[test]
fn lod_health_in_info_and_preprocess_stats() {
    let dir = tempfile::tempdir().unwrap();
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let (glb, gwk, stats) = (
        s(&dir.path().join("p.glb")),
        s(&dir.path().join("p.gwk")),
        s(&dir.path().join("s.json")),
    );
    let (ok, _, err) = gigawalk(&["generate", "plant", "--triangles", "5k", "-o", &glb]);
    assert!(ok, "{err}");
    let (ok, pre, err) = gigawalk(&["preprocess", &glb, "-o", &gwk, "--stats", &stats]);
    assert!(ok, "{err}");

    let (ok, text, err) = gigawalk(&["info", &gwk]);
    assert!(ok, "{err}");
    for line in [
        "LOD health",
        "  leaf floor ",
        "  switch         median ",
        "  switch above   2: ",
        "  worst switch   node ",
        // A preprocessed scene's default: every LOD on a 16-bit grid.
        "positions   16-bit grid over each LOD's box, meshopt-encoded (",
    ] {
        assert!(text.contains(line), "{line:?} missing from\n{text}");
    }
    let p: serde_json::Value = {
        let (ok, json, err) = gigawalk(&["info", &gwk, "--json"]);
        assert!(ok, "{err}");
        serde_json::from_str(&json).unwrap()
    };
    // ... and 8-bit normals: every LOD compact on a device, its bytes
    // stated from the records.
    let d = &p["device"];
    let lods = d["lods"].as_u64().unwrap();
    assert!(lods > 0 && d["compact_lods"].as_u64() == Some(lods), "{d}");
    assert_eq!(d["unstated_lods"].as_u64(), Some(0));
    let (bytes, triangles) = (
        d["bytes"].as_u64().unwrap(),
        d["triangles"].as_u64().unwrap(),
    );
    assert!(bytes > 12 * triangles / 2 && bytes < 40 * triangles, "{d}");
    assert!(text.contains(&format!(
        "{lods} LODs in 12-byte compact vertices, 0 in 20-byte"
    )));
    let p = &p["positions"];
    assert_eq!(
        (p["bits"].as_u64(), p["raw_lods"].as_u64()),
        (Some(16), Some(0))
    );
    assert!(p["encoded_lods"].as_u64().unwrap() > 0 && p["step_max"].as_f64().unwrap() > 0.0);
    // zstd by default: most blobs are smaller compressed.
    assert!(
        2 * p["compressed_lods"].as_u64().unwrap() > p["encoded_lods"].as_u64().unwrap(),
        "{p}"
    );
    let (ok, json, err) = gigawalk(&["info", &gwk, "--json"]);
    assert!(ok, "{err}");
    let info: serde_json::Value = serde_json::from_str(&json).unwrap();
    let floor = info["leaf_floor_triangles"].as_u64().unwrap();
    let levels = info["leaf_triangles_per_level"].as_array().unwrap();
    assert_eq!(levels.last().unwrap().as_u64(), Some(floor));
    assert!(floor > 0 && floor < info["triangles"].as_u64().unwrap());
    let f = &info["switch_factors"];
    let count = f["count"].as_u64().unwrap();
    assert!(count > 0, "{f}");
    let (median, p90, p99, max) = (
        f["median"].as_f64().unwrap(),
        f["p90"].as_f64().unwrap(),
        f["p99"].as_f64().unwrap(),
        f["max"].as_f64().unwrap(),
    );
    assert!(
        0.0 < median && median <= p90 && p90 <= p99 && p99 <= max,
        "{f}"
    );
    let over = |k: &str| f[k].as_u64().unwrap();
    assert!(over("over_8") <= over("over_4") && over("over_4") <= over("over_2"));
    assert!(over("over_2") <= count);
    assert_eq!(f["worst"]["factor"].as_f64(), Some(max), "{f}");
    let depth_max = info["hlod_levels_per_depth"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| d["switch_factor_max"].as_f64().unwrap())
        .fold(0.0, f64::max);
    assert_eq!(depth_max, max);

    // The preprocess table says the same, and the stats JSON has the same
    // figures beside its own.
    assert!(
        pre.contains(&format!("leaf floor        {floor} triangles")),
        "{pre}"
    );
    assert!(
        pre.contains(&format!(
            "switch factors    median {median:.2}, p90 {p90:.2}, max {max:.2}; {} of {count} inner nodes above 8",
            over("over_8")
        )),
        "{pre}"
    );
    let st: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    assert_eq!(st["leaf_floor_triangles"].as_u64(), Some(floor));
    assert_eq!(st["switch_factors"], *f);
    assert_eq!(st["nodes"], info["nodes"]);
    assert_eq!(st["triangles"], info["triangles"]);
    assert!(st["phase_seconds"].is_array() && st["output_bytes"].as_u64() > Some(0));

    // The HLOD phase as tasks: one per node, the work at least the
    // critical path, the work by kind adding up to the work, and the
    // speed-ups what W / max(W / N, S) gives.
    let w = &st["schedule"];
    assert_eq!(w["tasks"], st["nodes"], "{w}");
    let (work, span) = (
        w["work_seconds"].as_f64().unwrap(),
        w["span_seconds"].as_f64().unwrap(),
    );
    assert!(work > 0.0 && span > 0.0 && span <= work, "{w}");
    assert!(span >= w["largest_task_seconds"].as_f64().unwrap(), "{w}");
    assert!(span >= w["sink_seconds"].as_f64().unwrap(), "{w}");
    let kinds: Vec<(String, f64)> = serde_json::from_value(w["seconds_by_kind"].clone()).unwrap();
    let names: Vec<&str> = kinds.iter().map(|(k, _)| k.as_str()).collect();
    for k in [
        "simplify",
        "certify level->reference",
        "certify reference->level",
        "BVH builds",
        "other",
    ] {
        assert!(names.contains(&k), "{names:?}");
    }
    let by_kind: f64 = kinds.iter().map(|(_, s)| s).sum();
    assert!(
        (by_kind - work).abs() <= 1e-6 * work.max(1.0) + 1e-9,
        "{by_kind} vs {work}"
    );
    let ups: Vec<(usize, f64)> = serde_json::from_value(w["speedup"].clone()).unwrap();
    for (n, x) in ups {
        let expected = work / (work / n as f64).max(span);
        assert!(
            (x - expected).abs() < 1e-9 && x <= n as f64 + 1e-9,
            "{n}: {x}"
        );
    }
    assert!(pre.contains("hlod speed-up     W / max(W/N, S)"), "{pre}");
    // The whole run, its other phases serial but for the object table's
    // compression jobs: some speed-up, never more than the cores.
    let run: Vec<(usize, f64)> = serde_json::from_value(w["run_speedup"].clone()).unwrap();
    let phase: Vec<(usize, f64)> = serde_json::from_value(w["speedup"].clone()).unwrap();
    assert_eq!(run.len(), phase.len());
    for ((n, r), (m, _)) in run.iter().zip(&phase) {
        assert!(
            n == m && *r >= 1.0 - 1e-9 && *r <= *n as f64 + 1e-9,
            "{n}: run {r}"
        );
    }
    let jobs = &st["identity_compression"];
    assert!(
        jobs["pieces"].as_u64().unwrap() >= 1 && jobs["seconds"].as_f64().unwrap() >= 0.0,
        "{jobs}"
    );
    assert!(pre.contains("compressed in "), "{pre}");
    // Cores busy per phase, on Linux.
    if cfg!(target_os = "linux") {
        let cores: Vec<(String, f64)> = serde_json::from_value(st["phase_cores"].clone()).unwrap();
        let hlod = cores
            .iter()
            .find(|(p, _)| p == "hlod")
            .expect("hlod's cores");
        assert!(hlod.1 >= 0.0, "{cores:?}");
    }
}

/// One occluder over the first leaf and one view cell listing it, as OCCL
/// and OCVC sections for [`write_scene_with`].
fn occluder_sections() -> Vec<([u8; 4], Vec<u8>)> {
    use gigawalk_scene::occluder_cells::{self, CellNode, OccluderCells};
    use gigawalk_scene::occluders::{self, OccluderRecord};
    let occluder = OccluderRecord {
        vertices: vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(3.0, 0.0, 0.0),
            DVec3::new(3.0, 1.0, 0.0),
        ],
        area: 1.5,
    };
    let cells = OccluderCells {
        nodes: vec![CellNode::Leaf(0)],
        directions: vec![DVec3::X],
        k: 1,
        lists: vec![vec![0]],
    };
    vec![
        (
            occluders::TAG_OCCLUDERS,
            occluders::encode_occluders(&[occluder]),
        ),
        (
            occluder_cells::TAG_OCCLUDER_CELLS,
            occluder_cells::encode_occluder_cells(&cells),
        ),
    ]
}

#[test]
fn verify_names_a_damaged_optional_section() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("occ.gwk");
    write_scene_with(&path, occluder_sections());
    let (ok, out, err) = gigawalk(&["info", path.to_str().unwrap(), "--verify"]);
    assert!(ok, "{err}");
    assert!(out.contains("OCCL") && out.contains("OCVC"), "{out}");
    let good = std::fs::read(&path).unwrap();
    let sections = gigawalk_scene::SceneReader::open(&path)
        .unwrap()
        .sections()
        .to_vec();
    for tag in ["OCCL", "OCVC"] {
        let s = sections.iter().find(|s| s.name == tag).unwrap();
        let mut bytes = good.clone();
        bytes[(s.offset + s.len / 2) as usize] ^= 0x10;
        let damaged = dir.path().join(format!("damaged-{tag}.gwk"));
        std::fs::write(&damaged, &bytes).unwrap();
        let (ok, _, err) = gigawalk(&["info", damaged.to_str().unwrap(), "--verify"]);
        assert!(!ok, "{tag}: a damaged section must fail --verify");
        assert!(
            err.contains(&format!("damaged-{tag}.gwk"))
                && err.contains(&format!("checksum mismatch in {tag}")),
            "{tag}: {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn info_on_bad_input_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("junk.gwk");
    std::fs::write(
        &path,
        b"this is not a scene file, just some words that go on for a while",
    )
    .unwrap();
    let (ok, _, err) = gigawalk(&["info", path.to_str().unwrap()]);
    assert!(!ok);
    assert!(
        err.contains("junk.gwk") && err.contains("not a gigawalk scene file"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");

    let (ok, _, err) = gigawalk(&["info", "/nonexistent/x.gwk"]);
    assert!(!ok && err.contains("/nonexistent/x.gwk"), "{err}");
    // The OS error is said once, not repeated by the cause chain.
    assert_eq!(err.matches("No such file").count(), 1, "{err}");
}

#[test]
fn a_reader_that_stops_early_is_not_a_panic() {
    // `gigawalk info scene.gwk | head -1`: the pipe closes before the output ends.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.gwk");
    write_scene(&path);
    succeeds_with_stdout_closed(&["info", path.to_str().unwrap()]);
}

#[test]
fn preprocess_with_stdout_closed_still_writes_every_file() {
    // `gigawalk preprocess ... --stats s.json | true`: files first, then the
    // table; the closed pipe ends the program quietly with everything written.
    let dir = tempfile::tempdir().unwrap();
    let (glb, gwk, stats) = (
        dir.path().join("p.glb"),
        dir.path().join("p.gwk"),
        dir.path().join("s.json"),
    );
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let (ok, _, err) = gigawalk(&["generate", "plant", "--triangles", "5k", "-o", &s(&glb)]);
    assert!(ok, "{err}");
    succeeds_with_stdout_closed(&[
        "preprocess",
        &s(&glb),
        "-o",
        &s(&gwk),
        "--stats",
        &s(&stats),
    ]);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    assert!(json.is_object());
    gigawalk_scene::SceneReader::open(&gwk).unwrap();
}

/// Runs gigawalk with standard output a pipe whose read end is closed
/// before it starts (its first write fails with a broken pipe, every time)
/// and checks it ends successfully without a panic.
fn succeeds_with_stdout_closed(args: &[&str]) {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let out = Command::new(common::BIN)
        .args(args)
        .stdout(writer)
        .stderr(std::process::Stdio::piped())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    assert!(out.status.success(), "{args:?}: {:?}: {err}", out.status);
}

/// `info --adapters` lists what wgpu sees, each adapter usable or with what
/// it lacks, and which one a run would use; JSON says the same. Works (and
/// exits 0) with no adapter at all: it is how a user finds out why.
#[test]
fn adapters_are_listed_with_whether_gigawalk_can_use_them() {
    let (ok, text, err) = gigawalk(&["info", "--adapters"]);
    assert!(ok, "{err}");
    assert!(text.contains("would use"), "{text}");
    let (ok, json, err) = gigawalk(&["info", "--adapters", "--json"]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let adapters = v["adapters"].as_array().unwrap();
    for a in adapters {
        let name = a["name"].as_str().unwrap();
        assert!(text.contains(name), "{name} missing from the text");
        // A usable adapter lacks nothing; an unusable one says what.
        assert_eq!(
            a["usable"].as_bool().unwrap(),
            a["missing"].as_array().unwrap().is_empty(),
            "{a}"
        );
    }
    let used = adapters.iter().filter(|a| a["would_use"] == true).count();
    if v["error"].is_null() {
        assert_eq!(used, 1, "{json}");
    } else {
        assert_eq!(used, 0, "{json}");
        assert!(text.contains("would use   none:"), "{text}");
    }
    // --adapter picks by name; one that matches nothing says so.
    let (ok, text, _) = gigawalk(&["info", "--adapters", "--adapter", "no-such-gpu-xyz"]);
    assert!(ok);
    assert!(text.contains("would use   none:"), "{text}");
    // --adapter alone is not a scene.
    let (ok, _, err) = gigawalk(&["info", "--adapter", "x"]);
    assert!(!ok, "{err}");
}
