//! Summary figures of a scene file, for `gigawalk info` and reports.

use serde::Serialize;

use crate::{Provenance, SceneReader, NO_NODE};

/// What a scene file holds, in numbers. Serialised as `gigawalk info --json`.
#[derive(Clone, Debug, Serialize)]
pub struct SceneStats {
    pub format_version: String,
    pub file_bytes: u64,
    pub nodes: usize,
    pub leaves: usize,
    pub depth: u32,
    /// The most LODs any node has.
    pub max_lods_per_node: usize,
    /// Triangles of the original geometry (every leaf's finest LOD).
    pub triangles: u64,
    /// Sum over leaves of the triangles of their k-th LOD (a leaf with
    /// fewer levels counts its coarsest): the scene drawn from leaves only
    /// at level k.
    pub leaf_triangles_per_level: Vec<u64>,
    /// The leaf floor: sum over leaves of their coarsest LOD's triangles,
    /// the fewest triangles the scene can be drawn with from leaves alone
    /// (the last entry of `leaf_triangles_per_level`). A far view draws
    /// less only through HLODs.
    pub leaf_floor_triangles: u64,
    /// Sum over nodes at tree depth d (root = 0) of their finest LOD's
    /// triangles: the scene drawn as a cut through the tree at depth d.
    pub hlod_triangles_per_depth: Vec<u64>,
    /// The HLOD chains of the inner nodes at each tree depth (root = 0).
    pub hlod_levels_per_depth: Vec<DepthLevels>,
    /// The switch factors of every inner node with LODs, whatever its
    /// depth (per depth: `hlod_levels_per_depth`).
    pub switch_factors: SwitchFactors,
    /// The whole scene drawn at one error, frustum and occlusion aside:
    /// `(error, triangles)` at errors of the scene box's diagonal / 2^k,
    /// k = 1..=16, each node drawn from its coarsest level within the
    /// error, else through its children. At pixel error p a node at
    /// distance d is drawn at error p d / ppr, so how fast the triangles
    /// fall as the error doubles says what the far field costs (an
    /// opaque surface's LODs would fall about 4x per doubling).
    pub triangles_at_error: Vec<(f64, u64)>,
    pub bounds_min: [f64; 3],
    pub bounds_max: [f64; 3],
    pub origin: [f64; 3],
    /// Bytes of each section, by name, in file order.
    pub sections: Vec<(String, u64)>,
    /// Whole file size divided by the original triangle count.
    pub bytes_per_triangle: f64,
    /// How positions are stored.
    pub positions: PositionStats,
    pub provenance: Provenance,
}

/// How a scene stores its positions (docs/scene-format.md, GEOM).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PositionStats {
    /// LODs on a quantized grid, meshopt-encoded; the rest are raw f32.
    pub encoded_lods: usize,
    pub raw_lods: usize,
    /// Encoded LODs whose blob is zstd-compressed too.
    pub compressed_lods: usize,
    /// The grid's bits per axis, as the provenance records them (`None`
    /// when it does not).
    pub bits: Option<u8>,
    /// Bounds on the grid step of the encoded LODs, model units: each
    /// LOD's node box's longest side / (2^bits - 1) (its own box is no
    /// larger). Largest and median; 0 without encoded LODs or bits.
    pub step_max: f64,
    pub step_median: f64,
}

impl PositionStats {
    fn of(s: &crate::Skeleton) -> PositionStats {
        let encoded = s.lods().iter().filter(|l| l.encoded).count();
        let bits = s
            .provenance()
            .parameters
            .get("position_bits")
            .and_then(|v| {
                v.as_str()
                    .and_then(|t| t.parse().ok())
                    .or(v.as_u64().map(|b| b as u8))
            })
            .filter(|b| crate::codec::POSITION_BITS.contains(b));
        let mut steps: Vec<f64> = match bits {
            Some(b) if encoded > 0 => {
                let levels = ((1u64 << b) - 1) as f64;
                (0..s.lods().len() as u32)
                    .filter(|&l| s.lod(l).encoded)
                    .map(|l| s.node(s.owner(l)).bounds.extent().max_element() / levels)
                    .collect()
            }
            _ => Vec::new(),
        };
        PositionStats {
            compressed_lods: s.lods().iter().filter(|l| l.compressed).count(),
            encoded_lods: encoded,
            raw_lods: s.lods().len() - encoded,
            bits,
            step_max: steps.iter().copied().fold(0.0, f64::max),
            step_median: median(&mut steps),
        }
    }
}

