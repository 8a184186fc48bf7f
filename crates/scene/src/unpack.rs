//! The decoders a reader needs: zstd frames (with the file's dictionary)
//! and meshoptimizer's vertex and index codecs.
//!
//! Native builds use the C and C++ libraries the writer uses. The wasm32
//! build (the browser viewer) cannot compile them and uses pure-Rust
//! ports of the same formats, `ruzstd` and `meshoptimizer-rs`, which read
//! the same files. The tests below decode every stream both ways and
//! require the same bytes, so the browser reads exactly what a native
//! reader reads.

use bytemuck::Pod;

use crate::squeeze::Dictionary;

/// The content size a zstd frame's header states, when the frame is a
/// zstd frame that states one (RFC 8878, section 3.1.1.1). The writer
/// always sets it: the reader sizes its output from it, after checking it
/// against what the record's counts allow.
pub fn frame_content_size(frame: &[u8]) -> Option<u64> {
    const MAGIC: [u8; 4] = 0xFD2F_B528u32.to_le_bytes();
    if frame.get(..4)? != MAGIC {
        return None;
    }
    let descriptor = *frame.get(4)?;
    let single_segment = descriptor & 0x20 != 0;
    let fcs_bytes = match descriptor >> 6 {
        0 if single_segment => 1,
        0 => return None,
        1 => 2,
        2 => 4,
        _ => 8,
    };
    let dictionary_id_bytes = [0, 1, 2, 4][usize::from(descriptor & 3)];
    let at = 5 + usize::from(!single_segment) + dictionary_id_bytes;
    let field = frame.get(at..at + fcs_bytes)?;
    let mut le = [0u8; 8];
    le[..fcs_bytes].copy_from_slice(field);
    let value = u64::from_le_bytes(le);
    // A two-byte field stores the size less 256.
    Some(if fcs_bytes == 2 { value + 256 } else { value })
}

#[cfg(not(target_arch = "wasm32"))]
pub use native::{decompress, indices, vertices};
#[cfg(target_arch = "wasm32")]
pub use pure::{decompress, indices, vertices};

#[cfg(not(target_arch = "wasm32"))]
mod native {
    use std::cell::RefCell;

    use super::*;

    thread_local! {
        /// A decompression context with the last dictionary this thread used.
        static CONTEXT: RefCell<Option<(u64, zstd::bulk::Decompressor<'static>)>> =
            const { RefCell::new(None) };
    }

    /// Decompresses one zstd frame of `size` bytes with `dictionary`.
    pub fn decompress(
        frame: &[u8],
        dictionary: Option<&Dictionary>,
        size: usize,
    ) -> Result<Vec<u8>, String> {
        let id = dictionary.map_or(0, |d| d.id);
        CONTEXT.with(|c| {
            let mut c = c.borrow_mut();
            if c.as_ref().is_none_or(|(have, _)| *have != id) {
                let d = match dictionary {
                    Some(d) => zstd::bulk::Decompressor::with_dictionary(&d.bytes),
                    None => zstd::bulk::Decompressor::new(),
                }
                .map_err(|e| format!("zstd: {e}"))?;
                *c = Some((id, d));
            }
            let (_, d) = c.as_mut().expect("set above");
            d.decompress(frame, size).map_err(|e| e.to_string())
        })
    }

    /// Decodes `count` vertices of meshoptimizer's vertex codec.
    pub fn vertices<T: Pod + Default>(stream: &[u8], count: usize) -> Result<Vec<T>, String> {
        meshopt::decode_vertex_buffer::<T>(stream, count).map_err(|e| format!("{e:?}"))
    }

    /// Decodes `count` indices of meshoptimizer's index codec.
    pub fn indices(stream: &[u8], count: usize) -> Result<Vec<u32>, String> {
        meshopt::decode_index_buffer::<u32>(stream, count).map_err(|e| format!("{e:?}"))
    }
}

#[cfg(any(target_arch = "wasm32", test))]
mod pure {
    use std::cell::RefCell;

    use ruzstd::decoding::{BlockDecodingStrategy, FrameDecoder};

    use super::*;

    /// The id the dictionary is registered under in the decoder: the
    /// writer leaves dictionary ids out of frames (the file has one).
    const DICTIONARY: u32 = 1;

