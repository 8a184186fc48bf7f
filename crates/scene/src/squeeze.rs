//! The last step of an encoded blob (format 2.1): zstd over meshopt's
//! output. meshoptimizer's codecs are built to be followed by a general
//! compressor (gltfpack's files are meant to be gzip- or zstd-compressed
//! whole); a scene's blobs are a few KB each, too small for zstd alone
//! (measured on the 1M plant: 0.77x of the blobs), so the writer trains a
//! dictionary on the scene's first blobs (0.61-0.63x) and stores it once,
//! in the ZDIC section.

#[cfg(not(target_arch = "wasm32"))]
use std::cell::RefCell;
use std::sync::atomic::{AtomicU64, Ordering};

#[cfg(not(target_arch = "wasm32"))]
use zstd::stream::raw::CParameter;

/// zstd's level: 9 made 3% smaller blobs than 3 on the 1M plant, and
/// decompresses as fast.
pub const LEVEL: i32 = 9;
/// Largest dictionary trained (zstd's CLI default is 110 KB; 16 KB gave
/// 0.68x of the blobs instead of 0.63x).
pub const DICT_BYTES: usize = 64 << 10;
/// Blob bytes the writer holds back to train the dictionary on.
pub const SAMPLE_BYTES: usize = 4 << 20;

/// A dictionary as a reader holds it: its bytes and an id unique in the
/// process (each thread keeps a decompression context for the last one).
#[derive(Debug)]
pub struct Dictionary {
    pub(crate) id: u64,
    pub(crate) bytes: Vec<u8>,
}

impl Dictionary {
    pub fn new(bytes: Vec<u8>) -> Dictionary {
        static NEXT: AtomicU64 = AtomicU64::new(1);
        Dictionary {
            id: NEXT.fetch_add(1, Ordering::Relaxed),
            bytes,
        }
    }
}

#[cfg(not(target_arch = "wasm32"))]
/// The writer's compressor: a dictionary trained on sample blobs, or
/// none when there were too few to train one.
pub struct Squeezer {
    compressor: zstd::bulk::Compressor<'static>,
    pub dictionary: Option<Vec<u8>>,
    /// Unique in the process: which compressor [`compress_with`] keeps.
    pub id: u64,
}

#[cfg(not(target_arch = "wasm32"))]
/// A compressor with the writer's settings and `dictionary`.
fn compressor(dictionary: Option<&[u8]>) -> Result<zstd::bulk::Compressor<'static>, String> {
    let err = |e: std::io::Error| format!("zstd: {e}");
    let mut compressor = match dictionary {
        Some(d) => zstd::bulk::Compressor::with_dictionary(LEVEL, d),
        None => zstd::bulk::Compressor::new(LEVEL),
    }
    .map_err(err)?;
    // The LOD's CRC covers the stored bytes, and the reader needs the
    // size to allocate; the dictionary is the file's only one.
    for p in [
        CParameter::ChecksumFlag(false),
        CParameter::ContentSizeFlag(true),
        CParameter::DictIdFlag(false),
    ] {
        compressor.set_parameter(p).map_err(err)?;
    }
    Ok(compressor)
}

#[cfg(not(target_arch = "wasm32"))]
impl Squeezer {
    pub fn train(samples: &[&[u8]]) -> Result<Squeezer, String> {
        static NEXT: AtomicU64 = AtomicU64::new(1);
        // zstd's trainer refuses too few or too small samples: then
        // every blob is compressed alone.
        let dictionary = zstd::dict::from_samples(samples, DICT_BYTES)
            .ok()
            .filter(|d| !d.is_empty());
        Ok(Squeezer {
            compressor: compressor(dictionary.as_deref())?,
            dictionary,
            id: NEXT.fetch_add(1, Ordering::Relaxed),
        })
    }

    pub fn compress(&mut self, blob: &[u8]) -> Result<Vec<u8>, String> {
        self.compressor
            .compress(blob)
            .map_err(|e| format!("zstd: {e}"))
    }
}

#[cfg(not(target_arch = "wasm32"))]
thread_local! {
    /// A compressor with the dictionary of the last [`Squeezer`] id this
    /// thread compressed for.
    static SQUEEZER: RefCell<Option<(u64, zstd::bulk::Compressor<'static>)>> =
        const { RefCell::new(None) };
}

#[cfg(not(target_arch = "wasm32"))]
/// [`Squeezer::compress`] for the squeezer `id` (with `dictionary`) on any
/// thread: the same bytes.
pub fn compress_with(id: u64, dictionary: Option<&[u8]>, blob: &[u8]) -> Result<Vec<u8>, String> {
    SQUEEZER.with(|c| {
        let mut c = c.borrow_mut();
        if c.as_ref().is_none_or(|(have, _)| *have != id) {
            *c = Some((id, compressor(dictionary)?));
        }
        let (_, z) = c.as_mut().expect("set above");
        z.compress(blob).map_err(|e| format!("zstd: {e}"))
    })
}

/// Decompresses a stored blob of at most `limit` bytes (what its counts
/// allow), with the file's dictionary.
pub fn decompress(
    blob: &[u8],
    dictionary: Option<&Dictionary>,
    limit: usize,
) -> Result<Vec<u8>, String> {
    let size = match crate::unpack::frame_content_size(blob) {
        Some(size) => size,
        None => return Err("the compressed blob is not a zstd frame stating its size".into()),
    };
    if size > limit as u64 {
        return Err(format!(
            "the compressed blob says {size} bytes, more than its counts allow ({limit})"
        ));
    }
    let size = usize::try_from(size).map_err(|_| "the compressed blob is too large")?;
    let out = crate::unpack::decompress(blob, dictionary, size)
        .map_err(|e| format!("the compressed blob does not decompress: {e}"))?;
    if out.len() != size {
        return Err(format!(
            "the compressed blob gave {} bytes, not the {size} it states",
            out.len()
        ));
    }
    Ok(out)
}