/// The inner nodes at one tree depth: how many HLOD levels they have, and
/// their finest HLOD's size and error.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct DepthLevels {
    pub depth: usize,
    pub inner_nodes: usize,
    pub leaves: usize,
    pub levels_min: usize,
    pub levels_median: usize,
    pub levels_max: usize,
    /// Median triangles of the finest HLOD.
    pub finest_triangles_median: u64,
    /// Median finest-HLOD error as a fraction of the node's box diagonal.
    pub finest_error_median: f64,
    /// What crossing a node's switching distance costs: the triangles its
    /// subtree draws at the finest HLOD's error (each node its coarsest
    /// level within it, else its children's) over the finest HLOD's
    /// triangles. Median and largest over the depth's inner nodes with
    /// levels (0 when none has any); frustum and occlusion aside.
    pub switch_factor_median: f64,
    pub switch_factor_max: f64,
}

/// The distribution of switch factors (see
/// [`DepthLevels::switch_factor_median`]) over every inner node with at
/// least one LOD. A factor of 1 to 1 / lod-ratio is a smooth switch; a large
/// one means crossing that node's switching distance multiplies what its
/// subtree draws, a jump in frame time and a visible pop.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct SwitchFactors {
    /// Inner nodes with LODs: the nodes counted below.
    pub count: usize,
    /// Quantiles: the value at index floor(q count) of the sorted factors
    /// (the last for q count >= count), so the median is the upper one of
    /// an even count, as in [`DepthLevels`]. 0 when `count` is 0.
    pub median: f64,
    pub p90: f64,
    pub p99: f64,
    pub max: f64,
    /// Nodes whose factor is above 2, 4 and 8.
    pub over_2: usize,
    pub over_4: usize,
    pub over_8: usize,
    /// The node with the largest factor (the first in node order on a
    /// tie); `None` when `count` is 0.
    pub worst: Option<NodeSwitch>,
}

/// One node's switch: its finest LOD against what its children draw at
/// that LOD's error.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NodeSwitch {
    /// Node index in the scene file.
    pub node: u32,
    /// Tree depth, root = 0.
    pub depth: usize,
    /// `children_triangles / triangles`.
    pub factor: f64,
    /// The finest LOD's triangles and error (model units).
    pub triangles: u64,
    pub error: f64,
    /// The node's box diagonal (model units).
    pub diagonal: f64,
    /// Triangles the children's subtrees draw at `error`.
    pub children_triangles: u64,
}

impl SwitchFactors {
    /// The distribution over `s`'s inner nodes (every node's depth is
    /// computed here; [`SceneStats::of`] shares one pass with the per-depth
    /// figures).
    pub fn of(s: &crate::Skeleton) -> SwitchFactors {
        summarise_switches(&node_switches(s, &node_depths(s)))
    }
}

/// Every node's tree depth, root = 0. Children have larger indices than
/// their parent (validated), so one forward pass does.
fn node_depths(s: &crate::Skeleton) -> Vec<usize> {
    let mut depth = vec![0usize; s.nodes().len()];
    for (i, n) in s.nodes().iter().enumerate() {
        if n.parent != NO_NODE {
            depth[i] = depth[n.parent as usize] + 1;
        }
    }
    depth
}

/// The switch of every inner node with LODs, by node index (`None` for
/// leaves and nodes without LODs). Each node's children are walked once,
/// down to the cut at its error: on a tree whose errors grow towards the
/// root that is its children, so the whole pass is linear in the nodes.
fn node_switches(s: &crate::Skeleton, depth: &[usize]) -> Vec<Option<NodeSwitch>> {
    let mut stack = Vec::new();
    (0..s.nodes().len())
        .map(|i| {
            let n = &s.nodes()[i];
            if n.is_leaf() {
                return None;
            }
            let l = s.node_lods(i as u32).first()?;
            let below = triangles_within(s, n.children(), l.error, &mut stack);
            Some(NodeSwitch {
                node: i as u32,
                depth: depth[i],
                factor: below as f64 / f64::from(l.triangles.max(1)),
                triangles: u64::from(l.triangles),
                error: f64::from(l.error),
                diagonal: n.bounds.diagonal(),
                children_triangles: below,
            })
        })
        .collect()
}

/// Sum over leaves of their coarsest LOD's triangles (0 for a leaf
/// without any).
fn leaf_floor(s: &crate::Skeleton) -> u64 {
    s.leaves()
        .filter_map(|i| s.node_lods(i).last())
        .map(|l| u64::from(l.triangles))
        .sum()
}

/// The value at index floor(q len) of `sorted` (clamped to the last);
/// 0 when empty.
fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let i = ((q * sorted.len() as f64) as usize).min(sorted.len() - 1);
    sorted[i]
}

