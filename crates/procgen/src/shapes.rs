//! Triangle-mesh building blocks (boxes, tubes, spheres, tori, lofts) in f32
//! local coordinates, counter-clockwise front faces, with normals. None of
//! them emits a zero-area triangle, so an importer keeps every one and the
//! generator's triangle count is exact.

use glam::{DVec3, Vec2, Vec3};
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

/// Cosine of the largest angle between neighbouring faces of a loft ring
/// that is shaded smooth: 50 degrees, so an 8-sided tube looks round while
/// a hexagon keeps its edges.
const SMOOTH_COS: f32 = 0.643;

/// Local axes for [`Mesh::loft`]: outlines lie in the (u, v) plane and rings
/// stack along w = u x v.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub origin: Vec3,
    pub u: Vec3,
    pub v: Vec3,
    pub w: Vec3,
}

impl Frame {
    /// Axes `u` and `v` must be unit and orthogonal.
    pub fn new(origin: Vec3, u: Vec3, v: Vec3) -> Frame {
        Frame {
            origin,
            u,
            v,
            w: u.cross(v),
        }
    }

    /// Rings stacked along `axis` (any non-zero length), the outline's
    /// orientation about it left to [`frame`].
    pub fn along(origin: Vec3, axis: Vec3) -> Frame {
        let w = axis.normalize();
        let (u, v) = frame(w);
        Frame { origin, u, v, w }
    }

    pub fn at(&self, p: Vec2, z: f32) -> Vec3 {
        self.origin + self.u * p.x + self.v * p.y + self.w * z
    }
}

/// One cross-section of a [`Mesh::loft`]: an outline at height `z` along
/// the frame's w, or, with a single point, an apex closing the loft.
#[derive(Clone, Debug)]
pub struct Ring {
    pub z: f32,
    pub points: Vec<Vec2>,
}

impl Ring {
    pub fn new(z: f32, points: Vec<Vec2>) -> Ring {
        Ring { z, points }
    }

    /// The axis point at height `z`.
    pub fn apex(z: f32) -> Ring {
        Ring {
            z,
            points: vec![Vec2::ZERO],
        }
    }
}

/// `n` points on a circle of radius `r`, counter-clockwise from +u.
pub fn circle(r: f32, n: u32) -> Vec<Vec2> {
    (0..n)
        .map(|k| {
            let a = TAU * k as f32 / n as f32;
            Vec2::new(r * a.cos(), r * a.sin())
        })
        .collect()
}

/// A rectangle of half sizes `hx`, `hy` with corners rounded to radius `r`
/// (`0 < r <= min(hx, hy)`), `per_corner` points on each corner's arc (1: a
/// sharp corner, `r` unused); counter-clockwise, `4 * per_corner` points.
pub fn rounded_rect(hx: f32, hy: f32, r: f32, per_corner: u32) -> Vec<Vec2> {
    let mut out = Vec::with_capacity(4 * per_corner as usize);
    for (q, sx, sy) in [
        (0, 1.0, 1.0),
        (1, -1.0, 1.0),
        (2, -1.0, -1.0),
        (3, 1.0, -1.0),
    ] {
        if per_corner == 1 {
            out.push(Vec2::new(sx * hx, sy * hy));
            continue;
        }
        let c = Vec2::new(sx * (hx - r), sy * (hy - r));
        for k in 0..per_corner {
            let a = (q as f32 + k as f32 / (per_corner - 1) as f32) * std::f32::consts::FRAC_PI_2;
            out.push(c + Vec2::new(a.cos(), a.sin()) * r);
        }
    }
    out
}

/// A hexagon `across_flats` wide, flats facing +-v: corners only (6
/// points) or corners and flat midpoints (`split`, 12 points, so it can
/// share a loft with a 12-point circle).
pub fn hexagon(across_flats: f32, split: bool) -> Vec<Vec2> {
    let corner = across_flats / 3f32.sqrt();
    let mut out = Vec::with_capacity(12);
    for k in 0..6 {
        let a = std::f32::consts::FRAC_PI_3 * k as f32;
        out.push(Vec2::new(a.cos(), a.sin()) * corner);
        if split {
            let m = a + std::f32::consts::FRAC_PI_6;
            out.push(Vec2::new(m.cos(), m.sin()) * (0.5 * across_flats));
        }
    }
    out
}

/// A spur gear's outline: `teeth` trapezoidal teeth between radii `root`
/// and `tip`, 4 points a tooth, counter-clockwise.
pub fn gear_outline(root: f32, tip: f32, teeth: u32) -> Vec<Vec2> {
    let pitch = TAU / teeth as f32;
    let mut out = Vec::with_capacity(4 * teeth as usize);
    for t in 0..teeth {
        let a = t as f32 * pitch;
        for (f, r) in [(0.0, root), (0.2, tip), (0.45, tip), (0.65, root)] {
            let b = a + f * pitch;
            out.push(Vec2::new(b.cos(), b.sin()) * r);
        }
    }
    out
}

