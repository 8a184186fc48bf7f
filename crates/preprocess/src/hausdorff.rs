//! Measured LOD errors: an upper bound on the Hausdorff distance between two
//! triangle surfaces, from points sampled on them and a nearest-triangle
//! query through a BVH (obvhs).
//!
//! A simplifier's own error figure is an estimate (meshopt: a quadric
//! distance, or a grid cell for sloppy clustering), not a bound: a thin
//! sheet collapses to nothing with the error of its thickness. What the
//! runtime's pixel tolerance needs is a bound on how far a LOD's surface is
//! from the surface it stands for, both ways: no original point farther
//! from the LOD than the error (nothing vanished), no LOD point farther
//! from the original (nothing appeared).
//!
//! The bound. Every point p of a triangle T of surface A lies within
//! `cover(T)` of one of the samples s taken on T, and the distance to B is
//! 1-Lipschitz, so d(p, B) <= d(s, B) + cover(T). Hence
//! H(A -> B) <= max over samples of d(s, B) + max over triangles of
//! cover(T). Samples are the vertices, plus, for a triangle whose vertices
//! alone cover it too coarsely, the vertices of a regular barycentric
//! subdivision into m x m sub-triangles. Any point of a triangle with
//! longest edge L lies within L / sqrt(3) of one of its vertices (at most
//! the circumradius, L / (2 sin C) with C >= 60 degrees the angle opposite
//! L, for a non-obtuse triangle; at most L / 2 for an obtuse one), so
//! cover(T) = L / (m sqrt(3)).
//!
//! The subdivision is chosen from a first pass over the vertices: with
//! their largest distance M, triangles are subdivided until their cover is
//! at most `spacing` x M (a relative sampling density), but never finer
//! than `floor` (an absolute length: an exactly kept surface has M = 0 and
//! would otherwise need infinitely many samples) and never into more than
//! [`MAX_SUBDIVISION`]^2 pieces (a huge triangle then keeps a larger
//! cover, which the bound includes). So the bound is at most about
//! (1 + spacing) x the true distance, plus the floor.
//!
//! Queries run in f32 on positions relative to a nearby origin; the bound
//! adds [`ROUNDING`] x the surfaces' extent for the arithmetic's rounding.

use glam::{DVec3, Vec3A};
use obvhs::{
    aabb::Aabb as BvhAabb,
    bvh2::{builder::build_bvh2, Bvh2},
    BvhBuildParams,
};

/// Most sub-triangles per edge of one triangle (so at most
/// (m + 1)(m + 2) / 2 = 2145 samples per triangle).
pub const MAX_SUBDIVISION: u32 = 64;

/// Relative slack for f32 rounding in the closest-point arithmetic (about
/// 10 ulps of the largest coordinate).
pub const ROUNDING: f32 = 1e-6;

/// How densely surfaces are sampled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sampling {
    /// Cover of a triangle's samples, as a fraction of the largest vertex
    /// distance found (the bound exceeds the truth by at most about this
    /// fraction).
    pub spacing: f32,
    /// The finest cover aimed for, in model units.
    pub floor: f32,
}

/// A triangle surface: positions (relative to some origin) and indices.
#[derive(Clone, Copy, Debug)]
pub struct Surface<'a> {
    pub positions: &'a [[f32; 3]],
    pub indices: &'a [u32],
}

impl Surface<'_> {
    fn triangle(&self, t: usize) -> [Vec3A; 3] {
        let p = |k: usize| Vec3A::from_array(self.positions[self.indices[3 * t + k] as usize]);
        [p(0), p(1), p(2)]
    }

    fn triangles(&self) -> usize {
        self.indices.len() / 3
    }

    /// The largest absolute coordinate, for the rounding slack.
    fn magnitude(&self) -> f32 {
        self.positions
            .iter()
            .map(|p| p[0].abs().max(p[1].abs()).max(p[2].abs()))
            .fold(0.0, f32::max)
    }
}

/// Nearest-triangle queries on one surface.
pub struct Nearest {
    tris: Vec<[Vec3A; 3]>,
    bvh: Bvh2,
    stack: Vec<u32>,
    /// The triangle that answered the last query: neighbouring samples are
    /// usually answered by it again, without a traversal.
    hint: usize,
}

