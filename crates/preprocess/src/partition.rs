//! Partitioning (GigaWalk Sections 4.2.1 and 4.2.3): split big, long or
//! uneven parts into sub-parts, recursively, along the longest box axis.
//!
//! Triangles go by centroid and are never cut, so sibling boxes may overlap
//! a little (Bartz's "sloppy" trees); every triangle ends in exactly one part.

use gigawalk_scene::Aabb;
use glam::DVec3;
use rayon::prelude::*;

use crate::parts::{triangle, Part, Piece, Tris};
use crate::source::{Loaded, Source, SpillError};

/// Where a part is cut along the chosen axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SplitAt {
    /// The middle of the box (Partition-I, Section 4.2.1).
    Midpoint,
    /// The mean of the triangle centroids (Partition-II, Section 4.2.3:
    /// "splitting objects about their center of mass").
    CentreOfMass,
}

/// When a part is split: more than `max_triangles` triangles and (box
/// diagonal above `max_diagonal` or aspect ratio above `max_aspect`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitRule {
    pub max_triangles: usize,
    pub max_diagonal: f64,
    pub max_aspect: f64,
    pub at: SplitAt,
}

/// The paper does not define an "unbalanced" split (Section 4.2.1, step 2).
/// We call a split unbalanced when one side gets less than this fraction of
/// the triangles; then the next longest axis is tried, and when every axis
/// is unbalanced the part is cut at its median triangle along the longest
/// axis, so every split makes progress and the recursion depth stays
/// logarithmic in the triangle count.
const MIN_SIDE_FRACTION: f64 = 0.1;

/// Above this many triangles the two halves of a split are processed in
/// parallel; below it the work is too small to be worth a task.
const PARALLEL_SPLIT_TRIANGLES: usize = 32 * 1024;

impl SplitRule {
    pub fn needs_split(&self, triangles: usize, bounds: &Aabb) -> bool {
        triangles > self.max_triangles.max(1)
            && (bounds.diagonal() > self.max_diagonal || aspect_ratio(bounds) > self.max_aspect)
    }
}

/// Largest over smallest box side: infinite for a flat box, 1 for a point.
pub fn aspect_ratio(b: &Aabb) -> f64 {
    let e = b.extent();
    let (hi, lo) = (e.max_element(), e.min_element());
    if hi <= 0.0 {
        1.0
    } else if lo <= 0.0 {
        f64::INFINITY
    } else {
        hi / lo
    }
}

#[derive(Clone, Copy)]
struct Item {
    object: u32,
    triangle: u32,
    centroid: DVec3,
}

