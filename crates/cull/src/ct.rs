//! Coorg and Teller's object-space culler over the hierarchy (their
//! Fig. 9): a few large convex occluders chosen for the eye each frame,
//! and for each node the occluders that may still hide part of it carried
//! down the traversal as a bitmask. An occluder that hides a node fully
//! culls it; one that does not even partly hide it is dropped for the
//! node's subtree; a node with every occluder dropped is visible with its
//! whole subtree (no more tests below it). Tangent planes depend only on
//! the (node, occluder) pair, so they are cached across frames.
//!
//! Occluders come from the caller (preprocess's convex faces); the
//! view-cell tree that would pick them per region is not built yet: each
//! frame scores every occluder by the paper's area-angle metric.

use std::collections::HashMap;

use gigawalk_scene::Skeleton;
use glam::DVec3;

use crate::object_space::{pair_fully_occludes, ConvexOccluder, Occlusion, TangentPlanes};
use crate::{CullView, Culler, RelBox, Verdict};

/// Most occluders a frame uses (the bitmask's width).
pub const MAX_FRAME_OCCLUDERS: usize = 64;

/// What the culler did in a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CtStats {
    /// Occluders chosen for the frame.
    pub occluders: u64,
    /// Nodes tested, and (node, occluder) classifications.
    pub nodes_tested: u64,
    pub pair_tests: u64,
    /// Nodes hidden only by two connected occluders together.
    pub joint: u64,
    /// Tangent planes found in the cache, and computed.
    pub cache_hits: u64,
    pub cache_misses: u64,
}

/// Tangent planes by (node, occluder index), kept across frames; emptied
/// when it would pass `capacity` entries.
#[derive(Debug, Default)]
pub struct PlaneCache {
    planes: HashMap<(u32, u32), TangentPlanes>,
    capacity: usize,
    /// Occluder pairs sharing an edge: (i, j) with i < j -> (edge of i,
    /// edge of j). Found on first use.
    shared: Option<HashMap<(u32, u32), (usize, usize)>>,
}

/// Pairs of occluders sharing an edge (end points equal up to 1e-9 of the
/// edge's length).
fn shared_edges(occluders: &[ConvexOccluder]) -> HashMap<(u32, u32), (usize, usize)> {
    let mut by_end: HashMap<[i64; 6], Vec<(u32, usize)>> = HashMap::new();
    let key = |a: DVec3, b: DVec3, step: f64| {
        let (a, b) = if (a.x, a.y, a.z) <= (b.x, b.y, b.z) {
            (a, b)
        } else {
            (b, a)
        };
        let q = |v: f64| (v / step).round() as i64;
        [q(a.x), q(a.y), q(a.z), q(b.x), q(b.y), q(b.z)]
    };
    let mut out = HashMap::new();
    for (i, o) in occluders.iter().enumerate() {
        let v: Vec<DVec3> = o.vertices().collect();
        for e in 0..v.len() {
            let (a, b) = (v[e], v[(e + 1) % v.len()]);
            let step = ((b - a).length() * 1e-7).max(f64::MIN_POSITIVE);
            for (j, f) in by_end.entry(key(a, b, step)).or_default().iter() {
                out.insert((*j, i as u32), (*f, e));
            }
            by_end
                .get_mut(&key(a, b, step))
                .expect("entry")
                .push((i as u32, e));
        }
    }
    out
}

impl PlaneCache {
    /// `capacity` 0: no caching.
    pub fn new(capacity: usize) -> Self {
        PlaneCache {
            planes: HashMap::new(),
            capacity,
            shared: None,
        }
    }

    pub fn len(&self) -> usize {
        self.planes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.planes.is_empty()
    }
}

/// The culler for one frame. Its context is the set of chosen occluders
/// *dropped* for a subtree (bit i: the frame's i-th occluder), so the
/// root starts with none dropped.
pub struct CtCuller<'a> {
    skeleton: &'a Skeleton,
    occluders: &'a [ConvexOccluder],
    areas: &'a [f64],
    /// Occluders a frame may use (at most [`MAX_FRAME_OCCLUDERS`]).
    k: usize,
    chosen: Vec<u32>,
    cache: &'a mut PlaneCache,
    eye: DVec3,
    pub stats: CtStats,
}

