//! `gigawalk export-tiles`: the tileset's structure (errors never increase
//! down the tree, children inside their parents, every URI resolves,
//! every content parses and holds what the scene stores, feature IDs name
//! the scene's objects), bad input, the same structure checks on what
//! 3d-tiles-tools parses, and the real clients (glTF validator, CesiumJS,
//! 3d-tiles-renderer), through tests/tiles-clients when Node and Chromium
//! are there.

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
    /// Content URI -> its tile's geometric error and its triangles.
    errors: BTreeMap<PathBuf, (f64, u64)>,
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

/// Runs `gigawalk export-tiles gwk -o out --json` with `args`; returns the
/// summary it prints.
#[track_caller]
fn export(gwk: &Path, out: &Path, args: &[&str]) -> Value {
    let mut all = vec!["export-tiles", s(gwk), "-o", s(out), "--json"];
    all.extend_from_slice(args);
    json(&gigawalk_ok(&all).stdout)
}

/// The tile a content file is: its name is the tile's index in the plan.
fn tile_of(content: &Path) -> usize {
    content
        .file_stem()
        .and_then(|n| n.to_str())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{}: not a tile's content", content.display()))
}

/// The content target the small plant's tests export with: small enough
/// that its 8k triangles make a tree of several contents a level.
const SMALL_TARGET: &str = "600";

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
        let (triangles, features) = content(&path, objects);
        assert!(
            w.errors.insert(canonical, (error, triangles)).is_none(),
            "{uri} once"
        );
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
    // One node and mesh of one primitive per stored level.
    assert_eq!(g.nodes().count(), g.meshes().count());
    let triangles = g
        .meshes()
        .map(|m| {
            let mut p = m.primitives();
            let one = p.next().expect("a primitive");
            assert!(p.next().is_none(), "one primitive a level");
            one.indices().expect("indexed").count() as u64 / 3
        })
        .sum();
    let raw = read_glb_json(&bytes);
    let Some(meta) = raw.pointer("/extensions/EXT_structural_metadata") else {
        return (triangles, 0);
    };
    let table = objects.expect("features only where the scene has identity");
    let pt = &meta["propertyTables"][0];
    let count = pt["count"].as_u64().unwrap() as usize;
    // Each level's features are rows of the content's one table.
    let mut with_features = 0;
    for m in raw["meshes"].as_array().unwrap() {
        let fid = &m["primitives"][0]["extensions"]["EXT_mesh_features"]["featureIds"][0];
        if let Some(n) = fid["featureCount"].as_u64() {
            assert!(n >= 1 && n as usize <= count, "{fid}");
            assert_eq!(fid["propertyTable"], 0);
            with_features += 1;
        }
    }
    assert!(with_features > 0, "a table only where features use it");
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
    let sk = reader.skeleton();
    let lods = sk.lods();
    for (encoding, per_file, target) in [
        ("meshopt", "20", SMALL_TARGET),
        ("quantized", "4000", SMALL_TARGET),
        ("plain", "7", "100"),
        ("meshopt", "4000", "20000"),
    ] {
        let out = dir.path().join(format!("{encoding}-{target}"));
        let summary = export(
            &gwk,
            &out,
            &[
                "--encoding",
                encoding,
                "--tiles-per-file",
                per_file,
                "--content-triangles",
                target,
            ],
        );
        let w = walk(&out, &gwk);
        let plan = gigawalk_tiles::plan::plan(sk, target.parse().unwrap());
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
        assert_eq!(w.tiles, plan.tiles.len(), "{encoding} {target}");
        // Every content is its tile's stored levels, with an error at
        // least each one's stored error (written as the shortest decimal
        // at or above the plan's).
        for (path, &(error, triangles)) in &w.errors {
            let tile = &plan.tiles[tile_of(path)];
            let stored = tile
                .parts
                .iter()
                .map(|q| lods[q.lod as usize].error as f64)
                .fold(0.0, f64::max);
            assert!(
                tile.error >= stored
                    && error >= tile.error
                    && error - tile.error <= tile.error * 1e-7,
                "{}: {error} for a plan's {} over stored {stored}",
                path.display(),
                tile.error
            );
            let parts: u64 = tile
                .parts
                .iter()
                .map(|q| lods[q.lod as usize].triangles as u64)
                .sum();
            assert_eq!(triangles, parts, "{}", path.display());
        }
        // The tree reaches every leaf's full detail: a content drawing it
        // ends its branch.
        let mut finest = std::collections::BTreeSet::new();
        for (t, tile) in plan.tiles.iter().enumerate() {
            let p = out.join(format!("content/{}/{t}.glb", t / 1000));
            if tile.children.is_empty() && p.exists() {
                finest.extend(tile.parts.iter().map(|q| q.lod));
            }
        }
        for (i, n) in sk.nodes().iter().enumerate() {
            if n.is_leaf() && n.lod_count > 0 && lods[n.first_lod as usize].triangles > 0 {
                assert!(
                    finest.contains(&n.first_lod),
                    "{encoding} {target}: leaf {i}"
                );
            }
        }
        // The whole plant (8k triangles) fits a content of 20000: one
        // content a band, a chain down to full detail.
        if target == "20000" {
            assert!(plan.tiles.iter().all(|t| t.children.len() <= 1));
            assert_eq!(w.contents, plan.tiles.len());
        } else {
            assert!(plan.tiles.iter().any(|t| t.children.len() > 1));
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

/// tests/tiles-clients: the Node harness of the real clients.
fn harness() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/tiles-clients")
}

/// Why the real clients cannot run here (Node, the harness's packages or,
/// when `chromium` is given, Chromium missing), or `None` when they can.
fn clients_missing(harness: &Path, chromium: Option<&str>) -> Option<String> {
    if std::process::Command::new("node")
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
    } else if !harness.join("node_modules/3d-tiles-tools").exists() {
        Some(format!(
            "{}: no 3d-tiles-tools in node_modules (run npm ci there)",
            harness.display()
        ))
    } else {
        chromium
            .filter(|c| !Path::new(c).exists())
            .map(|c| format!("{c}: no Chromium (apt-get install chromium)"))
    }
}

