//! `SceneStats` of scene files written to disk: the leaf floor and the
//! switch factors, as `gigawalk info` prints them.

mod common;

use gigawalk_scene::{SceneReader, SceneStats};
use glam::DVec3;

#[test]
fn leaf_floor_and_switch_factors_of_a_written_scene() {
    let dir = tempfile::tempdir().unwrap();
    // A root over three leaves: every LOD a 12-triangle box; the root's at
    // error 2, the leaves' at 0 and 0.5.
    let path = dir.path().join("wide.gwk");
    common::write_tree(&path, &common::wide(3, DVec3::ZERO));
    let r = SceneReader::open(&path).unwrap();
    let s = SceneStats::of(&r);
    assert_eq!(s.leaf_floor_triangles, 36);
    assert_eq!(s.leaf_triangles_per_level.last(), Some(&36));
    let f = &s.switch_factors;
    assert_eq!((f.count, f.median, f.p90, f.max), (1, 3.0, 3.0, 3.0));
    assert_eq!((f.over_2, f.over_4, f.over_8), (1, 0, 0));
    let w = f.worst.as_ref().unwrap();
    assert_eq!((w.node, w.depth, w.triangles), (0, 0, 12));
    // Error 2 plus what the 16-bit grid moved the root's box's corners.
    assert!((2.0..2.00001).contains(&w.error), "{}", w.error);
    assert_eq!(w.children_triangles, 36);
    assert_eq!(w.diagonal, r.skeleton().nodes()[0].bounds.diagonal());
    assert_eq!(s.hlod_levels_per_depth[0].switch_factor_max, 3.0);

    // A chain: each inner node's error covers its child's coarsest level,
    // so every switch is one box for one box.
    let path = dir.path().join("chain.gwk");
    common::write_tree(&path, &common::chain(4));
    let s = SceneStats::of(&SceneReader::open(&path).unwrap());
    let f = &s.switch_factors;
    assert_eq!((f.count, f.median, f.max, f.over_2), (3, 1.0, 1.0, 0));
    assert_eq!(f.worst.as_ref().map(|w| w.node), Some(0));
    assert_eq!(s.leaf_floor_triangles, 12);
}
