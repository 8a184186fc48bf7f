//! `gigawalk export-tiles`: the tileset's structure (errors never increase
//! down the tree, children inside their parents, every URI resolves,
//! every content parses and holds what the scene stores, feature IDs name
//! the scene's objects), bad input, and the real clients (glTF validator,
//! CesiumJS, 3d-tiles-renderer) through tests/tiles-clients when Node and
//! Chromium are there.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use common::{gigawalk, gigawalk_ok, json, s, small_plant};
use gigawalk_scene::SceneReader;
use serde_json::Value;

/// What a walk over a tileset found.
#[derive(Default, Debug)]
struct Walk {
    tiles: usize,
    contents: usize,
    files: usize,
    triangles: u64,
    /// Feature rows checked against the scene's object table.
    features: usize,
    /// Content URI -> its tile's geometric error.
    errors: BTreeMap<PathBuf, f64>,
}

/// An axis-aligned box (min, max) from a 3D Tiles box whose half axes lie
/// on the axes, as the exporter writes them.
fn aabb(b: &Value) -> ([f64; 3], [f64; 3]) {
    let v: Vec<f64> = b
        .as_array()
        .expect("a box is an array")
        .iter()
        .map(|x| x.as_f64().expect("numbers"))
        .collect();
    assert_eq!(v.len(), 12, "a box has 12 numbers");
    let h = [
        v[3].abs() + v[6].abs() + v[9].abs(),
        v[4].abs() + v[7].abs() + v[10].abs(),
        v[5].abs() + v[8].abs() + v[11].abs(),
    ];
    (
        [v[0] - h[0], v[1] - h[1], v[2] - h[2]],
        [v[0] + h[0], v[1] + h[1], v[2] + h[2]],
    )
}

#[track_caller]
fn assert_inside(inner: &Value, outer: &Value, what: &str) {
    let (a0, a1) = aabb(inner);
    let (b0, b1) = aabb(outer);
    for k in 0..3 {
        let eps = 1e-9 * (1.0 + b1[k].abs().max(b0[k].abs()));
        assert!(
            a0[k] >= b0[k] - eps && a1[k] <= b1[k] + eps,
            "{what}: {inner} is not inside {outer}"
        );
    }
}

/// Walks the tileset in `dir` (the main file and every external one),
/// checking the structure; `scene` gives the object names features must
/// carry.
fn walk(dir: &Path, scene: &Path) -> Walk {
    let objects = SceneReader::open(scene).unwrap().objects().unwrap();
    let mut w = Walk::default();
    let main = dir.join("tileset.json");
    let doc = read_json(&main);
    assert_eq!(doc["asset"]["version"], "1.1");
    assert_eq!(doc["root"]["refine"], "REPLACE");
    assert!(doc["root"]["transform"].as_array().unwrap().len() == 16);
    let top = doc["geometricError"].as_f64().unwrap();
    assert!(top >= doc["root"]["geometricError"].as_f64().unwrap());
    w.files += 1;
    tile(&doc["root"], &main, None, &mut w, objects.as_ref());
    w
}

