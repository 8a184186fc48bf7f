//! Encoded geometry blobs (format 2): positions quantized to an integer
//! grid over the LOD's own box, then every stream compressed with
//! meshoptimizer's vertex and index codecs (as gltfpack stores glTF with
//! `EXT_meshopt_compression`; Kapoulkine, meshoptimizer). The grid's
//! step is part of the LOD's stored error: the writer adds the largest
//! distance any vertex moved (at most half a step's diagonal), so stored
//! errors stay upper bounds (a point of a triangle moves by at most what
//! its corners move).
//!
//! Blob layout (little-endian), docs/scene-format.md:
//!
//! | offset | type    | field |
//! |-------:|---------|-------|
//! | 0      | u8      | position bits b (8..=24) |
//! | 1      | u8      | normal bits: 16 (2 x snorm16) or 8 (2 x snorm8) |
//! | 2      | [u8; 2] | reserved, zero |
//! | 4      | 3 x f32 | grid origin, relative to the LOD's origin |
//! | 16     | 3 x f32 | grid step per axis (0 on an axis the LOD is flat in) |
//! | 28     | u32     | positions stream length P |
//! | 32     | u32     | normals stream length N |
//! | 36     | u32     | colours stream length C (0 for a uniform colour) |
//! | 40     | u32     | indices stream length I |
//! | 44     | P bytes | positions: u16 x 4 (b <= 16, the 4th zero) or u32 x 3, vertex codec |
//! |        | N bytes | octahedral normals, 2 x snorm16 or 4 x snorm8 (the last two zero), vertex codec |
//! |        | C bytes | RGBA8 colours, vertex codec |
//! |        | I bytes | triangle list, index codec |

use crate::format::{Get, Put};
use crate::mesh::{decode_normal_snorm, encode_normal_snorm};

/// Bytes before the streams.
pub const HEADER_LEN: usize = 44;
/// Position bits a writer may ask for.
pub const POSITION_BITS: std::ops::RangeInclusive<u8> = 8..=24;
/// Normal bits a writer may ask for: 16 (within 0.004 degrees; the
/// scene writer's default) or 8 (within 0.93 degrees, 0.34 on average
/// over the sphere; `gigawalk preprocess`'s default).
pub const NORMAL_BITS: [u8; 2] = [16, 8];

/// The most bytes an encoded blob of these counts can take (meshopt's
/// bounds for the widest streams, with room to spare): what a reader
/// lets a compressed blob decompress to.
pub fn blob_limit(vertices: u32, triangles: u32, colours: bool) -> usize {
    let v = vertices as u64;
    let stream = |size: u64| 2 * v * size + 4096;
    let total = HEADER_LEN as u64
        + stream(12)
        + stream(4)
        + if colours { stream(4) } else { 0 }
        + 16 * triangles as u64
        + 64;
    usize::try_from(total).unwrap_or(usize::MAX)
}

/// The largest snorm value of `bits` bits.
fn snorm_top(bits: u8) -> f32 {
    ((1u32 << (bits - 1)) - 1) as f32
}

/// One LOD's geometry with positions relative to its origin, as encoded
/// and decoded.
#[derive(Clone, Debug, PartialEq)]
pub struct Streams {
    pub positions: Vec<[f32; 3]>,
    pub normals: Vec<[f32; 3]>,
    /// Per-vertex colours, or none for a uniform colour.
    pub colours: Option<Vec<[u8; 4]>>,
    pub indices: Vec<u32>,
}

/// What encoding did to the positions.
#[derive(Clone, Debug, PartialEq)]
pub struct Encoded {
    pub blob: Vec<u8>,
    /// The positions as a reader decodes them.
    pub positions: Vec<[f32; 3]>,
    /// The largest distance a vertex moved, rounded up.
    pub moved: f64,
}

