//! Temporary files for atomic writes: every output of gigawalk (scene
//! files, camera paths, reports, screenshots) is written to a temporary
//! file in the destination's directory and renamed over it when complete,
//! so an interrupted write never leaves a file that looks finished.

use std::path::Path;

/// A temporary file in `dir` to be persisted (renamed) over the real
/// output. Unlike tempfile's default (0600) it gets the permissions a
/// plain `File::create` would (0666 less the umask on Unix), so renamed
/// outputs are readable like any other file the user writes.
pub fn temp_file_in(dir: &Path) -> std::io::Result<tempfile::NamedTempFile> {
    let mut b = tempfile::Builder::new();
    b.prefix(".gigawalk-").suffix(".tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt as _;
        b.permissions(std::fs::Permissions::from_mode(0o666));
    }
    b.tempfile_in(dir)
}

#[cfg(all(test, unix))]
mod tests {
    use std::os::unix::fs::PermissionsExt as _;

    #[test]
    fn temp_files_get_the_permissions_of_a_plain_create() {
        let dir = tempfile::tempdir().unwrap();
        let plain = dir.path().join("plain");
        std::fs::File::create(&plain).unwrap();
        let tmp = super::temp_file_in(dir.path()).unwrap();
        let out = dir.path().join("out");
        tmp.persist(&out).unwrap();
        let mode = |p: &std::path::Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&out), mode(&plain));
    }
}