fn read_json(p: &Path) -> Value {
    let text = std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn tile(
    t: &Value,
    file: &Path,
    parent: Option<&Value>,
    w: &mut Walk,
    objects: Option<&gigawalk_scene::objects::ObjectTable>,
) {
    w.tiles += 1;
    let error = t["geometricError"].as_f64().expect("a geometric error");
    assert!(error >= 0.0 && error.is_finite());
    let bv = &t["boundingVolume"]["box"];
    if let Some(p) = parent {
        let pe = p["geometricError"].as_f64().unwrap();
        assert!(
            error <= pe,
            "error {error} under a parent of {pe} ({file:?})"
        );
        assert_inside(bv, &p["boundingVolume"]["box"], "a child's box");
    }
    if let Some(c) = t.get("content") {
        let uri = c["uri"].as_str().expect("a content URI");
        let path = file.parent().unwrap().join(uri);
        assert!(path.exists(), "{uri} (from {}) resolves", file.display());
        if uri.ends_with(".json") {
            assert!(
                t.get("children").is_none(),
                "an external tileset's tile has no children"
            );
            let ext = read_json(&path);
            assert_eq!(ext["asset"]["version"], "1.1");
            let root = &ext["root"];
            assert_eq!(root["geometricError"], t["geometricError"]);
            assert_eq!(root["boundingVolume"], t["boundingVolume"]);
            w.files += 1;
            // Its root stands where the referencing tile does.
            w.tiles -= 1;
            tile(root, &path, parent, w, objects);
            return;
        }
        assert_inside(&c["boundingVolume"]["box"], bv, "a content's box");
        w.contents += 1;
        let canonical = path.canonicalize().unwrap();
        assert!(w.errors.insert(canonical, error).is_none(), "{uri} once");
        let (triangles, features) = content(&path, objects);
        w.triangles += triangles;
        w.features += features;
    }
    for c in t["children"].as_array().into_iter().flatten() {
        tile(c, file, Some(t), w, objects);
    }
}

/// Parses a .glb (the gltf crate reads its container and document);
/// returns its triangles and how many feature rows it names (each
/// checked against the scene's object table).
fn content(path: &Path, objects: Option<&gigawalk_scene::objects::ObjectTable>) -> (u64, usize) {
    let bytes = std::fs::read(path).unwrap();
    // Without validation: the gltf crate rejects custom attributes
    // (_FEATURE_ID_0) unless built with its `extras` feature.
    let g = gltf::Gltf::from_slice_without_validation(&bytes)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let prim = g.meshes().next().unwrap().primitives().next().unwrap();
    let triangles = prim.indices().expect("indexed").count() as u64 / 3;
    let raw = read_glb_json(&bytes);
    let Some(meta) = raw.pointer("/extensions/EXT_structural_metadata") else {
        return (triangles, 0);
    };
    let table = objects.expect("features only where the scene has identity");
    let pt = &meta["propertyTables"][0];
    let count = pt["count"].as_u64().unwrap() as usize;
    let fid =
        &raw["meshes"][0]["primitives"][0]["extensions"]["EXT_mesh_features"]["featureIds"][0];
    assert_eq!(fid["featureCount"].as_u64().unwrap() as usize, count);
    let blob = g.blob.as_ref().expect("a binary chunk");
    let view = |i: &Value| -> &[u8] {
        let v = &raw["bufferViews"][i.as_u64().unwrap() as usize];
        assert_eq!(v["buffer"], 0, "metadata views are uncompressed");
        let o = v["byteOffset"].as_u64().unwrap_or(0) as usize;
        assert_eq!(o % 8, 0, "metadata views start at 8 bytes");
        &blob[o..o + v["byteLength"].as_u64().unwrap() as usize]
    };
    let ids: Vec<u32> = view(&pt["properties"]["objectId"]["values"])
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    let names = view(&pt["properties"]["name"]["values"]);
    let offsets: Vec<usize> = view(&pt["properties"]["name"]["stringOffsets"])
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes(c.try_into().unwrap()) as usize)
        .collect();
    assert_eq!(ids.len(), count);
    assert_eq!(offsets.len(), count + 1);
    for (row, &id) in ids.iter().enumerate() {
        let name = std::str::from_utf8(&names[offsets[row]..offsets[row + 1]]).unwrap();
        assert_eq!(table.object(id).expect("an object of the scene").name, name);
    }
    (triangles, count)
}

fn read_glb_json(bytes: &[u8]) -> Value {
    assert_eq!(&bytes[0..4], b"glTF");
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    assert_eq!(&bytes[16..20], b"JSON");
    serde_json::from_slice(&bytes[20..20 + len]).unwrap()
}

