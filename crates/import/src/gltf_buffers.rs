//! glTF buffers as accessors see them: each buffer loaded (the GLB BIN
//! chunk, a base64 data: URI, or an external file read in place a range at
//! a time), and every meshopt-compressed view a mesh primitive reads
//! decoded whole up front, taking the place of its view's bytes.
//!
//! A buffer in a file (an external buffer, or the BIN chunk of a .glb read
//! in place) stays on disk until an accessor reads its range, so a large
//! model is not held whole; only when a primitive reads a meshopt-compressed
//! view are such buffers read into memory, since a compressed view decodes
//! whole.

use std::borrow::Cow;
use std::path::Path;

use base64::Engine as _;

use crate::error::ImportError;
use crate::gltf_import::RawRoot;
use crate::meshopt_views;

/// A buffer's bytes: in memory, or a range of a file read a piece at a
/// time.
pub(crate) enum Buffer<'a> {
    Bytes(Cow<'a, [u8]>),
    File {
        file: std::fs::File,
        at: u64,
        len: usize,
    },
}

impl Buffer<'_> {
    fn len(&self) -> usize {
        match self {
            Buffer::Bytes(b) => b.len(),
            Buffer::File { len, .. } => *len,
        }
    }

    /// `n` bytes from `start` (in range: `start + n <= len`).
    fn range(&self, start: usize, n: usize) -> std::io::Result<Cow<'_, [u8]>> {
        match self {
            Buffer::Bytes(b) => Ok(Cow::Borrowed(&b[start..start + n])),
            Buffer::File { file, at, .. } => {
                use std::os::unix::fs::FileExt as _;
                let mut out = vec![0u8; n];
                file.read_exact_at(&mut out, at + start as u64)?;
                Ok(Cow::Owned(out))
            }
        }
    }

    /// All of it in memory.
    fn into_bytes(self) -> std::io::Result<Cow<'static, [u8]>> {
        match self {
            Buffer::Bytes(b) => Ok(Cow::Owned(b.into_owned())),
            f @ Buffer::File { .. } => Ok(Cow::Owned(f.range(0, f.len())?.into_owned())),
        }
    }
}

/// The file's bytes as accessors see them: buffers (a meshopt fallback
/// buffer is empty) and decoded meshopt buffer views, which take the place
/// of their view's bytes.
pub(crate) struct BufferData<'a> {
    buffers: Vec<Buffer<'a>>,
    decoded: Vec<Option<Vec<u8>>>,
}

impl BufferData<'_> {
    /// The length of a buffer view's bytes, `None` when they run past its
    /// buffer.
    pub(crate) fn view_len(&self, view: &gltf::buffer::View) -> Option<usize> {
        if let Some(Some(bytes)) = self.decoded.get(view.index()) {
            return Some(bytes.len());
        }
        let buffer = &self.buffers[view.buffer().index()];
        let end = view.offset().checked_add(view.length())?;
        (end <= buffer.len()).then_some(view.length())
    }

    /// `n` bytes from `start` of a view ([`BufferData::view_len`] said
    /// they are in range).
    pub(crate) fn view_range(
        &self,
        view: &gltf::buffer::View,
        start: usize,
        n: usize,
    ) -> std::io::Result<Cow<'_, [u8]>> {
        if let Some(Some(bytes)) = self.decoded.get(view.index()) {
            return Ok(Cow::Borrowed(&bytes[start..start + n]));
        }
        self.buffers[view.buffer().index()].range(view.offset() + start, n)
    }
}

/// Loads the buffers, then decodes every meshopt-compressed view that a
/// mesh primitive reads (views only animations read are left alone).
pub(crate) fn load_data<'a>(
    doc: &gltf::Document,
    raw: &RawRoot,
    blob: Option<Buffer<'a>>,
    file: &str,
    base_dir: Option<&Path>,
) -> Result<BufferData<'a>, ImportError> {
    let mut buffers = load_buffers(doc, raw, blob, file, base_dir)?;
    let mut decoded: Vec<Option<Vec<u8>>> = vec![None; doc.views().len()];
    let compressed = doc
        .meshes()
        .flat_map(|m| m.primitives().collect::<Vec<_>>())
        .any(|p| {
            p.attributes()
                .map(|(_, a)| a)
                .chain(p.indices())
                .filter_map(|a| a.view())
                .any(|v| meshopt_views::find(&raw.buffer_views[v.index()].extensions).is_some())
        });
    if !compressed {
        return Ok(BufferData { buffers, decoded });
    }
    // A compressed view decodes whole, from its buffer in memory.
    for b in &mut buffers {
        if matches!(b, Buffer::File { .. }) {
            let whole = std::mem::replace(b, Buffer::Bytes(Cow::Borrowed(&[])));
            *b = Buffer::Bytes(whole.into_bytes().map_err(|source| ImportError::Io {
                file: file.to_owned(),
                source,
            })?);
        }
    }
    let sources: Vec<&[u8]> = buffers
        .iter()
        .map(|b| match b {
            Buffer::Bytes(b) => &b[..],
            Buffer::File { .. } => &[][..],
        })
        .collect();
    for mesh in doc.meshes() {
        for prim in mesh.primitives() {
            let accessors = prim.attributes().map(|(_, a)| a).chain(prim.indices());
            for view in accessors.filter_map(|a| a.view()) {
                let vi = view.index();
                if decoded[vi].is_some() {
                    continue;
                }
                if let Some((extension, params)) =
                    meshopt_views::find(&raw.buffer_views[vi].extensions)
                {
                    decoded[vi] = Some(meshopt_views::decode_view(
                        extension,
                        params,
                        vi,
                        view.length(),
                        &sources,
                        file,
                    )?);
                }
            }
        }
    }
    Ok(BufferData { buffers, decoded })
}