/// Whether `test` goes on: without the clients it prints one SKIP line
/// and does not, unless GIGAWALK_REQUIRE_CLIENTS=1 (CI), which makes that
/// a failure.
#[track_caller]
fn clients_here(test: &str, harness: &Path, chromium: Option<&str>) -> bool {
    let Some(why) = clients_missing(harness, chromium) else {
        return true;
    };
    if std::env::var("GIGAWALK_REQUIRE_CLIENTS").is_ok_and(|v| v == "1") {
        panic!("GIGAWALK_REQUIRE_CLIENTS=1 but {why}");
    }
    println!("SKIP {test}: {why}");
    false
}

/// Runs tests/tiles-clients/structure.mjs (the structure checks on what
/// 3d-tiles-tools parses) over `dirs`: whether every check passed, and
/// its report, one entry a directory.
fn structure_checks(harness: &Path, dirs: &[&Path], report: &Path) -> (bool, Value) {
    let out = std::process::Command::new("node")
        .current_dir(harness)
        .arg("structure.mjs")
        .args(dirs)
        .args(["--report", s(report)])
        .output()
        .expect("node runs");
    println!("{}", String::from_utf8_lossy(&out.stdout));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        matches!(out.status.code(), Some(0 | 1)),
        "structure.mjs did not run: {stderr}"
    );
    (out.status.success(), read_json(report))
}

/// A structure report of 3d-tiles-tools' traversal (structure.mjs) agrees
/// with the export's summary and found no fault: every tile the exporter
/// wrote was visited (an external tileset's root beside the tile that
/// references it), every content is a glb, and each check ran on every
/// tile.
#[track_caller]
fn assert_structure_holds(r: &Value, summary: &Value, what: &str) {
    let n = |v: &Value| v.as_u64().unwrap_or_else(|| panic!("{what}: {v} in {r}"));
    assert_eq!(r["ok"], true, "{what}: {r}");
    assert!(
        r["failed"].as_object().unwrap().values().all(|v| v == 0),
        "{what}: {r}"
    );
    let (tiles, external) = (n(&r["tiles"]), n(&r["externalTilesets"]));
    assert_eq!(tiles - external, n(&summary["tiles"]), "{what}: {r}");
    assert_eq!(external + 1, n(&summary["tileset_files"]), "{what}: {r}");
    assert_eq!(n(&r["glb"]), n(&summary["contents"]), "{what}: {r}");
    assert_eq!(n(&r["contents"]), n(&summary["contents"]) + external);
    let checked = &r["checked"];
    // Every tile against its parent, and the root against the tileset.
    assert_eq!(n(&checked["errors"]), tiles, "{what}: {r}");
    assert_eq!(n(&checked["boxes"]), tiles - 1, "{what}: {r}");
    assert_eq!(n(&checked["contentBoxes"]), n(&summary["contents"]));
    assert_eq!(n(&checked["uris"]), n(&r["contents"]), "{what}: {r}");
}

