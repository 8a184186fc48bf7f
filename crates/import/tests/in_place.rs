//! Binary glTF files and external buffers are read in place, an accessor
//! at a time: the objects are the same as from the bytes in memory, and a
//! file cut short or a buffer shorter than declared is an error naming it.

use std::path::{Path, PathBuf};

use gigawalk_import::{import, import_each, import_glb_bytes, ImportError};

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data")
        .join(name)
}

#[test]
fn a_glb_read_in_place_matches_its_bytes() {
    let path = data("cube.glb");
    let bytes = std::fs::read(&path).unwrap();
    let from_bytes = import_glb_bytes(&bytes, &path.display().to_string()).unwrap();
    let in_place = import(&path).unwrap();
    assert_eq!(in_place, from_bytes);
    // Streamed, the objects come one by one, the same and in order.
    let mut streamed = Vec::new();
    let stats = import_each(&path, &mut |o| {
        streamed.push(o);
        Ok(())
    })
    .unwrap();
    assert_eq!(streamed, from_bytes.objects);
    assert_eq!(stats, from_bytes.stats);
}

fn copy_cut(from: &Path, to: &Path, keep: usize) {
    let mut bytes = std::fs::read(from).unwrap();
    bytes.truncate(keep);
    std::fs::write(to, bytes).unwrap();
}

#[test]
fn a_glb_cut_anywhere_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let src = data("cube.glb");
    let len = std::fs::metadata(&src).unwrap().len() as usize;
    let cut = dir.path().join("cut.glb");
    for keep in [5, 12, 19, 20, len / 2, len - 1] {
        copy_cut(&src, &cut, keep);
        let e = import(&cut).expect_err("a cut file");
        assert!(e.to_string().contains("cut.glb"), "{keep}: {e}");
    }
}

#[test]
fn an_external_buffer_shorter_than_declared_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let gltf = data("triangle_external.gltf");
    std::fs::copy(&gltf, dir.path().join("t.gltf")).unwrap();
    let bin = data("triangle data.bin");
    let len = std::fs::metadata(&bin).unwrap().len() as usize;
    copy_cut(&bin, &dir.path().join("triangle data.bin"), len - 4);
    let e = import(&dir.path().join("t.gltf")).expect_err("a short buffer");
    assert!(matches!(e, ImportError::BufferTooShort { .. }), "{e:?}");
    assert!(e.to_string().contains("t.gltf"), "{e}");
    // Whole again, it imports as the original does.
    std::fs::copy(&bin, dir.path().join("triangle data.bin")).unwrap();
    let a = import(&dir.path().join("t.gltf")).unwrap();
    let b = import(&gltf).unwrap();
    assert_eq!(a.objects.len(), b.objects.len());
    assert_eq!(a.objects[0].positions, b.objects[0].positions);
}
