//! One LOD's geometry as the writer takes it and the reader returns it.

use glam::DVec3;

/// Vertex colours of one LOD.
#[derive(Clone, Debug, PartialEq)]
pub enum Colours {
    /// Every vertex has this sRGB-encoded RGBA colour (stored once).
    Uniform([u8; 4]),
    /// One sRGB-encoded RGBA colour per vertex.
    PerVertex(Vec<[u8; 4]>),
}

/// Geometry of one LOD: an indexed triangle list with positions relative
/// to `origin`.
#[derive(Clone, Debug, PartialEq)]
pub struct LodMesh {
    /// World position that `positions` are relative to; the writer
    /// recentres on the LOD's box centre, so any origin is fine here.
    pub origin: DVec3,
    pub positions: Vec<[f32; 3]>,
    /// Unit normals, one per position. Stored octahedrally encoded in
    /// 2 x 16 bits: a normal read back is within 1e-4 of the one written.
    pub normals: Vec<[f32; 3]>,
    pub colours: Colours,
    /// 3 indices per triangle, each `< positions.len()`.
    pub indices: Vec<u32>,
}

impl LodMesh {
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }
}

/// Octahedral encoding of a unit vector into two snorm16 values (Cigolle et
/// al. 2014, "A Survey of Efficient Representations for Independent Unit
/// Vectors"). Non-finite or zero vectors encode as +Z.
pub fn encode_normal(n: [f32; 3]) -> [i16; 2] {
    encode_normal_snorm(n, 32767.0)
}

/// [`encode_normal`] into snorm values of `top` steps each way (32767 for
/// 16 bits, 127 for 8).
pub fn encode_normal_snorm(n: [f32; 3], top: f32) -> [i16; 2] {
    let [x, y, z] = n;
    let l1 = x.abs() + y.abs() + z.abs();
    if !(l1.is_finite() && l1 > 0.0) {
        return [0, 0];
    }
    let (mut u, mut v) = (x / l1, y / l1);
    if z < 0.0 {
        let (pu, pv) = (u, v);
        u = (1.0 - pv.abs()) * sign_not_zero(pu);
        v = (1.0 - pu.abs()) * sign_not_zero(pv);
    }
    let q = |a: f32| (a.clamp(-1.0, 1.0) * top).round() as i16;
    [q(u), q(v)]
}

/// Inverse of [`encode_normal`]: a unit vector.
pub fn decode_normal(e: [i16; 2]) -> [f32; 3] {
    decode_normal_snorm(e, 32767.0)
}

/// Inverse of [`encode_normal_snorm`] with the same `top`.
pub fn decode_normal_snorm(e: [i16; 2], top: f32) -> [f32; 3] {
    let u = (e[0] as f32 / top).clamp(-1.0, 1.0);
    let v = (e[1] as f32 / top).clamp(-1.0, 1.0);
    let z = 1.0 - u.abs() - v.abs();
    let (x, y) = if z < 0.0 {
        (
            (1.0 - v.abs()) * sign_not_zero(u),
            (1.0 - u.abs()) * sign_not_zero(v),
        )
    } else {
        (u, v)
    };
    let len = (x * x + y * y + z * z).sqrt();
    [x / len, y / len, z / len]
}

fn sign_not_zero(a: f32) -> f32 {
    if a >= 0.0 {
        1.0
    } else {
        -1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `count` unit vectors on a spiral over the sphere, both hemispheres
    /// and the poles.
    fn spiral(count: u32) -> impl Iterator<Item = [f32; 3]> {
        (0..count).map(move |i| {
            let t = i as f32 / (count - 1) as f32;
            let z = 1.0 - 2.0 * t;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let a = i as f32 * 2.399_963;
            [r * a.cos(), r * a.sin(), z]
        })
    }

    #[test]
    fn normals_round_trip_within_1e4() {
        let mut worst = 0.0f32;
        for n in spiral(2000) {
            let d = decode_normal(encode_normal(n));
            let err =
                ((d[0] - n[0]).powi(2) + (d[1] - n[1]).powi(2) + (d[2] - n[2]).powi(2)).sqrt();
            worst = worst.max(err);
        }
        assert!(worst < 1e-4, "worst normal error {worst}");
    }

    #[test]
    fn eight_bit_normals_are_within_a_degree() {
        // The shading difference 8-bit normals make: the angle between a
        // normal and its decoded self, which bounds the change of any
        // Lambert term (|cos a - cos b| <= |a - b|).
        let mut worst = 0.0f32;
        for n in spiral(20000) {
            let d = decode_normal_snorm(encode_normal_snorm(n, 127.0), 127.0);
            let dot = (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]).clamp(-1.0, 1.0);
            worst = worst.max(dot.acos().to_degrees());
        }
        assert!(worst < 1.0, "worst 8-bit normal error {worst} degrees");
        assert!(worst > 0.1, "{worst}: 8 bits do cost something");
    }

    #[test]
    fn degenerate_normals_encode_as_plus_z() {
        assert_eq!(
            decode_normal(encode_normal([0.0, 0.0, 0.0])),
            [0.0, 0.0, 1.0]
        );
        assert_eq!(
            decode_normal(encode_normal([f32::NAN, 0.0, 1.0])),
            [0.0, 0.0, 1.0]
        );
    }
}
