//! Flat regions of a triangle surface that its triangles cover exactly:
//! a second way to bound a piece's distance to the surface in
//! [`crate::hausdorff`], for the case that costs the most samples there.
//!
//! A simplified level re-triangulates flat regions (a wall, a floor, a
//! tank's flat end): a piece of the original spanning two of the level's
//! coplanar triangles is within none of them alone, so the per-triangle
//! bounds split it down to the sampling floor along every edge of the
//! level. But if the level's triangles around it cover a convex planar
//! region R exactly, every point p is within
//! |n . p - d| + dist2(proj(p), R) of the surface (the first term along
//! the normal, the second within the plane), and both terms are convex in
//! p: over a piece, their maxima are at its corners.
//!
//! A patch is a set of edge-connected triangles on one plane with one
//! orientation. It covers its convex hull exactly when every edge used by
//! one patch triangle only (a boundary edge) lies on the hull's boundary
//! and the triangles' areas sum to the hull's area: the patch's winding
//! number over the hull then changes only across the hull's boundary, and
//! the areas make it 1. An edge used by three or more triangles, or any
//! failed check, leaves the patch out (its triangles get no planar bound).

use glam::{DVec2, DVec3, Vec3A};
use rustc_hash::FxHashMap as HashMap;

/// Relative tolerance of the planarity checks (of the patch's size) and of
/// the area check.
const FLAT: f64 = 1e-7;
const AREA: f64 = 1e-7;

/// A convex planar region covered exactly by some triangles.
#[derive(Clone, Debug)]
struct Region {
    normal: DVec3,
    offset: f64,
    origin: DVec3,
    u: DVec3,
    v: DVec3,
    /// Counter-clockwise hull in (u, v) coordinates about `origin`.
    hull: Vec<DVec2>,
    /// Added to every bound: the planarity tolerance.
    slack: f64,
}

impl Region {
    /// An upper bound on the distance from any point of the triangle with
    /// these corners to the region; infinite once it is known to exceed
    /// `limit`.
    fn bound(&self, corners: &[Vec3A; 3], limit: f64) -> f64 {
        let ps = corners.map(|c| c.as_dvec3());
        let along = ps
            .iter()
            .map(|&p| (self.normal.dot(p) - self.offset).abs())
            .fold(0.0f64, f64::max);
        if along + self.slack > limit {
            return f64::INFINITY;
        }
        let mut within = 0.0f64;
        for p in ps {
            let r = p - self.origin;
            within = within.max(outside(
                &self.hull,
                DVec2::new(r.dot(self.u), r.dot(self.v)),
            ));
        }
        along + within + self.slack
    }
}

