//! A scene file seen through the byte ranges fetched so far.
//!
//! The scene reader reads with positioned reads ([`ReadAt`]); a reader
//! that fetches a file in pieces (the browser page, with HTTP range
//! requests) has only what those brought. [`Sparse`] answers a read from
//! the fetched chunks, and when a read reaches bytes it does not have, it
//! fails that read and remembers the range, so the caller fetches it and
//! tries again. Opening a scene takes a few such rounds ([`open_step`]:
//! header, table of contents, skeleton), each one fetch; a LOD's blob is
//! fetched before it is read (its range is in the skeleton), then
//! dropped.
//!
//! Nothing here trusts what it holds: the reader checks every section's
//! and every LOD's checksum as it does for a file on disk. Nothing here
//! fetches either: how bytes arrive is the caller's.

use std::collections::BTreeMap;
use std::io;
use std::ops::Range;
use std::sync::{Arc, Mutex, MutexGuard};

use crate::{ReadAt, ReadError, SceneReader};

/// The least to fetch at once while opening a scene: the first round
/// brings the header, the second the table of contents at the end with
/// the sections just before it.
pub const OPEN_CHUNK: u64 = 64 << 10;

/// The fetched chunks of one file of `len` bytes.
#[derive(Debug, Default)]
pub struct Chunks {
    len: u64,
    /// Start offset -> bytes; chunks never overlap (inserts merge).
    chunks: BTreeMap<u64, Vec<u8>>,
    /// The first range a read wanted and did not find, since the last
    /// [`Sparse::take_missing`].
    missing: Option<(u64, u64)>,
}

/// A shared handle on a file's chunks: the reader owns one, the fetcher
/// another (it inserts what arrives). Shared as the runtime's LOD source
/// must be (`Sync`), though the browser page has one thread.
#[derive(Clone, Debug)]
pub struct Sparse(Arc<Mutex<Chunks>>);

impl Sparse {
    /// An empty view of a file of `len` bytes.
    pub fn new(len: u64) -> Sparse {
        Sparse(Arc::new(Mutex::new(Chunks {
            len,
            ..Chunks::default()
        })))
    }

    /// The chunks (a panic elsewhere while holding them leaves them
    /// whole: every change is made in one step).
    fn chunks(&self) -> MutexGuard<'_, Chunks> {
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }

    pub fn len(&self) -> u64 {
        self.chunks().len
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Adds the bytes fetched at `at`, merging them with the chunks they
    /// touch. Bytes beyond the file's end are an error (a server that
    /// answered another file).
    pub fn insert(&self, at: u64, bytes: Vec<u8>) -> Result<(), String> {
        let mut c = self.chunks();
        let end = at + bytes.len() as u64;
        if end > c.len {
            return Err(format!(
                "bytes {at}..{end} lie beyond the file's {} bytes",
                c.len
            ));
        }
        if bytes.is_empty() {
            return Ok(());
        }
        // Chunks overlapping or touching [at, end), merged into one.
        let touching: Vec<u64> = c
            .chunks
            .range(..=end)
            .filter(|(s, b)| *s + b.len() as u64 >= at)
            .map(|(s, _)| *s)
            .collect();
        let start = touching.first().map_or(at, |s| (*s).min(at));
        let mut last_end = end;
        for s in &touching {
            last_end = last_end.max(s + c.chunks[s].len() as u64);
        }
        let mut merged = vec![0u8; (last_end - start) as usize];
        for s in touching {
            let b = c.chunks.remove(&s).expect("listed above");
            let o = (s - start) as usize;
            merged[o..o + b.len()].copy_from_slice(&b);
        }
        let o = (at - start) as usize;
        merged[o..o + bytes.len()].copy_from_slice(&bytes);
        c.chunks.insert(start, merged);
        Ok(())
    }

    /// Drops every fetched byte in `range` that no other read needs to
    /// keep (a LOD's blob once decoded): a fetcher holds what it opened
    /// the scene with, and LOD blobs only while they are read.
    pub fn forget(&self, range: Range<u64>) {
        let mut c = self.chunks();
        let starts: Vec<u64> = c
            .chunks
            .range(..range.end)
            .filter(|(s, b)| *s + b.len() as u64 > range.start)
            .map(|(s, _)| *s)
            .collect();
        for s in starts {
            let b = c.chunks.remove(&s).expect("listed above");
            let end = s + b.len() as u64;
            if s < range.start {
                c.chunks.insert(s, b[..(range.start - s) as usize].to_vec());
            }
            if end > range.end {
                c.chunks
                    .insert(range.end, b[(range.end - s) as usize..].to_vec());
            }
        }
    }

    /// Bytes held now.
    pub fn held_bytes(&self) -> u64 {
        self.chunks().chunks.values().map(|b| b.len() as u64).sum()
    }

    /// Whether every byte of `range` is held.
    pub fn holds(&self, range: &Range<u64>) -> bool {
        let c = self.chunks();
        c.chunks
            .range(..=range.start)
            .next_back()
            .is_some_and(|(s, b)| s + b.len() as u64 >= range.end)
    }

    /// The range the last failed read wanted, if a read failed for want
    /// of bytes since the last call.
    pub fn take_missing(&self) -> Option<Range<u64>> {
        self.chunks().missing.take().map(|(s, e)| s..e)
    }
}

/// The error a read of bytes not fetched yet fails with: the reader turns
/// it into a `ReadError`, and [`open_step`] tells it from a real one by
/// [`Sparse::take_missing`].
fn not_fetched() -> io::Error {
    io::Error::new(io::ErrorKind::WouldBlock, "bytes not fetched yet")
}

