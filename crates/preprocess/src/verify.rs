//! Checks a preprocessed scene against its model: the properties the
//! pipeline promises (tree shape, nesting boxes, monotone errors, every
//! input triangle in exactly one leaf's finest LOD, partition targets met).
//! Used by the tests, on hand-built and generated scenes.

use std::collections::HashMap;

use gigawalk_import::Model;
use gigawalk_scene::{Aabb, LodMesh, Node, NO_NODE};
use glam::DVec3;
use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};

use crate::partition::{aspect_ratio, SplitRule};

/// What [`verify`] counted.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Verified {
    pub leaves: usize,
    pub matched_triangles: usize,
}

/// Checks `nodes` with LOD errors `errors` and geometry `mesh(lod)`
/// against `model`. `targets`, when given, is the Partition-II rule every
/// leaf must meet unless it is a single triangle. Returns the first
/// violation found, described.
pub fn verify(
    model: &Model,
    nodes: &[Node],
    errors: &[f32],
    mesh: &mut dyn FnMut(u32) -> LodMesh,
    targets: Option<&SplitRule>,
) -> Result<Verified, String> {
    if nodes.is_empty() || nodes[0].parent != NO_NODE {
        return Err("node 0 is not a root".into());
    }
    let mut reached = vec![false; nodes.len()];
    reached[0] = true;
    let model_size = model
        .objects
        .iter()
        .flat_map(|o| o.positions.iter().copied())
        .fold(Aabb::EMPTY, |mut b, p| {
            b.grow(p);
            b
        })
        .diagonal();
    let tol = 1e-5 * model_size.max(1e-30);
    let mut index = TriangleIndex::new(model, 1e-3 * model_size.max(1e-30));
    let mut out = Verified::default();
    for (i, n) in nodes.iter().enumerate() {
        for c in n.children() {
            let child = nodes
                .get(c as usize)
                .ok_or(format!("node {i}: child {c} out of range"))?;
            if c as usize <= i || child.parent != i as u32 {
                return Err(format!(
                    "node {i}: child {c} is before it or names another parent"
                ));
            }
            reached[c as usize] = true;
            if !n.bounds.contains_box(&child.bounds) {
                return Err(format!("node {i}: box does not contain child {c}'s box"));
            }
        }
        let errs = errors
            .get(n.lods())
            .ok_or(format!("node {i}: LODs out of range"))?;
        if errs.windows(2).any(|w| w[1] < w[0]) {
            return Err(format!("node {i}: LOD errors {errs:?} decrease"));
        }
        if n.is_leaf() && errs.is_empty() {
            return Err(format!("leaf {i} has no LOD"));
        }
        // An HLOD is built from child levels at least as fine as each
        // child's finest and claims at least their error.
        if let Some(&finest) = errs.first() {
            for c in n.children() {
                let ce = &errors[nodes[c as usize].lods()];
                if let Some(&child_finest) = ce.first() {
                    if finest < child_finest {
                        return Err(format!(
                            "node {i}: finest error {finest} below child {c}'s finest {child_finest}"
                        ));
                    }
                }
            }
        }
        for l in n.lods() {
            let m = mesh(l as u32);
            for p in &m.positions {
                let w = m.origin + glam::Vec3::from_array(*p).as_dvec3();
                if Aabb::new(
                    n.bounds.min - DVec3::splat(tol),
                    n.bounds.max + DVec3::splat(tol),
                )
                .distance_to_point(w)
                    > 0.0
                {
                    return Err(format!(
                        "node {i}: LOD {l} vertex {w} outside the box {:?}",
                        n.bounds
                    ));
                }
            }
            if l == n.first_lod as usize && n.is_leaf() {
                out.leaves += 1;
                let tris = m.triangle_count();
                if let Some(rule) = targets {
                    let b = Aabb::from_points(
                        m.positions
                            .iter()
                            .map(|p| m.origin + glam::Vec3::from_array(*p).as_dvec3()),
                    );
                    // A little slack: the box here is of f32-rounded positions.
                    let relaxed = SplitRule {
                        max_diagonal: rule.max_diagonal * (1.0 + 1e-5) + tol,
                        max_aspect: rule.max_aspect * (1.0 + 1e-5),
                        ..*rule
                    };
                    if tris > 1 && relaxed.needs_split(tris, &b) {
                        return Err(format!(
                            "leaf {i}: {tris} triangles, diagonal {}, aspect {} miss the partition targets {rule:?}",
                            b.diagonal(),
                            aspect_ratio(&b)
                        ));
                    }
                }
                for t in 0..tris {
                    let v = |k: usize| {
                        m.origin
                            + glam::Vec3::from_array(m.positions[m.indices[3 * t + k] as usize])
                                .as_dvec3()
                    };
                    let tri = [v(0), v(1), v(2)];
                    // Full detail is the input moved by no more than its
                    // stored error (a position grid's step; 0 stored raw).
                    if !index.take(&tri, tol + errs[0] as f64) {
                        return Err(format!(
                            "leaf {i}: triangle {t} {tri:?} matches no unused input triangle"
                        ));
                    }
                    out.matched_triangles += 1;
                }
            }
        }
    }
    if let Some(i) = reached.iter().position(|r| !r) {
        return Err(format!("node {i} is not reachable from the root"));
    }
    if index.left > 0 {
        return Err(format!(
            "{} input triangles are in no leaf's finest LOD",
            index.left
        ));
    }
    Ok(out)
}

