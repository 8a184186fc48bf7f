//! A scene opened and read through fetched byte ranges alone
//! ([`gigawalk_scene::sparse`]), as the browser page does over HTTP,
//! against the same file opened from disk.

use gigawalk_scene::sparse::{open_step, OpenStep, Sparse, OPEN_CHUNK};
use gigawalk_scene::{Aabb, SceneReader};
use gigawalk_testkit::scenes::{box_mesh, write_leaf_scene};
use glam::DVec3;

/// A scene of `n` boxes in a row, and its bytes.
fn scene(n: usize) -> (tempfile::TempDir, std::path::PathBuf, Vec<u8>) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("row.gwk");
    let leaves: Vec<_> = (0..n)
        .map(|i| {
            let min = DVec3::new(i as f64 * 2.0, 0.0, 0.0);
            let b = Aabb::new(min, min + DVec3::ONE);
            (b, box_mesh(&b, [200, (i % 256) as u8, 40, 255]))
        })
        .collect();
    write_leaf_scene(&path, 8, &leaves);
    let bytes = std::fs::read(&path).unwrap();
    (dir, path, bytes)
}

/// Opens `file` through a [`Sparse`] view, fetching what each attempt
/// asks for; returns the reader and how many fetches it took.
fn open(file: &[u8]) -> (Box<SceneReader<Sparse>>, Sparse, usize) {
    let sparse = Sparse::new(file.len() as u64);
    let mut fetches = 0;
    loop {
        match open_step(&sparse, "row.gwk") {
            OpenStep::Open(r) => return (r, sparse, fetches),
            OpenStep::Fetch(range) => {
                fetches += 1;
                assert!(fetches < 10, "opening keeps asking for more");
                let r = range.start as usize..range.end as usize;
                sparse.insert(range.start, file[r].to_vec()).unwrap();
            }
            OpenStep::Failed(e) => panic!("{e}"),
        }
    }
}

#[test]
fn a_scene_opens_from_a_few_ranges_and_reads_each_lod_from_its_own() {
    let (_dir, path, file) = scene(6000);
    assert!(file.len() as u64 > 4 * OPEN_CHUNK, "{} bytes", file.len());
    let (reader, sparse, fetches) = open(&file);
    assert!(fetches <= 3, "{fetches} fetches to open");
    let opened_with = sparse.held_bytes();
    let disk = SceneReader::open(&path).unwrap();
    // What opening reads: the header, the table of contents and every
    // section but the geometry; opening fetches that, the first chunk
    // and at most a chunk more at the end.
    let geometry = disk.sections().iter().find(|s| s.name == "GEOM").unwrap();
    let needed = file.len() as u64 - geometry.len;
    assert!(
        opened_with <= needed + 2 * OPEN_CHUNK,
        "opening fetched {opened_with} bytes to read {needed} of {}",
        file.len()
    );
    assert_eq!(reader.skeleton(), disk.skeleton());
    for (lod, info) in reader.skeleton().lods().iter().enumerate().step_by(97) {
        let lod = lod as u32;
        let range = info.offset..info.offset + info.len;
        let r = range.start as usize..range.end as usize;
        sparse.insert(range.start, file[r].to_vec()).unwrap();
        let a = reader.read_lod(lod).unwrap();
        assert_eq!(a, disk.read_lod(lod).unwrap(), "LOD {lod}");
        sparse.forget(range);
    }
    // What the reader kept beyond opening is what opening fetched.
    assert!(sparse.held_bytes() <= opened_with);
}

#[test]
fn a_corrupt_lod_blob_is_an_error_naming_its_checksum() {
    let (_dir, _path, file) = scene(50);
    let (reader, sparse, _) = open(&file);
    let info = reader.skeleton().lods()[7];
    let mut blob = file[info.offset as usize..(info.offset + info.len) as usize].to_vec();
    blob[3] ^= 0x40;
    sparse.forget(info.offset..info.offset + info.len);
    sparse.insert(info.offset, blob).unwrap();
    let e = reader.read_lod(7).unwrap_err().to_string();
    assert!(e.contains("checksum"), "{e}");
}

#[test]
fn a_file_that_is_not_a_scene_fails_to_open_with_the_reason() {
    let not_a_scene = b"<!doctype html><html><body>Not found</body></html>".repeat(100);
    let sparse = Sparse::new(not_a_scene.len() as u64);
    sparse.insert(0, not_a_scene.clone()).unwrap();
    match open_step(&sparse, "scene.gwk") {
        OpenStep::Failed(e) => {
            let e = e.to_string();
            assert!(e.contains("scene.gwk"), "{e}");
        }
        OpenStep::Open(_) => panic!("opened HTML as a scene"),
        OpenStep::Fetch(r) => panic!("asked for {r:?} of a complete file"),
    }
    // A truncated scene: every byte there is, and still short.
    let (_dir, _path, file) = scene(50);
    let cut = &file[..file.len() / 2];
    let sparse = Sparse::new(cut.len() as u64);
    sparse.insert(0, cut.to_vec()).unwrap();
    assert!(matches!(
        open_step(&sparse, "scene.gwk"),
        OpenStep::Failed(_)
    ));
}