/// The grid of `bits` bits over `positions`: its origin (their minimum)
/// and step per axis.
fn grid(positions: &[[f32; 3]], bits: u8) -> ([f32; 3], [f32; 3]) {
    let levels = ((1u64 << bits) - 1) as f64;
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in positions {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    // Rounded up, so that (hi - lo) / step never exceeds the top level.
    let step = std::array::from_fn(|a| {
        let s = ((hi[a] as f64 - lo[a] as f64) / levels) as f32;
        if (s as f64) * levels < hi[a] as f64 - lo[a] as f64 {
            s.next_up()
        } else {
            s
        }
    });
    (lo, step)
}

fn dequantize(origin: [f32; 3], step: [f32; 3], q: [u32; 3]) -> [f32; 3] {
    std::array::from_fn(|a| origin[a] + q[a] as f32 * step[a])
}

/// `s` with its triangles in vertex-cache order and its vertices in the
/// order the triangles first use them (meshoptimizer's
/// `optimizeVertexCache` and `optimizeVertexFetchRemap`): the same
/// triangles, each with the same corners in the same winding, in the
/// order the codecs compress best (consecutive triangles share vertices,
/// consecutive vertices lie near each other). Vertices no triangle uses
/// keep their order after the rest. With `runs` (triangle counts that
/// sum to the LOD's), triangles are reordered only within each run, so a
/// run's triangles stay consecutive and in place (a leaf's runs per
/// object, docs/scene-format.md "OBJT").
#[cfg(not(target_arch = "wasm32"))]
fn reorder(s: &Streams, runs: &[u32]) -> Streams {
    let nv = s.positions.len();
    let indices = if runs.is_empty() {
        meshopt::optimize_vertex_cache(&s.indices, nv)
    } else {
        let mut out = Vec::with_capacity(s.indices.len());
        let mut first = 0usize;
        for &r in runs {
            let end = first + 3 * r as usize;
            out.extend(meshopt::optimize_vertex_cache(&s.indices[first..end], nv));
            first = end;
        }
        out
    };
    let mut remap = meshopt::optimize_vertex_fetch_remap(&indices, nv);
    let used = remap.iter().filter(|&&r| r != u32::MAX).count() as u32;
    for (r, next) in remap.iter_mut().filter(|r| **r == u32::MAX).zip(used..) {
        *r = next;
    }
    let moved = |v: &[[f32; 3]]| {
        let mut out = vec![[0.0; 3]; nv];
        for (old, &new) in remap.iter().enumerate() {
            out[new as usize] = v[old];
        }
        out
    };
    Streams {
        positions: moved(&s.positions),
        normals: moved(&s.normals),
        colours: s.colours.as_ref().map(|c| {
            let mut out = vec![[0; 4]; nv];
            for (old, &new) in remap.iter().enumerate() {
                out[new as usize] = c[old];
            }
            out
        }),
        indices: indices.iter().map(|&i| remap[i as usize]).collect(),
    }
}

#[cfg(not(target_arch = "wasm32"))]
/// meshoptimizer's vertex codec at its default level (level 3 of
/// format version 1 gave the same bytes on the 1M plant).
fn vertex_codec<T>(v: &[T]) -> meshopt::Result<Vec<u8>> {
    meshopt::encode_vertex_buffer(v)
}

#[cfg(not(target_arch = "wasm32"))]
/// Encodes `s` with positions on a grid of `bits` bits (in
/// [`POSITION_BITS`]). Positions must be finite and indices in range (the
/// writer checks both first).
pub fn encode(s: &Streams, bits: u8, normal_bits: u8) -> Result<Encoded, String> {
    encode_in_runs(s, bits, normal_bits, &[])
}

#[cfg(not(target_arch = "wasm32"))]
/// [`encode`], reordering triangles only within each of `runs` (triangle
/// counts summing to the LOD's; empty: one run).
pub fn encode_in_runs(
    s: &Streams,
    bits: u8,
    normal_bits: u8,
    runs: &[u32],
) -> Result<Encoded, String> {
    if !POSITION_BITS.contains(&bits) {
        return Err(format!(
            "{bits} position bits is outside {}..={}",
            POSITION_BITS.start(),
            POSITION_BITS.end()
        ));
    }
    if !NORMAL_BITS.contains(&normal_bits) {
        return Err(format!("{normal_bits} normal bits is neither 16 nor 8"));
    }
    let triangles = s.indices.len() / 3;
    if s.positions.len() > 3 * triangles {
        return Err(format!(
            "{} vertices for {triangles} triangles: an encoded LOD keeps only the \
             vertices its triangles use",
            s.positions.len()
        ));
    }
    if !runs.is_empty() && runs.iter().map(|&r| r as usize).sum::<usize>() != triangles {
        return Err(format!(
            "runs of {} triangles for {triangles} triangles",
            runs.iter().map(|&r| r as u64).sum::<u64>()
        ));
    }
    let s = &reorder(s, runs);
    let top = (1u64 << bits) - 1;
    let (origin, step) = grid(&s.positions, bits);
    let quantized: Vec<[u32; 3]> = s
        .positions
        .iter()
        .map(|p| {
            std::array::from_fn(|a| {
                if step[a] > 0.0 {
                    let q = ((p[a] as f64 - origin[a] as f64) / step[a] as f64).round();
                    q.clamp(0.0, top as f64) as u32
                } else {
                    0
                }
            })
        })
        .collect();
    let positions: Vec<[f32; 3]> = quantized
        .iter()
        .map(|&q| dequantize(origin, step, q))
        .collect();
    let moved = s
        .positions
        .iter()
        .zip(&positions)
        .map(|(a, b)| {
            (0..3)
                .map(|i| (a[i] as f64 - b[i] as f64).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .fold(0.0, f64::max);
    let err = |what: &str, e: meshopt::Error| format!("cannot encode the {what}: {e:?}");
    let pos = if bits <= 16 {
        let v: Vec<[u16; 4]> = quantized
            .iter()
            .map(|q| [q[0] as u16, q[1] as u16, q[2] as u16, 0])
            .collect();
        vertex_codec(&v)
    } else {
        vertex_codec(&quantized)
    }
    .map_err(|e| err("positions", e))?;
    let ntop = snorm_top(normal_bits);
    let normals = s.normals.iter().map(|&n| encode_normal_snorm(n, ntop));
    let nor = if normal_bits == 16 {
        vertex_codec(&normals.collect::<Vec<[i16; 2]>>())
    } else {
        vertex_codec(
            &normals
                .map(|[u, v]| [u as i8, v as i8, 0, 0])
                .collect::<Vec<[i8; 4]>>(),
        )
    }
    .map_err(|e| err("normals", e))?;
    let col = match &s.colours {
        Some(c) => vertex_codec(c).map_err(|e| err("colours", e))?,
        None => Vec::new(),
    };
    let idx = meshopt::encode_index_buffer(&s.indices, s.positions.len())
        .map_err(|e| err("indices", e))?;
    let mut p = Put(Vec::with_capacity(
        HEADER_LEN + pos.len() + nor.len() + col.len() + idx.len(),
    ));
    p.bytes(&[bits, normal_bits, 0, 0]);
    origin.iter().for_each(|&v| p.f32(v));
    step.iter().for_each(|&v| p.f32(v));
    for stream in [&pos, &nor, &col, &idx] {
        let len = u32::try_from(stream.len()).map_err(|_| "a stream over 4 GiB".to_string())?;
        p.u32(len);
    }
    for stream in [&pos, &nor, &col, &idx] {
        p.bytes(stream);
    }
    Ok(Encoded {
        blob: p.0,
        positions,
        // Up to the next f64: the distances above are rounded.
        moved: if moved > 0.0 { moved.next_up() } else { 0.0 },
    })
}

/// Grid coordinates as stored: 16 bits an axis (the 4th zero) up to 16
/// bits, else 32.
#[derive(Clone, Debug, PartialEq)]
pub enum GridPositions {
    U16(Vec<[u16; 4]>),
    U32(Vec<[u32; 3]>),
}

impl GridPositions {
    pub fn len(&self) -> usize {
        match self {
            GridPositions::U16(v) => v.len(),
            GridPositions::U32(v) => v.len(),
        }
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Vertex `i`'s coordinates.
    pub fn get(&self, i: usize) -> [u32; 3] {
        match self {
            GridPositions::U16(v) => [v[i][0] as u32, v[i][1] as u32, v[i][2] as u32],
            GridPositions::U32(v) => v[i],
        }
    }
}

/// Octahedral normals as stored: 2 x snorm16, or 2 x snorm8 (the last
/// two bytes zero).
#[derive(Clone, Debug, PartialEq)]
pub enum OctNormals {
    Snorm16(Vec<[i16; 2]>),
    Snorm8(Vec<[i8; 4]>),
}

/// One LOD's streams as an encoded blob stores them, decoded but not
/// dequantized: what a renderer that reads grid coordinates itself takes.
#[derive(Clone, Debug, PartialEq)]
pub struct GridStreams {
    /// Position bits per axis ([`POSITION_BITS`]); every coordinate is
    /// below 2^bits.
    pub bits: u8,
    /// Normal bits ([`NORMAL_BITS`]).
    pub normal_bits: u8,
    /// The grid's origin, relative to the LOD's origin.
    pub origin: [f32; 3],
    /// The grid's step per axis (0 on an axis the LOD is flat in).
    pub step: [f32; 3],
    pub positions: GridPositions,
    pub normals: OctNormals,
    /// Per-vertex colours, or none for a uniform colour.
    pub colours: Option<Vec<[u8; 4]>>,
    pub indices: Vec<u32>,
}

impl GridStreams {
    /// Vertex `i`'s position relative to the LOD's origin, in f32 as
    /// [`decode`] gives it (the writer measured what quantizing moved
    /// with exactly this arithmetic).
    pub fn position(&self, i: usize) -> [f32; 3] {
        dequantize(self.origin, self.step, self.positions.get(i))
    }

    /// The smallest and the largest coordinate on each axis, `None`
    /// without vertices. Dequantizing is monotonic on each axis, so the
    /// two corners these give bound every decoded position.
    pub fn extent(&self) -> Option<([u32; 3], [u32; 3])> {
        let mut lo = [u32::MAX; 3];
        let mut hi = [0u32; 3];
        for i in 0..self.positions.len() {
            let q = self.positions.get(i);
            for a in 0..3 {
                lo[a] = lo[a].min(q[a]);
                hi[a] = hi[a].max(q[a]);
            }
        }
        (!self.positions.is_empty()).then_some((lo, hi))
    }

    /// The corners of [`GridStreams::extent`], dequantized.
    pub fn corners(&self) -> Option<([f32; 3], [f32; 3])> {
        self.extent().map(|(lo, hi)| {
            (
                dequantize(self.origin, self.step, lo),
                dequantize(self.origin, self.step, hi),
            )
        })
    }

    /// Vertex `i`'s normal, a unit vector.
    pub fn normal(&self, i: usize) -> [f32; 3] {
        let top = snorm_top(self.normal_bits);
        match &self.normals {
            OctNormals::Snorm16(n) => decode_normal_snorm(n[i], top),
            OctNormals::Snorm8(n) => decode_normal_snorm([n[i][0] as i16, n[i][1] as i16], top),
        }
    }

    /// Dequantized streams: what [`decode`] returns.
    pub fn into_streams(self) -> Streams {
        let n = self.positions.len();
        Streams {
            positions: (0..n).map(|i| self.position(i)).collect(),
            normals: (0..n).map(|i| self.normal(i)).collect(),
            colours: self.colours,
            indices: self.indices,
        }
    }
}

/// Decodes a blob for `vertices` vertices and `triangles` triangles, with
/// per-vertex colours when `colours`. Any inconsistency is an error saying
/// what (the blob's CRC has passed, so this is a writer's bug or a crafted
/// file, never a panic).
pub fn decode(
    blob: &[u8],
    vertices: usize,
    triangles: usize,
    colours: bool,
) -> Result<Streams, String> {
    decode_grid(blob, vertices, triangles, colours).map(GridStreams::into_streams)
}

/// [`decode`] without dequantizing: positions stay grid coordinates and
/// normals stay octahedral, as stored.
pub fn decode_grid(
    blob: &[u8],
    vertices: usize,
    triangles: usize,
    colours: bool,
) -> Result<GridStreams, String> {
    if blob.len() < HEADER_LEN {
        return Err(format!(
            "encoded blob of {} bytes is shorter than its {HEADER_LEN}-byte header",
            blob.len()
        ));
    }
    let mut g = Get::new(&blob[..HEADER_LEN]);
    let [bits, normal_bits, r0, r1] = g.tag();
    if !POSITION_BITS.contains(&bits) || !NORMAL_BITS.contains(&normal_bits) || [r0, r1] != [0; 2] {
        return Err(format!(
            "position bits {bits}, normal bits {normal_bits} (reserved {r0} {r1}) is not valid"
        ));
    }
    let origin = [g.f32(), g.f32(), g.f32()];
    let step = [g.f32(), g.f32(), g.f32()];
    if !origin.iter().chain(&step).all(|v| v.is_finite()) || step.iter().any(|&s| s < 0.0) {
        return Err(format!(
            "grid origin {origin:?} or step {step:?} is not finite and non-negative"
        ));
    }
    let lens = [g.u32(), g.u32(), g.u32(), g.u32()].map(|l| l as usize);
    let total = lens.iter().try_fold(HEADER_LEN, |a, &l| a.checked_add(l));
    if total != Some(blob.len()) {
        return Err(format!(
            "streams of {lens:?} bytes after the header do not fill the {}-byte blob",
            blob.len()
        ));
    }
    if colours != (lens[2] > 0) {
        return Err(format!(
            "a colours stream of {} bytes where the record says {}",
            lens[2],
            if colours {
                "per-vertex colours"
            } else {
                "one colour"
            }
        ));
    }
    let mut at = HEADER_LEN;
    let mut stream = |i: usize| {
        let s = &blob[at..at + lens[i]];
        at += lens[i];
        s
    };
    let (pos, nor, col, idx) = (stream(0), stream(1), stream(2), stream(3));
    // Counts a corrupt record could inflate are refused before anything
    // is allocated for them: the index codec spends at least a code byte
    // a triangle, and an encoded LOD has no vertex its triangles do not
    // use (the writer refuses one), so at most 3 a triangle. (The vertex
    // codec bounds nothing: a constant stream of any length encodes in a
    // few bytes.)
    if triangles > idx.len() {
        return Err(format!(
            "{triangles} triangles cannot come from a {}-byte index stream",
            idx.len()
        ));
    }
    if vertices > 3 * triangles {
        return Err(format!(
            "{vertices} vertices for {triangles} triangles: more than they can use"
        ));
    }
    let err = |what: &str, e: String| format!("the {what} stream does not decode: {e}");
    let positions = if bits > 16 {
        GridPositions::U32(
            crate::unpack::vertices::<[u32; 3]>(pos, vertices).map_err(|e| err("positions", e))?,
        )
    } else {
        GridPositions::U16(
            crate::unpack::vertices::<[u16; 4]>(pos, vertices).map_err(|e| err("positions", e))?,
        )
    };
    let top = ((1u64 << bits) - 1) as u32;
    if let Some(i) = (0..vertices).find(|&i| positions.get(i).iter().any(|&c| c > top)) {
        return Err(format!("vertex {i} lies beyond the {bits}-bit grid"));
    }
    let normals = if normal_bits == 16 {
        OctNormals::Snorm16(
            crate::unpack::vertices::<[i16; 2]>(nor, vertices).map_err(|e| err("normals", e))?,
        )
    } else {
        OctNormals::Snorm8(
            crate::unpack::vertices::<[i8; 4]>(nor, vertices).map_err(|e| err("normals", e))?,
        )
    };
    let colours = if colours {
        Some(crate::unpack::vertices::<[u8; 4]>(col, vertices).map_err(|e| err("colours", e))?)
    } else {
        None
    };
    let indices = crate::unpack::indices(idx, 3 * triangles).map_err(|e| err("indices", e))?;
    Ok(GridStreams {
        bits,
        normal_bits,
        origin,
        step,
        positions,
        normals,
        colours,
        indices,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bumpy grid of `n` x `n` vertices, far from its origin's scale.
    fn sheet(n: u32, scale: f32) -> Streams {
        let mut positions = Vec::new();
        let mut normals = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let (x, y) = (i as f32 / n as f32, j as f32 / n as f32);
                positions.push([x * scale, (x * 7.0).sin() * y * scale * 0.1, y * scale]);
                normals.push([0.0, 1.0, 0.0]);
            }
        }
        let mut indices = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let a = j * n + i;
                indices.extend([a, a + n, a + 1, a + 1, a + n, a + n + 1]);
            }
        }
        let colours = Some((0..n * n).map(|i| [(i % 7) as u8, 20, 30, 255]).collect());
        Streams {
            positions,
            normals,
            colours,
            indices,
        }
    }

    #[test]
    fn round_trip_moves_no_vertex_farther_than_it_says() {
        for (bits, scale) in [
            (8u8, 1.0f32),
            (12, 1.0),
            (16, 1000.0),
            (20, 0.001),
            (24, 3.0e5),
        ] {
            let s = sheet(40, scale);
            let e = encode(&s, bits, 16).unwrap();
            let d = decode(&e.blob, s.positions.len(), s.indices.len() / 3, true).unwrap();
            assert!(
                d.positions == e.positions,
                "the reader sees what the writer measured"
            );
            // Within `moved`, and within half a step's diagonal plus the
            // f32 rounding of a decoded coordinate.
            let (_, step) = grid(&s.positions, bits);
            let rounding = 4.0 * f32::EPSILON as f64 * scale as f64;
            let half_diag =
                0.5 * (step.iter().map(|&v| (v as f64).powi(2)).sum::<f64>()).sqrt() + rounding;
            assert!(
                e.moved <= half_diag,
                "{bits} bits: {} > {half_diag}",
                e.moved
            );
            // The vertices are reordered for the codecs: each decoded one
            // is the original nearest it (the sheet's spacing is far
            // above a step), with its normal and colour.
            let dist = |a: &[f32; 3], b: &[f32; 3]| {
                (0..3)
                    .map(|i| (a[i] as f64 - b[i] as f64).powi(2))
                    .sum::<f64>()
                    .sqrt()
            };
            let original: Vec<usize> = d
                .positions
                .iter()
                .map(|p| {
                    (0..s.positions.len())
                        .min_by(|&a, &b| {
                            dist(p, &s.positions[a]).total_cmp(&dist(p, &s.positions[b]))
                        })
                        .unwrap()
                })
                .collect();
            let mut seen = vec![false; s.positions.len()];
            let colours = d.colours.as_ref().unwrap();
            for (v, &o) in original.iter().enumerate() {
                assert!(
                    !std::mem::replace(&mut seen[o], true),
                    "{bits} bits: vertex {o} twice"
                );
                let m = dist(&d.positions[v], &s.positions[o]);
                assert!(m <= e.moved, "{bits} bits: moved {m} > {}", e.moved);
                assert!((d.normals[v][1] - s.normals[o][1]).abs() < 1e-4);
                assert_eq!(colours[v], s.colours.as_ref().unwrap()[o]);
            }
            // The same triangles, each perhaps starting at another corner
            // (winding kept), perhaps in another order.
            let canonical = |t: [u32; 3]| {
                let r = (0..3).min_by_key(|&k| t[k]).unwrap();
                [t[r], t[(r + 1) % 3], t[(r + 2) % 3]]
            };
            let mut a: Vec<[u32; 3]> = d
                .indices
                .chunks(3)
                .map(|t| canonical([0, 1, 2].map(|k| original[t[k] as usize] as u32)))
                .collect();
            let mut b: Vec<[u32; 3]> = s
                .indices
                .chunks(3)
                .map(|t| canonical([t[0], t[1], t[2]]))
                .collect();
            a.sort_unstable();
            b.sort_unstable();
            assert!(a == b, "{bits} bits: the triangles differ");
        }
    }

    #[test]
    fn runs_keep_their_triangles_consecutive_and_in_place() {
        let s = sheet(24, 5.0);
        let t = (s.indices.len() / 3) as u32;
        let runs = [7, t - 7 - 100, 100];
        let e = encode_in_runs(&s, 16, 8, &runs).unwrap();
        let d = decode(&e.blob, s.positions.len(), t as usize, true).unwrap();
        // Each decoded vertex is the original nearest it (the sheet's
        // spacing is far above a 16-bit step).
        let nearest = |p: &[f32; 3]| -> u32 {
            (0..s.positions.len() as u32)
                .min_by(|&a, &b| {
                    let d = |i: u32| {
                        let q = s.positions[i as usize];
                        (0..3).map(|k| (q[k] - p[k]).powi(2)).sum::<f32>()
                    };
                    d(a).total_cmp(&d(b))
                })
                .unwrap()
        };
        let original: Vec<u32> = d.positions.iter().map(nearest).collect();
        let tris = |idx: &[u32], map: &dyn Fn(u32) -> u32, range: std::ops::Range<usize>| {
            let mut v: Vec<[u32; 3]> = idx.chunks(3).collect::<Vec<_>>()[range]
                .iter()
                .map(|t| {
                    let mut k = [map(t[0]), map(t[1]), map(t[2])];
                    k.sort();
                    k
                })
                .collect();
            v.sort();
            v
        };
        let mut first = 0usize;
        for &r in &runs {
            let range = first..first + r as usize;
            assert_eq!(
                tris(&d.indices, &|i| original[i as usize], range.clone()),
                tris(&s.indices, &|i| i, range),
                "run of {r} from triangle {first}"
            );
            first += r as usize;
        }
        assert!(
            encode_in_runs(&s, 16, 8, &[1, 2]).is_err(),
            "runs must cover the triangles"
        );
    }

    #[test]
    fn eight_bit_normals_decode_within_a_degree_in_fewer_bytes() {
        let mut s = sheet(30, 1.0);
        for (i, n) in s.normals.iter_mut().enumerate() {
            let a = i as f32 * 0.37;
            let z = (i as f32 * 0.011).sin();
            let r = (1.0 - z * z).sqrt();
            *n = [r * a.cos(), z, r * a.sin()];
        }
        let (nv, nt) = (s.positions.len(), s.indices.len() / 3);
        let normals_len = |blob: &[u8]| u32::from_le_bytes(blob[32..36].try_into().unwrap());
        let wide = encode(&s, 16, 16).unwrap().blob;
        let narrow = encode(&s, 16, 8).unwrap().blob;
        assert!(normals_len(&narrow) < normals_len(&wide));
        let d = decode(&narrow, nv, nt, true).unwrap();
        // Decoded vertices are reordered: match each by its position.
        for (p, n) in d.positions.iter().zip(&d.normals) {
            let o = s
                .positions
                .iter()
                .position(|q| (0..3).all(|k| (q[k] - p[k]).abs() < 1e-3))
                .unwrap();
            let m = s.normals[o];
            let dot = (0..3).map(|k| m[k] * n[k]).sum::<f32>().clamp(-1.0, 1.0);
            assert!(dot.acos().to_degrees() < 0.94, "{m:?} decoded as {n:?}");
        }
    }

    #[test]
    fn flat_and_single_point_lods_encode() {
        let mut s = sheet(3, 1.0);
        s.positions.iter_mut().for_each(|p| p[1] = 0.25);
        let e = encode(&s, 16, 16).unwrap();
        let d = decode(&e.blob, 9, s.indices.len() / 3, true).unwrap();
        assert!(d.positions.iter().all(|p| p[1] == 0.25));
        s.positions.iter_mut().for_each(|p| *p = [1.0, 2.0, 3.0]);
        let e = encode(&s, 16, 16).unwrap();
        assert_eq!(e.moved, 0.0);
    }

    #[test]
    fn corrupt_blobs_are_errors_not_panics() {
        let s = sheet(20, 1.0);
        let (nv, nt) = (s.positions.len(), s.indices.len() / 3);
        let blob = encode(&s, 16, 16).unwrap().blob;
        let bad = |b: &[u8], nv: usize, nt: usize, c: bool| decode(b, nv, nt, c).unwrap_err();
        assert!(bad(&blob[..HEADER_LEN - 1], nv, nt, true).contains("shorter than"));
        assert!(bad(&blob[..blob.len() - 1], nv, nt, true).contains("do not fill"));
        let mut b = blob.clone();
        b[0] = 40;
        assert!(bad(&b, nv, nt, true).contains("position bits 40"));
        let mut b = blob.clone();
        b[1] = 12;
        assert!(bad(&b, nv, nt, true).contains("normal bits 12"));
        let mut b = blob.clone();
        b[16..20].copy_from_slice(&f32::NAN.to_le_bytes());
        assert!(bad(&b, nv, nt, true).contains("not finite"));
        assert!(bad(&blob, nv, nt, false).contains("colours stream"));
        assert!(bad(&blob, 3 * nt + 1, nt, true).contains("more than they can use"));
        assert!(bad(&blob, nv, 1 << 30, true).contains("cannot come from"));
        // Flipped bytes in the streams: an error or, where the codecs
        // cannot tell, wrong values (the CRC catches those first; indices
        // out of range are caught by the reader).
        for i in HEADER_LEN..blob.len() {
            let mut b = blob.clone();
            b[i] ^= 0x5a;
            let _ = decode(&b, nv, nt, true);
        }
        // Counts that do not match the streams.
        let _ = decode(&blob, nv - 1, nt, true);
        let _ = decode(&blob, nv, nt - 1, true);
    }

    #[test]
    fn bits_outside_the_range_are_refused() {
        let s = sheet(3, 1.0);
        assert!(encode(&s, 7, 16).unwrap_err().contains("outside 8..=24"));
        assert!(encode(&s, 25, 16).is_err());
        assert!(encode(&s, 16, 12).unwrap_err().contains("neither 16 nor 8"));
    }
}