fn summarise_switches(switches: &[Option<NodeSwitch>]) -> SwitchFactors {
    let mut factors: Vec<f64> = switches.iter().flatten().map(|w| w.factor).collect();
    factors.sort_by(f64::total_cmp);
    let over = |t: f64| factors.iter().filter(|&&f| f > t).count();
    let worst = switches
        .iter()
        .flatten()
        .fold(None::<&NodeSwitch>, |best, w| match best {
            Some(b) if b.factor >= w.factor => Some(b),
            _ => Some(w),
        })
        .cloned();
    SwitchFactors {
        count: factors.len(),
        median: quantile(&factors, 0.5),
        p90: quantile(&factors, 0.9),
        p99: quantile(&factors, 0.99),
        max: factors.last().copied().unwrap_or(0.0),
        over_2: over(2.0),
        over_4: over(4.0),
        over_8: over(8.0),
        worst,
    }
}

/// The median of `v` (sorted in place); the upper one of an even count.
fn median<T: Copy + PartialOrd + Default>(v: &mut [T]) -> T {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    v.get(v.len() / 2).copied().unwrap_or_default()
}

/// Triangles the subtrees of `nodes` draw at `error`: each node its
/// coarsest level within it, else its children's; a leaf with no level
/// within it draws its finest (as traversal does). Iterative, `stack` a
/// reused buffer: a validated scene may still be one long chain of nodes.
fn triangles_within(
    s: &crate::Skeleton,
    nodes: impl IntoIterator<Item = u32>,
    error: f32,
    stack: &mut Vec<u32>,
) -> u64 {
    let mut total = 0;
    stack.clear();
    stack.extend(nodes);
    while let Some(n) = stack.pop() {
        let lods = s.node_lods(n);
        match lods.iter().rev().find(|l| l.error <= error) {
            Some(l) => total += u64::from(l.triangles),
            None if s.nodes()[n as usize].is_leaf() => {
                total += lods.first().map_or(0, |l| u64::from(l.triangles));
            }
            None => stack.extend(s.nodes()[n as usize].children()),
        }
    }
    total
}

