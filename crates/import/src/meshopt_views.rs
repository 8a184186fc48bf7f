//! EXT_meshopt_compression and KHR_meshopt_compression: decode a compressed
//! buffer view into the bytes its accessors read, with the meshopt crate's
//! decoders and filters. Every parameter is checked before the decoder sees
//! it (meshoptimizer asserts on a bad stride or count), so a lying file
//! gives an error naming the buffer view, never a panic or an abort.

use serde::Deserialize;
use serde_json::Value;

use crate::error::ImportError;

/// The extension names, newest first; both share one JSON layout and one
/// bitstream (KHR adds the v1 attribute stream, which the decoder reads
/// either way, and the COLOR filter).
const NAMES: [&str; 2] = ["KHR_meshopt_compression", "EXT_meshopt_compression"];

/// The meshopt extension object in a buffer view's or buffer's
/// `extensions`, with its name.
pub(crate) fn find(extensions: &serde_json::Map<String, Value>) -> Option<(&'static str, &Value)> {
    NAMES
        .iter()
        .find_map(|&name| extensions.get(name).map(|v| (name, v)))
}

/// A buffer tagged `"fallback": true`: its bytes are only for readers
/// without the extension, so it is not loaded.
pub(crate) fn is_fallback_buffer(extensions: &serde_json::Map<String, Value>) -> bool {
    find(extensions)
        .and_then(|(_, v)| v.get("fallback"))
        .and_then(Value::as_bool)
        .unwrap_or(false)
}

/// The extension object of a buffer view (spec: "JSON schema updates").
#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct Compressed {
    buffer: usize,
    #[serde(default)]
    byte_offset: usize,
    byte_length: usize,
    byte_stride: usize,
    count: usize,
    mode: Mode,
    #[serde(default)]
    filter: Filter,
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
enum Mode {
    Attributes,
    Triangles,
    Indices,
}

impl std::fmt::Display for Mode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Mode::Attributes => "ATTRIBUTES",
            Mode::Triangles => "TRIANGLES",
            Mode::Indices => "INDICES",
        })
    }
}

#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
enum Filter {
    #[default]
    None,
    Octahedral,
    Quaternion,
    Exponential,
    Color,
}

/// The most bytes one compressed byte can decode to. An attribute stream
/// (v1) spends at least one control byte per 4 byte-channels of a block of
/// at most 256 elements, so 1 byte covers at most 4 x 256 output bytes; the
/// triangle codec spends a byte per triangle (12 bytes of u32 indices) and
/// the index codec a byte per index. Without this bound, a 100-byte file
/// could ask for terabytes and abort the process on allocation.
const MAX_EXPANSION: usize = 1024;

