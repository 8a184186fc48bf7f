//! Object-space occlusion by a large convex occluder (Coorg and Teller,
//! "Real-Time Occlusion Culling for Models with Large Occluders",
//! Section 2): from the eye position alone, is a box fully hidden behind
//! a convex planar polygon, partly hidden, or not at all?
//!
//! The planes through an occluder edge and a box vertex that touch the
//! box (tangent planes) do not depend on the eye, so they are computed
//! once per (occluder, box) ([`TangentPlanes`]) and the eye is then
//! tested against them by dot products. A *supporting* plane has the
//! occluder and the box on the same side, a *separating* plane on
//! opposite sides; both are oriented toward the occluder. The box is fully
//! occluded when it lies wholly beyond the occluder's plane, the eye is
//! in front of it and on the inner side of every supporting plane (exact,
//! as the paper notes); partly when the eye is on the inner side of every
//! separating plane, or the box reaches both sides of the occluder's
//! plane (conservative: "not even partly" is only said when no point of
//! the box is hidden, so a hierarchy may drop the occluder below it).
//! Walls occlude from both sides. A degenerate plane (a box vertex on an
//! edge's line) counts as not satisfied. Everything is computed relative
//! to the occluder's centroid in f64, so a scene 10^7 units from the
//! origin tests like one at the origin.
//!
//! This is the geometric core of the `ct` culler (crate::ct), with
//! connected occluders ([`connected_fully_occlude`]).

use gigawalk_scene::Aabb;
use glam::DVec3;

/// How much of a box an occluder hides from an eye.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Occlusion {
    None,
    Partial,
    Full,
}

/// A convex planar polygon, vertices in order around it.
#[derive(Clone, Debug, PartialEq)]
pub struct ConvexOccluder {
    /// Vertices relative to `origin`.
    rel: Vec<DVec3>,
    origin: DVec3,
    /// Unit normal; the vertices run counter-clockwise around it.
    normal: DVec3,
}

/// Relative tolerance of the planarity and convexity checks.
const SHAPE_TOLERANCE: f64 = 1e-9;

impl ConvexOccluder {
    /// `None` unless there are at least 3 vertices spanning an area, all on
    /// one plane, making a convex polygon (either winding).
    pub fn new(vertices: &[DVec3]) -> Option<Self> {
        if vertices.iter().any(|v| !v.is_finite()) {
            return None;
        }
        // Repeated vertices would make zero-length edges, whose planes
        // nothing satisfies.
        let mut vertices: Vec<DVec3> = vertices.to_vec();
        vertices.dedup();
        while vertices.len() > 1 && vertices.first() == vertices.last() {
            vertices.pop();
        }
        if vertices.len() < 3 {
            return None;
        }
        let origin = vertices.iter().copied().sum::<DVec3>() / vertices.len() as f64;
        let rel: Vec<DVec3> = vertices.iter().map(|v| *v - origin).collect();
        // Newell's normal: robust for any planar polygon.
        let mut n = DVec3::ZERO;
        for (i, a) in rel.iter().enumerate() {
            let b = rel[(i + 1) % rel.len()];
            n += a.cross(b);
        }
        // Sizes, plus the rounding of coordinates far from the origin.
        let size = rel.iter().map(|v| v.length()).fold(0.0, f64::max)
            + 64.0 * f64::EPSILON * origin.abs().max_element() / SHAPE_TOLERANCE;
        let area = n.length();
        if area.is_nan() || area <= SHAPE_TOLERANCE * size * size {
            return None;
        }
        let normal = n.normalize();
        let flat = rel
            .iter()
            .all(|v| normal.dot(*v).abs() <= SHAPE_TOLERANCE * size);
        let convex = (0..rel.len()).all(|i| {
            let (a, b, c) = (rel[i], rel[(i + 1) % rel.len()], rel[(i + 2) % rel.len()]);
            normal.dot((b - a).cross(c - b)) >= -SHAPE_TOLERANCE * size * size
        });
        (flat && convex).then_some(ConvexOccluder {
            rel,
            origin,
            normal,
        })
    }

    pub fn normal(&self) -> DVec3 {
        self.normal
    }

    /// The mean of the vertices (what the rest is relative to).
    pub fn centroid(&self) -> DVec3 {
        self.origin
    }

