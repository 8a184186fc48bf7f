//! Clustering (GigaWalk Section 4.2.2): group nearby small objects with a
//! minimum-spanning-forest merge in Kruskal order, using the
//! Felzenszwalb-Huttenlocher criterion and a maximum cluster volume.
//!
//! Neighbour pairs come from an AABB hierarchy query (obvhs), never from
//! an O(n^2) scan.

use gigawalk_scene::Aabb;
use glam::{DVec3, Vec3A};
use obvhs::{
    aabb::Aabb as BvhAabb,
    bvh2::{builder::build_bvh2, Bvh2},
    BvhBuildParams,
};
use rayon::prelude::*;

use crate::params::padded_volume;

/// Thresholds of one clustering run.
///
/// The paper's edge threshold is D = 0.1 x max bounding box dimension
/// (Section 6.3.1). We read "max bounding box dimension" per pair: the
/// largest box side of the larger of the two objects, so D_ij = d x
/// max(side_i, side_j). One global D from the largest object would give a
/// site-spanning floor's reach to every bolt: on a 10M-triangle plant that
/// made 256M edges (64 s, 5 GB); per pair it is a few per object.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClusterParams {
    /// D as a fraction of the larger object's largest box side.
    pub d: f64,
    /// Largest allowed cluster box volume (boxes measured with `min_extent`).
    pub v: f64,
    /// The Felzenszwalb-Huttenlocher K in thousandths of the edge's D (see
    /// `Params::k`): the merge test is w <= I(C) + (k / 1000) D_ij / |C|.
    pub k: f64,
    /// Thinnest side a box is given when measuring its volume.
    pub min_extent: f64,
}

/// One graph edge: two objects and the gap between their boxes (the
/// pair's D is recomputed where needed: edges outnumber objects, 17 to 1
/// on the generated plants, and their list is the clustering's largest
/// memory).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Edge {
    w: f64,
    a: u32,
    b: u32,
}

/// The largest side of each box: a pair's D is `d` times the larger of
/// its two.
fn sides(boxes: &[Aabb]) -> Vec<f64> {
    boxes.iter().map(|b| b.extent().max_element()).collect()
}

/// Groups objects (given by their boxes) into clusters. Returns the
/// clusters as lists of object indices, each list ascending, the lists
/// ordered by their first member (a fixed order for a fixed input), and
/// the number of edges in the graph.
pub fn cluster(boxes: &[Aabb], p: &ClusterParams) -> (Vec<Vec<u32>>, usize) {
    let edges = neighbour_edges(boxes, p.d);
    tracing::debug!(
        objects = boxes.len(),
        edges = edges.len(),
        "clustering graph"
    );
    (merge(boxes, &edges, p), edges.len())
}

/// Objects whose neighbours one task finds.
const EDGE_CHUNK: usize = 4096;

/// Every pair whose box gap is below its D, sorted by (weight, a, b).
fn neighbour_edges(boxes: &[Aabb], d: f64) -> Vec<Edge> {
    if boxes.len() < 2 {
        return Vec::new();
    }
    let side = sides(boxes);
    // The BVH is f32; build it relative to the scene centre so far-off
    // models keep their precision, and widen the queries by a margin that
    // covers f32 rounding. The exact test below is in f64.
    let scene = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
    let centre = scene.center();
    let slack = 1e-5 * scene.extent().max_element();
    let to_bvh = |b: &Aabb, pad: f64| {
        BvhAabb::new(
            Vec3A::from((b.min - centre - DVec3::splat(pad)).as_vec3()),
            Vec3A::from((b.max - centre + DVec3::splat(pad)).as_vec3()),
        )
    };
    let prims: Vec<BvhAabb> = boxes.iter().map(|b| to_bvh(b, 0.0)).collect();
    let bvh: Bvh2 = build_bvh2(
        &prims,
        BvhBuildParams::fast_build(),
        &mut Default::default(),
    );
    // Found in chunks of objects, each chunk's list cut to its length, then
    // joined into one list of exactly their total: growing lists hold up
    // to twice what they keep, and the edges are this step's memory.
    let n = boxes.len();
    let chunks: Vec<Vec<Edge>> = (0..n.div_ceil(EDGE_CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut found = Vec::new();
            for i in c * EDGE_CHUNK..(n.min((c + 1) * EDGE_CHUNK)) {
                // Each pair is found by the query of its larger member
                // (ties by index), whose reach is the pair's D.
                let di = d * side[i];
                bvh.aabb_traverse(to_bvh(&boxes[i], di + slack), |bvh, node| {
                    let n = &bvh.nodes[node as usize];
                    for k in n.first_index..n.first_index + n.prim_count {
                        let j = bvh.primitive_indices[k as usize] as usize;
                        if j != i && (side[j], j) < (side[i], i) {
                            let w = boxes[i].gap(&boxes[j]);
                            if w < di {
                                let (a, b) = (i.min(j) as u32, i.max(j) as u32);
                                found.push(Edge { w, a, b });
                            }
                        }
                    }
                    true
                });
            }
            found.shrink_to_fit();
            found
        })
        .collect();
    let mut edges = Vec::with_capacity(chunks.iter().map(Vec::len).sum());
    for chunk in chunks {
        edges.extend_from_slice(&chunk);
    }
    edges.par_sort_unstable_by(|x, y| x.w.total_cmp(&y.w).then((x.a, x.b).cmp(&(y.a, y.b))));
    edges
}