#[test]
fn a_small_plant_exports_a_tileset_whose_structure_holds() {
    let dir = tempfile::tempdir().unwrap();
    let (_, gwk) = small_plant(dir.path());
    let reader = SceneReader::open(&gwk).unwrap();
    for (encoding, per_file) in [("meshopt", "20"), ("quantized", "4000"), ("plain", "7")] {
        let out = dir.path().join(encoding);
        let o = gigawalk_ok(&[
            "export-tiles",
            s(&gwk),
            "-o",
            s(&out),
            "--encoding",
            encoding,
            "--tiles-per-file",
            per_file,
            "--json",
        ]);
        let summary = json(&o.stdout);
        let w = walk(&out, &gwk);
        assert_eq!(
            w.tiles as u64,
            summary["tiles"].as_u64().unwrap(),
            "{encoding}"
        );
        assert_eq!(w.contents as u64, summary["contents"].as_u64().unwrap());
        assert_eq!(w.files as u64, summary["tileset_files"].as_u64().unwrap());
        assert_eq!(w.triangles, summary["triangles"].as_u64().unwrap());
        assert!(w.features > 0, "features name objects");
        assert!(summary["identity"].as_bool().unwrap());
        if per_file != "4000" {
            assert!(w.files > 1, "{encoding}: external tilesets");
        }
        // Every content is a level of the scene, drawn with its own error.
        let lods = reader.skeleton().lods();
        for (path, error) in &w.errors {
            let lod: usize = path.file_stem().unwrap().to_str().unwrap().parse().unwrap();
            assert_eq!(*error, lods[lod].error as f64, "{}", path.display());
        }
        // The tree reaches every leaf's full detail.
        for n in reader.skeleton().nodes().iter().filter(|n| n.is_leaf()) {
            let finest = out.join(format!(
                "content/{}/{}.glb",
                n.first_lod / 1000,
                n.first_lod
            ));
            let coarser_same = lods[n.lods()]
                .iter()
                .skip(1)
                .any(|l| l.error == lods[n.first_lod as usize].error);
            assert!(finest.exists() || coarser_same, "{}", finest.display());
        }
    }
}

#[test]
fn bad_input_is_an_error_naming_the_thing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    // Not a scene file.
    let text = dir.path().join("notes.gwk");
    std::fs::write(&text, "hello").unwrap();
    let (ok, _, err) = gigawalk(&["export-tiles", s(&text), "-o", s(&out)]);
    assert!(!ok && err.contains("notes.gwk"), "{err}");
    assert!(!out.exists(), "nothing written for a bad scene");
    // Missing.
    let (ok, _, err) = gigawalk(&[
        "export-tiles",
        s(&dir.path().join("none.gwk")),
        "-o",
        s(&out),
    ]);
    assert!(!ok && err.contains("none.gwk"), "{err}");

    let (_, gwk) = small_plant(dir.path());
    // Truncated.
    let bytes = std::fs::read(&gwk).unwrap();
    let cut = dir.path().join("cut.gwk");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let (ok, _, err) = gigawalk(&["export-tiles", s(&cut), "-o", s(&out)]);
    assert!(
        !ok && err.contains("cut.gwk") && err.contains("truncated"),
        "{err}"
    );
    assert!(!out.exists());

    // Bad georeferencing.
    for (flag, value, says) in [
        ("--origin", "7.5,95,0", "latitude"),
        ("--origin", "7.5,47", "found 2"),
        ("--transform", "1 2 3", "16 numbers"),
    ] {
        let (ok, _, err) = gigawalk(&["export-tiles", s(&gwk), "-o", s(&out), flag, value]);
        assert!(!ok && err.contains(flag) && err.contains(says), "{err}");
    }
    assert!(!out.exists());

    // An existing directory with something in it: refused, untouched.
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("keep.txt"), "mine").unwrap();
    let (ok, _, err) = gigawalk(&["export-tiles", s(&gwk), "-o", s(&out)]);
    assert!(
        !ok && err.contains("--force") && err.contains("out"),
        "{err}"
    );
    assert!(!out.join("tileset.json").exists());
    // With --force it is written, and what is not the export's stays.
    gigawalk_ok(&[
        "export-tiles",
        s(&gwk),
        "-o",
        s(&out),
        "--force",
        "--origin",
        "-122.4,37.8,10",
    ]);
    assert!(out.join("tileset.json").exists() && out.join("keep.txt").exists());
    let doc = read_json(&out.join("tileset.json"));
    // Georeferenced: the root transform puts the model on the ellipsoid.
    let m: Vec<f64> = doc["root"]["transform"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let r = (m[12] * m[12] + m[13] * m[13] + m[14] * m[14]).sqrt();
    assert!((6.35e6..6.38e6).contains(&r), "{r}");
    // An output that is a file.
    let (ok, _, err) = gigawalk(&["export-tiles", s(&gwk), "-o", s(&text)]);
    assert!(!ok && err.contains("not a directory"), "{err}");
}