/// Decodes buffer view `view` (declared `view_length` bytes) from the
/// extension object `params` of `extension`, reading compressed bytes from
/// `buffers`. The result has exactly `view_length` bytes.
pub(crate) fn decode_view(
    extension: &'static str,
    params: &Value,
    view: usize,
    view_length: usize,
    buffers: &[&[u8]],
    file: &str,
) -> Result<Vec<u8>, ImportError> {
    let bad = |reason: String| ImportError::BadCompressedView {
        file: file.to_owned(),
        view,
        extension,
        reason,
    };
    let c =
        Compressed::deserialize(params).map_err(|e| bad(format!("bad extension object: {e}")))?;
    let (stride, count) = (c.byte_stride, c.count);
    if count.checked_mul(stride) != Some(view_length) {
        return Err(bad(format!(
            "count {count} x byteStride {stride} is not the bufferView's byteLength {view_length}"
        )));
    }
    match c.mode {
        Mode::Attributes if stride == 0 || stride % 4 != 0 || stride > 256 => {
            return Err(bad(format!(
                "ATTRIBUTES byteStride {stride} is not a multiple of 4 in 4..=256"
            )));
        }
        Mode::Triangles | Mode::Indices if stride != 2 && stride != 4 => {
            return Err(bad(format!("{} byteStride {stride} is not 2 or 4", c.mode)));
        }
        Mode::Triangles if count % 3 != 0 => {
            return Err(bad(format!(
                "TRIANGLES count {count} is not a multiple of 3"
            )));
        }
        Mode::Triangles | Mode::Indices if c.filter != Filter::None => {
            return Err(bad(format!("{} data cannot have a filter", c.mode)));
        }
        _ => {}
    }
    let filter_ok = match c.filter {
        Filter::None | Filter::Exponential => true,
        Filter::Octahedral | Filter::Color => stride == 4 || stride == 8,
        Filter::Quaternion => stride == 8,
    };
    if !filter_ok {
        return Err(bad(format!(
            "filter {} does not allow byteStride {stride}",
            c.filter
        )));
    }
    let source = buffers.get(c.buffer).ok_or_else(|| {
        bad(format!(
            "buffer {} does not exist ({} buffers)",
            c.buffer,
            buffers.len()
        ))
    })?;
    let compressed = c
        .byte_offset
        .checked_add(c.byte_length)
        .and_then(|end| source.get(c.byte_offset..end))
        .ok_or_else(|| {
            bad(format!(
                "compressed bytes {}..+{} run past the end of buffer {} ({} bytes)",
                c.byte_offset,
                c.byte_length,
                c.buffer,
                source.len()
            ))
        })?;
    if view_length > compressed.len().saturating_mul(MAX_EXPANSION) {
        return Err(bad(format!(
            "{} compressed bytes cannot hold {view_length} bytes",
            compressed.len()
        )));
    }
    let decoded = match (c.mode, stride) {
        (Mode::Attributes, _) => decode_attributes(compressed, count, stride),
        (Mode::Triangles, 2) => meshopt::decode_index_buffer::<u16>(compressed, count)
            .map(|v| v.iter().flat_map(|i| i.to_le_bytes()).collect()),
        (Mode::Triangles, _) => meshopt::decode_index_buffer::<u32>(compressed, count)
            .map(|v| v.iter().flat_map(|i| i.to_le_bytes()).collect()),
        (Mode::Indices, 2) => meshopt::decode_index_sequence::<u16>(compressed, count)
            .map(|v| v.iter().flat_map(|i| i.to_le_bytes()).collect()),
        (Mode::Indices, _) => meshopt::decode_index_sequence::<u32>(compressed, count)
            .map(|v| v.iter().flat_map(|i| i.to_le_bytes()).collect()),
    };
    let mut bytes = decoded.map_err(|e| {
        let why = match e {
            meshopt::Error::Native(-1) => "bad header or unknown version".to_owned(),
            meshopt::Error::Native(-2) => "the data ends too early".to_owned(),
            meshopt::Error::Native(-3) => "bytes are left over after the last element".to_owned(),
            other => other.to_string(),
        };
        bad(format!(
            "cannot decode {} data ({} bytes for {count} elements of {stride} bytes): {why}",
            c.mode,
            compressed.len()
        ))
    })?;
    debug_assert_eq!(bytes.len(), view_length);
    apply_filter(c.filter, stride, &mut bytes);
    Ok(bytes)
}

/// One element of `N` bytes: the attribute decoder is generic over the
/// element type and takes its size as the stride.
#[derive(Clone, Copy)]
struct Element<const N: usize>([u8; N]);

impl std::fmt::Display for Filter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Filter::None => "NONE",
            Filter::Octahedral => "OCTAHEDRAL",
            Filter::Quaternion => "QUATERNION",
            Filter::Exponential => "EXPONENTIAL",
            Filter::Color => "COLOR",
        })
    }
}

impl<const N: usize> Default for Element<N> {
    fn default() -> Self {
        Element([0; N])
    }
}

fn decode_elements<const N: usize>(compressed: &[u8], count: usize) -> meshopt::Result<Vec<u8>> {
    let elements = meshopt::decode_vertex_buffer::<Element<N>>(compressed, count)?;
    Ok(elements.iter().flat_map(|e| e.0).collect())
}

