//! Hand-built scenes for the scene-file tests.

#![allow(dead_code)]

use std::path::Path;

use gigawalk_scene::{Aabb, Node, Provenance, SceneWriter, WriteSummary, NO_NODE};
pub use gigawalk_testkit::box_mesh;
use glam::DVec3;

/// A tree described by each node's parent (parents before children, node 0
/// the root, children of one parent consecutive) and each leaf's box. Inner
/// nodes get the union of their children and one coarse LOD (a box) whose
/// error is `inner_error(depth)`.
pub struct TreeSpec {
    pub parents: Vec<u32>,
    pub leaf_boxes: Vec<Option<Aabb>>,
}

pub fn chain(depth: usize) -> TreeSpec {
    let parents = (0..depth)
        .map(|i| if i == 0 { NO_NODE } else { i as u32 - 1 })
        .collect();
    let mut leaf_boxes = vec![None; depth];
    leaf_boxes[depth - 1] = Some(Aabb::new(DVec3::ZERO, DVec3::ONE));
    TreeSpec {
        parents,
        leaf_boxes,
    }
}

pub fn wide(children: usize, offset: DVec3) -> TreeSpec {
    let mut parents = vec![NO_NODE];
    let mut leaf_boxes = vec![None];
    for i in 0..children {
        parents.push(0);
        let min = offset + DVec3::new(i as f64 * 2.0, (i % 7) as f64, 0.5 * (i % 3) as f64);
        leaf_boxes.push(Some(Aabb::new(min, min + DVec3::new(1.0, 0.5, 0.25))));
    }
    TreeSpec {
        parents,
        leaf_boxes,
    }
}

/// Writes the tree: leaves get two LODs (a box, error 0; the same box,
/// error 0.5), inner nodes one LOD (their box, error 1 + height).
pub fn write_tree(path: &Path, spec: &TreeSpec) -> WriteSummary {
    write_tree_with(path, spec, Vec::new())
}

/// Two square occluders and their view cells (a split at x = 0, two
/// leaves, two directions), as OCCL and OCVC sections for
/// [`write_tree_with`].
pub fn occluder_sections() -> Vec<([u8; 4], Vec<u8>)> {
    use gigawalk_scene::occluder_cells::{self, CellNode, OccluderCells};
    use gigawalk_scene::occluders::{self, OccluderRecord};
    let square = |x: f64| OccluderRecord {
        vertices: vec![
            DVec3::new(x, 0.0, 0.0),
            DVec3::new(x + 1.0, 0.0, 0.0),
            DVec3::new(x + 1.0, 1.0, 0.0),
            DVec3::new(x, 1.0, 0.0),
        ],
        area: 1.0,
    };
    let cells = OccluderCells {
        nodes: vec![
            CellNode::Split {
                axis: 0,
                at: 0.0,
                first: 1,
            },
            CellNode::Leaf(0),
            CellNode::Leaf(1),
        ],
        directions: vec![DVec3::X, DVec3::NEG_X],
        k: 2,
        lists: vec![vec![0, 1], vec![1], vec![], vec![1, 0]],
    };
    vec![
        (
            occluders::TAG_OCCLUDERS,
            occluders::encode_occluders(&[square(0.0), square(4.0)]),
        ),
        (
            occluder_cells::TAG_OCCLUDER_CELLS,
            occluder_cells::encode_occluder_cells(&cells),
        ),
    ]
}

/// [`write_tree`] with optional sections (tag, bytes) added.
pub fn write_tree_with(
    path: &Path,
    spec: &TreeSpec,
    optional: Vec<([u8; 4], Vec<u8>)>,
) -> WriteSummary {
    write_tree_opts(path, spec, optional, false)
}

/// [`write_tree_with`], its encoded blobs zstd-compressed when `compress`.
pub fn write_tree_opts(
    path: &Path,
    spec: &TreeSpec,
    optional: Vec<([u8; 4], Vec<u8>)>,
    compress: bool,
) -> WriteSummary {
    let n = spec.parents.len();
    let mut bounds: Vec<Aabb> = spec
        .leaf_boxes
        .iter()
        .map(|b| b.unwrap_or(Aabb::EMPTY))
        .collect();
    let mut height = vec![0u32; n];
    for i in (1..n).rev() {
        let p = spec.parents[i] as usize;
        bounds[p] = bounds[p].union(&bounds[i]);
        height[p] = height[p].max(height[i] + 1);
    }
    let mut w = SceneWriter::create(path).expect("create");
    w.set_compression(compress).unwrap();
    for (tag, bytes) in optional {
        w.add_optional_section(tag, bytes);
    }
    let mut nodes = Vec::with_capacity(n);
    for i in 0..n {
        let colour = [(i % 251) as u8, 100, 200, 255];
        let first_lod = if spec.leaf_boxes[i].is_some() {
            let a = w.add_lod(&box_mesh(&bounds[i], colour), 0.0).unwrap();
            w.add_lod(&box_mesh(&bounds[i], colour), 0.5).unwrap();
            a
        } else {
            w.add_lod(&box_mesh(&bounds[i], colour), 1.0 + height[i] as f32)
                .unwrap()
        };
        let children: Vec<u32> = (0..n as u32)
            .filter(|&c| spec.parents[c as usize] == i as u32)
            .collect();
        nodes.push(Node {
            bounds: bounds[i],
            parent: spec.parents[i],
            first_child: children.first().copied().unwrap_or(0),
            child_count: children.len() as u32,
            first_lod,
            lod_count: if spec.leaf_boxes[i].is_some() { 2 } else { 1 },
        });
    }
    let mut provenance = Provenance {
        source: "hand-built".into(),
        tool: "scene tests".into(),
        ..Default::default()
    };
    provenance
        .parameters
        .insert("nodes".into(), (n as u64).into());
    w.finish(nodes, provenance).expect("finish")
}