    /// World-space vertices.
    pub fn vertices(&self) -> impl Iterator<Item = DVec3> + '_ {
        self.rel.iter().map(|v| *v + self.origin)
    }

    /// The polygon's area.
    pub fn area(&self) -> f64 {
        let mut n = DVec3::ZERO;
        for (a, b) in self.edges() {
            n += a.cross(b);
        }
        0.5 * n.length()
    }

    /// The part on the side of the plane through `point` that `normal`
    /// points to (points on the plane kept); `None` when too little is
    /// left to be an occluder.
    pub fn clipped(&self, point: DVec3, normal: DVec3) -> Option<ConvexOccluder> {
        let side = |v: DVec3| (v - point).dot(normal);
        let mut out = Vec::with_capacity(self.rel.len() + 1);
        for (a, b) in self.edges() {
            let (a, b) = (a + self.origin, b + self.origin);
            let (sa, sb) = (side(a), side(b));
            if sa >= 0.0 {
                out.push(a);
            }
            if (sa >= 0.0) != (sb >= 0.0) {
                // Where the edge crosses the plane, pulled onto the kept
                // side if rounding left it just outside.
                let mut x = a + (b - a) * (sa / (sa - sb));
                let sx = side(x);
                if sx < 0.0 {
                    x -= normal * (sx / normal.length_squared());
                }
                out.push(x);
            }
        }
        ConvexOccluder::new(&out)
    }

    fn edges(&self) -> impl Iterator<Item = (DVec3, DVec3)> + '_ {
        (0..self.rel.len()).map(|i| (self.rel[i], self.rel[(i + 1) % self.rel.len()]))
    }
}

/// A plane through `point` (relative to the occluder's origin) whose
/// positive side `normal . (x - point) > 0` is the satisfied one.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Plane {
    point: DVec3,
    normal: DVec3,
}

impl Plane {
    /// Strictly on the positive side, beyond rounding.
    fn satisfied(&self, p: DVec3) -> bool {
        let d = p - self.point;
        self.normal.dot(d) > 1e-12 * self.normal.length() * d.length()
    }
}

/// The eye-independent part of the test for one (occluder, box) pair.
#[derive(Clone, Debug, PartialEq)]
pub struct TangentPlanes {
    origin: DVec3,
    /// The occluder's plane, positive on the side away from the box;
    /// `None` when the box reaches both sides of it (never fully
    /// occluded; partly, for all the test knows).
    front: Option<Plane>,
    /// One per occluder edge; `None` for an edge with no proper one
    /// (degenerate), which no eye satisfies.
    supporting: Vec<Option<Plane>>,
    separating: Vec<Option<Plane>>,
}

