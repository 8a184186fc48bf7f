//! Large convex occluders for object-space culling (Coorg and Teller):
//! the planar faces of a model's objects that are convex polygons, such as
//! building walls and floors, tank and wall panels.
//!
//! An object's positions are welded (vertices closer than 1e-9 of the
//! object's size are one), its triangles grouped into connected coplanar
//! patches (sharing welded edges, normals within 1e-6 rad, the same plane
//! within 1e-6 of the size), and a patch is kept when it is convex (the
//! area of its outline's convex hull equals its triangles' area within
//! 1e-6) and at least `min_area`. Its polygon is that hull. A non-convex
//! patch (an L-shaped wall) is skipped: the test needs convex occluders.
//!
//! Preprocess keeps the [`MAX_OCCLUDERS`] largest faces of the model of at
//! least [`MIN_OCCLUDER_SIZE`] squared (of the model's diagonal) in the
//! scene file's OCCL section, for the `ct` culler.

use std::collections::HashMap;

use glam::DVec3;

/// Most occluders a scene keeps (the largest).
pub const MAX_OCCLUDERS: usize = 4096;
/// Smallest occluder side kept, as a fraction of the model's diagonal
/// (its area must reach this squared).
pub const MIN_OCCLUDER_SIZE: f64 = 0.005;

/// The scene's occluders: every object's convex faces of at least
/// `(MIN_OCCLUDER_SIZE x diagonal)^2`, the [`MAX_OCCLUDERS`] largest.
pub fn scene_occluders(
    model: &gigawalk_import::Model,
) -> Vec<gigawalk_scene::occluders::OccluderRecord> {
    let (lo, hi) = model.objects.iter().flat_map(|o| &o.positions).fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let diag = (hi - lo).length();
    if !diag.is_finite() {
        return Vec::new();
    }
    let min_area = (MIN_OCCLUDER_SIZE * diag).powi(2);
    let mut all: Vec<OccluderPolygon> = model
        .objects
        .iter()
        .flat_map(|o| convex_faces(&o.positions, &o.indices, min_area))
        .filter(|o| o.vertices.len() <= gigawalk_scene::occluders::MAX_OCCLUDER_VERTICES)
        .collect();
    all.sort_by(|a, b| b.area.total_cmp(&a.area));
    all.truncate(MAX_OCCLUDERS);
    all.into_iter()
        .map(|o| gigawalk_scene::occluders::OccluderRecord {
            vertices: o.vertices,
            area: o.area,
        })
        .collect()
}

/// A convex planar polygon, vertices in order around its normal.
#[derive(Clone, Debug, PartialEq)]
pub struct OccluderPolygon {
    pub vertices: Vec<DVec3>,
    pub normal: DVec3,
    pub area: f64,
}

/// The convex planar faces of a triangle mesh with area at least
/// `min_area`, largest first.
pub fn convex_faces(positions: &[DVec3], indices: &[u32], min_area: f64) -> Vec<OccluderPolygon> {
    let (lo, hi) = positions.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let size = (hi - lo).max_element();
    if !(size.is_finite() && size > 0.0) {
        return Vec::new();
    }
    // Weld: quantize to a grid of 1e-9 of the size.
    let step = size * 1e-9;
    let mut ids: HashMap<[i64; 3], u32> = HashMap::new();
    let mut welded: Vec<DVec3> = Vec::new();
    let weld: Vec<u32> = positions
        .iter()
        .map(|p| {
            let k = ((*p - lo) / step).round();
            let key = [k.x as i64, k.y as i64, k.z as i64];
            *ids.entry(key).or_insert_with(|| {
                welded.push(*p);
                welded.len() as u32 - 1
            })
        })
        .collect();
    let tris: Vec<[u32; 3]> = indices
        .chunks_exact(3)
        .filter(|t| t.iter().all(|&i| (i as usize) < weld.len()))
        .map(|t| {
            [
                weld[t[0] as usize],
                weld[t[1] as usize],
                weld[t[2] as usize],
            ]
        })
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
        .collect();
    let normal = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| welded[i as usize]);
        (b - a).cross(c - a)
    };
    let mut by_edge: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
    for (i, t) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            by_edge.entry((a.min(b), a.max(b))).or_default().push(i);
        }
    }
    // Connected coplanar patches.
    let mut patch = vec![usize::MAX; tris.len()];
    let mut out = Vec::new();
    for seed in 0..tris.len() {
        if patch[seed] != usize::MAX {
            continue;
        }
        let n0 = normal(&tris[seed]);
        let Some(n) = n0.try_normalize() else {
            continue;
        };
        let d = n.dot(welded[tris[seed][0] as usize]);
        let coplanar = |t: &[u32; 3]| {
            normal(t)
                .try_normalize()
                .is_some_and(|m| m.dot(n) > 1.0 - 1e-12)
                && t.iter()
                    .all(|&i| (n.dot(welded[i as usize]) - d).abs() <= 1e-6 * size)
        };
        let mut members = vec![seed];
        patch[seed] = seed;
        let mut next = 0;
        while next < members.len() {
            let t = tris[members[next]];
            next += 1;
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                for &j in &by_edge[&(a.min(b), a.max(b))] {
                    if patch[j] == usize::MAX && coplanar(&tris[j]) {
                        patch[j] = seed;
                        members.push(j);
                    }
                }
            }
        }
        let area: f64 = members
            .iter()
            .map(|&i| normal(&tris[i]).length() / 2.0)
            .sum();
        if area < min_area {
            continue;
        }
        let points: Vec<DVec3> = members
            .iter()
            .flat_map(|&i| tris[i])
            .map(|i| welded[i as usize])
            .collect();
        if let Some(hull) = convex_hull_on_plane(&points, n) {
            let hull_area = polygon_area(&hull, n);
            if (hull_area - area).abs() <= 1e-6 * area {
                out.push(OccluderPolygon {
                    vertices: hull,
                    normal: n,
                    area,
                });
            }
        }
    }
    out.sort_by(|a, b| b.area.total_cmp(&a.area));
    out
}

