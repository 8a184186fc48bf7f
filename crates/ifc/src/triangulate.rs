//! Polygons with holes to triangles: earcut on 2D loops, and planar 3D
//! loops projected on their plane (Newell's normal) first.

use glam::{DVec2, DVec3};

/// Triangles (indices into the loops' points, concatenated in order) of
/// the polygon `outer` minus `holes`; empty when it has no area.
pub fn triangulate_2d(outer: &[DVec2], holes: &[Vec<DVec2>]) -> Vec<[usize; 3]> {
    let mut data: Vec<[f64; 2]> = outer.iter().map(|p| [p.x, p.y]).collect();
    let mut hole_starts: Vec<usize> = Vec::with_capacity(holes.len());
    for h in holes {
        if h.len() >= 3 {
            hole_starts.push(data.len());
            data.extend(h.iter().map(|p| [p.x, p.y]));
        }
    }
    if outer.len() < 3 || data.iter().any(|p| !(p[0].is_finite() && p[1].is_finite())) {
        return Vec::new();
    }
    let mut out: Vec<usize> = Vec::new();
    earcut::Earcut::new().earcut(data.iter().copied(), &hole_starts, &mut out);
    // Holes that were skipped (fewer than 3 points) shift no index:
    // `data` holds exactly the loops kept, and each kept loop's points
    // are in order; map back to the caller's concatenation.
    let mut map: Vec<usize> = (0..outer.len()).collect();
    let mut at = outer.len();
    for h in holes {
        if h.len() >= 3 {
            map.extend(at..at + h.len());
        }
        at += h.len();
    }
    out.chunks_exact(3)
        .map(|t| [map[t[0]], map[t[1]], map[t[2]]])
        .collect()
}

/// Newell's normal of a loop (not normalized; zero when degenerate).
pub fn newell(points: &[DVec3]) -> DVec3 {
    let mut n = DVec3::ZERO;
    for (i, a) in points.iter().enumerate() {
        let b = points[(i + 1) % points.len()];
        n += DVec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        );
    }
    n
}

/// Triangles of a planar face: `loops[0]` the outer boundary, the rest
/// holes; each triangle wound as the outer loop (its Newell normal).
pub fn triangulate_3d(loops: &[Vec<DVec3>]) -> Vec<[DVec3; 3]> {
    let Some(outer) = loops.first() else {
        return Vec::new();
    };
    if outer.len() < 3 {
        return Vec::new();
    }
    let n = newell(outer);
    let Some(n) = n.try_normalize() else {
        return Vec::new();
    };
    if outer.len() == 3 && loops.len() == 1 {
        return vec![[outer[0], outer[1], outer[2]]];
    }
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    let o = outer[0];
    let flat = |l: &Vec<DVec3>| -> Vec<DVec2> {
        l.iter()
            .map(|p| DVec2::new((*p - o).dot(u), (*p - o).dot(v)))
            .collect()
    };
    let outer2 = flat(outer);
    let holes2: Vec<Vec<DVec2>> = loops[1..].iter().map(flat).collect();
    let all: Vec<DVec3> = loops.iter().flatten().copied().collect();
    triangulate_2d(&outer2, &holes2)
        .into_iter()
        .map(|[a, b, c]| {
            let t = [all[a], all[b], all[c]];
            if (t[1] - t[0]).cross(t[2] - t[0]).dot(n) < 0.0 {
                [t[0], t[2], t[1]]
            } else {
                t
            }
        })
        .collect()
}

/// Drops a closing point that repeats the first.
pub fn open_loop(mut l: Vec<DVec3>) -> Vec<DVec3> {
    while l.len() > 1 && l[0].distance_squared(l[l.len() - 1]) < 1e-18 {
        l.pop();
    }
    l
}
