//! Small scene builders that more than one crate's tests use.

use std::path::Path;

use gigawalk_scene::{Aabb, Colours, LodMesh, Node, Provenance, SceneWriter, NO_NODE};
use glam::Vec3;

/// Writes a scene of one root over a leaf per mesh, each with that mesh
/// as its one LOD (bounds: the mesh's box), normals stored in
/// `normal_bits` (8: the GPU's compact layout, 16: the wide one).
pub fn write_leaf_scene(path: &Path, normal_bits: u8, leaves: &[(Aabb, LodMesh)]) {
    let mut w = SceneWriter::create(path).unwrap();
    w.set_normal_bits(normal_bits).unwrap();
    let mut nodes = vec![Node {
        bounds: Aabb::EMPTY,
        parent: NO_NODE,
        first_child: 1,
        child_count: leaves.len() as u32,
        first_lod: 0,
        lod_count: 0,
    }];
    for (i, (b, mesh)) in leaves.iter().enumerate() {
        w.add_lod(mesh, 0.0).unwrap();
        nodes[0].bounds = nodes[0].bounds.union(b);
        nodes.push(Node {
            bounds: *b,
            parent: 0,
            first_child: 0,
            child_count: 0,
            first_lod: i as u32,
            lod_count: 1,
        });
    }
    w.finish(nodes, Provenance::default()).unwrap();
}

/// A closed box mesh spanning `b` (8 vertices, 12 triangles, one colour),
/// positions relative to `b.min` so far-away boxes keep their precision.
/// Each corner's normal points away from the box's centre (+Y for a box
/// of zero size, whose corners are all the centre).
pub fn box_mesh(b: &Aabb, colour: [u8; 4]) -> LodMesh {
    let e = b.extent().as_vec3();
    let corner = |i: u32| {
        Vec3::new(
            if i & 1 != 0 { e.x } else { 0.0 },
            if i & 2 != 0 { e.y } else { 0.0 },
            if i & 4 != 0 { e.z } else { 0.0 },
        )
    };
    #[rustfmt::skip]
    let indices = vec![
        0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
        2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5,
    ];
    LodMesh {
        origin: b.min,
        positions: (0..8).map(|i| corner(i).to_array()).collect(),
        normals: (0..8)
            .map(|i| (corner(i) - e * 0.5).normalize_or(Vec3::Y).to_array())
            .collect(),
        colours: Colours::Uniform(colour),
        indices,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn a_box_is_closed_and_its_normals_point_out() {
        let b = Aabb::new(DVec3::new(1e7, 0.0, -3.0), DVec3::new(1e7 + 2.0, 1.0, -1.0));
        let m = box_mesh(&b, [1, 2, 3, 4]);
        assert_eq!(m.origin, b.min);
        assert_eq!((m.positions.len(), m.indices.len()), (8, 36));
        // Closed: every edge is used once in each direction.
        let mut edges: Vec<(u32, u32)> = m
            .indices
            .chunks(3)
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .collect();
        edges.sort();
        for &(a, c) in &edges {
            assert!(
                edges.binary_search(&(c, a)).is_ok(),
                "edge {a}-{c} unpaired"
            );
        }
        for (p, n) in m.positions.iter().zip(&m.normals) {
            let out = Vec3::from(*p) - b.extent().as_vec3() * 0.5;
            assert!(out.dot(Vec3::from(*n)) > 0.0);
        }
        let point = box_mesh(&Aabb::new(DVec3::ONE, DVec3::ONE), [0; 4]);
        assert!(point.normals.iter().all(|n| *n == [0.0, 1.0, 0.0]));
    }
}