/// The real clients: tests/tiles-clients runs the Khronos glTF validator
/// over every content and loads the tileset in CesiumJS and
/// 3d-tiles-renderer in headless Chromium. Skipped (one SKIP line) without
/// Node, the harness's packages or Chromium, unless
/// GIGAWALK_REQUIRE_CLIENTS=1 (CI), which makes that a failure.
#[test]
fn real_clients_load_the_tileset_and_pick_objects() {
    let harness = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/tiles-clients");
    let chromium = std::env::var("CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into());
    let missing = if std::process::Command::new("node")
        .arg("--version")
        .output()
        .map(|o| !o.status.success())
        .unwrap_or(true)
    {
        Some("node is not installed".to_string())
    } else if !harness.join("node_modules").exists() {
        Some(format!(
            "{}: no node_modules (run npm ci there)",
            harness.display()
        ))
    } else if !Path::new(&chromium).exists() {
        Some(format!(
            "{chromium}: no Chromium (apt-get install chromium)"
        ))
    } else {
        None
    };
    if let Some(why) = missing {
        if std::env::var("GIGAWALK_REQUIRE_CLIENTS").is_ok_and(|v| v == "1") {
            panic!("GIGAWALK_REQUIRE_CLIENTS=1 but {why}");
        }
        println!("SKIP real_clients_load_the_tileset_and_pick_objects: {why}");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (path, gwk) = small_plant(dir.path());
    let tiles = dir.path().join("tiles");
    let quantized = dir.path().join("tiles-quantized");
    gigawalk_ok(&[
        "export-tiles",
        s(&gwk),
        "-o",
        s(&tiles),
        "--tiles-per-file",
        "200",
    ]);
    gigawalk_ok(&[
        "export-tiles",
        s(&gwk),
        "-o",
        s(&quantized),
        "--encoding",
        "quantized",
    ]);
    let report = dir.path().join("clients.json");
    let out = std::process::Command::new("node")
        .current_dir(&harness)
        .args([
            "run.mjs",
            "--tiles",
            s(&tiles),
            "--validate",
            s(&quantized),
            "--path",
            s(&path),
            "--pose",
            "6",
            "--sse",
            "8",
            "--chromium",
            &chromium,
            "--report",
            s(&report),
        ])
        .output()
        .expect("node runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    println!("{stdout}");
    assert!(
        out.status.success(),
        "the clients' harness failed:\n{stdout}\n{stderr}"
    );
    let r = read_json(&report);
    assert_eq!(r["validator"]["errors"], 0, "{r}");
    for client in ["cesium", "threejs"] {
        let c = &r[client];
        assert!(c["tiles"].as_u64().unwrap() > 0, "{client}: {c}");
        assert!(c["triangles"].as_u64().unwrap() > 0, "{client}: {c}");
        let pick = &c["pick"];
        assert!(pick["featureId"].is_u64(), "{client} picks a feature: {c}");
        // The picked name is the object's in the scene.
        let id = pick["objectId"].as_u64().unwrap() as u32;
        let table = SceneReader::open(&gwk).unwrap().objects().unwrap().unwrap();
        assert_eq!(
            table.object(id).unwrap().name,
            pick["name"].as_str().unwrap()
        );
    }
}
