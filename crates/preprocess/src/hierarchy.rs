//! The AABB hierarchy over the final objects (GigaWalk Section 4.2.4),
//! built with obvhs and laid out the way the scene file wants it: node 0
//! the root, each node's children contiguous and after their parent.

use std::collections::VecDeque;

use gigawalk_scene::{Aabb, NO_NODE};
use glam::{DVec3, Vec3A};
use obvhs::{
    aabb::Aabb as BvhAabb,
    bvh2::builder::build_bvh2,
    ploc::{PlocSearchDistance, SortPrecision},
    BvhBuildParams,
};

/// One node of the hierarchy before its LODs exist.
#[derive(Clone, Debug, PartialEq)]
pub struct HNode {
    /// Holds every object below, slightly widened (see [`pad`]).
    pub bounds: Aabb,
    pub parent: u32,
    pub first_child: u32,
    pub child_count: u32,
    /// For a leaf, the final object it holds.
    pub object: Option<u32>,
    /// 1 for the root.
    pub depth: u32,
}

/// Builds a binary hierarchy with one object per leaf. The tree shape is
/// PLOC's (a bottom-up build by spatial proximity, then reinsertion), which
/// gives tighter, less overlapping sibling boxes than a median split; boxes
/// are then recomputed in f64 from the objects so nesting is exact.
pub fn build(boxes: &[Aabb]) -> Vec<HNode> {
    debug_assert!(!boxes.is_empty());
    if boxes.len() == 1 {
        return vec![HNode {
            bounds: pad(boxes[0]),
            parent: NO_NODE,
            first_child: 0,
            child_count: 0,
            object: Some(0),
            depth: 1,
        }];
    }
    let scene = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
    let centre = scene.center();
    let prims: Vec<BvhAabb> = boxes
        .iter()
        .map(|b| {
            BvhAabb::new(
                Vec3A::from((b.min - centre).as_vec3()),
                Vec3A::from((b.max - centre).as_vec3()),
            )
        })
        .collect();
    let config = BvhBuildParams {
        pre_split: false,
        ploc_search_distance: PlocSearchDistance::Medium,
        search_depth_threshold: 3,
        reinsertion_batch_ratio: 0.05,
        post_collapse_reinsertion_batch_ratio_multiplier: 0.0,
        sort_precision: SortPrecision::U64,
        // One object per leaf: the objects are already sized by Partition-II.
        max_prims_per_leaf: 1,
        collapse_traversal_cost: 1.0,
    };
    let bvh = build_bvh2(&prims, config, &mut Default::default());

    // Breadth-first renumbering: children get consecutive indices after
    // their parent, as the scene format requires.
    let mut out: Vec<HNode> = Vec::with_capacity(bvh.nodes.len());
    let mut queue: VecDeque<(Source, u32)> = VecDeque::new();
    out.push(HNode {
        bounds: Aabb::EMPTY,
        parent: NO_NODE,
        first_child: 0,
        child_count: 0,
        object: None,
        depth: 1,
    });
    queue.push_back((Source::Bvh(0), 0));
    while let Some((src, at)) = queue.pop_front() {
        let children: Vec<Source> = match src {
            Source::Object(o) => {
                out[at as usize].object = Some(o);
                continue;
            }
            Source::Bvh(i) => {
                let n = &bvh.nodes[i as usize];
                if n.is_leaf() {
                    let prims = (n.first_index..n.first_index + n.prim_count)
                        .map(|k| bvh.primitive_indices[k as usize]);
                    if n.prim_count == 1 {
                        out[at as usize].object =
                            Some(bvh.primitive_indices[n.first_index as usize]);
                        continue;
                    }
                    prims.map(Source::Object).collect()
                } else {
                    vec![Source::Bvh(n.first_index), Source::Bvh(n.first_index + 1)]
                }
            }
        };
        let first = out.len() as u32;
        let depth = out[at as usize].depth + 1;
        out[at as usize].first_child = first;
        out[at as usize].child_count = children.len() as u32;
        for c in children {
            let idx = out.len() as u32;
            out.push(HNode {
                bounds: Aabb::EMPTY,
                parent: at,
                first_child: 0,
                child_count: 0,
                object: None,
                depth,
            });
            queue.push_back((c, idx));
        }
    }
    // Children come after parents, so one backward pass fills every box.
    for i in (0..out.len()).rev() {
        let b = match out[i].object {
            Some(o) => boxes[o as usize],
            None => {
                let n = &out[i];
                (n.first_child..n.first_child + n.child_count)
                    .fold(Aabb::EMPTY, |a, c| a.union(&out[c as usize].bounds))
            }
        };
        out[i].bounds = pad(b);
    }
    out
}

enum Source {
    Bvh(u32),
    Object(u32),
}

/// Widens a box by a hair so that geometry stored as f32 offsets from a
/// point inside it still falls inside after rounding (f32 keeps about 7
/// digits: rounding moves a point by at most ~6e-8 of the box size).
/// Padding every node by its own size keeps nesting exact: a parent's box
/// contains its children's padded boxes before it is padded itself.
pub fn pad(b: Aabb) -> Aabb {
    let size = b.extent().max_element();
    let far = b.min.abs().max(b.max.abs()).max_element();
    let p = (1e-5 * size).max(1e-12 * far).max(f64::MIN_POSITIVE);
    Aabb::new(b.min - DVec3::splat(p), b.max + DVec3::splat(p))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_tree(nodes: &[HNode], objects: usize) {
        let mut seen = vec![false; objects];
        for (i, n) in nodes.iter().enumerate() {
            if let Some(o) = n.object {
                assert_eq!(n.child_count, 0);
                assert!(!seen[o as usize]);
                seen[o as usize] = true;
            } else {
                assert!(
                    n.child_count >= 2,
                    "inner node {i} has {} children",
                    n.child_count
                );
            }
            for c in n.first_child..n.first_child + n.child_count {
                assert!(c as usize > i);
                assert_eq!(nodes[c as usize].parent, i as u32);
                assert!(n.bounds.contains_box(&nodes[c as usize].bounds));
            }
        }
        assert!(seen.iter().all(|&s| s));
    }

    #[test]
    fn one_object_is_a_lone_root() {
        let nodes = build(&[Aabb::new(DVec3::ZERO, DVec3::ONE)]);
        assert_eq!(nodes.len(), 1);
        assert_eq!(nodes[0].object, Some(0));
        check_tree(&nodes, 1);
    }

    #[test]
    fn grid_of_boxes_far_from_origin() {
        let base = DVec3::splat(1e7);
        let boxes: Vec<Aabb> = (0..100)
            .map(|i| {
                let min = base + DVec3::new((i % 10) as f64 * 2.0, (i / 10) as f64 * 2.0, 0.0);
                Aabb::new(min, min + DVec3::ONE)
            })
            .collect();
        let nodes = build(&boxes);
        check_tree(&nodes, 100);
        assert_eq!(nodes.len(), 199);
        for n in &nodes {
            if let Some(o) = n.object {
                assert!(n.bounds.contains_box(&boxes[o as usize]));
            }
        }
    }
}
