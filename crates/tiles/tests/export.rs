//! The export on hand-built scenes: one without levels above its leaves
//! or object identity, far from its origin; a failed write; an existing
//! output directory.

use std::path::{Path, PathBuf};

use gigawalk_scene::Aabb;
use gigawalk_testkit::scenes::{box_mesh, write_leaf_scene};
use gigawalk_tiles::{export, Encoding, ExportError, ExportOptions, Quiet};
use glam::DVec3;

/// Three boxes a million units from the origin, a leaf each, the root
/// without levels, no object table, written as `boxes.gwk` in a new
/// temporary directory: the directory, the scene file and the boxes.
fn far_boxes() -> (tempfile::TempDir, PathBuf, Vec<Aabb>) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("boxes.gwk");
    let boxes: Vec<Aabb> = (0..3)
        .map(|i| {
            let min = DVec3::new(1.0e6 + 3.0 * i as f64, 2.0e6, -1.0e6);
            Aabb::new(min, min + DVec3::new(1.0, 2.0, 0.5))
        })
        .collect();
    let leaves: Vec<(Aabb, _)> = boxes
        .iter()
        .map(|b| (*b, box_mesh(b, [200, 100, 50, 255])))
        .collect();
    write_leaf_scene(&path, 8, &leaves);
    (dir, path, boxes)
}

fn json(p: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

#[test]
fn a_scene_without_levels_or_identity_far_from_its_origin() {
    let (dir, gwk, boxes) = far_boxes();
    for encoding in [Encoding::Meshopt, Encoding::Quantized, Encoding::Plain] {
        let out = dir.path().join(encoding.name());
        // A content a box (12 triangles each).
        let options = ExportOptions {
            encoding,
            content_triangles: 12,
            ..ExportOptions::default()
        };
        let s = export(&gwk, &out, &options, &Quiet).unwrap();
        assert_eq!((s.tiles, s.contents, s.triangles), (4, 3, 36));
        assert_eq!(s.median_content_triangles, 12);
        assert!(!s.identity && s.contents_with_features == 0);
        let t = json(&out.join("tileset.json"));
        let root = &t["root"];
        assert!(root.get("content").is_none(), "the root has no level");
        // The root's error covers the scene (its diagonal).
        let scene = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
        let diagonal = (scene.max - scene.min).length();
        assert!(root["geometricError"].as_f64().unwrap() >= diagonal);
        // The origin is in the root transform; boxes are small numbers.
        let m: Vec<f64> = root["transform"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        assert!(m[12].abs() > 9.0e5, "{m:?}");
        for c in root["children"].as_array().unwrap() {
            for x in c["boundingVolume"]["box"].as_array().unwrap() {
                assert!(x.as_f64().unwrap().abs() < 100.0, "{c}");
            }
            let uri = c["content"]["uri"].as_str().unwrap();
            let glb = std::fs::read(out.join(uri)).unwrap();
            let g = gltf::Gltf::from_slice_without_validation(&glb).unwrap();
            let node = g.nodes().next().unwrap();
            let (t, _, _) = node.transform().decomposed();
            // Content is relative to the scene origin: a small translation.
            assert!(t.iter().all(|x| x.abs() < 100.0), "{t:?}");
            let used: Vec<&str> = g.extensions_used().collect();
            match encoding {
                Encoding::Meshopt => assert!(used.contains(&"EXT_meshopt_compression")),
                Encoding::Quantized => assert_eq!(used, ["KHR_mesh_quantization"]),
                Encoding::Plain => assert!(used.is_empty()),
            }
        }
    }
}

#[test]
fn a_failed_write_leaves_no_tileset() {
    let (dir, gwk, _) = far_boxes();
    let out = dir.path().join("tiles");
    let options = ExportOptions {
        fail_after_contents: Some(1),
        content_triangles: 12,
        ..ExportOptions::default()
    };
    let e = export(&gwk, &out, &options, &Quiet).unwrap_err();
    assert!(matches!(e, ExportError::Write { .. }), "{e}");
    assert!(e.to_string().contains("no space left"), "{e}");
    // The directory the export made is gone with what it wrote.
    assert!(!out.exists());
    // Into an existing directory: it stays, empty of the export's files.
    std::fs::create_dir(&out).unwrap();
    export(&gwk, &out, &options, &Quiet).unwrap_err();
    assert!(out.exists() && std::fs::read_dir(&out).unwrap().next().is_none());
}

#[test]
fn small_levels_share_one_content() {
    let (dir, gwk, boxes) = far_boxes();
    let out = dir.path().join("tiles");
    let s = export(&gwk, &out, &ExportOptions::default(), &Quiet).unwrap();
    // The empty root over one content of the three boxes.
    assert_eq!((s.tiles, s.contents, s.triangles, s.parts), (2, 1, 36, 3));
    let t = json(&out.join("tileset.json"));
    let child = &t["root"]["children"][0];
    let glb = std::fs::read(out.join(child["content"]["uri"].as_str().unwrap())).unwrap();
    let g = gltf::Gltf::from_slice_without_validation(&glb).unwrap();
    // A node a box, each at its box's corner (the grid's origin).
    let origin = {
        let m = t["root"]["transform"].as_array().unwrap();
        // The transform holds the origin turned z up: x, -z, y.
        DVec3::new(
            m[12].as_f64().unwrap(),
            m[14].as_f64().unwrap(),
            -m[13].as_f64().unwrap(),
        )
    };
    assert_eq!(g.nodes().count(), 3);
    for (node, b) in g.nodes().zip(&boxes) {
        let (tr, _, _) = node.transform().decomposed();
        let at = origin + DVec3::new(tr[0] as f64, tr[1] as f64, tr[2] as f64);
        assert!((at - b.min).abs().max_element() < 1e-3, "{at:?} for {b:?}");
    }
}

#[test]
fn an_existing_directory_needs_force_which_replaces_the_tileset_first() {
    let (dir, gwk, _) = far_boxes();
    let out = dir.path().join("tiles");
    export(&gwk, &out, &ExportOptions::default(), &Quiet).unwrap();
    let e = export(&gwk, &out, &ExportOptions::default(), &Quiet).unwrap_err();
    assert!(matches!(e, ExportError::OutputExists(_)), "{e}");
    std::fs::write(out.join("content/0/stale.glb"), b"old").unwrap();
    // A forced export that fails leaves no tileset.json: the old one went first.
    let failing = ExportOptions {
        force: true,
        fail_after_contents: Some(0),
        ..ExportOptions::default()
    };
    export(&gwk, &out, &failing, &Quiet).unwrap_err();
    assert!(!out.join("tileset.json").exists() && !out.join("content").exists());
    let forced = ExportOptions {
        force: true,
        ..ExportOptions::default()
    };
    export(&gwk, &out, &forced, &Quiet).unwrap();
    assert!(out.join("tileset.json").exists());
    // A file is not a directory.
    let e = export(&gwk, &gwk, &forced, &Quiet).unwrap_err();
    assert!(matches!(e, ExportError::NotADirectory(_)), "{e}");
}