impl ReadAt for Sparse {
    fn read_exact_at(&self, buf: &mut [u8], offset: u64) -> io::Result<()> {
        let mut c = self.chunks();
        let end = offset
            .checked_add(buf.len() as u64)
            .ok_or(io::ErrorKind::UnexpectedEof)?;
        if end > c.len {
            return Err(io::ErrorKind::UnexpectedEof.into());
        }
        if let Some((s, b)) = c.chunks.range(..=offset).next_back() {
            if s + b.len() as u64 >= end {
                let o = (offset - s) as usize;
                buf.copy_from_slice(&b[o..o + buf.len()]);
                return Ok(());
            }
        }
        if c.missing.is_none() {
            c.missing = Some((offset, end));
        }
        Err(not_fetched())
    }

    fn size(&self) -> io::Result<u64> {
        Ok(self.len())
    }
}

/// What one attempt to open the scene came to.
pub enum OpenStep {
    Open(Box<SceneReader<Sparse>>),
    /// Fetch this range (what the reader missed, widened: see
    /// [`widen`]), insert it and try again.
    Fetch(Range<u64>),
    Failed(ReadError),
}

/// Tries to open the scene with what `sparse` holds. The rounds: the
/// header (the first [`OPEN_CHUNK`] of the file), the table of contents
/// at the end of the file (with [`OPEN_CHUNK`] before it), then every
/// section opening reads, in one request when they lie together, as the writer puts
/// them: the skeleton and nothing of the geometry or the optional
/// sections (object table, occluders), which are read when used.
pub fn open_step(sparse: &Sparse, name: &str) -> OpenStep {
    let missed = |e| match sparse.take_missing() {
        Some(m) => OpenStep::Fetch(widen(m, OPEN_CHUNK, sparse.len())),
        None => OpenStep::Failed(e),
    };
    sparse.take_missing();
    let reads = match crate::opening_reads(sparse, name) {
        Ok(r) => r,
        Err(e) => return missed(e),
    };
    let missing: Vec<&Range<u64>> = reads.iter().filter(|r| !sparse.holds(r)).collect();
    if let (Some(start), Some(end)) = (
        missing.iter().map(|r| r.start).min(),
        missing.iter().map(|r| r.end).max(),
    ) {
        return OpenStep::Fetch(start..end);
    }
    match SceneReader::from_source(sparse.clone(), name) {
        Ok(r) => OpenStep::Open(Box::new(r)),
        Err(e) => missed(e),
    }
}

/// `range` grown to at least `want` bytes within a file of `len` bytes:
/// forward, and backward where the file ends first (a scene's skeleton
/// sections lie just before its table of contents, at the end).
pub fn widen(range: Range<u64>, want: u64, len: u64) -> Range<u64> {
    let want = want.max(range.end - range.start);
    let end = (range.start + want).min(len).max(range.end);
    let start = end.saturating_sub(want).min(range.start);
    start..end
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bytes(n: usize) -> Vec<u8> {
        (0..n).map(|i| (i * 7 % 251) as u8).collect()
    }

    #[test]
    fn reads_come_from_chunks_and_a_miss_names_its_range() {
        let file = bytes(1000);
        let s = Sparse::new(1000);
        let mut buf = [0u8; 10];
        assert!(s.read_exact_at(&mut buf, 100).is_err());
        assert_eq!(s.take_missing(), Some(100..110));
        assert_eq!(s.take_missing(), None);
        s.insert(90, file[90..105].to_vec()).unwrap();
        assert!(
            s.read_exact_at(&mut buf, 100).is_err(),
            "only 5 of 10 bytes"
        );
        s.insert(105, file[105..200].to_vec()).unwrap();
        s.insert(50, file[50..95].to_vec()).unwrap();
        s.read_exact_at(&mut buf, 100).unwrap();
        assert_eq!(buf, file[100..110]);
        s.read_exact_at(&mut buf, 50).unwrap();
        assert_eq!(buf, file[50..60]);
        assert_eq!(s.held_bytes(), 150, "merged into one chunk of 50..200");
        assert!(s.read_exact_at(&mut buf, 995).is_err(), "past the end");
        assert!(s.insert(990, vec![0; 20]).is_err());
    }

    #[test]
    fn forgetting_keeps_the_rest_of_a_chunk() {
        let file = bytes(1000);
        let s = Sparse::new(1000);
        s.insert(0, file[..600].to_vec()).unwrap();
        s.forget(100..200);
        assert_eq!(s.held_bytes(), 500);
        let mut buf = [0u8; 50];
        s.read_exact_at(&mut buf, 50).unwrap();
        assert_eq!(buf, file[50..100]);
        s.read_exact_at(&mut buf, 200).unwrap();
        assert_eq!(buf, file[200..250]);
        assert!(s.read_exact_at(&mut buf, 150).is_err());
        s.forget(0..1000);
        assert_eq!(s.held_bytes(), 0);
    }

    #[test]
    fn widening_stays_in_the_file() {
        assert_eq!(widen(0..10, 64, 1 << 30), 0..64);
        assert_eq!(widen(5..10, 64, 100), 5..69);
        assert_eq!(widen(90..100, 64, 100), 36..100, "backward at the end");
        assert_eq!(widen(0..300, 64, 1 << 30), 0..300);
        assert_eq!(widen(10..20, 64, 30), 0..30, "the whole of a small file");
    }
}