impl Nearest {
    pub fn new(s: Surface<'_>) -> Self {
        let tris: Vec<[Vec3A; 3]> = (0..s.triangles()).map(|t| s.triangle(t)).collect();
        let boxes: Vec<BvhAabb> = tris
            .iter()
            .map(|t| BvhAabb::new(t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2])))
            .collect();
        let bvh = if boxes.is_empty() {
            Bvh2::default()
        } else {
            build_bvh2(
                &boxes,
                BvhBuildParams::fast_build(),
                &mut Default::default(),
            )
        };
        Nearest {
            tris,
            bvh,
            stack: Vec::new(),
            hint: 0,
        }
    }

    /// `None` when some triangle is within `r` of `p` (the caller's running
    /// maximum: such a sample cannot raise it); otherwise the exact
    /// distance to the nearest triangle (infinite for an empty surface).
    pub fn beyond(&mut self, p: Vec3A, r: f32) -> Option<f32> {
        if self.tris.is_empty() {
            return Some(f32::INFINITY);
        }
        let r2 = r * r;
        let mut best = point_triangle_sq(p, &self.tris[self.hint]);
        if best <= r2 {
            return None;
        }
        let nodes = &self.bvh.nodes;
        self.stack.clear();
        self.stack.push(0);
        while let Some(ni) = self.stack.pop() {
            let node = &nodes[ni as usize];
            if box_sq(p, node.aabb()) >= best {
                continue;
            }
            if node.is_leaf() {
                for k in node.first_index..node.first_index + node.prim_count {
                    let t = self.bvh.primitive_indices[k as usize] as usize;
                    let d = point_triangle_sq(p, &self.tris[t]);
                    if d < best {
                        best = d;
                        self.hint = t;
                        if best <= r2 {
                            return None;
                        }
                    }
                }
            } else {
                // Visit the nearer child first (pushed last).
                let (a, b) = (node.first_index, node.first_index + 1);
                let (da, db) = (
                    box_sq(p, nodes[a as usize].aabb()),
                    box_sq(p, nodes[b as usize].aabb()),
                );
                if da <= db {
                    self.stack.push(b);
                    self.stack.push(a);
                } else {
                    self.stack.push(a);
                    self.stack.push(b);
                }
            }
        }
        Some(best.sqrt())
    }
}

/// Upper bound on the one-sided Hausdorff distance from `a` to the surface
/// `b` answers for: every point of `a` is within the result of `b`.
/// Infinite when `b` is empty and `a` is not; 0 when `a` is empty.
pub fn one_sided(a: Surface<'_>, b: &mut Nearest, sampling: &Sampling) -> f32 {
    if a.triangles() == 0 {
        return 0.0;
    }
    // Pass 1: the vertices (only those triangles use).
    let mut max = 0.0f32;
    let mut seen = vec![false; a.positions.len()];
    for &i in a.indices {
        let i = i as usize;
        if std::mem::replace(&mut seen[i], true) {
            continue;
        }
        if let Some(d) = b.beyond(Vec3A::from_array(a.positions[i]), max) {
            max = d;
        }
    }
    if !max.is_finite() {
        return f32::INFINITY;
    }
    // Pass 2: subdivide the triangles the vertices cover too coarsely.
    let target = (sampling.spacing * max).max(sampling.floor);
    let inv_sqrt3 = 1.0 / 3.0f32.sqrt();
    let mut cover = 0.0f32;
    for t in 0..a.triangles() {
        let [p0, p1, p2] = a.triangle(t);
        let longest = (p1 - p0)
            .length()
            .max((p2 - p1).length())
            .max((p0 - p2).length());
        let whole = longest * inv_sqrt3;
        if whole <= target || !(whole > 0.0) {
            cover = cover.max(whole);
            continue;
        }
        let m = ((whole / target).ceil() as u32).clamp(2, MAX_SUBDIVISION);
        cover = cover.max(whole / m as f32);
        let (e1, e2) = ((p1 - p0) / m as f32, (p2 - p0) / m as f32);
        for i in 0..=m {
            for j in 0..=m - i {
                // The corners are vertices, measured in pass 1.
                if (i == 0 && (j == 0 || j == m)) || (i == m && j == 0) {
                    continue;
                }
                let s = p0 + e1 * i as f32 + e2 * j as f32;
                if let Some(d) = b.beyond(s, max) {
                    max = d;
                }
            }
        }
    }
    let slack = ROUNDING * a.magnitude().max(b.magnitude());
    max + cover + slack
}