/// Input triangles hashed by centroid cell, each usable once.
struct TriangleIndex {
    cell: f64,
    cells: HashMap<[i64; 3], Vec<([DVec3; 3], bool)>>,
    left: usize,
}

impl TriangleIndex {
    fn new(model: &Model, cell: f64) -> Self {
        let mut s = TriangleIndex {
            cell,
            cells: HashMap::new(),
            left: 0,
        };
        for o in &model.objects {
            for t in o.indices.chunks_exact(3) {
                let tri = [
                    o.positions[t[0] as usize],
                    o.positions[t[1] as usize],
                    o.positions[t[2] as usize],
                ];
                let degenerate = t[0] == t[1]
                    || t[1] == t[2]
                    || t[0] == t[2]
                    || (tri[1] - tri[0]).cross(tri[2] - tri[0]).length_squared() == 0.0;
                if !degenerate {
                    s.cells
                        .entry(s.key((tri[0] + tri[1] + tri[2]) / 3.0))
                        .or_default()
                        .push((tri, false));
                    s.left += 1;
                }
            }
        }
        s
    }

    fn key(&self, p: DVec3) -> [i64; 3] {
        let q = (p / self.cell).floor();
        [q.x as i64, q.y as i64, q.z as i64]
    }

    /// Marks an unused input triangle with the same corners (in order,
    /// within `tol`) as used; false when there is none.
    fn take(&mut self, tri: &[DVec3; 3], tol: f64) -> bool {
        let k = self.key((tri[0] + tri[1] + tri[2]) / 3.0);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(list) = self.cells.get_mut(&[k[0] + dx, k[1] + dy, k[2] + dz]) else {
                        continue;
                    };
                    // Any rotation of the corners (an encoded scene's
                    // index codec may start a triangle at another corner;
                    // the winding is kept).
                    let matches = |cand: &[DVec3; 3]| {
                        (0..3).any(|r| (0..3).all(|i| cand[(i + r) % 3].distance(tri[i]) <= tol))
                    };
                    for (cand, used) in list.iter_mut() {
                        if !*used && matches(cand) {
                            *used = true;
                            self.left -= 1;
                            return true;
                        }
                    }
                }
            }
        }
        false
    }
}

/// What [`check_error_bounds`] measured.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BoundCheck {
    /// (node, LOD) pairs checked.
    pub lods: usize,
    /// Sample points tested against a stored error.
    pub samples: usize,
    /// Largest ratio of a sample's distance to its LOD's stored error:
    /// at most 1 when every error is a bound; how tight the bounds are.
    pub worst_ratio: f64,
}