/// Splits every part that meets `rule` until none of the results does (or
/// it is down to a single triangle). Parts are processed in parallel; the
/// output order depends only on the input, never on scheduling.
pub fn partition(
    model: &dyn Source,
    parts: Vec<Part>,
    rule: &SplitRule,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Vec<Part>, SpillError> {
    let nested: Vec<Result<Vec<Part>, SpillError>> = parts
        .into_par_iter()
        .map(|p| {
            let n = p.triangles as u64;
            let out = split_part(model, p, rule);
            progress(n);
            out
        })
        .collect();
    let mut out = Vec::new();
    for n in nested {
        out.extend(n?);
    }
    Ok(out)
}

fn split_part(model: &dyn Source, part: Part, rule: &SplitRule) -> Result<Vec<Part>, SpillError> {
    if !rule.needs_split(part.triangles, &part.bounds) {
        return Ok(vec![part]);
    }
    let model = Loaded::of(model, part.pieces.iter().map(|p| p.object))?;
    let model = &model;
    let mut items = Vec::with_capacity(part.triangles);
    for piece in &part.pieces {
        let o = model.get(piece.object);
        items.extend(piece.triangles.iter().map(|t| {
            let [a, b, c] = triangle(o, t);
            Item {
                object: piece.object,
                triangle: t,
                centroid: (a + b + c) / 3.0,
            }
        }));
    }
    drop(part.pieces);
    Ok(split_range(model, &mut items, part.bounds, rule))
}

fn split_range(model: &Loaded, items: &mut [Item], bounds: Aabb, rule: &SplitRule) -> Vec<Part> {
    if !rule.needs_split(items.len(), &bounds) {
        return vec![make_part(model, items, bounds)];
    }
    let mid = cut(items, &bounds, rule.at);
    let (l, r) = items.split_at_mut(mid);
    let (mut left, right) = if l.len() + r.len() > PARALLEL_SPLIT_TRIANGLES {
        rayon::join(
            || split_range(model, l, items_bounds(model, l), rule),
            || split_range(model, r, items_bounds(model, r), rule),
        )
    } else {
        let left = split_range(model, l, items_bounds(model, l), rule);
        (left, split_range(model, r, items_bounds(model, r), rule))
    };
    left.extend(right);
    left
}

/// Reorders `items` so the first `k` go left and the rest right; 0 < k < len.
fn cut(items: &mut [Item], bounds: &Aabb, at: SplitAt) -> usize {
    let n = items.len();
    debug_assert!(n >= 2);
    let e = bounds.extent();
    // Longest axis first; ties broken by axis index so the order is fixed.
    let mut axes = [0usize, 1, 2];
    axes.sort_by(|&a, &b| e[b].total_cmp(&e[a]).then(a.cmp(&b)));
    let split = match at {
        SplitAt::Midpoint => bounds.center(),
        SplitAt::CentreOfMass => items.iter().map(|i| i.centroid).sum::<DVec3>() / n as f64,
    };
    let min_side = ((MIN_SIDE_FRACTION * n as f64).ceil() as usize).max(1);
    for &axis in &axes {
        let s = split[axis];
        let left = items.iter().filter(|i| i.centroid[axis] < s).count();
        if left.min(n - left) >= min_side {
            let mut k = 0;
            for j in 0..n {
                if items[j].centroid[axis] < s {
                    items.swap(k, j);
                    k += 1;
                }
            }
            return k;
        }
    }
    let axis = axes[0];
    let k = n / 2;
    items.select_nth_unstable_by(k, |a, b| {
        a.centroid[axis]
            .total_cmp(&b.centroid[axis])
            .then((a.object, a.triangle).cmp(&(b.object, b.triangle)))
    });
    k
}

fn items_bounds(model: &Loaded, items: &[Item]) -> Aabb {
    let mut b = Aabb::EMPTY;
    for i in items {
        for p in triangle(model.get(i.object), i.triangle) {
            b.grow(p);
        }
    }
    b
}

fn make_part(model: &Loaded, items: &mut [Item], bounds: Aabb) -> Part {
    items.sort_unstable_by_key(|i| (i.object, i.triangle));
    let pieces = items
        .chunk_by(|a, b| a.object == b.object)
        .map(|run| {
            let object = run[0].object;
            let list = run.iter().map(|i| i.triangle).collect();
            Piece {
                object,
                triangles: Tris::of(list, model.get(object).triangle_count()),
            }
        })
        .collect();
    Part {
        pieces,
        bounds,
        triangles: items.len(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::parts::initial_parts;
    use crate::test_models::{box_object, pipe_object};
    use gigawalk_import::Model;

    fn rule(max_triangles: usize, max_diagonal: f64, max_aspect: f64) -> SplitRule {
        SplitRule {
            max_triangles,
            max_diagonal,
            max_aspect,
            at: SplitAt::Midpoint,
        }
    }

    #[test]
    fn long_pipe_is_split_along_its_long_axis() {
        // A pipe along X, 100 long and 2 wide, 20k triangles.
        let m = Model {
            objects: vec![pipe_object(DVec3::ZERO, 100.0, 1.0, 500, 20)],
            ..Default::default()
        };
        let (parts, _) = initial_parts(&m).unwrap();
        let whole = parts[0].bounds;
        let out = partition(&m, parts, &rule(1000, 10.0, 2.5), &|_| {}).unwrap();
        assert!(out.len() >= 8, "{} parts", out.len());
        for p in &out {
            // Each part spans the pipe's full cross-section but only a slice of its length.
            let e = p.bounds.extent();
            assert!(
                e.x < whole.extent().x * 0.5,
                "part {:?} not cut along X",
                p.bounds
            );
            assert!((e.y - whole.extent().y).abs() < 1e-9 && (e.z - whole.extent().z).abs() < 1e-9);
            assert!(!rule(1000, 10.0, 2.5).needs_split(p.triangles, &p.bounds));
        }
        assert_eq!(out.iter().map(|p| p.triangles).sum::<usize>(), 20_000);
    }

    #[test]
    fn small_object_is_left_alone() {
        let m = Model {
            objects: vec![box_object(DVec3::ZERO, DVec3::ONE)],
            ..Default::default()
        };
        let (parts, _) = initial_parts(&m).unwrap();
        let out = partition(&m, parts.clone(), &rule(1000, 0.01, 2.5), &|_| {}).unwrap();
        assert_eq!(out, parts);
    }

    #[test]
    fn coincident_centroids_still_split_to_target() {
        // 4000 identical triangles: no axis separates them; the median cut must.
        let mut o = box_object(DVec3::ZERO, DVec3::ONE);
        let tri = o.indices[..3].to_vec();
        o.indices = tri.iter().copied().cycle().take(3 * 4000).collect();
        let m = Model {
            objects: vec![o],
            ..Default::default()
        };
        let (parts, _) = initial_parts(&m).unwrap();
        let out = partition(&m, parts, &rule(1000, 0.0, 1.0), &|_| {}).unwrap();
        assert!(out.iter().all(|p| p.triangles <= 1000));
        assert_eq!(out.iter().map(|p| p.triangles).sum::<usize>(), 4000);
    }

    #[test]
    fn every_triangle_lands_in_exactly_one_part() {
        let objects = (0..5)
            .map(|i| pipe_object(DVec3::new(0.0, i as f64 * 3.0, 0.0), 40.0, 1.0, 200, 8))
            .collect();
        let m = Model {
            objects,
            ..Default::default()
        };
        let (parts, _) = initial_parts(&m).unwrap();
        let r = SplitRule {
            at: SplitAt::CentreOfMass,
            ..rule(300, 5.0, 2.0)
        };
        let out = partition(&m, parts, &r, &|_| {}).unwrap();
        let mut seen: Vec<(u32, u32)> = out
            .iter()
            .flat_map(|p| {
                p.pieces
                    .iter()
                    .flat_map(|pc| pc.triangles.iter().map(move |t| (pc.object, t)))
            })
            .collect();
        seen.sort_unstable();
        let expect: Vec<(u32, u32)> = (0..5)
            .flat_map(|o| (0..3200).map(move |t| (o, t)))
            .collect();
        assert_eq!(seen, expect);
    }
}
