//! Hand-made fixtures in tests/data (written by tests/data/make_fixtures.py):
//! good files import to the expected objects, broken ones give an error
//! naming the file, the object and the index.

use std::path::PathBuf;

use gigawalk_import::{import, import_glb_bytes, import_obj_str, ImportError, Model};
use gigawalk_testkit::XorShift;
use glam::{DVec3, Vec3};

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data")
        .join(name)
}

fn ok(name: &str) -> Model {
    import(&data(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Imports `name`, expects an error whose message contains every fragment.
fn check_error(name: &str, fragments: &[&str]) -> ImportError {
    let e = import(&data(name)).expect_err(name);
    let msg = e.to_string();
    for f in fragments {
        assert!(msg.contains(f), "{name}: {msg:?} lacks {f:?}");
    }
    e
}

#[test]
fn triangle_embedded() {
    let m = ok("triangle_embedded.gltf");
    assert_eq!(m.objects.len(), 1);
    let o = &m.objects[0];
    assert_eq!(o.indices, vec![0, 1, 2]);
    assert_eq!(o.positions[1], DVec3::X);
    assert_eq!(o.colour, [0.25, 0.5, 0.75, 1.0]);
    assert_eq!(
        o.normals,
        vec![Vec3::Z; 3],
        "computed normals face the counter-clockwise side"
    );
    assert_eq!(m.stats.triangles, 1);
}

#[test]
fn triangle_external_buffer_with_escaped_uri() {
    let m = ok("triangle_external.gltf");
    assert_eq!(
        m.objects[0].positions,
        ok("triangle_embedded.gltf").objects[0].positions
    );
}

#[test]
fn cube_glb_keeps_file_normals() {
    let m = ok("cube.glb");
    let o = &m.objects[0];
    assert_eq!(o.triangle_count(), 12);
    assert_eq!(o.positions.len(), 24);
    for n in &o.normals {
        assert_eq!(n.abs().max_element(), 1.0);
        assert_eq!(n.length(), 1.0);
    }
    // The byte entry point gives the same model.
    let bytes = std::fs::read(data("cube.glb")).unwrap();
    let name = data("cube.glb").display().to_string();
    assert_eq!(import_glb_bytes(&bytes, &name).unwrap().objects, m.objects);
}

#[test]
fn strips_and_fans_become_triangles_points_are_skipped() {
    let m = ok("modes.gltf");
    assert_eq!(m.objects.len(), 2);
    assert_eq!(m.objects[0].triangle_count(), 2);
    assert_eq!(m.objects[1].triangle_count(), 3);
    assert_eq!(m.stats.skipped_primitives, 1);
    assert_eq!(m.stats.triangles, 5);
    // Every strip/fan triangle keeps the strip's facing (+Z).
    for o in &m.objects {
        assert!(o.normals.iter().all(|n| n.z > 0.99), "{}", o.name);
    }
    assert!(m
        .stats
        .summary(2)
        .contains("1 point/line primitives skipped"));
}

#[test]
fn far_from_origin_in_f64_and_mirror_flips_winding() {
    let m = ok("far_mirrored.gltf");
    let o = &m.objects[0];
    // x = 10^7 + 0.5 + 0.125 - x_local: exact in f64, off by ~0.5 in f32.
    assert_eq!(
        o.positions[0],
        DVec3::new(10_000_000.625, 0.0, -10_000_000.25)
    );
    assert_eq!(
        o.positions[1],
        DVec3::new(10_000_000.625 - 1.0, 0.0, -10_000_000.25)
    );
    // Mirrored, the triangle would face -Z; flipped winding keeps it +Z
    // (its computed normal agrees with the winding).
    let [a, b, c] = [0, 1, 2].map(|k| o.positions[o.indices[k] as usize]);
    assert!((b - a).cross(c - a).z > 0.0);
    assert!(o.normals[0].z > 0.99);
    assert!(o.name.contains("mirrored"), "{}", o.name);
}

#[test]
fn degenerate_triangles_dropped_and_counted() {
    let m = ok("degenerate.gltf");
    assert_eq!(m.objects[0].triangle_count(), 1);
    assert_eq!(m.stats.degenerate_triangles_dropped, 1);
    assert!(m
        .stats
        .summary(1)
        .contains("1 degenerate triangles dropped"));
}

#[test]
fn out_of_range_index() {
    let e = check_error(
        "out_of_range_index.gltf",
        &[
            "out_of_range_index.gltf",
            "mesh \"m\"",
            "primitive 0",
            "index 5 at position 2",
            "3 vertices",
        ],
    );
    assert!(matches!(
        e,
        ImportError::IndexOutOfRange {
            value: 5,
            position: 2,
            ..
        }
    ));
}

#[test]
fn nan_vertex() {
    let e = check_error(
        "nan_vertex.gltf",
        &["nan_vertex.gltf", "mesh \"m\"", "vertex 1", "non-finite"],
    );
    assert!(matches!(
        e,
        ImportError::NonFinitePosition { vertex: 1, .. }
    ));
}

#[test]
fn missing_buffer_file() {
    check_error(
        "missing_buffer.gltf",
        &["missing_buffer.gltf", "buffer 0", "does_not_exist.bin"],
    );
}

#[test]
fn truncated_glb() {
    check_error("truncated.glb", &["truncated.glb", "malformed glTF"]);
}

#[test]
fn malformed_json() {
    check_error("not_json.gltf", &["not_json.gltf", "malformed glTF"]);
}

#[test]
fn empty_mesh() {
    check_error(
        "empty_mesh.gltf",
        &["empty_mesh.gltf", "primitive 0", "empty mesh"],
    );
}

#[test]
fn unsupported_extension_and_missing_file() {
    check_error(
        "make_fixtures.py",
        &["make_fixtures.py", "unsupported file type"],
    );
    check_error("no_such_file.glb", &["no_such_file.glb", "cannot read"]);
}

#[test]
fn obj_groups_become_objects_with_kd_colours() {
    let m = ok("two_groups.obj");
    assert_eq!(m.objects.len(), 2);
    assert_eq!(m.objects[0].name, "pipe");
    assert_eq!(m.objects[0].triangle_count(), 2, "the quad is triangulated");
    assert_eq!(m.objects[0].colour, [1.0, 0.0, 0.0, 1.0]);
    assert_eq!(m.objects[1].colour, [0.0, 0.0, 1.0, 1.0]);
    assert!(m.stats.warnings.is_empty());
    assert!(m.objects[1].normals.iter().all(|n| *n == Vec3::Z));
}

#[test]
fn obj_missing_mtl_is_a_warning() {
    let m = ok("missing_mtl.obj");
    assert_eq!(m.objects.len(), 1);
    assert_eq!(m.stats.warnings.len(), 1, "{:?}", m.stats.warnings);
    assert!(m.stats.warnings[0].contains("material library"));
    assert_eq!(m.objects[0].colour, [0.8, 0.8, 0.8, 1.0]);
}

#[test]
fn obj_out_of_range_index_names_group_and_line() {
    let e = check_error(
        "obj_out_of_range.obj",
        &[
            "obj_out_of_range.obj",
            "group \"second\"",
            "line 7",
            "index 9",
            "3 vertices",
        ],
    );
    assert!(matches!(
        e,
        ImportError::IndexOutOfRange {
            value: 9,
            position: 2,
            ..
        }
    ));
}

#[test]
fn obj_nan_vertex() {
    check_error(
        "obj_nan.obj",
        &["obj_nan.obj", "group \"bad\"", "vertex 1", "non-finite"],
    );
}

#[test]
fn obj_from_str_negative_indices() {
    let m = import_obj_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n", "inline").unwrap();
    assert_eq!(m.objects[0].triangle_count(), 1);
    assert!(import_obj_str("v 0 0 0\nf 0 1 1\n", "inline").is_err());
    assert!(matches!(
        import_obj_str("", "inline"),
        Err(ImportError::NoGeometry { .. })
    ));
}

#[test]
fn garbage_bytes_are_errors_not_panics() {
    for bytes in [
        &b""[..],
        b"glTF",
        b"glTF\x02\0\0\0\xff\xff\xff\xff",
        b"{}",
        b"\0\0\0\0",
        b"{\"asset\":{\"version\":\"2.0\"}}",
    ] {
        assert!(import_glb_bytes(bytes, "garbage").is_err());
    }
}

/// A poor man's fuzzer for CI (cargo-fuzz targets live in fuzz/): flip,
/// truncate and overwrite bytes of the good fixtures; every result must be
/// a model or an error, never a panic.
#[test]
fn mutated_fixtures_never_panic() {
    let mut rng = XorShift::new(0x2545_F491_4F6C_DD1D);
    let mut next = move || rng.next_u64();
    let glb = std::fs::read(data("cube.glb")).unwrap();
    let gltf = std::fs::read(data("modes.gltf")).unwrap();
    let obj = std::fs::read(data("two_groups.obj")).unwrap();
    // GIGAWALK_MUTATION_ROUNDS=1000000 for a longer hunt.
    let rounds: usize = std::env::var("GIGAWALK_MUTATION_ROUNDS")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(6000);
    for round in 0..rounds {
        let src = [&glb, &gltf, &obj][round % 3];
        let mut bytes = src.clone();
        for _ in 0..1 + next() % 4 {
            let at = (next() as usize) % bytes.len();
            match next() % 4 {
                0 => bytes[at] ^= 1 << (next() % 8),
                1 => bytes[at] = b"0123456789-.e,:[]{}\" nf/"[(next() % 24) as usize],
                2 => bytes[at] = next() as u8,
                _ => bytes.truncate(at.max(1)),
            }
        }
        if round % 3 == 2 {
            let _ = import_obj_str(&String::from_utf8_lossy(&bytes), "mutated.obj");
        } else {
            let _ = import_glb_bytes(&bytes, "mutated");
        }
    }
}

#[test]
fn objects_carry_their_identity_node_path_file_and_extras() {
    let text = std::fs::read_to_string(data("triangle_embedded.gltf")).unwrap();
    let mut doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    // Two named nodes under a parent, one with extras, two siblings of one
    // name, and an unnamed node: all sharing the one mesh.
    doc["nodes"] = serde_json::json!([
        {"name": "Plant", "children": [1, 2, 3]},
        {"name": "Pipe.003", "mesh": 0, "extras": {"tag": "P-101", "dn": 50}},
        {"name": "Bolt", "mesh": 0},
        {"name": "Bolt", "mesh": 0, "translation": [0, 0, 1]},
        {"mesh": 0}
    ]);
    doc["scenes"] = serde_json::json!([{"nodes": [0, 4]}]);
    doc["scene"] = serde_json::json!(0);
    let m =
        gigawalk_import::import_gltf_bytes(doc.to_string().as_bytes(), "plant.gltf", None).unwrap();
    let ids: Vec<_> = m.objects.iter().map(|o| &o.identity).collect();
    assert_eq!(ids.len(), 4);
    assert_eq!(
        (ids[0].name.as_str(), ids[0].path.as_str()),
        ("Pipe.003", "Plant/Pipe.003")
    );
    assert_eq!(ids[0].file, "plant.gltf");
    let extras: serde_json::Value = serde_json::from_str(ids[0].extras.as_ref().unwrap()).unwrap();
    assert_eq!(extras, serde_json::json!({"tag": "P-101", "dn": 50}));
    // Siblings of one name share a path, not an identity.
    assert_eq!(ids[1].path, ids[2].path);
    assert!(!ids[1].same_object(ids[2]));
    assert!(ids[1].extras.is_none());
    // An unnamed node is named by its mesh, its path by its index.
    assert_eq!((ids[3].name.as_str(), ids[3].path.as_str()), ("m", "#4"));
    // OBJ: the group.
    let m = import_obj_str(
        "g Valve_7\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        "skid.obj",
    )
    .unwrap();
    let id = &m.objects[0].identity;
    assert_eq!(
        (id.name.as_str(), id.path.as_str(), id.file.as_str()),
        ("Valve_7", "Valve_7", "skid.obj")
    );
}