impl<'a> CtCuller<'a> {
    /// `areas[i]` is occluder i's area (the metric's weight).
    pub fn new(
        skeleton: &'a Skeleton,
        occluders: &'a [ConvexOccluder],
        areas: &'a [f64],
        k: usize,
        cache: &'a mut PlaneCache,
    ) -> Self {
        CtCuller {
            skeleton,
            occluders,
            areas,
            k: k.min(MAX_FRAME_OCCLUDERS),
            chosen: Vec::new(),
            cache,
            eye: DVec3::ZERO,
            stats: CtStats::default(),
        }
    }

    /// The occluders chosen for the last `begin`'s view.
    pub fn chosen(&self) -> &[u32] {
        &self.chosen
    }

    /// Whether two of the occluders that partly hide `node`, sharing an
    /// edge, hide it together (connected occluders, Figs. 3-5).
    fn jointly_hidden(&mut self, node: u32, partial: &[u32]) -> bool {
        if partial.len() < 2 {
            return false;
        }
        let occluders = self.occluders;
        let shared = self
            .cache
            .shared
            .get_or_insert_with(|| shared_edges(occluders));
        let pairs: Vec<(u32, u32, usize, usize)> = partial
            .iter()
            .enumerate()
            .flat_map(|(k, &i)| partial[k + 1..].iter().map(move |&j| (i.min(j), i.max(j))))
            .filter_map(|(i, j)| shared.get(&(i, j)).map(|&(ei, ej)| (i, j, ei, ej)))
            .collect();
        let Some(n) = self.skeleton.nodes.get(node as usize) else {
            return false;
        };
        pairs.into_iter().any(|(i, j, ei, ej)| {
            let (a, b) = (&occluders[i as usize], &occluders[j as usize]);
            let (pa, pb) = (
                TangentPlanes::new(a, &n.bounds),
                TangentPlanes::new(b, &n.bounds),
            );
            pair_fully_occludes((a, &pa, ei), (b, &pb, ej), self.eye)
        })
    }

    fn planes(&mut self, node: u32, occ: u32) -> Option<Occlusion> {
        let n = self.skeleton.nodes.get(node as usize)?;
        let o = self.occluders.get(occ as usize)?;
        if self.cache.capacity == 0 {
            self.stats.cache_misses += 1;
            return Some(TangentPlanes::new(o, &n.bounds).classify(self.eye));
        }
        if let Some(p) = self.cache.planes.get(&(node, occ)) {
            self.stats.cache_hits += 1;
            return Some(p.classify(self.eye));
        }
        self.stats.cache_misses += 1;
        if self.cache.planes.len() >= self.cache.capacity {
            self.cache.planes.clear();
        }
        let p = TangentPlanes::new(o, &n.bounds);
        let c = p.classify(self.eye);
        self.cache.planes.insert((node, occ), p);
        Some(c)
    }
}