/// The convex hull of points on a plane with normal `n`, counter-clockwise
/// around `n` (Andrew's monotone chain in the plane's own coordinates).
fn convex_hull_on_plane(points: &[DVec3], n: DVec3) -> Option<Vec<DVec3>> {
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    let origin = *points.first()?;
    let mut p: Vec<(f64, f64, DVec3)> = points
        .iter()
        .map(|q| {
            let r = *q - origin;
            (r.dot(u), r.dot(v), *q)
        })
        .collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    p.dedup_by(|a, b| a.0 == b.0 && a.1 == b.1);
    if p.len() < 3 {
        return None;
    }
    let cross = |o: &(f64, f64, DVec3), a: &(f64, f64, DVec3), b: &(f64, f64, DVec3)| {
        (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
    };
    let mut hull: Vec<(f64, f64, DVec3)> = Vec::new();
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &(f64, f64, DVec3)>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for q in iter {
            while hull.len() >= start + 2
                && cross(&hull[hull.len() - 2], &hull[hull.len() - 1], q) <= 0.0
            {
                hull.pop();
            }
            hull.push(*q);
        }
        hull.pop();
    }
    (hull.len() >= 3).then(|| hull.into_iter().map(|h| h.2).collect())
}

fn polygon_area(poly: &[DVec3], n: DVec3) -> f64 {
    let o = poly[0];
    (1..poly.len() - 1)
        .map(|i| n.dot((poly[i] - o).cross(poly[i + 1] - o)) / 2.0)
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A box as 12 triangles with unshared vertices per face (as flat
    /// shading writes it), shifted by `at`.
    fn boxed(at: DVec3, e: DVec3) -> (Vec<DVec3>, Vec<u32>) {
        let c = |i: u32| {
            at + DVec3::new(
                if i & 1 != 0 { e.x } else { 0.0 },
                if i & 2 != 0 { e.y } else { 0.0 },
                if i & 4 != 0 { e.z } else { 0.0 },
            )
        };
        let faces = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let (mut p, mut idx) = (Vec::new(), Vec::new());
        for f in faces {
            let base = p.len() as u32;
            p.extend(f.map(c));
            idx.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
        }
        (p, idx)
    }

    #[test]
    fn a_box_has_six_convex_faces_with_their_areas() {
        for at in [DVec3::ZERO, DVec3::new(1e7, -2e7, 3e6)] {
            let (p, i) = boxed(at, DVec3::new(10.0, 4.0, 0.5));
            let f = convex_faces(&p, &i, 0.0);
            assert_eq!(f.len(), 6, "{at}");
            let mut areas: Vec<f64> = f.iter().map(|o| o.area).collect();
            areas.sort_by(f64::total_cmp);
            for (a, want) in areas.iter().zip([2.0, 2.0, 5.0, 5.0, 40.0, 40.0]) {
                assert!((a - want).abs() < 1e-6, "{areas:?}");
            }
            for o in &f {
                assert_eq!(o.vertices.len(), 4);
                // Outward normals: the face's vertices lie on its plane.
                let d = o.normal.dot(o.vertices[0]);
                assert!(o
                    .vertices
                    .iter()
                    .all(|v| (o.normal.dot(*v) - d).abs() < 1e-6));
            }
            // A minimum area keeps the two big faces, largest first.
            assert_eq!(convex_faces(&p, &i, 10.0).len(), 2);
        }
    }

    #[test]
    fn non_convex_and_non_planar_patches_are_not_occluders() {
        // An L of three unit squares in z = 0.
        let sq = |x: f64, y: f64| {
            [
                DVec3::new(x, y, 0.0),
                DVec3::new(x + 1.0, y, 0.0),
                DVec3::new(x + 1.0, y + 1.0, 0.0),
                DVec3::new(x, y + 1.0, 0.0),
            ]
        };
        let mut p = Vec::new();
        let mut idx = Vec::new();
        for (x, y) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)] {
            let b = p.len() as u32;
            p.extend(sq(x, y));
            idx.extend([b, b + 1, b + 2, b, b + 2, b + 3]);
        }
        assert!(convex_faces(&p, &idx, 0.0).is_empty());
        // Two triangles folded along their shared edge: two faces, each a
        // triangle.
        let p = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 0.5)];
        let f = convex_faces(&p, &[0, 1, 2, 1, 3, 2], 0.0);
        assert_eq!(f.len(), 2);
        assert!(f.iter().all(|o| o.vertices.len() == 3));
        // Nothing, NaN and bad indices: no panic, nothing found.
        assert!(convex_faces(&[], &[], 0.0).is_empty());
        assert!(convex_faces(&[DVec3::NAN; 3], &[0, 1, 2], 0.0).is_empty());
        assert!(convex_faces(&p, &[0, 1, 9], 0.0).is_empty());
    }
}