/// Kruskal-order merge (Section 4.2.2, steps 2-4).
fn merge(boxes: &[Aabb], edges: &[Edge], p: &ClusterParams) -> Vec<Vec<u32>> {
    let n = boxes.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    // Per root: internal variation I(C) (largest MST edge), size |C|, box.
    let mut internal = vec![0.0f64; n];
    let mut size = vec![1u32; n];
    let mut bounds = boxes.to_vec();
    let side = sides(boxes);
    for e in edges {
        let (ra, rb) = (find(&mut parent, e.a), find(&mut parent, e.b));
        if ra == rb {
            continue;
        }
        let (ra, rb) = (ra as usize, rb as usize);
        // The pair's D, as its query found it (`d` times the larger side).
        let d = p.d * side[e.a as usize].max(side[e.b as usize]);
        let k = p.k / 1000.0 * d;
        let ma = internal[ra] + k / size[ra] as f64;
        let mb = internal[rb] + k / size[rb] as f64;
        if e.w > ma.min(mb) {
            continue;
        }
        let joined = bounds[ra].union(&bounds[rb]);
        if padded_volume(&joined, p.min_extent) > p.v {
            continue;
        }
        // Union by size keeps the forest shallow; the smaller index wins a
        // tie so the result does not depend on anything but the input.
        let (big, small) = if (size[ra], rb) > (size[rb], ra) {
            (ra, rb)
        } else {
            (rb, ra)
        };
        parent[small] = big as u32;
        size[big] += size[small];
        bounds[big] = joined;
        // Edges come in non-decreasing order, so w is the new largest MST edge.
        internal[big] = e.w;
    }
    let mut root_slot = vec![u32::MAX; n];
    let mut clusters: Vec<Vec<u32>> = Vec::new();
    for i in 0..n as u32 {
        let r = find(&mut parent, i) as usize;
        if root_slot[r] == u32::MAX {
            root_slot[r] = clusters.len() as u32;
            clusters.push(Vec::new());
        }
        clusters[root_slot[r] as usize].push(i);
    }
    clusters
}

/// Union-find root of `x`, halving the path on the way.
pub(crate) fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let up = parent[parent[x as usize] as usize];
        parent[x as usize] = up;
        x = up;
    }
    x
}

#[cfg(test)]
mod tests {
    use rand::rngs::SmallRng;
    use rand::{RngExt, SeedableRng};

    use super::*;

    fn unit_box(x: f64, y: f64, z: f64) -> Aabb {
        Aabb::new(DVec3::new(x, y, z), DVec3::new(x + 1.0, y + 1.0, z + 1.0))
    }

    /// For unit cubes, whose largest side is 1, `d` is also the distance.
    fn params(d: f64, v: f64) -> ClusterParams {
        ClusterParams {
            d,
            v,
            k: 1500.0,
            min_extent: 1e-3,
        }
    }