impl SceneStats {
    pub fn of<R: crate::ReadAt>(r: &SceneReader<R>) -> SceneStats {
        let s = r.skeleton();
        let max_lods = s
            .nodes()
            .iter()
            .map(|n| n.lod_count as usize)
            .max()
            .unwrap_or(0);
        let mut per_level = vec![0u64; max_lods];
        for leaf in s.leaves() {
            let lods = s.node_lods(leaf);
            for (k, slot) in per_level.iter_mut().enumerate() {
                if let Some(l) = lods.get(k).or(lods.last()) {
                    *slot += l.triangles as u64;
                }
            }
        }
        let depth = node_depths(s);
        let depths = depth.iter().copied().max().map_or(0, |d| d + 1);
        let mut per_depth = vec![0u64; depths];
        let mut at_depth: Vec<Vec<usize>> = vec![Vec::new(); depths];
        for (i, &d) in depth.iter().enumerate() {
            // A node without LODs is drawn through its children.
            per_depth[d] += s
                .node_lods(i as u32)
                .first()
                .map_or(0, |l| l.triangles as u64);
            at_depth[d].push(i);
        }
        let switches = node_switches(s, &depth);
        let mut levels_per_depth = Vec::with_capacity(depths);
        for (d, at) in at_depth.iter().enumerate() {
            let inner: Vec<usize> = at
                .iter()
                .copied()
                .filter(|&i| !s.nodes()[i].is_leaf())
                .collect();
            let mut counts: Vec<usize> = inner
                .iter()
                .map(|&i| s.nodes()[i].lod_count as usize)
                .collect();
            let mut tris: Vec<u64> = inner
                .iter()
                .filter_map(|&i| s.node_lods(i as u32).first().map(|l| l.triangles as u64))
                .collect();
            let mut switch: Vec<f64> = inner
                .iter()
                .filter_map(|&i| switches[i].as_ref().map(|w| w.factor))
                .collect();
            let mut errs: Vec<f64> = inner
                .iter()
                .filter_map(|&i| {
                    let diag = s.nodes()[i].bounds.diagonal();
                    let l = s.node_lods(i as u32).first()?;
                    (diag > 0.0).then(|| l.error as f64 / diag)
                })
                .collect();
            levels_per_depth.push(DepthLevels {
                depth: d,
                inner_nodes: inner.len(),
                leaves: at.len() - inner.len(),
                levels_min: counts.iter().copied().min().unwrap_or(0),
                levels_max: counts.iter().copied().max().unwrap_or(0),
                levels_median: median(&mut counts),
                finest_triangles_median: median(&mut tris),
                finest_error_median: median(&mut errs),
                switch_factor_max: switch.iter().copied().fold(0.0, f64::max),
                switch_factor_median: median(&mut switch),
            });
        }
        let switch_factors = summarise_switches(&switches);
        let triangles = s.finest_triangles();
        let diagonal = s.bounds().diagonal();
        let mut stack = Vec::new();
        let triangles_at_error = (1..=16)
            .map(|k| {
                let e = diagonal / f64::from(1u32 << k);
                // A validated scene has one root, node 0.
                (e, triangles_within(s, [0], e as f32, &mut stack))
            })
            .collect();
        let (major, minor) = r.version();
        let positions = PositionStats::of(s);
        SceneStats {
            format_version: format!("{major}.{minor}"),
            file_bytes: r.file_len(),
            nodes: s.nodes().len(),
            leaves: s.leaves().count(),
            depth: s.depth(),
            max_lods_per_node: max_lods,
            triangles,
            leaf_floor_triangles: leaf_floor(s),
            leaf_triangles_per_level: per_level,
            hlod_triangles_per_depth: per_depth,
            hlod_levels_per_depth: levels_per_depth,
            switch_factors,
            triangles_at_error,
            bounds_min: s.bounds().min.to_array(),
            bounds_max: s.bounds().max.to_array(),
            origin: s.origin().to_array(),
            sections: r
                .sections()
                .iter()
                .map(|x| (x.name.clone(), x.len))
                .collect(),
            bytes_per_triangle: r.file_len() as f64 / triangles.max(1) as f64,
            positions,
            provenance: s.provenance().clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::{Aabb, IndexFormat, LodInfo, Node, Skeleton};

    /// One node: parent, box min x, LODs as (triangles, error).
    type NodeSpec<'a> = (u32, f64, &'a [(u32, f32)]);

    /// A skeleton from one [`NodeSpec`] per node, parents first and
    /// siblings consecutive; each box is 1 x 1 x 1 from its min x, inner
    /// boxes the union of their children's.
    fn skeleton(spec: &[NodeSpec]) -> Skeleton {
        // Siblings are consecutive: a parent's first child is the first
        // node naming it.
        let mut children = vec![(0u32, 0u32); spec.len()];
        for (c, &(parent, _, _)) in spec.iter().enumerate().skip(1) {
            let slot = &mut children[parent as usize];
            if slot.1 == 0 {
                slot.0 = c as u32;
            }
            slot.1 += 1;
        }
        let mut nodes: Vec<Node> = Vec::new();
        let mut lods = Vec::new();
        for (i, &(parent, x, levels)) in spec.iter().enumerate() {
            nodes.push(Node {
                bounds: Aabb::new(DVec3::new(x, 0.0, 0.0), DVec3::new(x + 1.0, 1.0, 1.0)),
                parent,
                first_child: children[i].0,
                child_count: children[i].1,
                first_lod: lods.len() as u32,
                lod_count: levels.len() as u32,
            });
            lods.extend(levels.iter().map(|&(triangles, error)| LodInfo {
                error,
                triangles,
                vertices: 3 * triangles,
                origin: DVec3::ZERO,
                index_format: IndexFormat::U16,
                uniform_colour: None,
                encoded: false,
                grid: None,
                compressed: false,
                offset: 0,
                len: 0,
                checksum: 0,
            }));
        }
        for i in (1..nodes.len()).rev() {
            let p = nodes[i].parent as usize;
            nodes[p].bounds = nodes[p].bounds.union(&nodes[i].bounds);
        }
        Skeleton::new(
            DVec3::ZERO,
            nodes[0].bounds,
            nodes,
            lods,
            Default::default(),
        )
        .expect("a valid skeleton")
    }

    /// Root (100 triangles at error 4) over an inner node with two levels,
    /// an inner node without LODs and an inner node whose one HLOD is far
    /// coarser in triangles than its leaf at that error.
    fn hand_made() -> Skeleton {
        skeleton(&[
            (NO_NODE, 0.0, &[(100, 4.0)]),
            (0, 0.0, &[(10, 2.0), (5, 3.0)]),
            (0, 2.0, &[]),
            (0, 4.0, &[(1, 0.5)]),
            (1, 0.0, &[(8, 0.0), (4, 1.0), (2, 2.5)]),
            (1, 1.0, &[(8, 0.0), (4, 1.0)]),
            (2, 2.0, &[(6, 0.0)]),
            (2, 3.0, &[(6, 0.0), (3, 5.0)]),
            // Only its finest level is within its parent's 0.5.
            (3, 4.0, &[(20, 0.5), (10, 1.0)]),
        ])
    }

    #[test]
    fn switch_factors_of_a_hand_made_tree() {
        let s = hand_made();
        let switches = node_switches(&s, &node_depths(&s));
        // Root at error 4: node 1 its 5-triangle level, node 2 through its
        // leaves (6 + 6: 3 at error 5 is too coarse), node 3 its 1.
        let factor = |i: usize| switches[i].as_ref().map(|w| w.factor);
        assert_eq!(factor(0), Some(18.0 / 100.0));
        // Node 1 at error 2: each leaf its 4-triangle level.
        assert_eq!(factor(1), Some(8.0 / 10.0));
        assert_eq!(factor(2), None, "no LODs: not counted");
        assert_eq!(factor(3), Some(20.0));
        assert!((4..9).all(|i| factor(i).is_none()), "leaves");

        let f = summarise_switches(&switches);
        let diagonal = 3f64.sqrt();
        assert_eq!(
            f,
            SwitchFactors {
                count: 3,
                median: 0.8,
                p90: 20.0,
                p99: 20.0,
                max: 20.0,
                over_2: 1,
                over_4: 1,
                over_8: 1,
                worst: Some(NodeSwitch {
                    node: 3,
                    depth: 1,
                    factor: 20.0,
                    triangles: 1,
                    error: 0.5,
                    diagonal,
                    children_triangles: 20,
                }),
            }
        );
        assert_eq!(SwitchFactors::of(&s), f);
        // Leaves' coarsest levels: 2 + 4 + 6 + 3 + 10.
        assert_eq!(leaf_floor(&s), 25);
    }

    #[test]
    fn switch_factors_of_a_lone_root_are_empty() {
        let s = skeleton(&[(NO_NODE, 0.0, &[(12, 0.0), (6, 1.0)])]);
        let f = SwitchFactors::of(&s);
        assert_eq!(f, SwitchFactors::default());
        assert_eq!(leaf_floor(&s), 6);
    }

    #[test]
    fn switch_ties_name_the_first_node_and_thresholds_are_strict() {
        // Three inner nodes over one leaf each: factors 8, 8 and 2.
        let s = skeleton(&[
            (NO_NODE, 0.0, &[]),
            (0, 0.0, &[(1, 1.0)]),
            (0, 1.0, &[(1, 1.0)]),
            (0, 2.0, &[(4, 1.0)]),
            (1, 0.0, &[(8, 0.0)]),
            (2, 1.0, &[(8, 0.0)]),
            (3, 2.0, &[(8, 0.0)]),
        ]);
        let f = SwitchFactors::of(&s);
        assert_eq!((f.count, f.median, f.max), (3, 8.0, 8.0));
        assert_eq!((f.over_2, f.over_4, f.over_8), (2, 2, 0));
        let w = f.worst.unwrap();
        assert_eq!((w.node, w.depth, w.children_triangles), (1, 1, 8));
    }

    #[test]
    fn quantiles_index_floor_q_n() {
        let v: Vec<f64> = (1..=20).map(f64::from).collect();
        assert_eq!(quantile(&v, 0.5), 11.0);
        assert_eq!(quantile(&v, 0.9), 19.0);
        assert_eq!(quantile(&v, 0.99), 20.0);
        assert_eq!(quantile(&[3.0], 0.99), 3.0);
        assert_eq!(quantile(&[], 0.5), 0.0);
    }

    #[test]
    fn a_deep_chain_is_one_pass() {
        // 100k nodes in a chain, errors growing towards the root: each
        // node's walk stops at its child (a walk to the leaf from every
        // node would be 5e9 steps), and nothing recurses.
        let n = 100_000usize;
        let lods: Vec<[(u32, f32); 1]> = (0..n)
            .map(|i| {
                if i + 1 == n {
                    [(64, 0.0)]
                } else {
                    [(1, 1.0 / (1.0 + i as f32))]
                }
            })
            .collect();
        let borrowed: Vec<NodeSpec> = lods
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let parent = if i == 0 { NO_NODE } else { i as u32 - 1 };
                (parent, 0.0, l.as_slice())
            })
            .collect();
        let s = skeleton(&borrowed);
        let f = SwitchFactors::of(&s);
        assert_eq!(f.count, n - 1);
        // Each node's error is coarser than its child's: the child draws
        // its 1 triangle (the last inner node: the leaf's 64).
        assert_eq!((f.median, f.max, f.over_8), (1.0, 64.0, 1));
        assert_eq!(f.worst.unwrap().node, n as u32 - 2);
    }
}