/// A buffer whose bytes nobody reads: tagged as a meshopt fallback, or
/// with no URI (and not the GLB BIN chunk) and read only through
/// meshopt-compressed views. gltfpack writes one with no data at all.
fn is_placeholder(
    doc: &gltf::Document,
    raw: &RawRoot,
    buffer: &gltf::Buffer,
    has_blob: bool,
) -> bool {
    if meshopt_views::is_fallback_buffer(&raw.buffers[buffer.index()].extensions) {
        return true;
    }
    let no_uri = matches!(buffer.source(), gltf::buffer::Source::Bin);
    if !no_uri || (buffer.index() == 0 && has_blob) {
        return false;
    }
    let mut views = doc
        .views()
        .filter(|v| v.buffer().index() == buffer.index())
        .peekable();
    views.peek().is_some()
        && views.all(|v| meshopt_views::find(&raw.buffer_views[v.index()].extensions).is_some())
}

fn load_buffers<'a>(
    doc: &gltf::Document,
    raw: &RawRoot,
    mut blob: Option<Buffer<'a>>,
    file: &str,
    base_dir: Option<&Path>,
) -> Result<Vec<Buffer<'a>>, ImportError> {
    let mut out = Vec::new();
    let has_blob = blob.is_some();
    for buffer in doc.buffers() {
        if is_placeholder(doc, raw, &buffer, has_blob) {
            out.push(Buffer::Bytes(Cow::Borrowed(&[][..])));
            continue;
        }
        let missing = |uri: &str, reason: String| ImportError::MissingBuffer {
            file: file.to_owned(),
            buffer: buffer.index(),
            uri: uri.to_owned(),
            reason,
        };
        let data: Buffer = match buffer.source() {
            // glTF allows one buffer to be the BIN chunk (buffer 0).
            gltf::buffer::Source::Bin => match blob.take() {
                Some(b) => b,
                None => return Err(missing("GLB BIN chunk", "the file has no BIN chunk".into())),
            },
            gltf::buffer::Source::Uri(uri) => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    let (_, payload) = rest.split_once(";base64,").ok_or_else(|| {
                        missing("data: URI", "only base64 data URIs are supported".into())
                    })?;
                    let decoded = base64::engine::general_purpose::STANDARD
                        .decode(payload)
                        .map_err(|e| missing("data: URI", format!("bad base64: {e}")))?;
                    Buffer::Bytes(Cow::Owned(decoded))
                } else if uri.contains("://") {
                    return Err(missing(
                        uri,
                        "only relative file URIs and data: URIs are supported".into(),
                    ));
                } else {
                    let Some(dir) = base_dir else {
                        return Err(missing(
                            uri,
                            "external buffers need a file path, not bytes".into(),
                        ));
                    };
                    // Read in place, an accessor at a time.
                    let path = dir.join(percent_decode(uri));
                    let cannot = |e: std::io::Error| {
                        missing(uri, format!("cannot read {}: {e}", path.display()))
                    };
                    let f = std::fs::File::open(&path).map_err(cannot)?;
                    let meta = f.metadata().map_err(cannot)?;
                    if meta.is_dir() {
                        return Err(missing(uri, format!("{} is a directory", path.display())));
                    }
                    Buffer::File {
                        file: f,
                        at: 0,
                        len: usize::try_from(meta.len()).unwrap_or(usize::MAX),
                    }
                }
            }
        };
        if data.len() < buffer.length() {
            return Err(ImportError::BufferTooShort {
                file: file.to_owned(),
                buffer: buffer.index(),
                declared: buffer.length(),
                actual: data.len(),
            });
        }
        out.push(data);
    }
    Ok(out)
}

/// `%XX` escapes in relative URIs (spaces in file names are common).
fn percent_decode(uri: &str) -> String {
    let b = uri.as_bytes();
    let hex = |c: u8| (c as char).to_digit(16).map(|d| d as u8);
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push(h * 16 + l);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_escapes_decode() {
        assert_eq!(percent_decode("a%20b.bin"), "a b.bin");
        assert_eq!(percent_decode("50%"), "50%");
        assert_eq!(percent_decode("x%2"), "x%2");
    }
}