/// `outline`'s points moved along their directions from the origin to
/// radius `r`: the bore of a nut or gear with as many points as its rim.
pub fn at_radius(outline: &[Vec2], r: f32) -> Vec<Vec2> {
    outline.iter().map(|p| p.normalize() * r).collect()
}

/// Whether the triangle has non-zero area in f64, as an importer measures it.
fn has_area(a: Vec3, b: Vec3, c: Vec3) -> bool {
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    (b - a).cross(c - a) != DVec3::ZERO
}

impl Mesh {
    pub fn clear(&mut self) {
        self.positions.clear();
        self.normals.clear();
        self.indices.clear();
    }

    /// Appends `other`, re-indexed.
    pub fn append(&mut self, other: &Mesh) {
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        self.normals.extend_from_slice(&other.normals);
        self.indices.extend(other.indices.iter().map(|i| i + base));
    }

    /// A surface through `rings` in order (and back to the first when
    /// `closed`): between two outlines of `n` points `2n` triangles,
    /// between an outline and an apex `n`. Every point of every ring is
    /// computed once, so the faces meeting there share its exact position
    /// and the loft is one connected piece once positions are welded (what
    /// a simplifier does), while its faces keep their own normals: flat
    /// between rings, smooth around a ring where neighbours differ by less
    /// than 50 degrees.
    ///
    /// Outlines are counter-clockwise about w; the surface faces outward
    /// when the rings run up the outside (bottom to top), out along a
    /// bottom face and in along a top one: a bolt is apex, shank, shank,
    /// head, head, apex; a washer's closed section is inner bottom, outer
    /// bottom, outer top, inner top. Outlines meeting an apex must be
    /// star-shaped about the axis. Zero-area triangles are left out (none
    /// when consecutive rings differ everywhere).
    pub fn loft(&mut self, f: &Frame, rings: &[Ring], closed: bool) {
        debug_assert!(rings.len() >= 2);
        let n = rings.iter().map(|r| r.points.len()).max().unwrap_or(0);
        debug_assert!(rings
            .iter()
            .all(|r| r.points.len() == n || r.points.len() == 1));
        let pos: Vec<Vec<Vec3>> = rings
            .iter()
            .map(|r| r.points.iter().map(|&p| f.at(p, r.z)).collect())
            .collect();
        let strips = if closed { rings.len() } else { rings.len() - 1 };
        let mut quads = Vec::with_capacity(n);
        let mut normals = Vec::with_capacity(n);
        for s in 0..strips {
            let (lo, hi) = (&pos[s], &pos[(s + 1) % rings.len()]);
            if lo.len() == 1 && hi.len() == 1 {
                continue;
            }
            let p = |ring: &Vec<Vec3>, k: usize| ring[if ring.len() == 1 { 0 } else { k % n }];
            quads.clear();
            normals.clear();
            for k in 0..n {
                let q = [p(lo, k), p(lo, k + 1), p(hi, k + 1), p(hi, k)];
                let nq = (q[1] - q[0]).cross(q[2] - q[0]) + (q[2] - q[0]).cross(q[3] - q[0]);
                quads.push(q);
                normals.push(nq.normalize_or_zero());
            }
            // Ring point k is the edge between quads k - 1 and k; where they
            // meet smoothly they share its vertices (one normal), otherwise
            // each side has its own.
            let smooth: Vec<bool> = (0..n)
                .map(|k| normals[k].dot(normals[(k + n - 1) % n]) > SMOOTH_COS)
                .collect();
            let mut left = vec![[u32::MAX; 2]; n];
            let mut right = vec![[u32::MAX; 2]; n];
            for k in 0..n {
                let q = quads[k];
                for t in [[0, 1, 2], [0, 2, 3]] {
                    let [a, b, c] = t;
                    // An apex strip's quads have two corners at the apex:
                    // one of their triangles has no area.
                    if !has_area(q[a], q[b], q[c]) {
                        continue;
                    }
                    for i in t {
                        // Corners 0 and 3 lie on edge k, 1 and 2 on edge k + 1.
                        let (edge, level, is_left) = match i {
                            0 => (k, 0, true),
                            3 => (k, 1, true),
                            1 => ((k + 1) % n, 0, false),
                            _ => ((k + 1) % n, 1, false),
                        };
                        let shared = smooth[edge];
                        let slot = if shared || is_left {
                            &mut left[edge][level]
                        } else {
                            &mut right[edge][level]
                        };
                        if *slot == u32::MAX {
                            let normal = if shared {
                                (normals[edge] + normals[(edge + n - 1) % n]).normalize()
                            } else {
                                normals[k]
                            };
                            *slot = self.vertex(q[i], normal);
                        }
                        self.indices.push(*slot);
                    }
                }
            }
        }
    }
}

