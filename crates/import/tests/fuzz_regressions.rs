//! Inputs that once panicked inside a dependency (found by the cargo-fuzz
//! targets in fuzz/, run by benches/fuzz.sh): each must now be a clean
//! error naming the file and the problem. Run in debug builds (as `cargo
//! test` does), where the dependencies' unchecked arithmetic overflows.

use gigawalk_import::{import, import_glb_bytes, import_obj_str, ImportError};

/// Expects an error whose message contains every fragment.
fn check(result: Result<gigawalk_import::Model, ImportError>, fragments: &[&str]) -> ImportError {
    let e = result.expect_err("a clean error");
    let msg = e.to_string();
    for f in fragments {
        assert!(msg.contains(f), "{msg:?} lacks {f:?}");
    }
    e
}

/// gltf 1.4.1 `Glb::from_slice` computed `length - 12` on the header's
/// total-length field (binary.rs:252): a length under 12 overflowed.
#[test]
fn glb_total_length_under_12() {
    let mut bytes = b"glTF\x02\0\0\0\x05\0\0\0".to_vec();
    bytes.extend_from_slice(b"\x04\0\0\0JSON{}  ");
    check(
        import_glb_bytes(&bytes, "short.glb"),
        &["short.glb", "malformed glTF", "total length 5"],
    );
    // The smallest: a bare header whose length is 0.
    check(
        import_glb_bytes(b"glTF\x02\0\0\0\0\0\0\0", "zero.glb"),
        &["zero.glb", "total length 0"],
    );
}

/// tobj 4.0.5 resolved a relative normal index before the first normal to
/// a huge usize and computed `vn * 3 + 2` on it (lib.rs:860).
#[test]
fn obj_relative_normal_index_before_first() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\ng tri\nf 1//1 2//-3 3//1\n";
    let e = check(
        import_obj_str(text, "rel_normal.obj"),
        &[
            "rel_normal.obj",
            "group \"tri\" face at line 6",
            "normal index -3 at position 1",
            "(1 normals)",
        ],
    );
    assert!(matches!(
        e,
        ImportError::ObjIndexOutOfRange {
            kind: "normal",
            value: -3,
            count: 1,
            ..
        }
    ));
}

/// The same for texture coordinates (`vt * 2 + 1`, lib.rs:852).
#[test]
fn obj_relative_texcoord_index_before_first() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/-3 2/1 3/1\n";
    check(
        import_obj_str(text, "rel_texcoord.obj"),
        &[
            "rel_texcoord.obj",
            "face at line 5",
            "texcoord index -3 at position 0",
            "(1 texcoords)",
        ],
    );
}

/// A positive normal index so large that `(index - 1) * 3` overflows
/// (lib.rs:860).
#[test]
fn obj_huge_normal_index() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//9223372036854775807\n";
    check(
        import_obj_str(text, "huge_normal.obj"),
        &[
            "huge_normal.obj",
            "face at line 5",
            "normal index 9223372036854775807 at position 2",
        ],
    );
}

/// An `l` line, which tobj reads as a face, with a relative texcoord index
/// before the first texcoord (lib.rs:852).
#[test]
fn obj_line_element_texcoord_before_first() {
    let text = "v 0 0 0\nv 1 0 0\nvt 0 0\nl 1/1 2/-9\n";
    check(
        import_obj_str(text, "line.obj"),
        &[
            "line.obj",
            "line element at line 4",
            "texcoord index -9 at position 1",
        ],
    );
}

/// Not crashes, but indices tobj misreads or reports without a place, now
/// errors naming the line: index 0 (tobj reads it as "no normal"), an
/// index to an element not yet defined (tobj resolves it against the
/// elements at the end of the group), a huge texcoord index (tobj's error
/// names no line). Good relative and absolute indices still import.
#[test]
fn obj_indices_tobj_misreads() {
    let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n";
    check(
        import_obj_str(&format!("{head}f 1//0 2//1 3//1\n"), "zero.obj"),
        &["zero.obj", "normal index 0"],
    );
    check(
        import_obj_str(
            &format!("{head}f 1//1 2//2 3//1\nvn 0 0 1\n"),
            "forward.obj",
        ),
        &["forward.obj", "normal index 2", "(1 normals)"],
    );
    check(
        import_obj_str(
            &format!("{head}f 1/9223372036854775807 2/1 3/1\n"),
            "huge_texcoord.obj",
        ),
        &[
            "huge_texcoord.obj",
            "line 6",
            "texcoord index 9223372036854775807",
        ],
    );
    let m = import_obj_str(
        &format!("{head}vt 1 0\nf 1/1/1 2/-1/-1 -1/2/1\n"),
        "good.obj",
    )
    .unwrap();
    assert_eq!(m.objects[0].triangle_count(), 1);
}

/// tobj 4.0.5 `parse_float3` unwrapped a colour line with fewer than three
/// values (`Kd 1 1`), a panic in every build. The library is now skipped
/// with a warning naming it and the line, as an unreadable one is.
#[test]
fn mtl_colour_with_two_values() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("short.mtl"),
        "newmtl red\nKd 1 0\n", // line 2
    )
    .unwrap();
    let obj = dir.path().join("short_kd.obj");
    std::fs::write(
        &obj,
        "mtllib short.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n",
    )
    .unwrap();
    let m = import(&obj).expect("imports with the default colour");
    assert_eq!(m.stats.warnings.len(), 1, "{:?}", m.stats.warnings);
    let w = &m.stats.warnings[0];
    for f in [
        "short_kd.obj",
        "short.mtl",
        "line 2",
        "Kd needs 3 values, found 2",
    ] {
        assert!(w.contains(f), "{w:?} lacks {f:?}");
    }
    assert_eq!(m.objects[0].colour, [0.8, 0.8, 0.8, 1.0]);
}