fn corners(b: &Aabb, origin: DVec3) -> [DVec3; 8] {
    let (lo, hi) = (b.min - origin, b.max - origin);
    std::array::from_fn(|i| {
        DVec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

impl TangentPlanes {
    pub fn new(occluder: &ConvexOccluder, b: &Aabb) -> Self {
        let origin = occluder.origin;
        let c = corners(b, origin);
        let n = occluder.normal;
        let extent = c.iter().map(|v| v.length()).fold(0.0, f64::max)
            + occluder.rel.iter().map(|v| v.length()).fold(0.0, f64::max);
        let eps = 1e-12 * extent.max(f64::MIN_POSITIVE);
        // The box must lie wholly on one side of the occluder's plane.
        let side: Vec<f64> = c.iter().map(|v| n.dot(*v)).collect();
        let front = if side.iter().all(|&s| s < -eps) {
            Some(Plane {
                point: DVec3::ZERO,
                normal: n,
            })
        } else if side.iter().all(|&s| s > eps) {
            Some(Plane {
                point: DVec3::ZERO,
                normal: -n,
            })
        } else {
            None
        };
        let mut supporting = Vec::new();
        let mut separating = Vec::new();
        for (a, e) in occluder.edges() {
            let dir = e - a;
            // The occluder's side of any plane through this edge: its
            // centroid (the origin) lies strictly inside.
            let (mut sup, mut sep) = (None, None);
            for &v in &c {
                let m = dir.cross(v - a);
                let scale = m.length();
                if scale.is_nan() || scale <= eps * dir.length().max(f64::MIN_POSITIVE) {
                    continue; // the vertex is on the edge's line
                }
                let tol = 1e-12 * scale * extent;
                let q = m.dot(-a); // the occluder's centroid
                if q.abs() <= tol {
                    continue; // the occluder's own plane
                }
                let s = q.signum();
                let all = |same: bool| {
                    c.iter().all(|&w| {
                        let d = m.dot(w - a) * s;
                        if same {
                            d >= -tol
                        } else {
                            d <= tol
                        }
                    })
                };
                let plane = Plane {
                    point: a,
                    normal: m * s,
                };
                if sup.is_none() && all(true) {
                    sup = Some(plane);
                }
                if sep.is_none() && all(false) {
                    sep = Some(plane);
                }
            }
            supporting.push(sup);
            separating.push(sep);
        }
        TangentPlanes {
            origin,
            front,
            supporting,
            separating,
        }
    }

    /// How much of the box the occluder hides from `eye`.
    pub fn classify(&self, eye: DVec3) -> Occlusion {
        let Some(front) = self.front else {
            return Occlusion::Partial;
        };
        let e = eye - self.origin;
        if !front.satisfied(e) {
            return Occlusion::None;
        }
        let all =
            |planes: &[Option<Plane>]| planes.iter().all(|p| p.is_some_and(|p| p.satisfied(e)));
        if all(&self.supporting) {
            Occlusion::Full
        } else if all(&self.separating) {
            Occlusion::Partial
        } else {
            Occlusion::None
        }
    }
}

/// An edge two occluders of a set share: (occluder, its edge, occluder,
/// its edge), occluders by their index in the set, edge i running from
/// vertex i to vertex i + 1.
pub type SharedEdge = (usize, usize, usize, usize);

/// Connected occluders (Coorg and Teller, Figs. 3-5): occluders that share
/// edges may hide together a box that none hides alone. Two occluders are
/// joined across a shared edge when the box lies beyond both planes with
/// the eye in front of both and the edge is not a silhouette edge from the
/// eye (the eye's plane through it has the two occluders on opposite
/// sides; Fig. 4 shows why a silhouette edge cannot be ignored). A joined
/// group of two or more hides the box when one of them partly hides it and
/// the eye is inside every supporting plane of every member except those
/// through the group's joining edges.
///
/// Why that is conservative, for any number of occluders: seen from the
/// eye, the group is a surface that does not fold at its joining edges,
/// so the outline of its image is made of the other edges only. The box's
/// image lies on the inner side of each of those edges' lines (their
/// supporting planes), so it crosses no part of the outline; it is
/// connected and meets the group's image (one member partly hides it), so
/// it lies inside it. Every ray to the box therefore meets some member,
/// and meets it before the box (the box is beyond every member's plane).
/// An outline that is not convex from the eye (Fig. 5b) or a group with a
/// hole fails the test; disconnected occluders (Fig. 5c) are never joined.
/// `shared` names the edges shared in `members`; a pair that is not the
/// same segment (up to rounding) is ignored.
pub fn connected_fully_occlude(
    members: &[(&ConvexOccluder, &TangentPlanes)],
    shared: &[SharedEdge],
    eye: DVec3,
) -> bool {
    let n = members.len();
    if n < 2 {
        return false;
    }
    let front: Vec<bool> = members
        .iter()
        .map(|(o, t)| t.front.is_some_and(|f| f.satisfied(eye - o.origin)))
        .collect();
    let mut group: Vec<usize> = (0..n).collect();
    fn root(group: &mut [usize], mut i: usize) -> usize {
        while group[i] != i {
            group[i] = group[group[i]];
            i = group[i];
        }
        i
    }
    let mut joining: Vec<(usize, usize)> = Vec::new();
    for &(i, ei, j, ej) in shared {
        if i >= n || j >= n || i == j || !front[i] || !front[j] {
            continue;
        }
        let (a, b) = (members[i].0, members[j].0);
        if ei >= a.rel.len() || ej >= b.rel.len() || !joined(a, ei, b, ej, eye) {
            continue;
        }
        joining.extend([(i, ei), (j, ej)]);
        let (ri, rj) = (root(&mut group, i), root(&mut group, j));
        group[ri] = rj;
    }
    if joining.is_empty() {
        return false;
    }
    let roots: Vec<usize> = (0..n).map(|i| root(&mut group, i)).collect();
    let mut seen = vec![false; n];
    for &r in &roots {
        if std::mem::replace(&mut seen[r], true) {
            continue;
        }
        let group: Vec<usize> = (0..n).filter(|&i| roots[i] == r).collect();
        if group.len() < 2 {
            continue;
        }
        let all = |planes: &[Option<Plane>], e: DVec3, skip: &dyn Fn(usize) -> bool| {
            planes
                .iter()
                .enumerate()
                .all(|(k, p)| skip(k) || p.is_some_and(|p| p.satisfied(e)))
        };
        let partly = group.iter().any(|&m| {
            let (o, t) = members[m];
            all(&t.separating, eye - o.origin, &|_| false)
        });
        let inside = group.iter().all(|&m| {
            let (o, t) = members[m];
            all(&t.supporting, eye - o.origin, &|k| {
                joining.contains(&(m, k))
            })
        });
        if partly && inside {
            return true;
        }
    }
    false
}

/// Whether edge `ea` of `a` and edge `eb` of `b` are the same segment and
/// not a silhouette edge from `eye`.
fn joined(a: &ConvexOccluder, ea: usize, b: &ConvexOccluder, eb: usize, eye: DVec3) -> bool {
    let edge = |o: &ConvexOccluder, i: usize| {
        let n = o.rel.len();
        (o.rel[i % n] + o.origin, o.rel[(i + 1) % n] + o.origin)
    };
    let ((p0, p1), (q0, q1)) = (edge(a, ea), edge(b, eb));
    // The same segment, up to the rounding of each occluder's vertices
    // about its own centroid.
    let tol = 1e-9 * (p1 - p0).length() + 1e-12 * p0.abs().max_element();
    let same = |u: DVec3, v: DVec3| (u - v).abs().max_element() <= tol;
    if !((same(p0, q0) && same(p1, q1)) || (same(p0, q1) && same(p1, q0))) {
        return false;
    }
    // Not a silhouette edge: the plane through the eye and the edge has
    // the two occluders' centroids strictly on opposite sides.
    let m = (p1 - p0).cross(eye - p0);
    let (sa, sb) = (m.dot(a.origin - p0), m.dot(b.origin - p0));
    let tol = 1e-12 * m.length() * ((a.origin - p0).length() + (b.origin - p0).length());
    sa * sb < 0.0 && sa.abs() > tol && sb.abs() > tol
}

/// [`connected_fully_occlude`] for two occluders sharing one edge (`ea`
/// of `a`, `eb` of `b`); `false` when they are not the same segment.
pub fn pair_fully_occludes(
    (a, pa, ea): (&ConvexOccluder, &TangentPlanes, usize),
    (b, pb, eb): (&ConvexOccluder, &TangentPlanes, usize),
    eye: DVec3,
) -> bool {
    connected_fully_occlude(&[(a, pa), (b, pb)], &[(0, ea, 1, eb)], eye)
}

/// [`TangentPlanes::new`] then [`TangentPlanes::classify`].
pub fn occlusion(occluder: &ConvexOccluder, b: &Aabb, eye: DVec3) -> Occlusion {
    TangentPlanes::new(occluder, b).classify(eye)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether the segment from `eye` to `p` crosses the occluder at a
    /// point at least `margin` inside it (negative: up to -margin outside),
    /// and `p` is beyond its plane by `margin`.
    fn hidden(o: &ConvexOccluder, eye: DVec3, p: DVec3, margin: f64) -> bool {
        let (eye, p) = (eye - o.origin, p - o.origin);
        let n = o.normal;
        let (de, dp) = (n.dot(eye), n.dot(p));
        if de.signum() == dp.signum() || dp.abs() < margin || de.abs() < margin {
            return false;
        }
        let t = de / (de - dp);
        let x = eye + (p - eye) * t;
        o.edges().all(|(a, b)| {
            let inward = n.cross(b - a).normalize();
            inward.dot(x - a) >= margin
        })
    }

    use crate::test_rng::Lcg;

    /// A random convex polygon: a regular k-gon, squashed, rotated, moved.
    fn polygon(rng: &mut Lcg, at: DVec3) -> (ConvexOccluder, DVec3) {
        let k = 3 + (rng.unit() * 6.0) as usize;
        let (rx, ry) = (rng.range(1.0, 6.0), rng.range(1.0, 6.0));
        let normal = rng.vec(1.0).normalize_or(DVec3::Z);
        let u = normal.any_orthonormal_vector();
        let v = normal.cross(u);
        let verts: Vec<DVec3> = (0..k)
            .map(|i| {
                let a = i as f64 / k as f64 * std::f64::consts::TAU;
                at + u * (rx * a.cos()) + v * (ry * a.sin())
            })
            .collect();
        (
            ConvexOccluder::new(&verts).expect("a convex polygon"),
            normal,
        )
    }

    fn check_random_cases(offset: DVec3) {
        let mut rng = Lcg(11);
        let (mut full, mut partial) = (0, 0);
        for _ in 0..3000 {
            let at = offset + rng.vec(2.0);
            let (o, n) = polygon(&mut rng, at);
            // A box behind the occluder, an eye in front of it.
            let c = offset + n * -rng.range(0.5, 12.0) + rng.vec(3.0);
            let h = DVec3::new(
                rng.range(0.05, 2.0),
                rng.range(0.05, 2.0),
                rng.range(0.05, 2.0),
            );
            let b = Aabb::new(c - h, c + h);
            let eye = offset + n * rng.range(0.2, 15.0) + rng.vec(4.0);
            let got = occlusion(&o, &b, eye);
            let cs = corners(&b, DVec3::ZERO);
            // Exact for full occlusion, away from the boundary.
            let strict = cs.iter().all(|&p| hidden(&o, eye, p, 1e-6));
            let loose = cs.iter().all(|&p| hidden(&o, eye, p, -1e-6));
            if got == Occlusion::Full {
                assert!(loose, "full, but a corner shows: {o:?} {b:?} {eye}");
                full += 1;
            }
            if strict {
                assert_eq!(got, Occlusion::Full, "{o:?} {b:?} {eye}");
            }
            // Conservative for partial: "none" only when no point of the
            // box is hidden (sampled: corners, centre, face centres).
            if got == Occlusion::None {
                let samples =
                    cs.iter().copied().chain([c]).chain(
                        (0..3).flat_map(|a| [-1.0, 1.0].map(|s| c + DVec3::AXES[a] * h[a] * s)),
                    );
                for p in samples {
                    assert!(!hidden(&o, eye, p, 1e-6), "none, but {p} is hidden");
                }
            } else if got == Occlusion::Partial {
                partial += 1;
            }
        }
        assert!(
            full > 100 && partial > 100,
            "{full} full, {partial} partial"
        );
    }

    #[test]
    fn full_occlusion_is_exact_and_none_is_conservative_against_brute_force() {
        check_random_cases(DVec3::ZERO);
    }

    #[test]
    fn far_from_the_origin_the_test_is_the_same() {
        check_random_cases(DVec3::new(1e7, -3e7, 2e7));
    }

    #[test]
    fn boxes_in_front_of_or_through_the_plane_are_never_fully_occluded() {
        let o = ConvexOccluder::new(&[
            DVec3::new(-5.0, -5.0, 0.0),
            DVec3::new(5.0, -5.0, 0.0),
            DVec3::new(5.0, 5.0, 0.0),
            DVec3::new(-5.0, 5.0, 0.0),
        ])
        .unwrap();
        let eye = DVec3::new(0.0, 0.0, 10.0);
        let behind = Aabb::new(DVec3::new(-1.0, -1.0, -3.0), DVec3::new(1.0, 1.0, -2.0));
        let through = Aabb::new(DVec3::new(-1.0, -1.0, -3.0), DVec3::new(1.0, 1.0, 1.0));
        let front = Aabb::new(DVec3::new(-1.0, -1.0, 2.0), DVec3::new(1.0, 1.0, 3.0));
        assert_eq!(occlusion(&o, &behind, eye), Occlusion::Full);
        assert_eq!(occlusion(&o, &front, eye), Occlusion::None);
        // From behind the box, nothing is hidden (walls occlude from both
        // sides only with the eye on the far side of the box).
        assert_eq!(
            occlusion(&o, &behind, DVec3::new(0.0, 0.0, -10.0)),
            Occlusion::None
        );
        // Seen from the side, the box peeks out: partly hidden; from far to
        // the side, not at all.
        assert_eq!(
            occlusion(&o, &behind, DVec3::new(20.0, 0.0, 10.0)),
            Occlusion::Partial
        );
        assert_eq!(
            occlusion(&o, &behind, DVec3::new(60.0, 0.0, 10.0)),
            Occlusion::None
        );
        // A box through the plane may be partly hidden.
        assert_eq!(occlusion(&o, &through, eye), Occlusion::Partial);
    }

    /// Whether `p` is hidden from `eye` by either occluder.
    fn hidden_by_either(a: &ConvexOccluder, b: &ConvexOccluder, eye: DVec3, p: DVec3) -> bool {
        hidden(a, eye, p, 1e-9) || hidden(b, eye, p, 1e-9)
    }

    /// Points on the box's surface: a 6 x 6 grid on every face.
    fn surface(b: &Aabb) -> Vec<DVec3> {
        let mut out = Vec::new();
        let e = b.max - b.min;
        for axis in 0..3 {
            for side in [0.0, 1.0] {
                for i in 0..6 {
                    for j in 0..6 {
                        let (u, v) = (i as f64 / 5.0, j as f64 / 5.0);
                        let mut t = [0.0; 3];
                        t[axis] = side;
                        t[(axis + 1) % 3] = u;
                        t[(axis + 2) % 3] = v;
                        out.push(b.min + e * DVec3::from(t));
                    }
                }
            }
        }
        out
    }

    fn quad(v: [[f64; 3]; 4]) -> ConvexOccluder {
        ConvexOccluder::new(&v.map(DVec3::from)).unwrap()
    }

    #[test]
    fn two_panels_sharing_an_edge_hide_a_box_neither_hides_alone() {
        // Fig. 3, flat: a 2 x 1 wall in z = 0 made of two unit squares
        // sharing the edge x = 0; a box behind the seam.
        let a = quad([
            [-1.0, 0.0, 0.0],
            [0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [-1.0, 1.0, 0.0],
        ]);
        let b = quad([
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ]);
        let bx = Aabb::new(DVec3::new(-0.2, 0.3, -2.0), DVec3::new(0.2, 0.6, -1.5));
        let eye = DVec3::new(0.05, 0.45, 3.0);
        let (ta, tb) = (TangentPlanes::new(&a, &bx), TangentPlanes::new(&b, &bx));
        assert_eq!(ta.classify(eye), Occlusion::Partial);
        assert_eq!(tb.classify(eye), Occlusion::Partial);
        // a's edge 1 runs (0,0) -> (0,1); b's edge 3 runs (0,1) -> (0,0).
        assert!(pair_fully_occludes((&a, &ta, 1), (&b, &tb, 3), eye));
        assert!(surface(&bx)
            .iter()
            .all(|&p| hidden_by_either(&a, &b, eye, p)));
        // Not the shared edge: no joint occlusion.
        assert!(!pair_fully_occludes((&a, &ta, 0), (&b, &tb, 3), eye));
        // From far to the side the box shows beside the wall.
        let side = DVec3::new(6.0, 0.45, 3.0);
        assert!(!pair_fully_occludes((&a, &ta, 1), (&b, &tb, 3), side));
    }

    #[test]
    fn seen_across_a_ridge_joint_occlusion_stays_conservative() {
        // Fig. 4: a roof ridge seen from the side of one slope, so the
        // ridge is a silhouette edge: a box behind the ridge peeks over it.
        let a = quad([
            [-1.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 1.0],
            [-1.0, 1.0, 1.0],
        ]);
        let b = quad([
            [-1.0, 1.0, 1.0],
            [1.0, 1.0, 1.0],
            [1.0, 0.0, 2.0],
            [-1.0, 0.0, 2.0],
        ]);
        let bx = Aabb::new(DVec3::new(-0.2, 0.0, 0.6), DVec3::new(0.2, 0.3, 1.4));
        for eye in [DVec3::new(0.0, 3.0, -4.0), DVec3::new(0.1, 0.8, -3.0)] {
            let (ta, tb) = (TangentPlanes::new(&a, &bx), TangentPlanes::new(&b, &bx));
            let full = pair_fully_occludes((&a, &ta, 2), (&b, &tb, 0), eye);
            if full {
                assert!(
                    surface(&bx)
                        .iter()
                        .all(|&p| hidden_by_either(&a, &b, eye, p)),
                    "{eye}"
                );
            }
        }
    }

    #[test]
    fn connected_occlusion_never_hides_a_visible_point() {
        let mut rng = Lcg(21);
        let mut full = 0;
        for _ in 0..3000 {
            // Two panels sharing an edge along y, bent by a random angle.
            let h = rng.range(0.5, 3.0);
            let (w1, w2) = (rng.range(0.5, 3.0), rng.range(0.5, 3.0));
            let bend = rng.range(-1.2, 1.2);
            let p0 = DVec3::new(0.0, 0.0, 0.0);
            let p1 = DVec3::new(0.0, h, 0.0);
            let da = DVec3::new(-w1, 0.0, 0.0);
            let db = DVec3::new(w2 * bend.cos(), 0.0, w2 * bend.sin());
            let a = ConvexOccluder::new(&[p0 + da, p0, p1, p1 + da]).unwrap();
            let b = ConvexOccluder::new(&[p0, p0 + db, p1 + db, p1]).unwrap();
            let c = DVec3::new(
                rng.range(-1.0, 1.0),
                rng.range(0.0, h),
                -rng.range(0.3, 4.0),
            );
            let e = DVec3::new(
                rng.range(0.05, 0.6),
                rng.range(0.05, 0.6),
                rng.range(0.05, 0.6),
            );
            let bx = Aabb::new(c - e, c + e);
            let eye = DVec3::new(
                rng.range(-3.0, 3.0),
                rng.range(-1.0, h + 1.0),
                rng.range(1.0, 8.0),
            );
            let (ta, tb) = (TangentPlanes::new(&a, &bx), TangentPlanes::new(&b, &bx));
            // a's edge 1 is p0 -> p1, b's edge 3 is p1 -> p0.
            if pair_fully_occludes((&a, &ta, 1), (&b, &tb, 3), eye) {
                full += 1;
                for p in surface(&bx) {
                    assert!(
                        hidden_by_either(&a, &b, eye, p),
                        "{p} shows; eye {eye}, bend {bend}"
                    );
                }
            }
        }
        assert!(
            full > 50,
            "only {full} jointly hidden cases: the test proves little"
        );
    }

    /// A strip of `widths.len()` panels of height `h` along y, each bent
    /// from the one before by `bends[i]` radians about their shared edge;
    /// panel i's edge 1 is shared with panel i + 1's edge 3.
    fn strip(h: f64, widths: &[f64], bends: &[f64]) -> (Vec<ConvexOccluder>, Vec<SharedEdge>) {
        let mut at = DVec3::ZERO;
        let mut angle: f64 = 0.0;
        let mut out = Vec::new();
        for (&w, &bend) in widths.iter().zip(bends) {
            angle += bend;
            let next = at + DVec3::new(angle.cos(), 0.0, angle.sin()) * w;
            let up = DVec3::Y * h;
            out.push(ConvexOccluder::new(&[at, next, next + up, at + up]).unwrap());
            at = next;
        }
        let shared = (0..out.len().saturating_sub(1))
            .map(|i| (i, 1, i + 1, 3))
            .collect();
        (out, shared)
    }

    #[test]
    fn chains_of_connected_occluders_never_hide_a_visible_point_and_hide_what_no_pair_does() {
        let mut rng = Lcg(31);
        let (mut full, mut only_chain) = (0, 0);
        for _ in 0..3000 {
            let n = 3 + (rng.unit() * 3.0) as usize;
            let h = rng.range(1.0, 3.0);
            let widths: Vec<f64> = (0..n).map(|_| rng.range(0.3, 1.5)).collect();
            let bends: Vec<f64> = (0..n)
                .map(|i| if i == 0 { 0.0 } else { rng.range(-0.6, 0.6) })
                .collect();
            let (panels, shared) = strip(h, &widths, &bends);
            let span = widths.iter().sum::<f64>();
            let c = DVec3::new(
                rng.range(0.0, span * 0.8),
                rng.range(0.0, h),
                -rng.range(1.0, 5.0),
            );
            let e = DVec3::new(
                rng.range(0.05, 0.8),
                rng.range(0.05, 0.6),
                rng.range(0.05, 0.6),
            );
            let bx = Aabb::new(c - e, c + e);
            let eye = DVec3::new(
                rng.range(-2.0, span + 2.0),
                rng.range(-1.0, h + 1.0),
                rng.range(2.0, 10.0),
            );
            let planes: Vec<TangentPlanes> =
                panels.iter().map(|p| TangentPlanes::new(p, &bx)).collect();
            let members: Vec<(&ConvexOccluder, &TangentPlanes)> =
                panels.iter().zip(&planes).collect();
            if !connected_fully_occlude(&members, &shared, eye) {
                continue;
            }
            full += 1;
            for p in surface(&bx) {
                assert!(
                    panels.iter().any(|o| hidden(o, eye, p, 1e-9)),
                    "{p} shows; eye {eye}, widths {widths:?}, bends {bends:?}"
                );
            }
            let by_one = planes.iter().any(|t| t.classify(eye) == Occlusion::Full);
            let by_pair = shared.iter().any(|&(i, ei, j, ej)| {
                pair_fully_occludes(
                    (&panels[i], &planes[i], ei),
                    (&panels[j], &planes[j], ej),
                    eye,
                )
            });
            if !by_one && !by_pair {
                only_chain += 1;
            }
        }
        assert!(
            full > 100 && only_chain > 20,
            "{full} hidden, {only_chain} only by a chain: the test proves little"
        );
    }

    #[test]
    fn a_ring_with_a_hole_does_not_hide_what_shows_through_the_hole() {
        // The eight unit squares of a 3 x 3 wall in z = 0 around its empty
        // centre, each sharing whole edges with its neighbours; a box
        // behind the hole, a little larger than it, is partly hidden by
        // the ring but shows through the hole.
        let cells: Vec<(i32, i32)> = (0..3)
            .flat_map(|x| (0..3).map(move |y| (x, y)))
            .filter(|&c| c != (1, 1))
            .collect();
        let panels: Vec<ConvexOccluder> = cells
            .iter()
            .map(|&(x, y)| {
                let (x, y) = (x as f64, y as f64);
                quad([
                    [x, y, 0.0],
                    [x + 1.0, y, 0.0],
                    [x + 1.0, y + 1.0, 0.0],
                    [x, y + 1.0, 0.0],
                ])
            })
            .collect();
        // Edge 1 (right) of (x, y) is edge 3 (left) of (x + 1, y); edge 2
        // (top) of (x, y) is edge 0 (bottom) of (x, y + 1).
        let at = |c: (i32, i32)| cells.iter().position(|&d| d == c);
        let mut shared: Vec<SharedEdge> = Vec::new();
        for (i, &(x, y)) in cells.iter().enumerate() {
            if let Some(j) = at((x + 1, y)) {
                shared.push((i, 1, j, 3));
            }
            if let Some(j) = at((x, y + 1)) {
                shared.push((i, 2, j, 0));
            }
        }
        assert_eq!(shared.len(), 8);
        let bx = Aabb::new(DVec3::new(0.7, 0.7, -1.2), DVec3::new(2.3, 2.3, -1.0));
        let eye = DVec3::new(1.5, 1.5, 4.0);
        let planes: Vec<TangentPlanes> =
            panels.iter().map(|p| TangentPlanes::new(p, &bx)).collect();
        let members: Vec<_> = panels.iter().zip(&planes).collect();
        assert!(planes.iter().any(|t| t.classify(eye) == Occlusion::Partial));
        assert!(!connected_fully_occlude(&members, &shared, eye));
        // The same wall with its centre: the box is hidden.
        let mut whole = panels.clone();
        whole.push(quad([
            [1.0, 1.0, 0.0],
            [2.0, 1.0, 0.0],
            [2.0, 2.0, 0.0],
            [1.0, 2.0, 0.0],
        ]));
        let centre = whole.len() - 1;
        for (i, &(x, y)) in cells.iter().enumerate() {
            match (x, y) {
                (0, 1) => shared.push((i, 1, centre, 3)),
                (2, 1) => shared.push((centre, 1, i, 3)),
                (1, 0) => shared.push((i, 2, centre, 0)),
                (1, 2) => shared.push((centre, 2, i, 0)),
                _ => {}
            }
        }
        let planes: Vec<TangentPlanes> = whole.iter().map(|p| TangentPlanes::new(p, &bx)).collect();
        let members: Vec<_> = whole.iter().zip(&planes).collect();
        assert!(connected_fully_occlude(&members, &shared, eye));
    }

    #[test]
    fn non_planar_non_convex_and_degenerate_polygons_are_refused() {
        let sq = |z: f64| {
            vec![
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(1.0, 0.0, 0.0),
                DVec3::new(1.0, 1.0, z),
                DVec3::new(0.0, 1.0, 0.0),
            ]
        };
        assert!(ConvexOccluder::new(&sq(0.0)).is_some());
        assert!(ConvexOccluder::new(&sq(0.1)).is_none());
        let dart = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 1.0, 0.0),
            DVec3::new(0.0, 2.0, 0.0),
            DVec3::new(0.5, 1.0, 0.0),
        ];
        assert!(ConvexOccluder::new(&dart).is_none());
        let line = [DVec3::ZERO, DVec3::X, DVec3::X * 2.0];
        assert!(ConvexOccluder::new(&line).is_none());
        assert!(ConvexOccluder::new(&[DVec3::ZERO, DVec3::X]).is_none());
        assert!(ConvexOccluder::new(&[DVec3::ZERO, DVec3::X, DVec3::NAN]).is_none());
    }
}
