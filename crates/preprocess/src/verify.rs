//! Checks a preprocessed scene against its model: the properties the
//! pipeline promises (tree shape, nesting boxes, monotone errors, every
//! input triangle in exactly one leaf's finest LOD, partition targets met).
//! Used by the tests, on hand-built and generated scenes.

use std::collections::HashMap;

use gigawalk_import::Model;
use gigawalk_scene::{Aabb, LodMesh, Node, NO_NODE};
use glam::DVec3;

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
        if let Some(&finest) = errs.first() {
            for c in n.children() {
                let ce = &errors[nodes[c as usize].lods()];
                if let Some(&coarsest) = ce.last() {
                    if finest < coarsest {
                        return Err(format!(
                            "node {i}: finest error {finest} below child {c}'s coarsest {coarsest}"
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
                    if !index.take(&tri, tol) {
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
                    for (cand, used) in list.iter_mut() {
                        if !*used && (0..3).all(|i| cand[i].distance(tri[i]) <= tol) {
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
