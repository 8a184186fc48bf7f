//! Hand-built scenes of boxes for runtime tests: a bounding-volume tree
//! over the boxes (median splits, up to 4 children), every inner node with
//! a one-box HLOD whose error covers its children.

use std::path::Path;

use gigawalk_scene::{Aabb, IndexFormat, LodInfo, Node, Provenance, SceneWriter, NO_NODE};
use glam::DVec3;

/// A LOD record with only an error and a triangle count (no geometry,
/// no vertices), for skeletons that are culled but never drawn.
pub fn bare_lod(error: f32, triangles: u32) -> LodInfo {
    LodInfo {
        error,
        triangles,
        vertices: 0,
        origin: DVec3::ZERO,
        index_format: IndexFormat::U16,
        uniform_colour: None,
        encoded: false,
        grid: None,
        compressed: false,
        offset: 0,
        len: 0,
        checksum: 0,
    }
}

pub use gigawalk_testkit::box_mesh;

/// Writes a scene of the given boxes. Leaves are the boxes (one LOD, error
/// 0); inner nodes get their union box as HLOD with error = its diagonal.
pub fn write_boxes_scene(path: &Path, boxes: &[(Aabb, [u8; 4])]) {
    assert!(!boxes.is_empty());
    // Build the tree top-down over index ranges, breadth-first so children
    // are contiguous.
    struct Pending {
        items: Vec<usize>,
        parent: u32,
    }
    let mut nodes: Vec<Node> = Vec::new();
    let mut node_items: Vec<Vec<usize>> = Vec::new();
    let mut queue = std::collections::VecDeque::from([Pending {
        items: (0..boxes.len()).collect(),
        parent: NO_NODE,
    }]);
    while let Some(p) = queue.pop_front() {
        let me = nodes.len() as u32;
        let bounds = p
            .items
            .iter()
            .fold(Aabb::EMPTY, |b, &i| b.union(&boxes[i].0));
        if p.parent != NO_NODE {
            let parent = &mut nodes[p.parent as usize];
            if parent.child_count == 0 {
                parent.first_child = me;
            }
            parent.child_count += 1;
        }
        nodes.push(Node {
            bounds,
            parent: p.parent,
            first_child: 0,
            child_count: 0,
            first_lod: 0,
            lod_count: 1,
        });
        node_items.push(p.items.clone());
        if p.items.len() > 1 {
            let axis = bounds.extent().max_position();
            let mut items = p.items;
            items.sort_by(|&a, &b| boxes[a].0.center()[axis].total_cmp(&boxes[b].0.center()[axis]));
            let parts = items.len().min(4);
            let per = items.len().div_ceil(parts);
            for chunk in items.chunks(per) {
                queue.push_back(Pending {
                    items: chunk.to_vec(),
                    parent: me,
                });
            }
        }
    }
    let mut w = SceneWriter::create(path).expect("create scene");
    for (i, node) in nodes.iter_mut().enumerate() {
        let items = &node_items[i];
        let (mesh, error) = if node.child_count == 0 {
            let (b, c) = boxes[items[0]];
            (box_mesh(&b, c), 0.0)
        } else {
            (
                box_mesh(&node.bounds, [128, 128, 128, 255]),
                node.bounds.diagonal() as f32,
            )
        };
        node.first_lod = w.add_lod(&mesh, error).expect("add LOD");
    }
    w.finish(nodes, Provenance::default())
        .expect("finish scene");
}

/// A street of boxes: a wall across the view with a gap, rows of small
/// boxes behind it (mostly hidden), and pillars beside the street, all
/// shifted by `shift`. About `n` small boxes.
pub fn street(n: usize, shift: DVec3) -> Vec<(Aabb, [u8; 4])> {
    let b = |min: DVec3, max: DVec3| Aabb::new(min + shift, max + shift);
    let mut v = vec![
        // The wall: x -20..20 at z -10, with a gap at x 2..4.
        (
            b(DVec3::new(-20.0, 0.0, -10.5), DVec3::new(2.0, 8.0, -10.0)),
            [200, 200, 180, 255],
        ),
        (
            b(DVec3::new(4.0, 0.0, -10.5), DVec3::new(20.0, 8.0, -10.0)),
            [200, 200, 180, 255],
        ),
        // The ground.
        (
            b(DVec3::new(-40.0, -0.2, -80.0), DVec3::new(40.0, 0.0, 10.0)),
            [90, 110, 90, 255],
        ),
    ];
    let side = (n as f64).sqrt().ceil() as usize;
    for i in 0..n {
        let (gx, gz) = ((i % side) as f64, (i / side) as f64);
        let x = -15.0 + 30.0 * gx / side as f64;
        let z = -12.0 - 60.0 * gz / side as f64;
        let h = 0.5 + (i * 7 % 5) as f64 * 0.4;
        let c = [(50 + i * 37 % 200) as u8, (i * 91 % 255) as u8, 200, 255];
        v.push((b(DVec3::new(x, 0.0, z), DVec3::new(x + 0.6, h, z + 0.6)), c));
    }
    for k in 0..10 {
        let z = -2.0 - 7.0 * k as f64;
        v.push((
            b(DVec3::new(-25.0, 0.0, z), DVec3::new(-24.0, 10.0, z + 1.0)),
            [150, 60, 60, 255],
        ));
        v.push((
            b(DVec3::new(24.0, 0.0, z), DVec3::new(25.0, 10.0, z + 1.0)),
            [150, 60, 60, 255],
        ));
    }
    v
}