    #[test]
    fn empty_and_single() {
        assert!(cluster(&[], &params(1.0, 10.0)).0.is_empty());
        assert_eq!(
            cluster(&[unit_box(0.0, 0.0, 0.0)], &params(1.0, 10.0)).0,
            vec![vec![0]]
        );
    }

    #[test]
    fn two_far_apart_groups_stay_separate() {
        // Two 2x2 groups of cubes 0.1 apart, the groups 50 apart.
        let mut boxes = Vec::new();
        for base in [0.0, 50.0] {
            for (dx, dy) in [(0.0, 0.0), (1.1, 0.0), (0.0, 1.1), (1.1, 1.1)] {
                boxes.push(unit_box(base + dx, dy, 0.0));
            }
        }
        let (c, _) = cluster(&boxes, &params(1.0, 1e6));
        assert_eq!(c, vec![vec![0, 1, 2, 3], vec![4, 5, 6, 7]]);
    }

    #[test]
    fn touching_row_merges_until_the_volume_cap() {
        // 20 touching unit cubes in a row along X; clusters may hold at most 5.
        let boxes: Vec<Aabb> = (0..20).map(|i| unit_box(i as f64, 0.0, 0.0)).collect();
        let (c, _) = cluster(&boxes, &params(0.5, 5.0));
        assert!(c.len() >= 4, "{c:?}");
        assert!(c.len() < 20, "nothing merged: {c:?}");
        for members in &c {
            let b = members
                .iter()
                .fold(Aabb::EMPTY, |a, &i| a.union(&boxes[i as usize]));
            assert!(
                b.volume() <= 5.0 + 1e-9,
                "cluster {members:?} has volume {}",
                b.volume()
            );
            // Touching cubes merge into contiguous runs.
            assert_eq!(b.extent().x as usize, members.len());
        }
        // Without the cap, the row is one cluster.
        assert_eq!(cluster(&boxes, &params(0.5, 1e9)).0.len(), 1);
    }

    #[test]
    fn criterion_rejects_a_wide_gap_to_a_tight_cluster() {
        // Five cubes 0.01 apart, then one 0.9 away: with K small, the tight
        // cluster's K/|C| term is too small to accept the wide gap.
        let mut boxes: Vec<Aabb> = (0..5)
            .map(|i| unit_box(i as f64 * 1.01, 0.0, 0.0))
            .collect();
        boxes.push(unit_box(4.0 * 1.01 + 1.0 + 0.9, 0.0, 0.0));
        // K = 200 thousandths of D = 1: a K/|C| term of 0.2 for a lone cube.
        let p = ClusterParams {
            d: 1.0,
            v: 1e9,
            k: 200.0,
            min_extent: 1e-3,
        };
        let (c, _) = cluster(&boxes, &p);
        assert_eq!(c, vec![vec![0, 1, 2, 3, 4], vec![5]]);
        // A larger K accepts it.
        let p = ClusterParams { k: 10_000.0, ..p };
        assert_eq!(cluster(&boxes, &p).0.len(), 1);
    }

    #[test]
    fn edges_match_brute_force() {
        let mut boxes = Vec::new();
        let mut rng = SmallRng::seed_from_u64(12345);
        let mut rnd = || rng.random::<f64>();
        for _ in 0..300 {
            let min = DVec3::new(rnd() * 100.0, rnd() * 100.0, rnd() * 10.0);
            boxes.push(Aabb::new(
                min,
                min + DVec3::new(rnd() * 3.0, rnd() * 3.0, rnd() * 3.0),
            ));
        }
        let got = neighbour_edges(&boxes, 0.5);
        let mut want = Vec::new();
        for i in 0..boxes.len() {
            for j in i + 1..boxes.len() {
                let w = boxes[i].gap(&boxes[j]);
                let d = 0.5
                    * boxes[i]
                        .extent()
                        .max_element()
                        .max(boxes[j].extent().max_element());
                if w < d {
                    want.push(Edge {
                        w,
                        a: i as u32,
                        b: j as u32,
                    });
                }
            }
        }
        want.sort_by(|x, y| x.w.total_cmp(&y.w).then((x.a, x.b).cmp(&(y.a, y.b))));
        assert_eq!(got, want);
    }
}
