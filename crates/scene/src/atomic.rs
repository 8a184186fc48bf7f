//! Atomic writes: every output of gigawalk (scene files, camera paths,
//! reports, stats, screenshots) is written to a temporary file beside the
//! destination and renamed over it when complete, so an interrupted write
//! never leaves a file that looks finished.
//!
//! A temporary file deletes itself when dropped, but a process ended by a
//! signal drops nothing. So every live temporary file is also listed in a
//! process-wide registry, and [`remove_temp_files`] deletes them all: the
//! `gigawalk` binary calls it on SIGINT and SIGTERM before it exits.
//! Libraries never call it, and nothing here installs a signal handler.

use std::io::{self, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};

/// The temporary files of unfinished writes, and whether the process is
/// stopping (then no new one may start and none may be renamed into place).
struct Registry {
    live: Vec<PathBuf>,
    stopping: bool,
}

static REGISTRY: Mutex<Registry> = Mutex::new(Registry {
    live: Vec::new(),
    stopping: false,
});

/// The registry, also after a panic elsewhere: its list stays consistent
/// because every change is a single push or remove.
fn registry() -> MutexGuard<'static, Registry> {
    REGISTRY.lock().unwrap_or_else(PoisonError::into_inner)
}

fn stopping_error() -> io::Error {
    io::Error::new(
        io::ErrorKind::Interrupted,
        "the process is stopping: no file is written",
    )
}

/// A temporary file from [`temp_file_for`]: written like a file, then
/// [`TempFile::persist`]ed (renamed) over its destination. Dropped before
/// that, it deletes itself.
#[derive(Debug)]
pub struct TempFile {
    /// `Some` until persisted or dropped.
    file: Option<tempfile::NamedTempFile>,
}

impl TempFile {
    fn inner(&self) -> &tempfile::NamedTempFile {
        self.file
            .as_ref()
            .expect("present until persisted or dropped")
    }

    fn inner_mut(&mut self) -> &mut tempfile::NamedTempFile {
        self.file
            .as_mut()
            .expect("present until persisted or dropped")
    }

    pub fn as_file(&self) -> &std::fs::File {
        self.inner().as_file()
    }

    pub fn as_file_mut(&mut self) -> &mut std::fs::File {
        self.inner_mut().as_file_mut()
    }

    /// Where the temporary file is (a hidden `.gigawalk-*.tmp` file).
    pub fn path(&self) -> &Path {
        self.inner().path()
    }

    /// Renames the file over `path`. Fails without renaming when the
    /// process is stopping ([`remove_temp_files`] ran), so a signal never
    /// races a rename into leaving a file behind.
    pub fn persist(mut self, path: &Path) -> io::Result<()> {
        let file = self
            .file
            .take()
            .expect("present until persisted or dropped");
        // Held across the rename: the signal handler's clean-up sees the
        // file either still temporary (and deletes it) or already in place.
        let mut reg = registry();
        reg.live.retain(|p| p != file.path());
        if reg.stopping {
            return Err(stopping_error());
        }
        file.persist(path).map_err(|e| e.error)?;
        Ok(())
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if let Some(file) = self.file.take() {
            let mut reg = registry();
            reg.live.retain(|p| p != file.path());
            // Deleted under the lock, so it is never unlisted yet present.
            drop(file);
        }
    }
}

impl Write for TempFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.as_file_mut().write(buf)
    }

    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        self.as_file_mut().write_all(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.as_file_mut().flush()
    }
}

impl Seek for TempFile {
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        self.as_file_mut().seek(pos)
    }
}

/// A temporary file in `path`'s directory, to be persisted (renamed) over
/// `path`. Unlike tempfile's default (0600) it gets the permissions a
/// plain `File::create` would (0666 less the umask on Unix), so renamed
/// outputs are readable like any other file the user writes.
pub fn temp_file_for(path: &Path) -> io::Result<TempFile> {
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
    // Created and listed under the lock: a clean-up never misses it.
    let mut reg = registry();
    if reg.stopping {
        return Err(stopping_error());
    }
    let file = b.tempfile_in(dir)?;
    reg.live.push(file.path().to_path_buf());
    Ok(TempFile { file: Some(file) })
}

/// Writes `bytes` to `path` through [`temp_file_for`]: flushed to disk,
/// then renamed into place.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let mut tmp = temp_file_for(path)?;
    tmp.write_all(bytes)?;
    tmp.as_file().sync_all()?;
    tmp.persist(path)
}

/// For a process about to exit on a signal: deletes the temporary file of
/// every unfinished write and makes every later [`temp_file_for`] and
/// [`TempFile::persist`] fail, so nothing half-written stays behind and
/// nothing new starts. Files already renamed into place are complete and
/// stay. Returns how many files it deleted. Irreversible: call it only on
/// the way out (the `gigawalk` binary's signal handler does).
pub fn remove_temp_files() -> usize {
    let mut reg = registry();
    reg.stopping = true;
    let live = std::mem::take(&mut reg.live);
    live.iter()
        .filter(|p| std::fs::remove_file(p).is_ok())
        .count()
}

#[cfg(test)]
mod tests {
    use std::io::Write as _;

    fn listed(p: &std::path::Path) -> bool {
        super::registry().live.iter().any(|l| l == p)
    }

    #[cfg(unix)]
    #[test]
    fn temp_files_get_the_permissions_of_a_plain_create() {
        use std::os::unix::fs::PermissionsExt as _;
        let dir = tempfile::tempdir().unwrap();
        let plain = dir.path().join("plain");
        std::fs::File::create(&plain).unwrap();
        let out = dir.path().join("out");
        super::write_atomic(&out, b"x").unwrap();
        let mode = |p: &std::path::Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&out), mode(&plain));
        assert_eq!(std::fs::read(&out).unwrap(), b"x");
    }

    #[test]
    fn temp_files_are_listed_until_persisted_or_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        let mut kept = super::temp_file_for(&out).unwrap();
        let tmp = kept.path().to_path_buf();
        assert!(listed(&tmp) && tmp.is_file());
        kept.write_all(b"done").unwrap();
        kept.persist(&out).unwrap();
        assert!(!listed(&tmp) && !tmp.exists());
        assert_eq!(std::fs::read(&out).unwrap(), b"done");

        let dropped = super::temp_file_for(&out).unwrap();
        let tmp = dropped.path().to_path_buf();
        assert!(listed(&tmp));
        drop(dropped);
        assert!(!listed(&tmp) && !tmp.exists());
        assert_eq!(std::fs::read(&out).unwrap(), b"done");
    }
}