impl Nearest {
    fn magnitude(&self) -> f32 {
        self.tris
            .iter()
            .flatten()
            .map(|p| p.abs().max_element())
            .fold(0.0, f32::max)
    }
}

/// Upper bound on the symmetric Hausdorff distance between `reference`
/// (with its prepared queries) and `lod`.
pub fn symmetric(
    reference: Surface<'_>,
    reference_queries: &mut Nearest,
    lod: Surface<'_>,
    sampling: &Sampling,
) -> f32 {
    let mut to_lod = Nearest::new(lod);
    let forward = one_sided(reference, &mut to_lod, sampling);
    let backward = one_sided(lod, reference_queries, sampling);
    forward.max(backward)
}

/// Squared distance from `p` to a box (0 inside).
fn box_sq(p: Vec3A, b: &BvhAabb) -> f32 {
    let d = (b.min - p).max(p - b.max).max(Vec3A::ZERO);
    d.length_squared()
}

/// Squared distance from `p` to a triangle (Ericson, Real-Time Collision
/// Detection, 5.1.5: the Voronoi regions of the vertices, edges and face).
/// In f64: on a sliver (a 10 x 0.01 box face) the f32 products of the
/// region tests lose about a tenth of the sliver's width.
pub(crate) fn point_triangle_sq(p: Vec3A, t: &[Vec3A; 3]) -> f32 {
    point_triangle_sq64(
        p.as_dvec3(),
        [t[0].as_dvec3(), t[1].as_dvec3(), t[2].as_dvec3()],
    ) as f32
}

fn point_triangle_sq64(p: DVec3, t: [DVec3; 3]) -> f64 {
    let [a, b, c] = t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.length_squared();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.length_squared();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (p - (a + ab * v)).length_squared();
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.length_squared();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (p - (a + ac * w)).length_squared();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (p - (b + (c - b) * w)).length_squared();
    }
    let denom = va + vb + vc;
    if !(denom.abs() > 0.0) || !denom.is_finite() {
        // Degenerate (zero-area) triangle: nearest of its edges.
        return seg_sq(p, a, b).min(seg_sq(p, b, c)).min(seg_sq(p, c, a));
    }
    let (v, w) = (vb / denom, vc / denom);
    (p - (a + ab * v + ac * w)).length_squared()
}

fn seg_sq(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let l = ab.length_squared();
    let t = if l > 0.0 {
        ((p - a).dot(ab) / l).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + ab * t)).length_squared()
}

#[cfg(test)]
mod tests {
    use super::*;

    const S: Sampling = Sampling {
        spacing: 0.25,
        floor: 1e-3,
    };

    fn quad(z: f32, size: f32) -> (Vec<[f32; 3]>, Vec<u32>) {
        (
            vec![
                [0.0, 0.0, z],
                [size, 0.0, z],
                [size, size, z],
                [0.0, size, z],
            ],
            vec![0, 1, 2, 0, 2, 3],
        )
    }