/// Runs tests/tiles-clients/run.mjs on `tilesets` (its `--tiles` and
/// `--validate` arguments) from pose `pose` of the camera path `path` at
/// screen-space error `sse`, with gigawalk's near plane for the scene
/// `gwk`; returns its report.
fn run_clients(
    harness: &Path,
    chromium: &str,
    tilesets: &[&str],
    (gwk, path, pose, sse): (&Path, &Path, usize, f64),
    report: &Path,
) -> Value {
    let reader = SceneReader::open(gwk).unwrap();
    let near = gigawalk_cull::default_near(&reader.skeleton().bounds()).to_string();
    let out = std::process::Command::new("node")
        .current_dir(harness)
        .arg("run.mjs")
        .args(tilesets)
        .args(["--path", s(path), "--pose", &pose.to_string()])
        .args(["--sse", &sse.to_string(), "--near", &near])
        .args(["--chromium", chromium, "--report", s(report)])
        .output()
        .expect("node runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    println!("{stdout}");
    assert!(
        out.status.success(),
        "the clients' harness failed:\n{stdout}\n{stderr}"
    );
    read_json(report)
}

/// What one renderer drew at a pose: the tiles (or gigawalk's nodes), their
/// triangles, and the depth in the tile tree of what it drew.
#[derive(Debug)]
struct Drawn {
    renderer: &'static str,
    items: usize,
    triangles: u64,
    /// Mean and deepest tile depth (the root tile is 1), over what was drawn.
    mean_depth: f64,
    max_depth: usize,
}

/// The same pose and pixel error in gigawalk's own traversal (hlod mode:
/// frustum culling and levels of detail, no occlusion) and in the clients'
/// report, set side by side. Depths are those of the tile tree the export
/// plans; a level gigawalk draws that is no tile (coarser than its
/// parent's finest, see docs/tiles.md) counts at its node's coarsest tile.
fn compare_depths(gwk: &Path, path: &Path, pose: usize, report: &Value, target: u64) -> Vec<Drawn> {
    use gigawalk_cull::{default_near, Camera, CullView, NoOcclusion, TraversalOptions, Viewport};
    let reader = SceneReader::open(gwk).unwrap();
    let sk = reader.skeleton();
    let plan = gigawalk_tiles::plan::plan(sk, target);
    let mut depth = vec![0usize; plan.tiles.len()];
    depth[0] = 1;
    // The shallowest tile drawing a level, and drawing any level of a node.
    let mut lod_depth = std::collections::HashMap::new();
    let mut node_top = std::collections::HashMap::new();
    for t in 0..plan.tiles.len() {
        let tile = &plan.tiles[t];
        for &c in &tile.children {
            depth[c as usize] = depth[t] + 1;
        }
        for q in &tile.parts {
            lod_depth.entry(q.lod).or_insert(depth[t]);
            node_top.entry(q.node).or_insert(depth[t]);
        }
    }
    // A level no tile draws counts at its node's shallowest tile, or its
    // nearest ancestor's.
    let depth_of = |node: u32, l: u32| -> usize {
        if let Some(&d) = lod_depth.get(&l) {
            return d;
        }
        let mut n = node;
        loop {
            if let Some(&d) = node_top.get(&n) {
                return d;
            }
            n = sk.node(n).parent;
            assert_ne!(n, gigawalk_scene::NO_NODE, "level {l}: no tile above it");
        }
    };
    let stats = |renderer, items: usize, lods: &[(u32, u32)]| {
        let depths: Vec<usize> = lods.iter().map(|&(node, l)| depth_of(node, l)).collect();
        Drawn {
            renderer,
            items,
            triangles: lods
                .iter()
                .map(|&(_, l)| sk.lods()[l as usize].triangles as u64)
                .sum(),
            mean_depth: depths.iter().sum::<usize>() as f64 / depths.len().max(1) as f64,
            max_depth: depths.iter().copied().max().unwrap_or(0),
        }
    };
    let parts_of = |t: u32| -> Vec<(u32, u32)> {
        plan.tiles[t as usize]
            .parts
            .iter()
            .map(|q| (q.node, q.lod))
            .collect()
    };

    let (w, h) = (
        report["width"].as_u64().unwrap() as u32,
        report["height"].as_u64().unwrap() as u32,
    );
    let sse = report["sse"].as_f64().unwrap();
    let poses = gigawalk_scene::path::CameraPath::read(path).unwrap().poses;
    let viewport = Viewport::new(w, h);
    let camera = Camera::of_pose(&poses[pose], viewport, default_near(&sk.bounds()));
    let view = CullView::new(camera, viewport);
    let mut ours = Vec::new();
    gigawalk_cull::traverse(
        sk,
        &view,
        &NoOcclusion,
        &TraversalOptions {
            occlusion: false,
            hlod: true,
            pixel_error: sse,
        },
        &mut |item: gigawalk_cull::DrawItem| {
            ours.push((item.node, sk.node(item.node).first_lod + item.lod))
        },
    );
    let mut out = vec![stats("gigawalk hlod", ours.len(), &ours)];
    // The 3D Tiles rule on the exported tree, computed here: a tile in
    // the frustum is drawn when error x ppr / (distance to its box) is at
    // most the pixel error or it has no children, else its children
    // replace it. What a client should select; it differs from gigawalk's
    // traversal only in the distance (gigawalk's is shortened off the
    // view axis, so it refines sooner).
    let frustum = gigawalk_cull::Frustum::new(&camera);
    let ppr = camera.pixels_per_radian(viewport);
    let mut rule = Vec::new();
    let mut rule_tiles = 0;
    let mut stack = vec![0u32];
    while let Some(t) = stack.pop() {
        let tile = &plan.tiles[t as usize];
        let bounds = tile
            .nodes
            .iter()
            .fold(gigawalk_scene::Aabb::EMPTY, |b, &n| {
                b.union(&sk.node(n).bounds)
            });
        let (min, max) = view.rel_f64(&bounds);
        let (inside, _) = frustum.test(min, max, gigawalk_cull::ALL_PLANES);
        if inside == gigawalk_cull::Containment::Outside {
            continue;
        }
        let d = gigawalk_cull::lod::distance_to_rel_box(min, max);
        if tile.children.is_empty() || tile.error * ppr <= sse * d {
            let parts = parts_of(t);
            if parts
                .iter()
                .any(|&(_, l)| sk.lods()[l as usize].triangles > 0)
            {
                rule_tiles += 1;
                rule.extend(parts);
            }
        } else {
            stack.extend(&tile.children);
        }
    }
    out.push(stats("3D Tiles rule (computed)", rule_tiles, &rule));
    // A content URI is content/K/T.glb: tile T.
    let tile_of = |uri: &str| -> u32 {
        let stem = uri.rsplit('/').next().unwrap().trim_end_matches(".glb");
        stem.parse()
            .unwrap_or_else(|_| panic!("{uri}: not a tile's content"))
    };
    for (name, client) in [("CesiumJS", "cesium"), ("3d-tiles-renderer", "threejs")] {
        let selected = report[client]["selected"].as_array().unwrap();
        let lods: Vec<(u32, u32)> = selected
            .iter()
            .flat_map(|t| parts_of(tile_of(t["uri"].as_str().unwrap())))
            .collect();
        out.push(stats(name, selected.len(), &lods));
    }
    println!("| renderer | tiles / nodes drawn | triangles | mean depth | deepest |");
    println!("|---|---:|---:|---:|---:|");
    for d in &out {
        println!(
            "| {} | {} | {} | {:.2} | {} |",
            d.renderer, d.items, d.triangles, d.mean_depth, d.max_depth
        );
    }
    out
}

/// What gigawalk's own pick (exact, against full detail) finds at each of
/// the report's grid pixels and at the pixels `margin` away on either
/// axis: the object index at the pixel, when the object is the same at
/// all five (an object's inside, where a level within `margin` pixels of
/// full detail shows that object too), else `None`.
fn interior_objects(
    gwk: &Path,
    path: &Path,
    pose: usize,
    report: &Value,
    margin: u32,
) -> Vec<Option<u32>> {
    let (w, h) = (
        report["width"].as_u64().unwrap() as u32,
        report["height"].as_u64().unwrap() as u32,
    );
    let grid: Vec<(u32, u32)> = report["grid"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| (p[0].as_u64().unwrap() as u32, p[1].as_u64().unwrap() as u32))
        .collect();
    let mut pixels = Vec::new();
    for &(x, y) in &grid {
        pixels.push((x, y));
        pixels.push((x.saturating_sub(margin), y));
        pixels.push(((x + margin).min(w - 1), y));
        pixels.push((x, y.saturating_sub(margin)));
        pixels.push((x, (y + margin).min(h - 1)));
    }
    let picks = gigawalk_review::select::pick(&gigawalk_review::select::PickRequest {
        scene: gwk.to_path_buf(),
        path: path.to_path_buf(),
        frame: pose,
        pixels,
        section: None,
        width: w,
        height: h,
        near: None,
    })
    .unwrap();
    picks
        .chunks_exact(5)
        .map(|five| {
            let id = five[0].object.as_ref().map(|(id, _)| *id)?;
            five.iter()
                .all(|p| p.object.as_ref().map(|(i, _)| *i) == Some(id))
                .then_some(id)
        })
        .collect()
}

/// The real clients: tests/tiles-clients runs the Khronos glTF validator
/// over every content and loads the tileset in CesiumJS and
/// 3d-tiles-renderer in headless Chromium at a pose of the path and a
/// screen-space error of 8. Both must render gigawalk's pose (a grid of
/// pixels picks the object gigawalk's own pick finds there), and draw
/// geometry from the depth of the tree gigawalk's traversal draws at that
/// pixel error. Skipped (one SKIP line) without Node, the harness's
/// packages or Chromium, unless GIGAWALK_REQUIRE_CLIENTS=1 (CI), which
/// makes that a failure.
#[test]
fn real_clients_load_the_tileset_and_pick_objects() {
    let harness = harness();
    let chromium = std::env::var("CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into());
    if !clients_here(
        "real_clients_load_the_tileset_and_pick_objects",
        &harness,
        Some(&chromium),
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (path, gwk) = small_plant(dir.path());
    let tiles = dir.path().join("tiles");
    let quantized = dir.path().join("tiles-quantized");
    let meshopt_summary = export(
        &gwk,
        &tiles,
        &[
            "--tiles-per-file",
            "200",
            "--content-triangles",
            SMALL_TARGET,
        ],
    );
    let quantized_summary = export(
        &gwk,
        &quantized,
        &[
            "--encoding",
            "quantized",
            "--content-triangles",
            SMALL_TARGET,
        ],
    );
    let reader = SceneReader::open(&gwk).unwrap();
    let (pose, sse) = (6, 8.0);
    let r = run_clients(
        &harness,
        &chromium,
        &["--tiles", s(&tiles), "--validate", s(&quantized)],
        (&gwk, &path, pose, sse),
        &dir.path().join("clients.json"),
    );
    assert_eq!(r["validator"]["errors"], 0, "{r}");
    // The structure as 3d-tiles-tools parses it, --validate's first.
    let structure = r["structure"].as_array().unwrap();
    assert_eq!(structure.len(), 2);
    assert_structure_holds(&structure[0], &quantized_summary, "quantized");
    assert_structure_holds(&structure[1], &meshopt_summary, "meshopt");
    let table = reader.objects().unwrap().unwrap();
    for client in ["cesium", "threejs"] {
        let c = &r[client];
        assert!(c["tiles"].as_u64().unwrap() > 0, "{client}: {c}");
        assert!(c["triangles"].as_u64().unwrap() > 0, "{client}: {c}");
        // Every picked name is the object's in the scene.
        for p in c["picks"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|p| !p.is_null())
        {
            let id = p["objectId"].as_u64().unwrap() as u32;
            assert_eq!(table.object(id).unwrap().name, p["name"].as_str().unwrap());
        }
    }

    // The same image: at each grid pixel inside an object (as gigawalk's
    // own pick finds it, `sse` pixels around), each client picks that
    // object wherever it picks a feature, and the two clients agree.
    let ours = interior_objects(&gwk, &path, pose, &r, sse as u32);
    let picks = |c: &str| -> Vec<Option<u32>> {
        r[c]["picks"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p["objectId"].as_u64().map(|v| v as u32))
            .collect()
    };
    let (cesium, three) = (picks("cesium"), picks("threejs"));
    assert_eq!(cesium.len(), ours.len());
    let mut checked = 0;
    for (i, want) in ours.iter().enumerate() {
        let Some(want) = want else { continue };
        for (client, got) in [("cesium", cesium[i]), ("threejs", three[i])] {
            if let Some(got) = got {
                checked += 1;
                assert_eq!(
                    got, *want,
                    "{client} at {}: object {got}, gigawalk pick: {want}",
                    r["grid"][i]
                );
            }
        }
    }
    let both = cesium
        .iter()
        .zip(&three)
        .filter(|(a, b)| a.is_some() && b.is_some())
        .count();
    let same = cesium
        .iter()
        .zip(&three)
        .filter(|(a, b)| a.is_some() && a == b)
        .count();
    println!("picks: {checked} client picks inside objects checked against gigawalk's; the clients agree at {same} of {both} pixels both pick");
    assert!(checked >= 20, "too few pixels checked: {checked}");
    assert!(same * 20 >= both * 19, "clients agree at {same} of {both}");

    let target = SMALL_TARGET.parse().unwrap();
    assert_same_depth(&compare_depths(&gwk, &path, pose, &r, target));
}

/// 3d-tiles-tools (CesiumGS's 3D Tiles library) parses the tileset and,
/// following its external tilesets through its own traversal, the
/// structure checks of tests/tiles-clients/structure.mjs pass on what it
/// parsed: errors never increase down the tree, every child's box lies
/// inside its parent's and every content's inside its tile's, every
/// content URI resolves to a glb or a tileset. The same checks fail on a
/// copy broken on purpose: a child's error raised above its parent's, an
/// external tileset's root box grown past the tile that references it,
/// and a content file removed. Skipped as the real clients' test is
/// (Chromium not needed).
#[test]
fn tiles_tools_parse_the_tileset_and_its_structure_holds() {
    let harness = harness();
    if !clients_here(
        "tiles_tools_parse_the_tileset_and_its_structure_holds",
        &harness,
        None,
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (_, gwk) = small_plant(dir.path());
    let tiles = dir.path().join("tiles");
    // Small files, so the tree spans external tilesets.
    let summary = export(
        &gwk,
        &tiles,
        &["--tiles-per-file", "4", "--content-triangles", SMALL_TARGET],
    );
    assert!(summary["tileset_files"].as_u64().unwrap() > 1, "{summary}");
    let (ok, r) = structure_checks(&harness, &[&tiles], &dir.path().join("good.json"));
    assert!(ok, "{r}");
    assert_structure_holds(&r[0], &summary, "external tilesets");

    let broken = dir.path().join("broken");
    copy_dir(&tiles, &broken);
    // A child of the root with an error above the root's.
    let main = broken.join("tileset.json");
    let mut doc = read_json(&main);
    let raised = doc["root"]["geometricError"].as_f64().unwrap() * 2.0 + 1.0;
    doc["root"]["children"][0]["geometricError"] = raised.into();
    std::fs::write(&main, doc.to_string()).unwrap();
    // An external tileset's root box grown tenfold about its centre.
    let external = std::fs::read_dir(broken.join("tilesets"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let mut ext = read_json(&external);
    for half in ext["root"]["boundingVolume"]["box"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .skip(3)
    {
        *half = (half.as_f64().unwrap() * 10.0).into();
    }
    std::fs::write(&external, ext.to_string()).unwrap();
    // A content the tree names, gone.
    let gone = walk(&tiles, &gwk).errors.into_keys().next().unwrap();
    let gone = broken.join(gone.strip_prefix(tiles.canonicalize().unwrap()).unwrap());
    std::fs::remove_file(&gone).unwrap();

    let (ok, r) = structure_checks(&harness, &[&broken], &dir.path().join("broken.json"));
    let r = &r[0];
    assert!(!ok && r["ok"] == false, "{r}");
    assert_eq!(r["failed"]["errors"], 1, "{r}");
    assert_eq!(r["failed"]["boxes"], 1, "{r}");
    assert_eq!(r["failed"]["uris"], 1, "{r}");
    assert_eq!(r["failed"]["read"], 0, "{r}");
    let kinds: Vec<&str> = r["failures"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["kind"].as_str().unwrap())
        .collect();
    assert_eq!(kinds.len(), 3, "{r}");
    let uri = r["failures"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["kind"] == "uris")
        .unwrap()["uri"]
        .as_str()
        .unwrap();
    assert!(
        gone.ends_with(uri.trim_start_matches("../")),
        "{uri} for {}",
        gone.display()
    );

    // Not a tileset at all: a failure to read, not a crash.
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let (ok, r) = structure_checks(&harness, &[&empty], &dir.path().join("empty.json"));
    assert!(!ok && r[0]["failed"]["read"] == 1, "{r}");
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &to.join(e.file_name()));
        } else {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

/// Each client draws what the 3D Tiles rule selects on the exported tree
/// (a mean depth within half a level, triangles within 1.25x either way:
/// clients also cull by each content's own box and keep tiles that are
/// loading), and from the depth of the tree gigawalk's traversal draws
/// from at the same pose and pixel error: a mean depth within 1.5 levels
/// and at least half of gigawalk's triangles (never much coarser). A
/// client may draw several times gigawalk's triangles: a content unites
/// a group of nodes, refined together where gigawalk refines each node on
/// its own (docs/tiles.md has the figures).
#[track_caller]
fn assert_same_depth(drawn: &[Drawn]) {
    let (ours, rule) = (&drawn[0], &drawn[1]);
    assert!(ours.items > 0 && ours.triangles > 0, "{ours:?}");
    for c in &drawn[2..] {
        assert!(
            (c.mean_depth - rule.mean_depth).abs() <= 0.5,
            "{c:?} against {rule:?}"
        );
        let ratio = c.triangles as f64 / rule.triangles as f64;
        assert!(
            (1.0 / 1.25..=1.25).contains(&ratio),
            "{c:?} against {rule:?}"
        );
        assert!(
            (c.mean_depth - ours.mean_depth).abs() <= 1.5,
            "{c:?} against {ours:?}"
        );
        assert!(
            c.triangles as f64 >= 0.5 * ours.triangles as f64,
            "{c:?} against {ours:?}"
        );
    }
}

/// The clients against gigawalk on a scene of any size, for the figures in
/// docs/tiles.md: GIGAWALK_TILES_SCENE (a .gwk), GIGAWALK_TILES_DIR (its
/// export), GIGAWALK_TILES_PATH (a camera path), GIGAWALK_TILES_POSE
/// (default 100), GIGAWALK_TILES_SSE (default 4) and
/// GIGAWALK_TILES_TARGET (the export's --content-triangles, default
/// 20000). Prints the table;
/// asserts what the small plant's test asserts. Run with --ignored.
#[test]
#[ignore = "needs a large scene and its export: set GIGAWALK_TILES_SCENE, _DIR and _PATH"]
fn clients_against_gigawalk_at_scale() {
    let var = |k: &str| std::env::var(k).unwrap_or_else(|_| panic!("set {k}"));
    let (gwk, tiles, path) = (
        PathBuf::from(var("GIGAWALK_TILES_SCENE")),
        PathBuf::from(var("GIGAWALK_TILES_DIR")),
        PathBuf::from(var("GIGAWALK_TILES_PATH")),
    );
    let pose: usize = std::env::var("GIGAWALK_TILES_POSE").map_or(100, |v| v.parse().unwrap());
    let sse: f64 = std::env::var("GIGAWALK_TILES_SSE").map_or(4.0, |v| v.parse().unwrap());
    let harness = harness();
    let chromium = std::env::var("CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into());
    if let Some(why) = clients_missing(&harness, Some(&chromium)) {
        panic!("{why}");
    }
    let report = tiles.with_extension("clients.json");
    let r = run_clients(
        &harness,
        &chromium,
        &["--tiles", s(&tiles)],
        (&gwk, &path, pose, sse),
        &report,
    );
    assert_eq!(r["structure"][0]["ok"], true, "{}", r["structure"]);
    let ours = interior_objects(&gwk, &path, pose, &r, sse.ceil() as u32);
    for client in ["cesium", "threejs"] {
        let mut agree = 0;
        let mut checked = 0;
        for (i, want) in ours.iter().enumerate() {
            if let (Some(want), Some(got)) = (want, r[client]["picks"][i]["objectId"].as_u64()) {
                checked += 1;
                agree += (got as u32 == *want) as usize;
            }
        }
        println!("{client}: {agree} of {checked} picks inside objects are gigawalk's object");
        assert_eq!(agree, checked, "{client}");
    }
    let target = std::env::var("GIGAWALK_TILES_TARGET")
        .map_or(gigawalk_tiles::plan::DEFAULT_CONTENT_TRIANGLES, |v| {
            v.parse().unwrap()
        });
    assert_same_depth(&compare_depths(&gwk, &path, pose, &r, target));
}

/// One level of a content as a client reads it (node `k`, the content's
/// k-th level): positions (16-bit grid or f32) through the node's scale
/// and translation, relative to the scene origin, indices. Plain and
/// quantized encodings (no meshopt views).
fn content_mesh(path: &Path, k: usize, scene_origin: glam::DVec3) -> gigawalk_scene::LodMesh {
    let bytes = std::fs::read(path).unwrap();
    let doc = read_glb_json(&bytes);
    let jl = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let blob = &bytes[20 + jl + 8..];
    let node = &doc["nodes"][k];
    let v3 = |v: &Value, default: f64| -> glam::DVec3 {
        match v.as_array() {
            Some(a) => glam::DVec3::new(
                a[0].as_f64().unwrap(),
                a[1].as_f64().unwrap(),
                a[2].as_f64().unwrap(),
            ),
            None => glam::DVec3::splat(default),
        }
    };
    let (translation, scale) = (v3(&node["translation"], 0.0), v3(&node["scale"], 1.0));
    let prim = &doc["meshes"][node["mesh"].as_u64().unwrap() as usize]["primitives"][0];
    // One accessor's elements, each as f64 components.
    let read = |a: usize| -> Vec<Vec<f64>> {
        let acc = &doc["accessors"][a];
        let view = &doc["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
        assert!(view.get("extensions").is_none(), "no compressed views here");
        let base = view["byteOffset"].as_u64().unwrap_or(0) as usize
            + acc["byteOffset"].as_u64().unwrap_or(0) as usize;
        let n = match acc["type"].as_str().unwrap() {
            "SCALAR" => 1,
            "VEC3" => 3,
            t => panic!("{t}"),
        };
        let (size, get): (usize, fn(&[u8]) -> f64) = match acc["componentType"].as_u64().unwrap() {
            5123 => (2, |b| u16::from_le_bytes([b[0], b[1]]) as f64),
            5125 => (4, |b| u32::from_le_bytes(b[..4].try_into().unwrap()) as f64),
            5126 => (4, |b| f32::from_le_bytes(b[..4].try_into().unwrap()) as f64),
            c => panic!("component type {c}"),
        };
        let stride = view["byteStride"].as_u64().map_or(n * size, |s| s as usize);
        (0..acc["count"].as_u64().unwrap() as usize)
            .map(|i| {
                (0..n)
                    .map(|k| get(&blob[base + i * stride + k * size..]))
                    .collect()
            })
            .collect()
    };
    let positions: Vec<[f32; 3]> = read(prim["attributes"]["POSITION"].as_u64().unwrap() as usize)
        .iter()
        .map(|p| {
            (translation + scale * glam::DVec3::new(p[0], p[1], p[2]))
                .as_vec3()
                .to_array()
        })
        .collect();
    let indices: Vec<u32> = read(prim["indices"].as_u64().unwrap() as usize)
        .iter()
        .map(|i| i[0] as u32)
        .collect();
    // The level's own vertices: its group's stream holds other levels'
    // too (placed by their own nodes).
    let mut remap = BTreeMap::new();
    let mut own = Vec::new();
    let indices: Vec<u32> = indices
        .iter()
        .map(|&i| {
            *remap.entry(i).or_insert_with(|| {
                own.push(positions[i as usize]);
                own.len() as u32 - 1
            })
        })
        .collect();
    let positions = own;
    gigawalk_scene::LodMesh {
        origin: scene_origin,
        normals: vec![[0.0, 1.0, 0.0]; positions.len()],
        positions,
        colours: gigawalk_scene::Colours::Uniform([255; 4]),
        indices,
    }
}

/// No tile's geometric error is under-stated as a client draws it: the
/// same brute-force check the scene's own errors pass
/// (`check_error_bounds`: points sampled on the full-detail surface below
/// a node lie within a level's error of the level, and points on the
/// level within it of that surface), on the exported contents themselves
/// (the quantized and plain encodings, decoded as a client decodes them;
/// meshopt carries the quantized grid losslessly), every third node. A
/// content unites levels of disjoint subtrees, so each within the tile's
/// error of its own subtree's full detail is the union within it of the
/// tile's: each level is checked against the least error of the tiles
/// that draw it.
#[test]
fn exported_errors_bound_the_distance_to_full_detail() {
    let dir = tempfile::tempdir().unwrap();
    let (_, gwk) = small_plant(dir.path());
    let reader = SceneReader::open(&gwk).unwrap();
    let sk = reader.skeleton();
    let nodes: Vec<u32> = (0..sk.nodes().len() as u32).step_by(3).collect();
    let target = SMALL_TARGET.parse().unwrap();
    let plan = gigawalk_tiles::plan::plan(sk, target);
    for encoding in ["quantized", "plain"] {
        let out = dir.path().join(encoding);
        let summary = export(
            &gwk,
            &out,
            &["--encoding", encoding, "--content-triangles", SMALL_TARGET],
        );
        // Each content's error as the tileset states it, and where each
        // level is drawn (its tile's content and node there).
        let w = walk(&out, &gwk);
        let mut errors: Vec<f32> = sk.lods().iter().map(|l| l.error).collect();
        let mut drawn: BTreeMap<u32, (PathBuf, usize)> = BTreeMap::new();
        let mut least: BTreeMap<u32, f32> = BTreeMap::new();
        for (path, (e, _)) in &w.errors {
            // The f32 at or below the stated error: a check against it is
            // at least as strict as one against the stated number.
            let mut f = *e as f32;
            if f as f64 > *e {
                f = f.next_down();
            }
            for (k, q) in plan.tiles[tile_of(path)].parts.iter().enumerate() {
                drawn.entry(q.lod).or_insert_with(|| (path.clone(), k));
                let l = least.entry(q.lod).or_insert(f);
                *l = l.min(f);
            }
        }
        for (&l, &e) in &least {
            errors[l as usize] = e;
        }
        let (mut from_tiles, mut from_scene) = (0usize, 0usize);
        let b = gigawalk_preprocess::verify::check_error_bounds(
            sk.nodes(),
            &errors,
            &mut |l| match drawn.get(&l) {
                Some((p, k)) => {
                    from_tiles += 1;
                    content_mesh(p, *k, sk.origin())
                }
                None => {
                    // A level no tile draws (left out or empty): the
                    // scene's own, so the nodes above still get checked.
                    from_scene += 1;
                    reader.read_lod(l).unwrap()
                }
            },
            Some(&nodes),
            200,
            5,
        )
        .unwrap_or_else(|e| panic!("{encoding}: a tile's error is under-stated: {e}"));
        println!(
            "{encoding}: {} levels of {} nodes, {} samples, worst distance / stated error {:.3}; meshes from the tiles {from_tiles}, from the scene {from_scene}",
            b.lods,
            nodes.len(),
            b.samples,
            b.worst_ratio
        );
        assert!(b.worst_ratio <= 1.0, "{encoding}: {b:?}");
        assert!(
            b.lods > 0 && from_tiles >= from_scene,
            "{encoding}: {b:?}, {from_tiles} {from_scene}"
        );
        assert!(summary["contents"].as_u64().unwrap() as usize == w.contents);
    }
}
