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
//!
//! A process killed outright (SIGKILL, a crash, the power) cleans up
//! nothing. Temporary names therefore carry their owner's process id
//! (`.gigawalk-<pid>-XXXXXX.tmp`), and the first write into a directory
//! removes the temporary files there whose owner is gone (on Linux, where
//! `/proc` says which processes run; elsewhere they stay), as well as
//! `.gigawalk-work-<pid>-*` directories of split builds.
//! [`stale_temp_files_removed`] lists what was removed, for the caller to
//! say so.

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

/// Directories swept of dead processes' temporaries, and what was removed.
static SWEPT: Mutex<(Vec<PathBuf>, Vec<PathBuf>)> = Mutex::new((Vec::new(), Vec::new()));

/// The process id a gigawalk temporary name carries:
/// `.gigawalk-<pid>-*.tmp` (a file) or `.gigawalk-work-<pid>-*` (a split
/// build's directory); `None` for any other name.
fn owner_pid(name: &str, is_dir: bool) -> Option<u32> {
    let rest = name.strip_prefix(".gigawalk-")?;
    let rest = match (is_dir, rest.strip_prefix("work-")) {
        (true, Some(r)) => r,
        (false, None) if name.ends_with(".tmp") => rest,
        _ => return None,
    };
    let (pid, _) = rest.split_once('-')?;
    pid.parse().ok()
}

/// Whether process `pid` may still run (`true` where that cannot be told).
fn alive(pid: u32) -> bool {
    if cfg!(target_os = "linux") {
        Path::new("/proc").join(pid.to_string()).exists()
    } else {
        true
    }
}

/// Removes, once per directory per process, the temporaries in `dir` whose
/// owner is gone.
fn sweep(dir: &Path) {
    let key = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
    let mut swept = SWEPT.lock().unwrap_or_else(PoisonError::into_inner);
    if swept.0.contains(&key) {
        return;
    }
    swept.0.push(key);
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let me = std::process::id();
    for e in entries.flatten() {
        let Ok(kind) = e.file_type() else { continue };
        let name = e.file_name();
        let Some(pid) = name.to_str().and_then(|n| owner_pid(n, kind.is_dir())) else {
            continue;
        };
        if pid == me || alive(pid) {
            continue;
        }
        let path = e.path();
        let removed = if kind.is_dir() {
            std::fs::remove_dir_all(&path)
        } else {
            std::fs::remove_file(&path)
        };
        if removed.is_ok() {
            swept.1.push(path);
        }
    }
}

/// The temporary files and directories of gigawalk processes that are gone
/// that this process removed so far (see the module's note).
pub fn stale_temp_files_removed() -> Vec<PathBuf> {
    SWEPT
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .1
        .clone()
}

/// The prefix of this process's temporary work directories (split
/// builds): removed like its temporary files once it is gone.
pub fn work_dir_prefix() -> String {
    format!(".gigawalk-work-{}-", std::process::id())
}

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
    sweep(dir);
    let prefix = format!(".gigawalk-{}-", std::process::id());
    let mut b = tempfile::Builder::new();
    b.prefix(&prefix).suffix(".tmp");
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

    #[test]
    fn temporaries_of_processes_that_are_gone_are_removed_and_listed() {
        assert_eq!(super::owner_pid(".gigawalk-123-abc.tmp", false), Some(123));
        assert_eq!(super::owner_pid(".gigawalk-work-45-x", true), Some(45));
        assert_eq!(super::owner_pid(".gigawalk-abc.tmp", false), None);
        assert_eq!(super::owner_pid(".gigawalk-123-abc", false), None);
        assert_eq!(super::owner_pid(".gigawalk-work-45-x", false), None);
        assert_eq!(super::owner_pid("scene.gwk", false), None);
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        // Above Linux's largest pid: never a running process.
        let dead = d.join(".gigawalk-4000000000-dead.tmp");
        let dead_work = d.join(".gigawalk-work-4000000000-w");
        let mine = d.join(format!(".gigawalk-{}-mine.tmp", std::process::id()));
        let old = d.join(".gigawalk-old.tmp");
        for f in [&dead, &mine, &old] {
            std::fs::write(f, b"x").unwrap();
        }
        std::fs::create_dir(&dead_work).unwrap();
        std::fs::write(dead_work.join("plan.json"), b"{}").unwrap();
        super::write_atomic(&d.join("out"), b"y").unwrap();
        assert!(
            mine.exists() && old.exists(),
            "a live owner's and an unnamed one stay"
        );
        if cfg!(target_os = "linux") {
            assert!(!dead.exists() && !dead_work.exists());
            let removed = super::stale_temp_files_removed();
            assert!(
                removed.contains(&dead) && removed.contains(&dead_work),
                "{removed:?}"
            );
        }
        assert_eq!(std::fs::read(d.join("out")).unwrap(), b"y");
    }

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