    fn surface<'a>(m: &'a (Vec<[f32; 3]>, Vec<u32>)) -> Surface<'a> {
        Surface {
            positions: &m.0,
            indices: &m.1,
        }
    }

    #[test]
    fn point_triangle_regions() {
        let t = [Vec3A::ZERO, Vec3A::X, Vec3A::Y];
        let check = |p: Vec3A, want: f32| {
            let got = point_triangle_sq(p, &t).sqrt();
            assert!((got - want).abs() < 1e-6, "{p:?}: {got} vs {want}");
        };
        check(Vec3A::new(0.2, 0.2, 1.0), 1.0); // face
        check(Vec3A::new(-1.0, -1.0, 0.0), 2.0f32.sqrt()); // vertex a
        check(Vec3A::new(0.5, -2.0, 0.0), 2.0); // edge ab
        check(Vec3A::new(1.0, 1.0, 0.0), 0.5f32.sqrt()); // edge bc
        check(Vec3A::new(3.0, 0.0, 0.0), 2.0); // vertex b
                                               // Degenerate triangle: a segment.
        let seg = [Vec3A::ZERO, Vec3A::X, Vec3A::X * 2.0];
        assert!((point_triangle_sq(Vec3A::new(1.0, 1.0, 0.0), &seg) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn point_on_a_sliver_is_on_it() {
        // A 10 x 0.01 face of a thin box, far from the origin's scale.
        let t = [
            Vec3A::new(5.0, -5.0, -0.005),
            Vec3A::new(5.0, 5.0, -0.005),
            Vec3A::new(5.0, 5.0, 0.005),
        ];
        let p = t[0] + (t[1] - t[0]) * 0.7 + (t[2] - t[0]) * 0.2;
        assert!(point_triangle_sq(p, &t).sqrt() < 1e-6);
    }

    #[test]
    fn identical_surfaces_are_within_the_floor() {
        let m = quad(0.0, 10.0);
        let mut q = Nearest::new(surface(&m));
        let h = symmetric(surface(&m), &mut q, surface(&m), &S);
        // One triangle of side 10 needs the cap: cover = 14.1 / (64 sqrt 3).
        assert!(h <= 14.2 / (64.0 * 3.0f32.sqrt()) + 1e-4, "{h}");
    }

    #[test]
    fn parallel_sheets_are_their_gap_apart() {
        let a = quad(0.0, 1.0);
        let b = quad(0.5, 1.0);
        let mut qa = Nearest::new(surface(&a));
        let h = symmetric(surface(&a), &mut qa, surface(&b), &S);
        assert!((0.5..=0.5 * 1.25 + 1e-3).contains(&h), "{h}");
    }

    #[test]
    fn a_hole_in_the_middle_is_found_by_interior_samples() {
        // B: a ring around a 2 x 2 hole in a 6 x 6 square; A: the full
        // square, whose corners B keeps. The hole's centre is 1 from B.
        let ring: (Vec<[f32; 3]>, Vec<u32>) = {
            let xs = [0.0, 2.0, 4.0, 6.0];
            let mut p = Vec::new();
            for y in xs {
                for x in xs {
                    p.push([x, y, 0.0]);
                }
            }
            let mut idx = Vec::new();
            for cy in 0..3u32 {
                for cx in 0..3u32 {
                    if (cx, cy) == (1, 1) {
                        continue;
                    }
                    let v = cy * 4 + cx;
                    idx.extend([v, v + 1, v + 5, v, v + 5, v + 4]);
                }
            }
            (p, idx)
        };
        let full = quad(0.0, 6.0);
        let mut q = Nearest::new(surface(&ring));
        let h = one_sided(surface(&full), &mut q, &S);
        assert!(h >= 1.0, "{h}");
        // The other way nothing is missing.
        let mut qf = Nearest::new(surface(&full));
        assert!(one_sided(surface(&ring), &mut qf, &S) < 0.1);
    }

    #[test]
    fn vanished_piece_costs_its_distance() {
        let a = quad(0.0, 1.0);
        let mut both = quad(0.0, 1.0);
        let far = quad(7.0, 1.0);
        both.1.extend(far.1.iter().map(|i| i + 4));
        both.0.extend(far.0);
        let mut qa = Nearest::new(surface(&a));
        let h = symmetric(surface(&both), &mut qa, surface(&a), &S);
        assert!((7.0..7.0 * 1.25 + 1e-3).contains(&h), "{h}");
    }

    #[test]
    fn empty_surfaces() {
        let a = quad(0.0, 1.0);
        let empty: (Vec<[f32; 3]>, Vec<u32>) = (vec![], vec![]);
        let mut qe = Nearest::new(surface(&empty));
        assert_eq!(one_sided(surface(&a), &mut qe, &S), f32::INFINITY);
        let mut qa = Nearest::new(surface(&a));
        assert_eq!(one_sided(surface(&empty), &mut qa, &S), 0.0);
    }
}
