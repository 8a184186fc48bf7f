//! Shared last step of both importers: drop degenerate triangles, settle
//! normals (the file's, else area-weighted), and build the [`Object`].

use glam::{DVec3, Vec3};

use crate::model::{ImportStats, Object};

/// One object as an importer read it: world positions, validated indices
/// (every index `< positions.len()`), and normals when the file had them.
pub(crate) struct RawObject {
    pub name: String,
    pub identity: crate::Identity,
    pub positions: Vec<DVec3>,
    /// World-space normals, not necessarily unit length.
    pub normals: Option<Vec<DVec3>>,
    pub indices: Vec<u32>,
    pub colour: [f32; 4],
    pub vertex_colours: Option<Vec<[f32; 4]>>,
}

/// Drops zero-area triangles (counted in `stats`) and fills in normals.
/// Returns `None`, with a warning, when no triangle survives.
pub(crate) fn finish(raw: RawObject, stats: &mut ImportStats) -> Option<Object> {
    let RawObject {
        name,
        identity,
        positions,
        normals,
        mut indices,
        colour,
        vertex_colours,
    } = raw;
    let before = indices.len() / 3;
    indices.truncate(before * 3);
    let mut kept = 0;
    for t in 0..before {
        let (a, b, c) = (indices[3 * t], indices[3 * t + 1], indices[3 * t + 2]);
        // Exact zero only: a sliver is still a surface the renderer draws,
        // while a repeated index or collinear points cover no pixel at all.
        let degenerate = a == b || b == c || a == c || {
            let (pa, pb, pc) = (
                positions[a as usize],
                positions[b as usize],
                positions[c as usize],
            );
            let n = (pb - pa).cross(pc - pa);
            n == DVec3::ZERO || !n.is_finite()
        };
        if !degenerate {
            indices.copy_within(3 * t..3 * t + 3, 3 * kept);
            kept += 1;
        }
    }
    indices.truncate(kept * 3);
    stats.degenerate_triangles_dropped += (before - kept) as u64;
    if kept == 0 {
        stats.warnings.push(format!(
            "{name}: every triangle is degenerate; object dropped"
        ));
        return None;
    }
    stats.triangles += kept as u64;

    let file_normals = normals.and_then(|ns| {
        let unit: Vec<Vec3> = ns.iter().map(|n| n.normalize_or_zero().as_vec3()).collect();
        if unit.iter().all(|n| *n != Vec3::ZERO && n.is_finite()) {
            Some(unit)
        } else {
            stats.warnings.push(format!(
                "{name}: zero or non-finite normals in the file; normals recomputed"
            ));
            None
        }
    });
    let normals = file_normals.unwrap_or_else(|| area_weighted_normals(&positions, &indices));
    Some(Object {
        name,
        identity,
        positions,
        normals,
        indices,
        colour,
        vertex_colours,
    })
}

/// Vertex normals as the sum of adjacent face normals weighted by face area
/// (the unnormalised cross product is twice the area), computed in world
/// space so mirrored instances come out right. Vertices on no triangle get +Y.
pub(crate) fn area_weighted_normals(positions: &[DVec3], indices: &[u32]) -> Vec<Vec3> {
    let mut acc = vec![DVec3::ZERO; positions.len()];
    for t in indices.chunks_exact(3) {
        let (a, b, c) = (t[0] as usize, t[1] as usize, t[2] as usize);
        let n = (positions[b] - positions[a]).cross(positions[c] - positions[a]);
        acc[a] += n;
        acc[b] += n;
        acc[c] += n;
    }
    acc.iter()
        .map(|n| {
            let u = n.normalize_or_zero();
            if u == DVec3::ZERO {
                Vec3::Y
            } else {
                u.as_vec3()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn raw(positions: Vec<DVec3>, indices: Vec<u32>) -> RawObject {
        RawObject {
            name: "t".into(),
            identity: Default::default(),
            positions,
            normals: None,
            indices,
            colour: [1.0; 4],
            vertex_colours: None,
        }
    }

    #[test]
    fn degenerate_triangles_are_dropped_and_counted() {
        let p = vec![
            DVec3::ZERO,
            DVec3::X,
            DVec3::Y,
            DVec3::new(2.0, 0.0, 0.0), // collinear with 0 and X
        ];
        let mut stats = ImportStats::default();
        let o = finish(raw(p, vec![0, 1, 2, 0, 1, 3, 0, 0, 2]), &mut stats).unwrap();
        assert_eq!(o.indices, vec![0, 1, 2]);
        assert_eq!(stats.degenerate_triangles_dropped, 2);
        assert_eq!(stats.triangles, 1);
        assert_eq!(o.normals[0], Vec3::Z);
    }

    #[test]
    fn all_degenerate_object_is_dropped_with_warning() {
        let mut stats = ImportStats::default();
        assert!(finish(raw(vec![DVec3::ZERO; 3], vec![0, 1, 2]), &mut stats).is_none());
        assert_eq!(stats.warnings.len(), 1);
    }

    #[test]
    fn normals_are_area_weighted() {
        // A big triangle in the XY plane and a small one in the XZ plane share vertex 0.
        let p = vec![
            DVec3::ZERO,
            DVec3::new(10.0, 0.0, 0.0),
            DVec3::new(0.0, 10.0, 0.0),
            DVec3::new(0.0, 0.0, -1.0),
        ];
        let n = area_weighted_normals(&p, &[0, 1, 2, 0, 3, 1]);
        assert!(n[0].z > 0.99 && n[0].y < 0.0, "{:?}", n[0]);
    }
}