/// Each triangle's connected piece, numbered from 0 in order of first
/// appearance, once vertices with equal `keys` are welded: the pieces a
/// simplifier sees (the tests count a model's parts with it).
pub fn welded_pieces<K: Ord>(keys: &[K], indices: &[u32]) -> Vec<usize> {
    fn root(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let join = |p: &mut [usize], a: usize, b: usize| {
        let (ra, rb) = (root(p, a), root(p, b));
        p[ra] = rb;
    };
    let mut parent: Vec<usize> = (0..keys.len()).collect();
    let mut order: Vec<usize> = (0..keys.len()).collect();
    order.sort_by(|&a, &b| keys[a].cmp(&keys[b]));
    for w in order.windows(2) {
        if keys[w[0]] == keys[w[1]] {
            join(&mut parent, w[0], w[1]);
        }
    }
    for t in indices.chunks_exact(3) {
        join(&mut parent, t[0] as usize, t[1] as usize);
        join(&mut parent, t[0] as usize, t[2] as usize);
    }
    let mut number = vec![usize::MAX; keys.len()];
    let mut next = 0;
    indices
        .chunks_exact(3)
        .map(|t| {
            let r = root(&mut parent, t[0] as usize);
            if number[r] == usize::MAX {
                number[r] = next;
                next += 1;
            }
            number[r]
        })
        .collect()
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

    /// Connected pieces once equal positions are welded.
    fn pieces(m: &Mesh) -> usize {
        let keys: Vec<[u32; 3]> = m
            .positions
            .iter()
            .map(|p| p.to_array().map(f32::to_bits))
            .collect();
        welded_pieces(&keys, &m.indices)
            .into_iter()
            .max()
            .map_or(0, |n| n + 1)
    }

    #[test]
    fn lofts_face_outward_in_one_piece_with_documented_counts() {
        let f = Frame::along(Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.3, 1.0, -0.2));
        // A bolt: hex head on a round shank, 12 points a ring.
        let (shank, head) = (circle(0.005, 12), hexagon(0.016, true));
        let mut m = Mesh::default();
        m.loft(
            &f,
            &[
                Ring::apex(-0.04),
                Ring::new(-0.04, shank.clone()),
                Ring::new(0.0, shank),
                Ring::new(0.0, head.clone()),
                Ring::new(0.0065, head),
                Ring::apex(0.0065),
            ],
            false,
        );
        assert_eq!(m.triangles(), 12 + 24 + 24 + 24 + 12);
        check_outward(&m);
        assert_eq!(pieces(&m), 1);
        // A washer's closed section; a gear with its bore.
        for outer in [circle(0.01, 10), gear_outline(0.1, 0.12, 9)] {
            let inner = at_radius(&outer, 0.04);
            let mut m = Mesh::default();
            m.loft(
                &f,
                &[
                    Ring::new(0.0, inner.clone()),
                    Ring::new(0.0, outer.clone()),
                    Ring::new(0.02, outer.clone()),
                    Ring::new(0.02, inner),
                ],
                true,
            );
            assert_eq!(m.triangles(), 8 * outer.len());
            check_outward(&m);
            assert_eq!(pieces(&m), 1);
        }
        // A sheet-metal cover: open bottom, both faces, rim between them.
        let outer = rounded_rect(0.5, 0.3, 0.05, 4);
        let inner = rounded_rect(0.49, 0.29, 0.04, 4);
        let mut m = Mesh::default();
        m.loft(
            &Frame::new(Vec3::ZERO, Vec3::Z, Vec3::X),
            &[
                Ring::apex(0.39),
                Ring::new(0.39, inner.clone()),
                Ring::new(0.0, inner),
                Ring::new(0.0, outer.clone()),
                Ring::new(0.4, outer),
                Ring::apex(0.4),
            ],
            false,
        );
        assert_eq!(m.triangles(), 16 * 8);
        check_outward(&m);
        assert_eq!(pieces(&m), 1);
        // Boxes, spheres and tori are one piece too; two lofts are two.
        let mut m = Mesh::default();
        m.oriented_box(
            Vec3::ONE,
            [Vec3::Z, Vec3::Y, -Vec3::X],
            Vec3::new(1.0, 0.5, 0.2),
        );
        assert_eq!(pieces(&m), 1);
        m.sphere(Vec3::new(5.0, 0.0, 0.0), 1.0, Vec3::ONE, 4, 6);
        m.torus(Vec3::new(-5.0, 0.0, 0.0), Vec3::X, 1.0, 0.1, 8, 6);
        assert_eq!(pieces(&m), 3);
        let mut other = Mesh::default();
        other.loft(
            &Frame::along(Vec3::ZERO, Vec3::Y),
            &[
                Ring::apex(0.0),
                Ring::new(0.0, circle(0.1, 6)),
                Ring::new(0.1, circle(0.1, 6)),
                Ring::apex(0.1),
            ],
            false,
        );
        assert_eq!(other.triangles(), 24);
        check_outward(&other);
        m.append(&other);
        assert_eq!(pieces(&m), 4);
    }
}
