//! Checks a binary glTF (.glb) container before `gltf::Glb::from_slice`
//! sees it.
//!
//! gltf 1.4.1 (`binary.rs`) trusts the header's total length: it computes
//! `length - 12` unchecked, which overflows (a panic in debug builds) when
//! the field is under 12, and it never holds the chunks to that length. It
//! checks each of the first two chunk lengths against the bytes left, reads
//! the second chunk's header straight after the first chunk's data without
//! regard to padding, and ignores whatever follows the second chunk. Here
//! the container is checked as glTF 2.0 (section 4.4) lays it out, each
//! problem named with its byte offset, and gltf is handed only the bytes
//! the header declares.

/// The 12-byte file header: magic, version, total length.
const HEADER_LEN: usize = 12;
/// A chunk header: data length, chunk type.
const CHUNK_HEADER_LEN: usize = 8;
const JSON: [u8; 4] = *b"JSON";
const BIN: [u8; 4] = *b"BIN\0";

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]])
}

fn chunk_name(ty: [u8; 4]) -> String {
    match ty {
        JSON => "JSON".into(),
        BIN => "BIN".into(),
        _ => format!("unknown ({})", ty.escape_ascii()),
    }
}

/// Checks the header and every chunk header of a file that starts with the
/// GLB magic; returns the bytes the header declares (anything after them is
/// ignored, as gltf ignores it), or what is wrong.
///
/// Rules: version 2; a declared length that covers the header and a chunk
/// header and fits the file; chunks that each fit the declared length, the
/// first JSON, the second (if any) BIN, later ones of any other type
/// (ignored, as the spec asks of unknown chunks); a chunk followed by
/// another has a length that is a multiple of 4, since the next header
/// would otherwise be misaligned and readers disagree on where it is (the
/// last chunk may end unpadded: nothing depends on it).
pub(crate) fn check(bytes: &[u8]) -> Result<&[u8], String> {
    let (declared, _) = layout(bytes.len(), &mut |at, n| Ok(bytes[at..at + n].to_vec()))?;
    Ok(&bytes[..declared])
}

/// A chunk [`layout`] found: its type, and where its data lies.
struct Chunk {
    ty: [u8; 4],
    at: usize,
    len: usize,
}

/// Where a chunk's data lies in a file: offset, length.
pub(crate) type Span = (u64, usize);

/// [`check`] for a file read in place: its JSON chunk's bytes, and where
/// its BIN chunk's data lies, if it has one. Only the headers and the JSON
/// are read.
pub(crate) fn check_file(file: &std::fs::File) -> Result<(Vec<u8>, Option<Span>), String> {
    use std::os::unix::fs::FileExt as _;
    let len = file.metadata().map_err(|e| e.to_string())?.len();
    let len = usize::try_from(len).map_err(|_| "the file is too large".to_string())?;
    let mut read = |at: usize, n: usize| {
        let mut b = vec![0u8; n];
        file.read_exact_at(&mut b, at as u64)
            .map_err(|e| format!("cannot read bytes {at}..{}: {e}", at + n))?;
        Ok(b)
    };
    let (_, chunks) = layout(len, &mut read)?;
    let json = read(chunks[0].at, chunks[0].len)?;
    let bin = chunks
        .get(1)
        .filter(|c| c.ty == BIN)
        .map(|c| (c.at as u64, c.len));
    Ok((json, bin))
}

