//! glTF accessors read by hand rather than with the `gltf` crate's reader:
//! every offset, stride and count is checked against its buffer view before
//! a byte is read, so a lying file gives an error instead of a panic.
//! Integer components are dequantized here (KHR_mesh_quantization), so
//! compressed positions and normals read like floats.

use std::borrow::Cow;

use gltf::accessor::{DataType, Dimensions};

use crate::error::ImportError;
use crate::gltf_buffers::BufferData;

pub(crate) fn bad_accessor(
    file: &str,
    object: &str,
    acc: &gltf::Accessor,
    semantic: &'static str,
    reason: String,
) -> ImportError {
    ImportError::BadAccessor {
        file: file.to_owned(),
        object: object.to_owned(),
        accessor: acc.index(),
        semantic,
        reason,
    }
}

/// The bytes of an accessor's elements, bounds-checked: `(data, stride,
/// element size)` with `data[k * stride..][..element size]` in range for
/// every element `k < count`.
fn accessor_bytes<'b>(
    acc: &gltf::Accessor,
    data: &'b BufferData,
    file: &str,
    object: &str,
    semantic: &'static str,
) -> Result<(Cow<'b, [u8]>, usize, usize), ImportError> {
    let bad = |reason: String| bad_accessor(file, object, acc, semantic, reason);
    if acc.sparse().is_some() {
        return Err(bad("sparse accessors are not supported".into()));
    }
    let view = acc
        .view()
        .ok_or_else(|| bad("no bufferView (all-zero accessors are not supported)".into()))?;
    let view_len = data.view_len(&view).ok_or_else(|| {
        bad(format!(
            "bufferView {} runs past the end of its buffer",
            view.index()
        ))
    })?;
    let elem = acc.data_type().size() * acc.dimensions().multiplicity();
    let stride = view.stride().unwrap_or(elem);
    if stride < elem {
        return Err(bad(format!(
            "byteStride {stride} is smaller than an element ({elem} bytes)"
        )));
    }
    let count = acc.count();
    if count == 0 {
        return Ok((Cow::Borrowed(&[]), stride, elem));
    }
    let needed = (count - 1)
        .checked_mul(stride)
        .and_then(|x| x.checked_add(elem))
        .and_then(|x| x.checked_add(acc.offset()));
    match needed {
        Some(end) if end <= view_len => {
            let bytes = data
                .view_range(&view, acc.offset(), end - acc.offset())
                .map_err(|source| ImportError::Io {
                    file: file.to_owned(),
                    source,
                })?;
            Ok((bytes, stride, elem))
        }
        _ => Err(bad(format!(
            "{count} elements at offset {} do not fit in bufferView {} ({view_len} bytes)",
            acc.offset(),
            view.index(),
        ))),
    }
}

/// Reads a float (or normalised integer) accessor of `dims` components per
/// element into a flat f32 list.
pub(crate) fn read_floats(
    acc: &gltf::Accessor,
    dims: usize,
    data: &BufferData,
    file: &str,
    object: &str,
    semantic: &'static str,
) -> Result<Vec<f32>, ImportError> {
    if acc.dimensions().multiplicity() != dims
        || matches!(
            acc.dimensions(),
            Dimensions::Mat2 | Dimensions::Mat3 | Dimensions::Mat4
        )
    {
        return Err(bad_accessor(
            file,
            object,
            acc,
            semantic,
            format!("expected {dims} components, found {:?}", acc.dimensions()),
        ));
    }
    let (bytes, stride, elem) = accessor_bytes(acc, data, file, object, semantic)?;
    let count = acc.count();
    let dt = acc.data_type();
    let cs = dt.size();
    let norm = acc.normalized();
    let mut out = Vec::with_capacity(count * dims);
    for k in 0..count {
        let e = &bytes[k * stride..k * stride + elem];
        for c in 0..dims {
            let b = &e[c * cs..(c + 1) * cs];
            // Normalised integers map to [0, 1] or [-1, 1] (glTF 2.0 spec, 3.11).
            let v = match dt {
                DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                DataType::U8 if norm => b[0] as f32 / 255.0,
                DataType::U8 => b[0] as f32,
                DataType::I8 if norm => (b[0] as i8 as f32 / 127.0).max(-1.0),
                DataType::I8 => b[0] as i8 as f32,
                DataType::U16 if norm => u16::from_le_bytes([b[0], b[1]]) as f32 / 65535.0,
                DataType::U16 => u16::from_le_bytes([b[0], b[1]]) as f32,
                DataType::I16 if norm => {
                    (i16::from_le_bytes([b[0], b[1]]) as f32 / 32767.0).max(-1.0)
                }
                DataType::I16 => i16::from_le_bytes([b[0], b[1]]) as f32,
                DataType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
            };
            out.push(v);
        }
    }
    Ok(out)
}

pub(crate) fn read_indices(
    acc: &gltf::Accessor,
    data: &BufferData,
    file: &str,
    object: &str,
) -> Result<Vec<u32>, ImportError> {
    if acc.dimensions() != Dimensions::Scalar
        || !matches!(
            acc.data_type(),
            DataType::U8 | DataType::U16 | DataType::U32
        )
    {
        return Err(bad_accessor(
            file,
            object,
            acc,
            "indices",
            "must be unsigned integer scalars".into(),
        ));
    }
    let (bytes, stride, _) = accessor_bytes(acc, data, file, object, "indices")?;
    let count = acc.count();
    let mut out = Vec::with_capacity(count);
    for k in 0..count {
        let b = &bytes[k * stride..];
        out.push(match acc.data_type() {
            DataType::U8 => b[0] as u32,
            DataType::U16 => u16::from_le_bytes([b[0], b[1]]) as u32,
            _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        });
    }
    Ok(out)
}