/// Brute-force check that every stored LOD error is a bound, both ways:
/// points sampled at random on the full-detail surface a node stands for
/// (its leaves' finest levels, which are the input triangles) lie within
/// the LOD's error of the LOD, and points sampled on the LOD lie within it
/// of that surface. `samples` random points per surface, plus every
/// vertex; `nodes_to_check` limits the nodes (all when `None`). Written
/// apart from `hausdorff.rs` (its own BVH queries, an independent sample
/// set), so it checks that code rather than repeating it.
pub fn check_error_bounds(
    nodes: &[Node],
    errors: &[f32],
    mesh: &mut dyn FnMut(u32) -> LodMesh,
    nodes_to_check: Option<&[u32]>,
    samples: usize,
    seed: u64,
) -> Result<BoundCheck, String> {
    let mut rng = SmallRng::seed_from_u64(seed);
    let all: Vec<u32> = (0..nodes.len() as u32).collect();
    let mut out = BoundCheck::default();
    for &ni in nodes_to_check.unwrap_or(&all) {
        let node = &nodes[ni as usize];
        if node.lods().is_empty() {
            continue;
        }
        let centre = node.bounds.center();
        // The original surface: the finest level of every leaf below.
        let mut original = Tris::default();
        let mut stack = vec![ni];
        while let Some(n) = stack.pop() {
            let nd = &nodes[n as usize];
            if nd.is_leaf() {
                original.add(&mesh(nd.first_lod), centre);
            } else {
                stack.extend(nd.children());
            }
        }
        let original_samples = original.samples(samples, &mut rng);
        let original_q = original.queries();
        for l in node.lods() {
            let e = errors[l];
            let mut lod = Tris::default();
            lod.add(&mesh(l as u32), centre);
            let lod_q = lod.queries();
            // f32 rounding of positions relative to two origins.
            let slack =
                1e-5 * (node.bounds.diagonal() as f32 + centre.abs().max_element() as f32 * 1e-2);
            let checks = [
                (&original_samples, &lod, &lod_q, "original point", "the LOD"),
                (
                    &lod.samples(samples, &mut rng),
                    &original,
                    &original_q,
                    "LOD point",
                    "the original",
                ),
            ];
            for (points, target, q, what, to) in checks {
                for p in points.iter() {
                    let d = target.nearest_within(q, *p, e + slack);
                    out.samples += 1;
                    match d {
                        Some(d) => {
                            if e > 0.0 {
                                out.worst_ratio = out.worst_ratio.max(d as f64 / e as f64);
                            }
                        }
                        None => {
                            let d = target
                                .nearest_within(q, *p, f32::INFINITY)
                                .unwrap_or(f32::INFINITY);
                            return Err(format!(
                                "node {ni} LOD {l}: {what} {p:?} is {d} from {to}, stored error {e}"
                            ));
                        }
                    }
                }
            }
            out.lods += 1;
        }
    }
    Ok(out)
}

/// Triangles in f32 relative to a node's centre.
#[derive(Default)]
struct Tris(Vec<[glam::Vec3A; 3]>);

impl Tris {
    fn add(&mut self, m: &LodMesh, centre: DVec3) {
        let shift = (m.origin - centre).as_vec3a();
        let p = |i: u32| glam::Vec3A::from_array(m.positions[i as usize]) + shift;
        for t in m.indices.chunks_exact(3) {
            self.0.push([p(t[0]), p(t[1]), p(t[2])]);
        }
    }

    /// Every vertex, and `n` points uniform over the area.
    fn samples(&self, n: usize, rng: &mut SmallRng) -> Vec<glam::Vec3A> {
        let mut out: Vec<glam::Vec3A> = self.0.iter().flatten().copied().collect();
        let areas: Vec<f32> = self
            .0
            .iter()
            .scan(0.0f32, |acc, [a, b, c]| {
                *acc += (*b - *a).cross(*c - *a).length();
                Some(*acc)
            })
            .collect();
        let Some(&total) = areas.last() else {
            return out;
        };
        for _ in 0..n {
            let at = rng.random_range(0.0..total);
            let t = areas.partition_point(|&x| x < at).min(self.0.len() - 1);
            let [a, b, c] = self.0[t];
            let (mut u, mut v): (f32, f32) = (rng.random(), rng.random());
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            out.push(a + (b - a) * u + (c - a) * v);
        }
        out
    }

    fn queries(&self) -> obvhs::bvh2::Bvh2 {
        let boxes: Vec<obvhs::aabb::Aabb> = self
            .0
            .iter()
            .map(|[a, b, c]| obvhs::aabb::Aabb::new(a.min(*b).min(*c), a.max(*b).max(*c)))
            .collect();
        if boxes.is_empty() {
            return Default::default();
        }
        obvhs::bvh2::builder::build_bvh2(
            &boxes,
            obvhs::BvhBuildParams::fast_build(),
            &mut Default::default(),
        )
    }

    /// The nearest triangle's distance if one is within `r` of `p`.
    fn nearest_within(&self, bvh: &obvhs::bvh2::Bvh2, p: glam::Vec3A, r: f32) -> Option<f32> {
        let reach = if r.is_finite() { r } else { f32::MAX / 4.0 };
        let query = obvhs::aabb::Aabb::new(p - reach, p + reach);
        let mut best: Option<f32> = None;
        bvh.aabb_traverse(query, |bvh, node| {
            let n = &bvh.nodes[node as usize];
            for k in n.first_index..n.first_index + n.prim_count {
                let t = &self.0[bvh.primitive_indices[k as usize] as usize];
                let d = crate::hausdorff::point_triangle_sq(p, t).sqrt();
                if d <= r && best.is_none_or(|b| d < b) {
                    best = Some(d);
                }
            }
            true
        });
        best
    }
}