/// Attribute decoding for a stride the caller checked: a multiple of 4 in
/// 4..=256.
fn decode_attributes(compressed: &[u8], count: usize, stride: usize) -> meshopt::Result<Vec<u8>> {
    macro_rules! by_stride {
        ($($n:literal)*) => {
            match stride {
                $($n => decode_elements::<$n>(compressed, count),)*
                _ => unreachable!("byteStride {stride} was checked"),
            }
        };
    }
    by_stride!(
        4 8 12 16 20 24 28 32 36 40 44 48 52 56 60 64
        68 72 76 80 84 88 92 96 100 104 108 112 116 120 124 128
        132 136 140 144 148 152 156 160 164 168 172 176 180 184 188 192
        196 200 204 208 212 216 220 224 228 232 236 240 244 248 252 256
    )
}

/// Undoes a filter in place (spec Appendix B) on decoded elements of
/// `stride` bytes, a stride `decode_view` checked for the filter.
fn apply_filter(filter: Filter, stride: usize, bytes: &mut [u8]) {
    match (filter, stride) {
        (Filter::None, _) => {}
        (Filter::Octahedral, 4) => {
            let mut v: Vec<[i8; 4]> = bytes
                .chunks_exact(4)
                .map(|c| [c[0] as i8, c[1] as i8, c[2] as i8, c[3] as i8])
                .collect();
            meshopt::decode_filter_oct(&mut v);
            store(bytes, v.iter().flatten().map(|&x| x as u8));
        }
        (Filter::Octahedral, _) => {
            let mut v = read_i16x4(bytes);
            meshopt::decode_filter_oct(&mut v);
            store(bytes, v.iter().flatten().flat_map(|x| x.to_le_bytes()));
        }
        (Filter::Quaternion, _) => {
            let mut v = read_i16x4(bytes);
            meshopt::decode_filter_quat(&mut v);
            store(bytes, v.iter().flatten().flat_map(|x| x.to_le_bytes()));
        }
        (Filter::Exponential, _) => {
            // Each 32-bit component decodes on its own, whatever the stride.
            let mut v: Vec<[u32; 1]> = bytes
                .chunks_exact(4)
                .map(|c| [u32::from_le_bytes([c[0], c[1], c[2], c[3]])])
                .collect();
            meshopt::decode_filter_exp(&mut v);
            store(bytes, v.iter().flatten().flat_map(|x| x.to_le_bytes()));
        }
        (Filter::Color, 4) => {
            let mut v: Vec<[u8; 4]> = bytes
                .chunks_exact(4)
                .map(|c| [c[0], c[1], c[2], c[3]])
                .collect();
            meshopt::decode_filter_color(&mut v);
            store(bytes, v.into_iter().flatten());
        }
        (Filter::Color, _) => {
            let mut v: Vec<[u16; 4]> = bytes
                .chunks_exact(8)
                .map(|c| [0, 2, 4, 6].map(|k| u16::from_le_bytes([c[k], c[k + 1]])))
                .collect();
            meshopt::decode_filter_color(&mut v);
            store(bytes, v.iter().flatten().flat_map(|x| x.to_le_bytes()));
        }
    }
}

fn read_i16x4(bytes: &[u8]) -> Vec<[i16; 4]> {
    bytes
        .chunks_exact(8)
        .map(|c| [0, 2, 4, 6].map(|k| i16::from_le_bytes([c[k], c[k + 1]])))
        .collect()
}