    thread_local! {
        static CONTEXT: RefCell<Option<(u64, FrameDecoder)>> = const { RefCell::new(None) };
    }

    /// [`super::native::decompress`] in pure Rust.
    pub fn decompress(
        frame: &[u8],
        dictionary: Option<&Dictionary>,
        size: usize,
    ) -> Result<Vec<u8>, String> {
        let id = dictionary.map_or(0, |d| d.id);
        CONTEXT.with(|c| {
            let mut c = c.borrow_mut();
            if c.as_ref().is_none_or(|(have, _)| *have != id) {
                let mut decoder = FrameDecoder::new();
                if let Some(d) = dictionary {
                    let mut dict = ruzstd::decoding::Dictionary::decode_dict(&d.bytes)
                        .map_err(|e| format!("the dictionary does not decode: {e}"))?;
                    dict.id = DICTIONARY;
                    decoder.add_dict(dict).map_err(|e| e.to_string())?;
                }
                *c = Some((id, decoder));
            }
            let (_, decoder) = c.as_mut().expect("set above");
            let mut input = frame;
            decoder.init(&mut input).map_err(|e| e.to_string())?;
            if dictionary.is_some() {
                decoder.force_dict(DICTIONARY).map_err(|e| e.to_string())?;
            }
            decoder
                .decode_blocks(&mut input, BlockDecodingStrategy::All)
                .map_err(|e| e.to_string())?;
            if !decoder.is_finished() || !input.is_empty() {
                return Err("the frame ends early or has bytes after it".into());
            }
            let mut out = vec![0u8; size];
            let mut at = 0;
            while at < size {
                match std::io::Read::read(decoder, &mut out[at..]).map_err(|e| e.to_string())? {
                    0 => break,
                    n => at += n,
                }
            }
            if decoder.can_collect() != 0 {
                return Err(format!("the frame holds more than {size} bytes"));
            }
            out.truncate(at);
            Ok(out)
        })
    }

    thread_local! {
        static WORKSPACE: RefCell<meshoptimizer_rs::Workspace> =
            RefCell::new(meshoptimizer_rs::Workspace::default());
    }

    /// [`super::native::vertices`] in pure Rust.
    pub fn vertices<T: Pod + Default>(stream: &[u8], count: usize) -> Result<Vec<T>, String> {
        let mut out = vec![T::default(); count];
        WORKSPACE.with(|w| {
            meshoptimizer_rs::codec::decode_vertex_buffer_into(
                bytemuck::cast_slice_mut(&mut out),
                count,
                std::mem::size_of::<T>(),
                stream,
                &mut w.borrow_mut(),
            )
            .map_err(|e| format!("{e:?}"))
        })?;
        Ok(out)
    }