impl Culler for CtCuller<'_> {
    type Ctx = u64;

    /// Chooses the frame's occluders: the `k` best by the paper's metric
    /// A |N . V| / |D|^2 (area, normal against the view direction, distance
    /// to the eye; walls occlude from both sides), leaving out any with a
    /// vertex nearer than the near plane (the image does not show what is
    /// in front of it, so it could not hide what is behind).
    fn begin(&mut self, view: &CullView) {
        let eye = view.camera.position;
        let forward = view.camera.forward();
        let near = view.camera.near;
        self.eye = eye;
        let mut scored: Vec<(f64, u32)> = self
            .occluders
            .iter()
            .enumerate()
            .filter(|(_, o)| o.vertices().all(|v| (v - eye).dot(forward) > near))
            .map(|(i, o)| {
                let d = o.centroid() - eye;
                let area = self.areas.get(i).copied().unwrap_or(0.0);
                (
                    area * o.normal().dot(forward).abs() / d.length_squared(),
                    i as u32,
                )
            })
            .filter(|(s, _)| s.is_finite() && *s > 0.0)
            .collect();
        let k = self.k.min(scored.len());
        if k < scored.len() {
            scored.select_nth_unstable_by(k, |a, b| b.0.total_cmp(&a.0));
        }
        scored.truncate(k);
        scored.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        self.chosen = scored.into_iter().map(|(_, i)| i).collect();
        self.stats.occluders = self.chosen.len() as u64;
    }

    fn test(&mut self, _: &CullView, node: u32, _: &RelBox, dropped: &u64) -> (Verdict, u64) {
        self.stats.nodes_tested += 1;
        let mut dropped = *dropped;
        let mut partial = Vec::new();
        for i in 0..self.chosen.len() {
            if dropped & (1 << i) != 0 {
                continue;
            }
            self.stats.pair_tests += 1;
            match self.planes(node, self.chosen[i]) {
                Some(Occlusion::Full) => return (Verdict::Occluded, dropped),
                Some(Occlusion::Partial) => partial.push(self.chosen[i]),
                Some(Occlusion::None) | None => dropped |= 1 << i,
            }
        }
        if self.jointly_hidden(node, &partial) {
            self.stats.joint += 1;
            return (Verdict::Occluded, dropped);
        }
        let all = if self.chosen.len() >= 64 {
            u64::MAX
        } else {
            (1u64 << self.chosen.len()) - 1
        };
        if dropped & all == all {
            (Verdict::VisibleBelow, dropped)
        } else {
            (Verdict::Visible, dropped)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Camera, NoOcclusion, TraversalOptions, Traverser, Viewport};
    use gigawalk_scene::{Aabb, IndexFormat, LodInfo, Node, NO_NODE};

    use crate::test_rng::Lcg;

    /// A binary tree over `leaves` (median splits along x, built breadth
    /// first so children are contiguous and after their parent), every
    /// node with one LOD.
    fn tree(leaves: &[Aabb]) -> Skeleton {
        // Breadth-first so children are contiguous and after parents.
        let mut nodes: Vec<Node> = Vec::new();
        let mut queue: std::collections::VecDeque<(Vec<Aabb>, u32)> = Default::default();
        queue.push_back((leaves.to_vec(), NO_NODE));
        let mut slots: Vec<(Vec<Aabb>, u32)> = Vec::new();
        while let Some((boxes, parent)) = queue.pop_front() {
            slots.push((boxes.clone(), parent));
            if boxes.len() > 1 {
                let mut b = boxes;
                b.sort_by(|a, c| a.center().x.total_cmp(&c.center().x));
                let r = b.split_off(b.len() / 2);
                let me = slots.len() as u32 - 1;
                queue.push_back((b, me));
                queue.push_back((r, me));
            }
        }
        for (i, (boxes, parent)) in slots.iter().enumerate() {
            let bounds = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
            nodes.push(Node {
                bounds,
                parent: *parent,
                first_child: 0,
                child_count: 0,
                first_lod: i as u32,
                lod_count: 1,
            });
        }
        for i in 1..nodes.len() {
            let p = nodes[i].parent as usize;
            if nodes[p].child_count == 0 {
                nodes[p].first_child = i as u32;
            }
            nodes[p].child_count += 1;
        }
        let lods = (0..nodes.len())
            .map(|_| LodInfo {
                error: 0.0,
                triangles: 12,
                vertices: 8,
                origin: DVec3::ZERO,
                index_format: IndexFormat::U16,
                uniform_colour: None,
                offset: 0,
                len: 0,
                checksum: 0,
            })
            .collect();
        Skeleton {
            origin: DVec3::ZERO,
            bounds: nodes[0].bounds,
            nodes,
            lods,
            provenance: Default::default(),
        }
    }

    /// A street: walls (occluders) along both sides, boxes behind them.
    fn street(rng: &mut Lcg, offset: DVec3) -> (Skeleton, Vec<ConvexOccluder>, Vec<f64>) {
        let mut boxes = Vec::new();
        for _ in 0..300 {
            let side = if rng.unit() < 0.5 { -1.0 } else { 1.0 };
            let c = offset
                + DVec3::new(
                    side * (6.0 + 30.0 * rng.unit()),
                    2.0 * rng.unit(),
                    -200.0 * rng.unit(),
                );
            let h = DVec3::splat(0.3 + rng.unit());
            boxes.push(Aabb::new(c - h, c + h));
        }
        let mut occ = Vec::new();
        let mut areas = Vec::new();
        for i in 0..10 {
            for side in [-1.0, 1.0] {
                let x = offset.x + side * 5.0;
                let z0 = offset.z - 20.0 * i as f64;
                let v = [
                    DVec3::new(x, offset.y - 1.0, z0),
                    DVec3::new(x, offset.y - 1.0, z0 - 18.0),
                    DVec3::new(x, offset.y + 6.0, z0 - 18.0),
                    DVec3::new(x, offset.y + 6.0, z0),
                ];
                occ.push(ConvexOccluder::new(&v).unwrap());
                areas.push(18.0 * 7.0);
            }
        }
        (tree(&boxes), occ, areas)
    }

    fn run(offset: DVec3) {
        let mut rng = Lcg(5);
        let (sk, occ, areas) = street(&mut rng, offset);
        let opts = TraversalOptions {
            occlusion: true,
            hlod: false,
            pixel_tolerance: 0.0,
        };
        let mut culled_somewhere = 0;
        let mut cache = PlaneCache::new(1 << 16);
        for step in 0..12 {
            let eye = offset + DVec3::new(rng.unit() * 4.0 - 2.0, 1.7, -15.0 * step as f64);
            let target = eye + DVec3::new(rng.unit() - 0.5, 0.0, -1.0);
            let view = CullView::new(
                Camera::look_at(eye, target, 70f64.to_radians(), 1.6, 0.1),
                Viewport::new(160, 100),
            );
            let leaves = |c: &mut dyn FnMut(u32)| {
                let mut t = Traverser::new();
                let mut out = Vec::new();
                t.traverse(
                    &sk,
                    &view,
                    &NoOcclusion,
                    &opts,
                    &mut |i: crate::DrawItem| out.push(i.node),
                );
                out.into_iter().for_each(c);
            };
            // Hierarchical, with the cache carried across frames and without.
            let mut drawn = Vec::new();
            let mut ct = CtCuller::new(&sk, &occ, &areas, 32, &mut cache);
            Traverser::new().traverse_culled(
                &sk,
                &view,
                &mut ct,
                &opts,
                &mut |i: crate::DrawItem| drawn.push(i.node),
                &mut |_, _| {},
            );
            let chosen = ct.chosen().to_vec();
            let mut nocache = PlaneCache::new(0);
            let mut drawn2 = Vec::new();
            let mut ct2 = CtCuller::new(&sk, &occ, &areas, 32, &mut nocache);
            Traverser::new().traverse_culled(
                &sk,
                &view,
                &mut ct2,
                &opts,
                &mut |i: crate::DrawItem| drawn2.push(i.node),
                &mut |_, _| {},
            );
            assert_eq!(drawn, drawn2, "cache on and off differ");
            // Flat: every frustum-visible leaf against every chosen occluder.
            let mut flat = Vec::new();
            leaves(&mut |n| {
                let hidden = chosen.iter().any(|&o| {
                    occlusion(&occ[o as usize], &sk.nodes[n as usize].bounds, eye)
                        == Occlusion::Full
                });
                if !hidden {
                    flat.push(n);
                }
            });
            let (mut a, mut b) = (drawn.clone(), flat.clone());
            a.sort();
            b.sort();
            assert_eq!(a, b, "hierarchical and flat culling differ at step {step}");
            let mut all = 0;
            leaves(&mut |_| all += 1);
            culled_somewhere += all - drawn.len();
        }
        assert!(
            culled_somewhere > 50,
            "the walls hid little: {culled_somewhere}"
        );
    }

    use crate::object_space::occlusion;

    #[test]
    fn hierarchical_culling_equals_flat_culling_of_every_leaf_with_or_without_the_cache() {
        run(DVec3::ZERO);
    }

    #[test]
    fn far_from_the_origin_too() {
        run(DVec3::new(1e7, 2e6, -3e7));
    }
}
