//! Several files, and directories of them, imported as one model.

use std::path::{Path, PathBuf};

use gigawalk_import::{import_all, model_files, ImportError};

/// A one-triangle OBJ named `group`.
fn triangle(at: f64, group: &str) -> String {
    format!(
        "g {group}\nv {at} 0 0\nv {} 0 0\nv {at} 1 0\nf 1 2 3\n",
        at + 1.0
    )
}

fn write(path: &Path, text: &str) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, text).unwrap();
}

/// dir/{b.obj, a.obj, sub/c.OBJ} and files that are not models.
fn tree() -> (tempfile::TempDir, PathBuf) {
    let t = tempfile::tempdir().unwrap();
    let dir = t.path().join("plant");
    write(&dir.join("b.obj"), &triangle(2.0, "valve"));
    write(&dir.join("a.obj"), &triangle(0.0, "pipe"));
    write(&dir.join("sub/c.OBJ"), &triangle(4.0, "tank"));
    write(&dir.join("notes.txt"), "not a model");
    write(&dir.join("a.bin"), "buffer bytes");
    write(&dir.join(".hidden.obj"), "garbage that would not parse");
    (t, dir)
}

#[test]
fn a_directory_is_its_model_files_in_path_order_each_name_keeping_its_file() {
    let (_t, dir) = tree();
    let files = model_files(std::slice::from_ref(&dir)).unwrap();
    assert_eq!(
        files,
        vec![dir.join("a.obj"), dir.join("b.obj"), dir.join("sub/c.OBJ")]
    );
    let mut heard = Vec::new();
    let m = import_all(std::slice::from_ref(&dir), &mut |i, n, p| {
        heard.push((i, n, p.to_path_buf()))
    })
    .unwrap();
    assert_eq!(heard.len(), 3);
    assert_eq!(heard[2], (2, 3, dir.join("sub/c.OBJ")));
    assert_eq!(m.objects.len(), 3);
    assert_eq!(m.stats.triangles, 3);
    let names: Vec<&str> = m.objects.iter().map(|o| o.name.as_str()).collect();
    for (name, (file, group)) in
        names
            .iter()
            .zip([("a.obj", "pipe"), ("b.obj", "valve"), ("sub/c.OBJ", "tank")])
    {
        let prefix = format!("{}/", dir.join(file).display());
        assert!(
            name.starts_with(&prefix),
            "{name} should start with {prefix}"
        );
        assert!(name.contains(group), "{name}");
    }
    // Each object keeps its own geometry, in world coordinates.
    assert_eq!(m.objects[1].positions[0].x, 2.0);
}

#[test]
fn files_and_directories_mix_and_a_file_named_twice_counts_once() {
    let (_t, dir) = tree();
    let inputs = [dir.join("b.obj"), dir.clone(), dir.join("./a.obj")];
    let files = model_files(&inputs).unwrap();
    assert_eq!(
        files,
        vec![dir.join("b.obj"), dir.join("a.obj"), dir.join("sub/c.OBJ")]
    );
    let m = import_all(&inputs, &mut |_, _, _| {}).unwrap();
    assert_eq!(m.stats.triangles, 3);
}

#[test]
fn one_file_keeps_its_object_names() {
    let (_t, dir) = tree();
    let m = import_all(&[dir.join("a.obj")], &mut |_, _, _| {}).unwrap();
    assert_eq!(m.objects.len(), 1);
    assert!(
        !m.objects[0].name.contains("a.obj/"),
        "{}",
        m.objects[0].name
    );
}

#[test]
fn the_first_file_that_fails_names_itself() {
    let (_t, dir) = tree();
    write(&dir.join("b.obj"), "v 0 0 0\nf 1 2 3\n");
    let e = import_all(std::slice::from_ref(&dir), &mut |_, _, _| {}).unwrap_err();
    assert!(e.to_string().contains("b.obj"), "{e}");
    // A named file of another kind, or one that is missing.
    let e = import_all(
        &[dir.join("a.obj"), dir.join("notes.txt")],
        &mut |_, _, _| {},
    )
    .unwrap_err();
    assert!(matches!(e, ImportError::UnsupportedFormat { .. }), "{e}");
    assert!(e.to_string().contains("notes.txt"), "{e}");
    let e = import_all(&[dir.join("missing.glb")], &mut |_, _, _| {}).unwrap_err();
    assert!(e.to_string().contains("missing.glb"), "{e}");
}

#[test]
fn a_directory_without_models_is_an_error_naming_it() {
    let t = tempfile::tempdir().unwrap();
    let empty = t.path().join("empty");
    write(&empty.join("readme.txt"), "no models here");
    let e = model_files(std::slice::from_ref(&empty)).unwrap_err();
    assert!(matches!(e, ImportError::NoModelFiles { .. }), "{e}");
    assert!(e.to_string().contains("empty"), "{e}");
    assert!(import_all(&[], &mut |_, _, _| {}).is_err());
}