/// The container's declared length and chunks, checked as [`check`] says,
/// for a file of `len` bytes whose bytes `read(at, n)` gives (every read
/// in range).
fn layout(
    len: usize,
    read: &mut dyn FnMut(usize, usize) -> Result<Vec<u8>, String>,
) -> Result<(usize, Vec<Chunk>), String> {
    if len < HEADER_LEN {
        return Err(format!(
            "GLB header needs {HEADER_LEN} bytes, the file has {len}"
        ));
    }
    let header = read(0, HEADER_LEN)?;
    let version = u32_at(&header, 4);
    if version != 2 {
        return Err(format!(
            "GLB header (byte 4): version {version}, only version 2 is supported"
        ));
    }
    let declared = u32_at(&header, 8) as usize;
    let least = HEADER_LEN + CHUNK_HEADER_LEN;
    if declared < least {
        return Err(format!(
            "GLB header (byte 8): total length {declared} is less than the {least} bytes of the \
             header and a JSON chunk header"
        ));
    }
    if declared > len {
        return Err(format!(
            "GLB header (byte 8): total length {declared} but the file has {len} bytes (truncated?)"
        ));
    }
    let mut chunks = Vec::new();
    let mut at = HEADER_LEN;
    let mut index = 0usize;
    while at < declared {
        let left = declared - at;
        if left < CHUNK_HEADER_LEN {
            return Err(format!(
                "chunk {index} header at byte {at}: needs {CHUNK_HEADER_LEN} bytes, {left} left \
                 before the declared end ({declared})"
            ));
        }
        let h = read(at, CHUNK_HEADER_LEN)?;
        let length = u32_at(&h, 0) as usize;
        let ty = [h[4], h[5], h[6], h[7]];
        let name = chunk_name(ty);
        let expected = match index {
            0 => Some(JSON),
            1 => Some(BIN),
            _ => None,
        };
        match expected {
            Some(e) if e != ty => {
                return Err(format!(
                    "chunk {index} at byte {at}: type {name}, expected {}",
                    chunk_name(e)
                ));
            }
            None if ty == JSON || ty == BIN => {
                return Err(format!("chunk {index} at byte {at}: a second {name} chunk"));
            }
            _ => {}
        }
        let data_at = at + CHUNK_HEADER_LEN;
        let room = declared - data_at;
        if length > room {
            return Err(format!(
                "chunk {index} ({name}) at byte {at}: length {length} runs past the declared end \
                 ({room} bytes left)"
            ));
        }
        let end = data_at + length;
        if end < declared && !length.is_multiple_of(4) {
            return Err(format!(
                "chunk {index} ({name}) at byte {at}: length {length} is not a multiple of 4, so \
                 the chunk after it is misaligned"
            ));
        }
        chunks.push(Chunk {
            ty,
            at: data_at,
            len: length,
        });
        at = end;
        index += 1;
    }
    // declared >= HEADER_LEN + CHUNK_HEADER_LEN, so the loop has checked
    // the JSON chunk at least.
    Ok((declared, chunks))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A GLB with the given chunks, each length as written (no padding added).
    fn glb(total: Option<u32>, chunks: &[(u32, &[u8; 4], &[u8])]) -> Vec<u8> {
        let mut b = b"glTF".to_vec();
        b.extend_from_slice(&2u32.to_le_bytes());
        b.extend_from_slice(&0u32.to_le_bytes());
        for (length, ty, data) in chunks {
            b.extend_from_slice(&length.to_le_bytes());
            b.extend_from_slice(*ty);
            b.extend_from_slice(data);
        }
        let total = total.unwrap_or(b.len() as u32);
        b[8..12].copy_from_slice(&total.to_le_bytes());
        b
    }

    #[test]
    fn good_container_passes_and_trailing_bytes_are_dropped() {
        let mut b = glb(None, &[(4, b"JSON", b"{}  "), (2, b"BIN\0", b"\x01\x02")]);
        let len = b.len();
        b.extend_from_slice(b"junk");
        assert_eq!(check(&b).unwrap().len(), len);
        // Unknown chunks after the BIN chunk are allowed.
        let b = glb(
            None,
            &[
                (4, b"JSON", b"{}  "),
                (0, b"BIN\0", b""),
                (1, b"XTRA", b"x"),
            ],
        );
        assert!(check(&b).is_ok());
    }

    #[test]
    fn each_problem_is_named() {
        let cases: Vec<(Vec<u8>, &str)> = vec![
            (b"glTF\x02\0\0\0".to_vec(), "needs 12 bytes"),
            (
                {
                    let mut b = glb(None, &[(4, b"JSON", b"{}  ")]);
                    b[4] = 1;
                    b
                },
                "version 1",
            ),
            (glb(Some(0), &[(4, b"JSON", b"{}  ")]), "total length 0"),
            (glb(Some(99), &[(4, b"JSON", b"{}  ")]), "truncated"),
            (
                glb(None, &[(4, b"BIN\0", b"{}  ")]),
                "type BIN, expected JSON",
            ),
            (
                glb(None, &[(4, b"JSON", b"{}  "), (0, b"JSON", b"")]),
                "type JSON, expected BIN",
            ),
            (
                glb(
                    None,
                    &[
                        (4, b"JSON", b"{}  "),
                        (0, b"BIN\0", b""),
                        (0, b"BIN\0", b""),
                    ],
                ),
                "a second BIN chunk",
            ),
            (
                glb(None, &[(9, b"JSON", b"{}  ")]),
                "runs past the declared end",
            ),
            (
                glb(None, &[(u32::MAX, b"JSON", b"{}  ")]),
                "runs past the declared end",
            ),
            (
                glb(None, &[(3, b"JSON", b"{} "), (0, b"BIN\0", b"")]),
                "not a multiple of 4",
            ),
            (
                {
                    let mut b = glb(None, &[(4, b"JSON", b"{}  "), (0, b"BIN\0", b"")]);
                    b.truncate(b.len() - 2);
                    let len = b.len() as u32;
                    b[8..12].copy_from_slice(&len.to_le_bytes());
                    b
                },
                "needs 8 bytes, 6 left",
            ),
        ];
        for (bytes, fragment) in cases {
            let e = check(&bytes).expect_err(fragment);
            assert!(e.contains(fragment), "{e:?} lacks {fragment:?}");
        }
    }
}