/// Distance from `q` to a counter-clockwise convex polygon (0 inside).
fn outside(hull: &[DVec2], q: DVec2) -> f64 {
    let n = hull.len();
    let inside = (0..n).all(|i| {
        let (a, b) = (hull[i], hull[(i + 1) % n]);
        (b - a).perp_dot(q - a) >= 0.0
    });
    if inside {
        return 0.0;
    }
    (0..n)
        .map(|i| {
            let (a, b) = (hull[i], hull[(i + 1) % n]);
            let ab = b - a;
            let t = ((q - a).dot(ab) / ab.length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
            (a + ab * t - q).length()
        })
        .fold(f64::INFINITY, f64::min)
}

/// The planar regions of a surface and which triangle belongs to which.
#[derive(Clone, Debug, Default)]
pub struct Planar {
    /// Per triangle: its region, or `u32::MAX`.
    region: Vec<u32>,
    regions: Vec<Region>,
}

impl Planar {
    pub fn new(tris: &[[Vec3A; 3]]) -> Self {
        let mut out = Planar {
            region: vec![u32::MAX; tris.len()],
            regions: Vec::new(),
        };
        // Vertices by exact position, edges by vertex pair.
        let mut ids: HashMap<[u32; 3], u32> = HashMap::default();
        let mut pos: Vec<DVec3> = Vec::new();
        let tv: Vec<[u32; 3]> = tris
            .iter()
            .map(|t| {
                t.map(|p| {
                    *ids.entry(p.to_array().map(f32::to_bits))
                        .or_insert_with(|| {
                            pos.push(p.as_dvec3());
                            pos.len() as u32 - 1
                        })
                })
            })
            .collect();
        let adj = adjacency(&tv);
        // Each triangle's unit normal, once (a triangle is looked at from
        // each of its neighbours).
        let unit: Vec<Option<DVec3>> = tv
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| pos[i as usize]);
                (b - a).cross(c - a).try_normalize()
            })
            .collect();
        let mut seen = vec![false; tris.len()];
        // Per triangle: the seed of the patch it was last put in.
        let mut patch = vec![u32::MAX; tris.len()];
        for seed in 0..tris.len() {
            if seen[seed] {
                continue;
            }
            seen[seed] = true;
            let Some(n) = unit[seed] else {
                continue;
            };
            let d = n.dot(pos[tv[seed][0] as usize]);
            let size = {
                let [a, b, c] = tv[seed].map(|i| pos[i as usize]);
                (b - a).length().max((c - a).length()).max((c - b).length())
            };
            let mut members = vec![seed as u32];
            let mut next = 0;
            let mut manifold = true;
            while next < members.len() {
                let t_index = members[next] as usize;
                next += 1;
                for &j in &adj[t_index] {
                    manifold &= j != SHARED;
                    if j == BORDER || j == SHARED || seen[j as usize] {
                        continue;
                    }
                    let j = j as usize;
                    let coplanar = unit[j].is_some_and(|m| m.dot(n) > 1.0 - 1e-12)
                        && tv[j]
                            .iter()
                            .all(|&i| (n.dot(pos[i as usize]) - d).abs() <= FLAT * size);
                    if coplanar {
                        seen[j] = true;
                        members.push(j as u32);
                    }
                }
            }
            if members.len() < 2 || !manifold {
                continue;
            }
            for &m in &members {
                patch[m as usize] = seed as u32;
            }
            if let Some(region) = Self::region(&members, &tv, &pos, &adj, &patch, n, d) {
                let id = out.regions.len() as u32;
                out.regions.push(region);
                for &m in &members {
                    out.region[m as usize] = id;
                }
            }
        }
        out
    }

    /// The region `members` cover, if they cover their convex hull exactly.
    fn region(
        members: &[u32],
        tv: &[[u32; 3]],
        pos: &[DVec3],
        adj: &[[u32; 3]],
        patch: &[u32],
        n: DVec3,
        d: f64,
    ) -> Option<Region> {
        let origin = pos[tv[members[0] as usize][0] as usize];
        let u = n.any_orthonormal_vector();
        let v = n.cross(u);
        let to2 = |p: DVec3| {
            let r = p - origin;
            DVec2::new(r.dot(u), r.dot(v))
        };
        let points: Vec<(DVec2, ())> = members
            .iter()
            .flat_map(|&m| tv[m as usize])
            .map(|i| (to2(pos[i as usize]), ()))
            .collect();
        let hull: Vec<DVec2> = hull2(points)?.into_iter().map(|h| h.0).collect();
        let hull_area = area2(&hull);
        let area: f64 = members
            .iter()
            .map(|&m| {
                let [a, b, c] = tv[m as usize].map(|i| pos[i as usize]);
                (b - a).cross(c - a).length() / 2.0
            })
            .sum();
        // NaN-safe: a NaN area fails.
        let close = (hull_area - area).abs() <= AREA * area;
        if !close {
            return None;
        }
        let extent = hull
            .iter()
            .map(|p| p.length())
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
        let tol = 1e-9 * extent;
        // Every boundary edge on the hull's boundary: its midpoint is.
        let mine = patch[members[0] as usize];
        for &m in members {
            let t = tv[m as usize];
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                // Patches are manifold: the edge's other user, if any, is
                // the only one.
                let other = adj[m as usize][k];
                let inside_users = if other != BORDER && patch[other as usize] == mine {
                    2
                } else {
                    1
                };
                if inside_users == 1 {
                    let mid = to2((pos[a as usize] + pos[b as usize]) * 0.5);
                    let on = (0..hull.len()).any(|i| {
                        let (p, q) = (hull[i], hull[(i + 1) % hull.len()]);
                        let e = q - p;
                        let t = (mid - p).dot(e) / e.length_squared().max(f64::MIN_POSITIVE);
                        (-1e-9..=1.0 + 1e-9).contains(&t) && (p + e * t - mid).length() <= tol
                    });
                    if !on {
                        return None;
                    }
                }
            }
        }
        let flat = members
            .iter()
            .flat_map(|&m| tv[m as usize])
            .map(|i| (n.dot(pos[i as usize]) - d).abs())
            .fold(0.0, f64::max);
        Some(Region {
            normal: n,
            offset: d,
            origin,
            u,
            v,
            hull,
            slack: flat + tol,
        })
    }

    /// The best bound the regions of triangles `near` give on the distance
    /// from any point of the triangle `corners` to the surface (infinite
    /// when none of them is in a region, or when a region's is seen to
    /// exceed `limit` before it is complete).
    pub fn bound(&self, corners: &[Vec3A; 3], near: &[u32], limit: f64) -> f64 {
        let mut best = f64::INFINITY;
        for (k, &t) in near.iter().enumerate() {
            let Some(&r) = self.region.get(t as usize) else {
                continue;
            };
            if r == u32::MAX
                || near[..k]
                    .iter()
                    .any(|&o| self.region.get(o as usize) == Some(&r))
            {
                continue;
            }
            best = best.min(self.regions[r as usize].bound(corners, limit));
        }
        best
    }

    /// Regions found (for tests).
    #[cfg(test)]
    pub fn regions(&self) -> usize {
        self.regions.len()
    }
}