    /// [`super::native::indices`] in pure Rust.
    pub fn indices(stream: &[u8], count: usize) -> Result<Vec<u32>, String> {
        let mut out = vec![0u32; count];
        WORKSPACE.with(|w| {
            meshoptimizer_rs::codec::decode_index_buffer_into(
                bytemuck::cast_slice_mut(&mut out),
                count,
                4,
                stream,
                &mut w.borrow_mut(),
            )
            .map_err(|e| format!("{e:?}"))
        })?;
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic stream of smooth, noisy values, like a mesh's.
    fn smooth(n: usize, seed: u32) -> Vec<[u16; 4]> {
        let mut x = seed;
        (0..n)
            .map(|i| {
                x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                let jitter = (x >> 24) as u16;
                let i = i as u16;
                [
                    i.wrapping_mul(3),
                    i / 2 + jitter,
                    4000u16.wrapping_sub(i / 4),
                    0,
                ]
            })
            .collect()
    }

    #[test]
    fn frame_content_size_reads_every_field_width() {
        for size in [0usize, 1, 200, 255, 256, 300, 65_791, 70_000, 5 << 20] {
            let data: Vec<u8> = (0..size).map(|i| (i % 251) as u8).collect();
            let frame = zstd::bulk::compress(&data, 3).unwrap();
            assert_eq!(
                frame_content_size(&frame),
                zstd::zstd_safe::get_frame_content_size(&frame).unwrap(),
                "{size} bytes"
            );
            assert_eq!(frame_content_size(&frame), Some(size as u64));
        }
        assert_eq!(frame_content_size(b"not a frame"), None);
        assert_eq!(frame_content_size(&[0x28, 0xB5, 0x2F, 0xFD]), None);
    }

    #[test]
    fn pure_zstd_decodes_what_native_does_with_and_without_the_dictionary() {
        let samples: Vec<Vec<u8>> = (0..400)
            .map(|s| bytemuck::cast_slice(&smooth(300 + s, s as u32)).to_vec())
            .collect();
        let refs: Vec<&[u8]> = samples.iter().map(|s| s.as_slice()).collect();
        let mut squeezer = crate::squeeze::Squeezer::train(&refs).unwrap();
        let bytes = squeezer
            .dictionary
            .clone()
            .expect("enough samples to train");
        let dictionary = Dictionary::new(bytes);
        for (i, s) in samples.iter().enumerate().step_by(37) {
            let frame = squeezer.compress(s).unwrap();
            let size = frame_content_size(&frame).unwrap() as usize;
            let a = native::decompress(&frame, Some(&dictionary), size).unwrap();
            let b = pure::decompress(&frame, Some(&dictionary), size).unwrap();
            assert_eq!(a, *s, "sample {i}");
            assert_eq!(b, *s, "sample {i}");
            let plain = zstd::bulk::compress(s, 19).unwrap();
            assert_eq!(pure::decompress(&plain, None, s.len()).unwrap(), *s);
        }
        // A frame of more bytes than asked for is an error both ways.
        let frame = squeezer.compress(&samples[0]).unwrap();
        let short = samples[0].len() - 1;
        assert!(native::decompress(&frame, Some(&dictionary), short).is_err());
        assert!(pure::decompress(&frame, Some(&dictionary), short).is_err());
        // Corrupt frames are errors, never panics.
        for cut in [5, frame.len() / 2, frame.len() - 1] {
            assert!(pure::decompress(&frame[..cut], Some(&dictionary), 1 << 16).is_err());
        }
    }

    #[test]
    fn pure_meshopt_decodes_what_native_does() {
        for (n, seed) in [
            (0usize, 1u32),
            (1, 2),
            (15, 3),
            (16, 4),
            (257, 5),
            (5000, 6),
        ] {
            let v = smooth(n, seed);
            let stream = meshopt::encode_vertex_buffer(&v).unwrap();
            let a: Vec<[u16; 4]> = native::vertices(&stream, n).unwrap();
            let b: Vec<[u16; 4]> = pure::vertices(&stream, n).unwrap();
            assert_eq!(a, v);
            assert_eq!(b, v);
            let bytes: Vec<[u8; 4]> = v.iter().map(|c| [c[0] as u8, c[1] as u8, 7, 9]).collect();
            let stream = meshopt::encode_vertex_buffer(&bytes).unwrap();
            assert_eq!(pure::vertices::<[u8; 4]>(&stream, n).unwrap(), bytes);

            let triangles = n.saturating_sub(2);
            let idx: Vec<u32> = (0..triangles as u32)
                .flat_map(|t| [t, t + 1, t + 2])
                .collect();
            let stream = meshopt::encode_index_buffer(&idx, n).unwrap();
            let a = native::indices(&stream, idx.len()).unwrap();
            assert_eq!(pure::indices(&stream, idx.len()).unwrap(), a);
            // The codec may rotate a triangle's corners, never change them.
            for (t, (x, y)) in a.chunks(3).zip(idx.chunks(3)).enumerate() {
                let rotations = [[y[0], y[1], y[2]], [y[1], y[2], y[0]], [y[2], y[0], y[1]]];
                assert!(
                    rotations.iter().any(|r| r == x),
                    "triangle {t}: {x:?} {y:?}"
                );
            }
        }
        let v = smooth(100, 9);
        let stream = meshopt::encode_vertex_buffer(&v).unwrap();
        for cut in [0, 1, stream.len() / 2, stream.len() - 1] {
            assert!(pure::vertices::<[u16; 4]>(&stream[..cut], 100).is_err());
        }
    }
}
