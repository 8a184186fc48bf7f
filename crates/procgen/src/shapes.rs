//! Triangle-mesh building blocks (boxes, tubes, spheres, tori) in f32 local
//! coordinates, counter-clockwise front faces, with normals. None of them
//! emits a zero-area triangle, so an importer keeps every one and the
//! generator's triangle count is exact.

use glam::Vec3;
use std::f32::consts::TAU;

#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub indices: Vec<u32>,
}

/// Two unit vectors perpendicular to `d` and to each other.
fn frame(d: Vec3) -> (Vec3, Vec3) {
    let u = if d.y.abs() < 0.9 {
        d.cross(Vec3::Y).normalize()
    } else {
        d.cross(Vec3::X).normalize()
    };
    (u, d.cross(u))
}

impl Mesh {
    pub fn triangles(&self) -> usize {
        self.indices.len() / 3
    }

    fn vertex(&mut self, p: Vec3, n: Vec3) -> u32 {
        self.positions.push(p);
        self.normals.push(n);
        (self.positions.len() - 1) as u32
    }

    /// A flat quad a-b-c-d, counter-clockwise seen from the side `n` points to.
    fn quad(&mut self, a: Vec3, b: Vec3, c: Vec3, d: Vec3, n: Vec3) {
        let i = self.vertex(a, n);
        self.vertex(b, n);
        self.vertex(c, n);
        self.vertex(d, n);
        self.indices
            .extend_from_slice(&[i, i + 1, i + 2, i, i + 2, i + 3]);
    }

    /// Box with its edges along `axes` (unit, orthogonal, right-handed) and
    /// half sizes `h`: 12 triangles.
    pub fn oriented_box(&mut self, c: Vec3, axes: [Vec3; 3], h: Vec3) {
        let [ax, ay, az] = [axes[0] * h.x, axes[1] * h.y, axes[2] * h.z];
        let corner = |sx: f32, sy: f32, sz: f32| c + ax * sx + ay * sy + az * sz;
        for (n, s) in [
            (axes[0], 1.0f32),
            (-axes[0], -1.0),
            (axes[1], 1.0),
            (-axes[1], -1.0),
            (axes[2], 1.0),
            (-axes[2], -1.0),
        ] {
            // The face's own frame: u x v = outward normal.
            let (a, b, k) = if n.abs_diff_eq(axes[0], 0.0) || n.abs_diff_eq(-axes[0], 0.0) {
                (0, 1, 2)
            } else if n.abs_diff_eq(axes[1], 0.0) || n.abs_diff_eq(-axes[1], 0.0) {
                (1, 2, 0)
            } else {
                (2, 0, 1)
            };
            let mut p = [0.0f32; 3];
            p[a] = s;
            let mut q = |u: f32, v: f32| {
                p[b] = u * s;
                p[k] = v;
                corner(p[0], p[1], p[2])
            };
            let (c0, c1, c2, c3) = (q(-1.0, -1.0), q(1.0, -1.0), q(1.0, 1.0), q(-1.0, 1.0));
            self.quad(c0, c1, c2, c3, n);
        }
    }

    /// Axis-aligned box from `min` to `max`: 12 triangles.
    pub fn aabox(&mut self, min: Vec3, max: Vec3) {
        self.oriented_box(
            (min + max) * 0.5,
            [Vec3::X, Vec3::Y, Vec3::Z],
            (max - min) * 0.5,
        );
    }