fn store(bytes: &mut [u8], values: impl Iterator<Item = u8>) {
    for (b, v) in bytes.iter_mut().zip(values) {
        *b = v;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn decode(params: Value, view_length: usize, buffer: &[u8]) -> Result<Vec<u8>, String> {
        decode_view(NAMES[1], &params, 7, view_length, &[buffer], "f.glb")
            .map_err(|e| e.to_string())
    }

    #[test]
    fn attributes_round_trip_at_every_stride() {
        for stride in (4..=256).step_by(4) {
            let data: Vec<u8> = (0..stride * 5).map(|i| (i * 7 % 251) as u8).collect();
            let encoded = encode_at_stride(&data, stride);
            let params = json!({"buffer": 0, "byteLength": encoded.len(), "byteStride": stride,
                                "count": 5, "mode": "ATTRIBUTES"});
            assert_eq!(
                decode(params, data.len(), &encoded),
                Ok(data),
                "stride {stride}"
            );
        }
    }

    fn encode_at_stride(data: &[u8], stride: usize) -> Vec<u8> {
        fn enc<const N: usize>(data: &[u8]) -> Vec<u8> {
            let e: Vec<Element<N>> = data
                .chunks_exact(N)
                .map(|c| Element(c.try_into().unwrap()))
                .collect();
            meshopt::encode_vertex_buffer(&e).unwrap()
        }
        macro_rules! by_stride {
            ($($n:literal)*) => {
                match stride {
                    $($n => enc::<$n>(data),)*
                    _ => unreachable!(),
                }
            };
        }
        by_stride!(
            4 8 12 16 20 24 28 32 36 40 44 48 52 56 60 64
            68 72 76 80 84 88 92 96 100 104 108 112 116 120 124 128
            132 136 140 144 148 152 156 160 164 168 172 176 180 184 188 192
            196 200 204 208 212 216 220 224 228 232 236 240 244 248 252 256
        )
    }

    #[test]
    fn bad_parameters_are_named() {
        let cases = [
            (
                json!({"buffer": 0, "byteLength": 4, "byteStride": 6, "count": 2, "mode": "ATTRIBUTES"}),
                12,
                "byteStride 6",
            ),
            (
                json!({"buffer": 0, "byteLength": 4, "byteStride": 4, "count": 2, "mode": "ATTRIBUTES"}),
                12,
                "not the bufferView's byteLength 12",
            ),
            (
                json!({"buffer": 0, "byteLength": 4, "byteStride": 2, "count": 4, "mode": "TRIANGLES"}),
                8,
                "not a multiple of 3",
            ),
            (
                json!({"buffer": 0, "byteLength": 4, "byteStride": 8, "count": 3, "mode": "INDICES"}),
                24,
                "not 2 or 4",
            ),
            (
                json!({"buffer": 0, "byteLength": 4, "byteStride": 4, "count": 3, "mode": "ATTRIBUTES", "filter": "QUATERNION"}),
                12,
                "filter QUATERNION",
            ),
            (
                json!({"buffer": 0, "byteLength": 4, "byteStride": 4, "count": 3, "mode": "TRIANGLES", "filter": "EXPONENTIAL"}),
                12,
                "cannot have a filter",
            ),
            (
                json!({"buffer": 0, "byteLength": 4, "byteStride": 4, "count": 3, "mode": "SPIRAL"}),
                12,
                "bad extension object",
            ),
            (
                json!({"buffer": 3, "byteLength": 4, "byteStride": 4, "count": 3, "mode": "ATTRIBUTES"}),
                12,
                "buffer 3 does not exist",
            ),
            (
                json!({"buffer": 0, "byteOffset": 2, "byteLength": 4, "byteStride": 4, "count": 3, "mode": "ATTRIBUTES"}),
                12,
                "run past the end of buffer 0",
            ),
            (
                json!({"buffer": 0, "byteLength": 4, "byteStride": 4, "count": 1u64 << 40, "mode": "ATTRIBUTES"}),
                4usize << 40,
                "cannot hold",
            ),
            (
                json!({"buffer": 0, "byteLength": 4, "byteStride": 4, "count": 3, "mode": "ATTRIBUTES"}),
                12,
                "the data ends too early",
            ),
        ];
        for (params, view_length, fragment) in cases {
            let e = decode(params.clone(), view_length, &[0xa0, 0, 0, 0]).unwrap_err();
            assert!(
                e.starts_with("f.glb: bufferView 7 (EXT_meshopt_compression): "),
                "{e}"
            );
            assert!(e.contains(fragment), "{params}: {e:?} lacks {fragment:?}");
        }
    }

    /// Encodes `values` with a meshopt filter, undoes it through
    /// `apply_filter` and returns the components as normalized integers
    /// read back to f32 (signed when `signed`).
    fn filter_round_trip(filter: Filter, stride: usize, values: &[[f32; 4]]) -> Vec<f32> {
        let (bytes, size, signed): (Vec<u8>, usize, bool) = match (filter, stride) {
            (Filter::Octahedral, 4) => {
                let e = meshopt::encode_filter_oct::<i8>(values, 8);
                (e.iter().flatten().map(|&x| x as u8).collect(), 1, true)
            }
            (Filter::Octahedral, _) => {
                let e = meshopt::encode_filter_oct::<i16>(values, 16);
                (
                    e.iter().flatten().flat_map(|x| x.to_le_bytes()).collect(),
                    2,
                    true,
                )
            }
            (Filter::Quaternion, _) => {
                let e = meshopt::encode_filter_quat(values, 16);
                (
                    e.iter().flatten().flat_map(|x| x.to_le_bytes()).collect(),
                    2,
                    true,
                )
            }
            (Filter::Color, 4) => {
                let e = meshopt::encode_filter_color::<u8>(values, 8);
                (e.into_iter().flatten().collect(), 1, false)
            }
            _ => {
                let e = meshopt::encode_filter_color::<u16>(values, 16);
                (
                    e.iter().flatten().flat_map(|x| x.to_le_bytes()).collect(),
                    2,
                    false,
                )
            }
        };
        let mut bytes = bytes;
        apply_filter(filter, stride, &mut bytes);
        bytes
            .chunks_exact(size)
            .map(|c| match (size, signed) {
                (1, true) => (c[0] as i8 as f32 / 127.0).max(-1.0),
                (1, false) => c[0] as f32 / 255.0,
                (_, true) => (i16::from_le_bytes([c[0], c[1]]) as f32 / 32767.0).max(-1.0),
                (_, false) => u16::from_le_bytes([c[0], c[1]]) as f32 / 65535.0,
            })
            .collect()
    }

    #[test]
    fn octahedral_quaternion_and_colour_filters_decode_in_place() {
        let s = 0.5f32.sqrt();
        let units = [
            [0.0, 0.0, 1.0, 0.0],
            [s, -s, 0.0, 0.0],
            [0.6, 0.0, -0.8, 0.0],
        ];
        for stride in [4, 8] {
            let got = filter_round_trip(Filter::Octahedral, stride, &units);
            for (g, w) in got.chunks_exact(4).zip(&units) {
                for k in 0..3 {
                    assert!(
                        (g[k] - w[k]).abs() < 0.02,
                        "stride {stride}: {g:?} vs {w:?}"
                    );
                }
            }
        }
        let quats = [[0.0, 0.0, 0.0, 1.0], [0.5, 0.5, 0.5, 0.5], [s, 0.0, 0.0, s]];
        let got = filter_round_trip(Filter::Quaternion, 8, &quats);
        for (g, w) in got.chunks_exact(4).zip(&quats) {
            // q and -q are the same rotation.
            let dot: f32 = g.iter().zip(w).map(|(a, b)| a * b).sum();
            assert!(dot.abs() > 0.999, "{g:?} vs {w:?}");
        }
        let colours = [
            [1.0, 0.0, 0.0, 1.0],
            [0.2, 0.4, 0.6, 0.5],
            [0.0, 0.0, 0.0, 0.0],
        ];
        for stride in [4, 8] {
            let got = filter_round_trip(Filter::Color, stride, &colours);
            for (g, w) in got.chunks_exact(4).zip(&colours) {
                for k in 0..4 {
                    assert!(
                        (g[k] - w[k]).abs() < 0.02,
                        "stride {stride}: {g:?} vs {w:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn exponential_filter_decodes_each_component() {
        let values = [[1.5f32, -0.25, 1000.0], [0.0, 3.0e-3, -7.0]];
        let encoded = meshopt::encode_filter_exp(&values, 20, meshopt::EncodeExpMode::Separate);
        let mut bytes: Vec<u8> = encoded
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        apply_filter(Filter::Exponential, 12, &mut bytes);
        let got: Vec<f32> = bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        for (g, w) in got.iter().zip(values.iter().flatten()) {
            assert!((g - w).abs() <= w.abs() * 1e-5, "{g} vs {w}");
        }
    }
}