/// [`adjacency`]: an edge no other triangle uses.
const BORDER: u32 = u32::MAX;
/// [`adjacency`]: an edge three or more triangles use.
const SHARED: u32 = u32::MAX - 1;

/// Per triangle and edge k (corners k, k + 1): the one other triangle
/// using that edge, [`BORDER`] or [`SHARED`].
fn adjacency(tv: &[[u32; 3]]) -> Vec<[u32; 3]> {
    let mut edges: Vec<(u64, u32)> = Vec::with_capacity(3 * tv.len());
    for (i, t) in tv.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let key = (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
            edges.push((key, 3 * i as u32 + k as u32));
        }
    }
    edges.sort_unstable();
    let mut adj = vec![[BORDER; 3]; tv.len()];
    for group in edges.chunk_by(|x, y| x.0 == y.0) {
        let slot = |e: u32| (e / 3) as usize;
        match group {
            [_] => {}
            [(_, e), (_, f)] => {
                adj[slot(*e)][(e % 3) as usize] = f / 3;
                adj[slot(*f)][(f % 3) as usize] = e / 3;
            }
            _ => {
                for (_, e) in group {
                    adj[slot(*e)][(e % 3) as usize] = SHARED;
                }
            }
        }
    }
    adj
}

/// Convex hull of points in a plane, each carrying `T` along, counter-
/// clockwise (Andrew's monotone chain; collinear points left out);
/// `None` when the points span no area. Of points at one position the
/// first is kept.
pub(crate) fn hull2<T: Copy>(mut p: Vec<(DVec2, T)>) -> Option<Vec<(DVec2, T)>> {
    p.sort_by(|a, b| a.0.x.total_cmp(&b.0.x).then(a.0.y.total_cmp(&b.0.y)));
    p.dedup_by(|a, b| a.0 == b.0);
    if p.len() < 3 {
        return None;
    }
    let turn = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);
    let mut h: Vec<(DVec2, T)> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = h.len();
        let pts: Box<dyn Iterator<Item = &(DVec2, T)>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for &q in pts {
            while h.len() >= start + 2 && turn(h[h.len() - 2].0, h[h.len() - 1].0, q.0) <= 0.0 {
                h.pop();
            }
            h.push(q);
        }
        h.pop();
    }
    (h.len() >= 3).then_some(h)
}

fn area2(poly: &[DVec2]) -> f64 {
    let n = poly.len();
    (0..n)
        .map(|i| poly[i].perp_dot(poly[(i + 1) % n]))
        .sum::<f64>()
        / 2.0
}

#[cfg(test)]
mod tests {
    use rand::rngs::SmallRng;
    use rand::{RngExt, SeedableRng};

    use super::*;

    fn v(x: f32, y: f32, z: f32) -> Vec3A {
        Vec3A::new(x, y, z)
    }