    /// Tube (cylinder or frustum) from `a` (radius `r0`) to `b` (radius
    /// `r1 > 0`), `segments` around and `sections` along, with optional flat
    /// caps: `2 * segments * sections` side triangles plus `segments` per cap.
    #[allow(clippy::too_many_arguments)] // a tube is naturally described by its 7 numbers
    pub fn tube(
        &mut self,
        a: Vec3,
        b: Vec3,
        r0: f32,
        r1: f32,
        segments: u32,
        sections: u32,
        caps: bool,
    ) {
        let axis = b - a;
        let len = axis.length();
        let d = axis / len;
        let (u, v) = frame(d);
        let base = self.positions.len() as u32;
        for s in 0..=sections {
            let t = s as f32 / sections as f32;
            let r = r0 + (r1 - r0) * t;
            let c = a + axis * t;
            for k in 0..segments {
                let ang = TAU * k as f32 / segments as f32;
                let radial = u * ang.cos() + v * ang.sin();
                let n = (radial * len + d * (r0 - r1)).normalize();
                self.vertex(c + radial * r, n);
            }
        }
        for s in 0..sections {
            for k in 0..segments {
                let k1 = (k + 1) % segments;
                let i0 = base + s * segments + k;
                let i1 = base + s * segments + k1;
                let j0 = i0 + segments;
                let j1 = i1 + segments;
                self.indices.extend_from_slice(&[i0, i1, j1, i0, j1, j0]);
            }
        }
        if caps {
            for (c, r, n) in [(a, r0, -d), (b, r1, d)] {
                let centre = self.vertex(c, n);
                for k in 0..segments {
                    let ang = TAU * k as f32 / segments as f32;
                    self.vertex(c + (u * ang.cos() + v * ang.sin()) * r, n);
                }
                for k in 0..segments {
                    let (p, q) = (centre + 1 + k, centre + 1 + (k + 1) % segments);
                    if n == d {
                        self.indices.extend_from_slice(&[centre, p, q]);
                    } else {
                        self.indices.extend_from_slice(&[centre, q, p]);
                    }
                }
            }
        }
    }

    /// Cone from base centre `a` (radius `r`) to apex `b`, with a base cap:
    /// `2 * segments` triangles.
    pub fn cone(&mut self, a: Vec3, b: Vec3, r: f32, segments: u32) {
        let axis = b - a;
        let len = axis.length();
        let d = axis / len;
        let (u, v) = frame(d);
        for k in 0..segments {
            let a0 = TAU * k as f32 / segments as f32;
            let a1 = TAU * (k + 1) as f32 / segments as f32;
            let (r0, r1) = (u * a0.cos() + v * a0.sin(), u * a1.cos() + v * a1.sin());
            let n = ((r0 + r1).normalize() * len + d * r).normalize();
            let i = self.vertex(a + r0 * r, n);
            self.vertex(a + r1 * r, n);
            self.vertex(b, n);
            self.indices.extend_from_slice(&[i, i + 1, i + 2]);
        }
        let centre = self.vertex(a, -d);
        for k in 0..segments {
            let ang = TAU * k as f32 / segments as f32;
            self.vertex(a + (u * ang.cos() + v * ang.sin()) * r, -d);
        }
        for k in 0..segments {
            self.indices.extend_from_slice(&[
                centre,
                centre + 1 + (k + 1) % segments,
                centre + 1 + k,
            ]);
        }
    }

    /// Sphere (optionally squashed by `scale`) of `rings` latitude bands
    /// (>= 2) and `segments` longitudes: `2 * segments * (rings - 1)` triangles.
    pub fn sphere(&mut self, c: Vec3, r: f32, scale: Vec3, rings: u32, segments: u32) {
        let base = self.positions.len() as u32;
        let top = self.vertex(c + Vec3::Y * r * scale.y, Vec3::Y);
        for i in 1..rings {
            let phi = std::f32::consts::PI * i as f32 / rings as f32;
            for k in 0..segments {
                let th = TAU * k as f32 / segments as f32;
                let dir = Vec3::new(phi.sin() * th.cos(), phi.cos(), -phi.sin() * th.sin());
                self.vertex(c + dir * r * scale, (dir / scale).normalize());
            }
        }
        let bottom = self.vertex(c - Vec3::Y * r * scale.y, -Vec3::Y);
        let ring = |i: u32, k: u32| base + 1 + (i - 1) * segments + k % segments;
        for k in 0..segments {
            self.indices
                .extend_from_slice(&[top, ring(1, k), ring(1, k + 1)]);
            self.indices
                .extend_from_slice(&[bottom, ring(rings - 1, k + 1), ring(rings - 1, k)]);
        }
        for i in 1..rings - 1 {
            for k in 0..segments {
                let (a, b, c2, d) = (
                    ring(i, k),
                    ring(i, k + 1),
                    ring(i + 1, k + 1),
                    ring(i + 1, k),
                );
                self.indices.extend_from_slice(&[a, d, c2, a, c2, b]);
            }
        }
    }

