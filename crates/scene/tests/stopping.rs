//! `remove_temp_files`, what a process does on its way out after a signal:
//! unfinished writes leave nothing, finished ones stay, and nothing new
//! starts. In its own test binary because the clean-up is process-wide and
//! irreversible.

use std::io::Write as _;

use gigawalk_scene::{remove_temp_files, temp_file_for, write_atomic};

#[test]
fn removing_temp_files_deletes_unfinished_writes_and_stops_new_ones() {
    let dir = tempfile::tempdir().unwrap();
    let done = dir.path().join("done");
    write_atomic(&done, b"complete").unwrap();
    let mut unfinished = temp_file_for(&dir.path().join("a")).unwrap();
    unfinished.write_all(b"half").unwrap();
    let late = temp_file_for(&dir.path().join("b")).unwrap();
    let (a, b) = (unfinished.path().to_owned(), late.path().to_owned());
    assert!(a.is_file() && b.is_file());

    assert_eq!(remove_temp_files(), 2);
    assert!(!a.exists() && !b.exists());
    assert_eq!(std::fs::read(&done).unwrap(), b"complete");

    // A write that finishes after the clean-up is not renamed into place.
    let e = late.persist(&dir.path().join("b")).unwrap_err();
    assert_eq!(e.kind(), std::io::ErrorKind::Interrupted);
    assert!(!dir.path().join("b").exists());
    drop(unfinished);
    let e = temp_file_for(&dir.path().join("c")).unwrap_err();
    assert_eq!(e.kind(), std::io::ErrorKind::Interrupted);
    let e = write_atomic(&done, b"overwrite").unwrap_err();
    assert_eq!(e.kind(), std::io::ErrorKind::Interrupted);
    assert_eq!(std::fs::read(&done).unwrap(), b"complete");
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(left.len(), 1, "only the finished file: {left:?}");
}
