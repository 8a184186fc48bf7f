//! Atomic writes: every output of gigawalk (scene files, camera paths,
//! reports, stats, screenshots) is written to a temporary file beside the
//! destination and renamed over it when complete, so an interrupted write
//! never leaves a file that looks finished.

use std::io::Write as _;
use std::path::Path;

/// A temporary file in `path`'s directory, to be persisted (renamed) over
/// `path`. Unlike tempfile's default (0600) it gets the permissions a
/// plain `File::create` would (0666 less the umask on Unix), so renamed
/// outputs are readable like any other file the user writes.
pub fn temp_file_for(path: &Path) -> std::io::Result<tempfile::NamedTempFile> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut b = tempfile::Builder::new();
    b.prefix(".gigawalk-").suffix(".tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt as _;
        b.permissions(std::fs::Permissions::from_mode(0o666));
    }
    b.tempfile_in(dir)
}

/// Writes `bytes` to `path` through [`temp_file_for`]: flushed to disk,
/// then renamed into place.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut tmp = temp_file_for(path)?;
    tmp.write_all(bytes)?;
    tmp.as_file().sync_all()?;
    tmp.persist(path).map_err(|e| e.error)?;
    Ok(())
}

#[cfg(all(test, unix))]
mod tests {
    use std::os::unix::fs::PermissionsExt as _;

    #[test]
    fn temp_files_get_the_permissions_of_a_plain_create() {
        let dir = tempfile::tempdir().unwrap();
        let plain = dir.path().join("plain");
        std::fs::File::create(&plain).unwrap();
        let out = dir.path().join("out");
        super::write_atomic(&out, b"x").unwrap();
        let mode = |p: &std::path::Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&out), mode(&plain));
        assert_eq!(std::fs::read(&out).unwrap(), b"x");
    }
}