    /// Torus around `axis` through `c`: `2 * segments * sides` triangles.
    pub fn torus(
        &mut self,
        c: Vec3,
        axis: Vec3,
        major: f32,
        minor: f32,
        segments: u32,
        sides: u32,
    ) {
        let d = axis.normalize();
        let (u, v) = frame(d);
        let base = self.positions.len() as u32;
        for s in 0..segments {
            let a = TAU * s as f32 / segments as f32;
            let radial = u * a.cos() + v * a.sin();
            let ring_c = c + radial * major;
            for k in 0..sides {
                let b = TAU * k as f32 / sides as f32;
                let n = radial * b.cos() + d * b.sin();
                self.vertex(ring_c + n * minor, n);
            }
        }
        for s in 0..segments {
            for k in 0..sides {
                let s1 = (s + 1) % segments;
                let k1 = (k + 1) % sides;
                let i = |s: u32, k: u32| base + s * sides + k;
                self.indices.extend_from_slice(&[
                    i(s, k),
                    i(s1, k),
                    i(s1, k1),
                    i(s, k),
                    i(s1, k1),
                    i(s, k1),
                ]);
            }
        }
    }

    /// A flat grid in the XZ plane facing +Y: `2 * nx * nz` triangles.
    pub fn ground(&mut self, min: Vec3, size_x: f32, size_z: f32, nx: u32, nz: u32) {
        let base = self.positions.len() as u32;
        for j in 0..=nz {
            for i in 0..=nx {
                let p = min
                    + Vec3::new(
                        size_x * i as f32 / nx as f32,
                        0.0,
                        size_z * j as f32 / nz as f32,
                    );
                self.vertex(p, Vec3::Y);
            }
        }
        let w = nx + 1;
        for j in 0..nz {
            for i in 0..nx {
                let a = base + j * w + i;
                self.indices
                    .extend_from_slice(&[a, a + w, a + w + 1, a, a + w + 1, a + 1]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every triangle has non-zero area and faces the way its vertex
    /// normals point (counter-clockwise front faces).
    fn check_outward(m: &Mesh) {
        for t in m.indices.chunks_exact(3) {
            let [a, b, c] = [0, 1, 2].map(|k| m.positions[t[k] as usize]);
            let n = (b - a).cross(c - a);
            assert!(n.length() > 0.0, "degenerate triangle {t:?}");
            let vn = m.normals[t[0] as usize] + m.normals[t[1] as usize] + m.normals[t[2] as usize];
            assert!(n.dot(vn) > 0.0, "triangle {t:?} faces inward");
        }
    }

    #[test]
    fn shapes_face_outward_with_documented_counts() {
        let mut m = Mesh::default();
        m.aabox(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(m.triangles(), 12);
        check_outward(&m);
        let mut m = Mesh::default();
        m.oriented_box(
            Vec3::ONE,
            [Vec3::Z, Vec3::Y, -Vec3::X],
            Vec3::new(1.0, 0.5, 0.2),
        );
        check_outward(&m);
        let mut m = Mesh::default();
        m.tube(Vec3::ZERO, Vec3::new(0.0, 0.0, 10.0), 1.0, 0.5, 8, 3, true);
        assert_eq!(m.triangles(), 2 * 8 * 3 + 16);
        check_outward(&m);
        let mut m = Mesh::default();
        m.tube(Vec3::ZERO, Vec3::Y, 1.0, 1.0, 6, 1, false);
        check_outward(&m);
        let mut m = Mesh::default();
        m.cone(Vec3::ZERO, Vec3::Y * 3.0, 1.0, 7);
        assert_eq!(m.triangles(), 14);
        check_outward(&m);
        let mut m = Mesh::default();
        m.sphere(Vec3::ZERO, 2.0, Vec3::new(1.0, 0.5, 1.0), 5, 9);
        assert_eq!(m.triangles(), 2 * 9 * 4);
        check_outward(&m);
        let mut m = Mesh::default();
        m.torus(Vec3::ZERO, Vec3::X, 1.0, 0.1, 12, 6);
        assert_eq!(m.triangles(), 144);
        check_outward(&m);
        let mut m = Mesh::default();
        m.ground(Vec3::ZERO, 4.0, 2.0, 4, 2);
        assert_eq!(m.triangles(), 16);
        check_outward(&m);
    }
}
