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
    /// Sum over nodes at tree depth d (root = 0) of their finest LOD's
    /// triangles: the scene drawn as a cut through the tree at depth d.
    pub hlod_triangles_per_depth: Vec<u64>,
    /// The HLOD chains of the inner nodes at each tree depth (root = 0).
    pub hlod_levels_per_depth: Vec<DepthLevels>,
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
    pub provenance: Provenance,
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

/// The median of `v` (sorted in place); the upper one of an even count.
fn median<T: Copy + PartialOrd + Default>(v: &mut [T]) -> T {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    v.get(v.len() / 2).copied().unwrap_or_default()
}

/// Triangles the subtree of `node` draws at `error`: each node its
/// coarsest level within it, else its children's; a leaf with no level
/// within it draws its finest (as traversal does). Iterative: a
/// validated scene may still be one long chain of nodes.
fn triangles_within(s: &crate::Skeleton, node: u32, error: f32) -> u64 {
    let mut total = 0;
    let mut stack = vec![node];
    while let Some(n) = stack.pop() {
        let lods = s.node_lods(n);
        match lods.iter().rev().find(|l| l.error <= error) {
            Some(l) => total += u64::from(l.triangles),
            None if s.nodes[n as usize].is_leaf() => {
                total += lods.first().map_or(0, |l| u64::from(l.triangles));
            }
            None => stack.extend(s.nodes[n as usize].children()),
        }
    }
    total
}

impl SceneStats {
    pub fn of<R: crate::ReadAt>(r: &SceneReader<R>) -> SceneStats {
        let s = r.skeleton();
        let max_lods = s
            .nodes
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
        let mut depth = vec![0usize; s.nodes.len()];
        let mut per_depth: Vec<u64> = Vec::new();
        for (i, n) in s.nodes.iter().enumerate() {
            if n.parent != NO_NODE {
                depth[i] = depth[n.parent as usize] + 1;
            }
            if per_depth.len() <= depth[i] {
                per_depth.resize(depth[i] + 1, 0);
            }
            // A node without LODs is drawn through its children.
            per_depth[depth[i]] += s
                .node_lods(i as u32)
                .first()
                .map_or(0, |l| l.triangles as u64);
        }
        let mut levels_per_depth = Vec::new();
        for d in 0..per_depth.len() {
            let at: Vec<usize> = (0..s.nodes.len()).filter(|&i| depth[i] == d).collect();
            let inner: Vec<usize> = at
                .iter()
                .copied()
                .filter(|&i| !s.nodes[i].is_leaf())
                .collect();
            let mut counts: Vec<usize> = inner
                .iter()
                .map(|&i| s.nodes[i].lod_count as usize)
                .collect();
            let mut tris: Vec<u64> = inner
                .iter()
                .filter_map(|&i| s.node_lods(i as u32).first().map(|l| l.triangles as u64))
                .collect();
            let mut switch: Vec<f64> = inner
                .iter()
                .filter_map(|&i| {
                    let l = s.node_lods(i as u32).first()?;
                    let below: u64 = s.nodes[i]
                        .children()
                        .map(|c| triangles_within(s, c, l.error))
                        .sum();
                    Some(below as f64 / f64::from(l.triangles.max(1)))
                })
                .collect();
            let mut errs: Vec<f64> = inner
                .iter()
                .filter_map(|&i| {
                    let diag = s.nodes[i].bounds.diagonal();
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
        let triangles = s.finest_triangles();
        let diagonal = s.bounds.diagonal();
        let triangles_at_error = (1..=16)
            .map(|k| {
                let e = diagonal / f64::from(1u32 << k);
                // A validated scene has one root, node 0.
                (e, triangles_within(s, 0, e as f32))
            })
            .collect();
        let (major, minor) = r.version();
        SceneStats {
            format_version: format!("{major}.{minor}"),
            file_bytes: r.file_len(),
            nodes: s.nodes.len(),
            leaves: s.leaves().count(),
            depth: s.depth(),
            max_lods_per_node: max_lods,
            triangles,
            leaf_triangles_per_level: per_level,
            hlod_triangles_per_depth: per_depth,
            hlod_levels_per_depth: levels_per_depth,
            triangles_at_error,
            bounds_min: s.bounds.min.to_array(),
            bounds_max: s.bounds.max.to_array(),
            origin: s.origin.to_array(),
            sections: r
                .sections()
                .iter()
                .map(|x| (x.name.clone(), x.len))
                .collect(),
            bytes_per_triangle: r.file_len() as f64 / triangles.max(1) as f64,
            provenance: s.provenance.clone(),
        }
    }
}