    /// A 4 x 4 grid of quads over [0, 4]^2 in z = 0, two triangles each.
    fn grid() -> Vec<[Vec3A; 3]> {
        let mut out = Vec::new();
        for i in 0..4 {
            for j in 0..4 {
                let (x, y) = (i as f32, j as f32);
                out.push([v(x, y, 0.0), v(x + 1.0, y, 0.0), v(x + 1.0, y + 1.0, 0.0)]);
                out.push([v(x, y, 0.0), v(x + 1.0, y + 1.0, 0.0), v(x, y + 1.0, 0.0)]);
            }
        }
        out
    }

    fn brute(tris: &[[Vec3A; 3]], p: Vec3A) -> f64 {
        tris.iter()
            .map(|t| crate::hausdorff::point_triangle_sq(p, t) as f64)
            .fold(f64::INFINITY, f64::min)
            .sqrt()
    }

    #[test]
    fn a_covered_square_bounds_a_piece_spanning_many_triangles() {
        let tris = grid();
        let p = Planar::new(&tris);
        assert_eq!(p.regions(), 1);
        // A piece 0.25 above the plane spanning most of the grid.
        let piece = [v(0.3, 0.2, 0.25), v(3.7, 0.5, 0.25), v(1.0, 3.9, 0.25)];
        let b = p.bound(&piece, &[0, 5, 30], f64::INFINITY);
        assert!((b - 0.25).abs() < 1e-6, "{b}");
        // A limit only gives up on bounds above it.
        assert_eq!(p.bound(&piece, &[0, 5, 30], 0.3), b);
        assert_eq!(p.bound(&piece, &[0, 5, 30], 0.2), f64::INFINITY);
        // Reaching out of the square by 1: the bound grows by it.
        let out = [v(-1.0, 2.0, 0.0), v(1.0, 2.0, 0.0), v(1.0, 3.0, 0.0)];
        let b = p.bound(&out, &[0], f64::INFINITY);
        assert!((b - 1.0).abs() < 1e-6, "{b}");
        // The bound holds against brute force on random points of pieces.
        let mut rng = SmallRng::seed_from_u64(7);
        let mut r = || rng.random::<f32>();
        for _ in 0..300 {
            let piece = [0, 1, 2].map(|_| v(r() * 6.0 - 1.0, r() * 6.0 - 1.0, r() - 0.5));
            let b = p.bound(&piece, &[3], f64::INFINITY);
            for _ in 0..20 {
                let (a, c) = (r(), r());
                let (a, c) = if a + c > 1.0 {
                    (1.0 - a, 1.0 - c)
                } else {
                    (a, c)
                };
                let q = piece[0] + (piece[1] - piece[0]) * a + (piece[2] - piece[0]) * c;
                assert!(brute(&tris, q) <= b + 1e-5, "{q} {b}");
            }
        }
    }

    #[test]
    fn a_region_with_a_hole_or_a_notch_or_a_fold_gets_no_bound() {
        // The grid without one inner quad: a hole.
        let mut holed = grid();
        holed.drain(10..12);
        assert_eq!(Planar::new(&holed).regions(), 0);
        // Without a corner quad: an L (not convex).
        let mut notched = grid();
        notched.drain(0..2);
        assert_eq!(Planar::new(&notched).regions(), 0);
        // Two triangles on one plane covering the same square twice, with
        // opposite orientation: not one patch.
        let fold = vec![
            [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(1.0, 1.0, 0.0)],
            [v(0.0, 0.0, 0.0), v(1.0, 1.0, 0.0), v(1.0, 0.0, 0.0)],
        ];
        assert_eq!(Planar::new(&fold).regions(), 0);
        // A bent pair: two planes.
        let bent = vec![
            [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(1.0, 1.0, 0.0)],
            [v(0.0, 0.0, 0.0), v(1.0, 1.0, 0.0), v(0.0, 1.0, 0.1)],
        ];
        assert_eq!(Planar::new(&bent).regions(), 0);
        let p = Planar::new(&holed);
        assert_eq!(
            p.bound(&[v(0.0, 0.0, 0.0); 3], &[0, 1], f64::INFINITY),
            f64::INFINITY
        );
    }
}
