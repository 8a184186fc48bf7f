//! Coorg and Teller's object-space culler over the hierarchy (their
//! Fig. 9): a few large convex occluders chosen for the eye each frame,
//! and for each node the occluders that may still hide part of it carried
//! down the traversal as a bitmask. An occluder that hides a node fully
//! culls it; one that does not even partly hide it is dropped for the
//! node's subtree; a node with every occluder dropped is visible with its
//! whole subtree (no more tests below it). Occluders that partly hide a
//! node and share edges hide it together when they do (connected
//! occluders, Figs. 3-5, any number). Tangent planes depend only on the
//! (node, occluder) pair, so they are cached across frames.
//!
//! Candidates come from the scene's view cells (Section 3.1: the eye's
//! kD-tree cell lists the best occluders for the view direction nearest
//! the camera's) or, without them, are every occluder; the frame keeps the
//! best `k` by the area-angle metric from the eye. An occluder reaching
//! nearer than the near plane is clipped to it first (the image does not
//! show what lies in front of the near plane, so that part hides nothing);
//! a clipped occluder's planes are not cached and it is not joined with
//! others.

use std::collections::HashMap;

use gigawalk_scene::occluder_cells::OccluderCells;
use gigawalk_scene::Skeleton;
use glam::DVec3;

use crate::object_space::{
    connected_fully_occlude, ConvexOccluder, Occlusion, SharedEdge, TangentPlanes,
};
use crate::{CullView, Culler, RelBox, Verdict};

/// Most occluders a frame uses (the bitmask's width).
pub const MAX_FRAME_OCCLUDERS: usize = 64;

/// An occluder is clipped this far beyond the near plane (relative to the
/// near distance), so rounding never keeps a sliver the image lacks.
const NEAR_MARGIN: f64 = 1e-3;

/// What the culler did in a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CtStats {
    /// Occluders scored for the frame (the view cell's list, or all), and
    /// chosen.
    pub candidates: u64,
    pub occluders: u64,
    /// Chosen occluders that reached nearer than the near plane, clipped.
    pub clipped: u64,
    /// Nodes tested, and (node, occluder) classifications.
    pub nodes_tested: u64,
    pub pair_tests: u64,
    /// Nodes hidden only by connected occluders together.
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

/// An occluder the frame uses: a stored one, or one clipped to the near
/// plane.
#[derive(Clone, Debug)]
enum Chosen {
    Stored(u32),
    Clipped(ConvexOccluder),
}

/// The culler for one frame. Its context is the set of chosen occluders
/// *dropped* for a subtree (bit i: the frame's i-th occluder), so the
/// root starts with none dropped.
pub struct CtCuller<'a> {
    skeleton: &'a Skeleton,
    occluders: &'a [ConvexOccluder],
    areas: &'a [f64],
    /// View cells whose lists index `occluders`.
    cells: Option<&'a OccluderCells>,
    /// Occluders a frame may use (at most [`MAX_FRAME_OCCLUDERS`]).
    k: usize,
    /// Clip occluders at the near plane (else leave them out).
    clip: bool,
    chosen: Vec<Chosen>,
    cache: &'a mut PlaneCache,
    eye: DVec3,
    pub stats: CtStats,
}

impl<'a> CtCuller<'a> {
    /// `areas[i]` is occluder i's area (the metric's weight); `cells`, when
    /// given, list candidates by index into `occluders`.
    pub fn new(
        skeleton: &'a Skeleton,
        occluders: &'a [ConvexOccluder],
        areas: &'a [f64],
        cells: Option<&'a OccluderCells>,
        k: usize,
        cache: &'a mut PlaneCache,
    ) -> Self {
        CtCuller {
            skeleton,
            occluders,
            areas,
            cells,
            k: k.min(MAX_FRAME_OCCLUDERS),
            clip: true,
            chosen: Vec::new(),
            cache,
            eye: DVec3::ZERO,
            stats: CtStats::default(),
        }
    }

    /// Leaves out occluders reaching nearer than the near plane instead
    /// of clipping them.
    pub fn without_clipping(mut self) -> Self {
        self.clip = false;
        self
    }

    /// The occluders chosen for the last `begin`'s view, as used (clipped
    /// to the near plane where they reach nearer).
    pub fn chosen(&self) -> Vec<ConvexOccluder> {
        self.chosen
            .iter()
            .map(|c| match c {
                Chosen::Stored(i) => self.occluders[*i as usize].clone(),
                Chosen::Clipped(o) => o.clone(),
            })
            .collect()
    }

    /// Whether occluders that partly hide `node` (indices into the frame's
    /// chosen ones), joined across shared edges, hide it together.
    fn jointly_hidden(&mut self, node: u32, partial: &[usize]) -> bool {
        if partial.len() < 2 {
            return false;
        }
        let occluders = self.occluders;
        let stored: Vec<u32> = partial
            .iter()
            .filter_map(|&c| match self.chosen[c] {
                Chosen::Stored(i) => Some(i),
                Chosen::Clipped(_) => None,
            })
            .collect();
        let shared = self
            .cache
            .shared
            .get_or_insert_with(|| shared_edges(occluders));
        let mut edges: Vec<SharedEdge> = Vec::new();
        for (a, &i) in stored.iter().enumerate() {
            for (b, &j) in stored.iter().enumerate().skip(a + 1) {
                let (lo, hi, flip) = if i < j { (i, j, false) } else { (j, i, true) };
                if let Some(&(el, eh)) = shared.get(&(lo, hi)) {
                    let (ea, eb) = if flip { (eh, el) } else { (el, eh) };
                    edges.push((a, ea, b, eb));
                }
            }
        }
        if edges.is_empty() {
            return false;
        }
        let n = self.skeleton.node(node);
        let planes: Vec<TangentPlanes> = stored
            .iter()
            .map(|&i| match self.cache.planes.get(&(node, i)) {
                Some(p) => p.clone(),
                None => TangentPlanes::new(&occluders[i as usize], &n.bounds),
            })
            .collect();
        let members: Vec<(&ConvexOccluder, &TangentPlanes)> = stored
            .iter()
            .map(|&i| &occluders[i as usize])
            .zip(&planes)
            .collect();
        connected_fully_occlude(&members, &edges, self.eye)
    }

    /// How the frame's `c`-th occluder hides `node`.
    fn classify(&mut self, node: u32, c: usize) -> Option<Occlusion> {
        let n = self.skeleton.node(node);
        let occ = match &self.chosen[c] {
            Chosen::Clipped(o) => {
                self.stats.cache_misses += 1;
                return Some(TangentPlanes::new(o, &n.bounds).classify(self.eye));
            }
            Chosen::Stored(i) => *i,
        };
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

    /// Chooses the frame's occluders: of the candidates (the eye's view
    /// cell's list for the nearest direction, or every occluder), the `k`
    /// best by the paper's metric A |N . V| / |D|^2 (area, normal against
    /// the view direction, distance to the eye; walls occlude from both
    /// sides), each clipped to the near plane first.
    fn begin(&mut self, view: &CullView) {
        let eye = view.camera.position;
        let forward = view.camera.forward();
        let clip_at = view.camera.near * (1.0 + NEAR_MARGIN);
        self.eye = eye;
        let all: Vec<u32>;
        let candidates: &[u32] = match self.cells {
            Some(c) => c.lookup(eye, forward),
            None => {
                all = (0..self.occluders.len() as u32).collect();
                &all
            }
        };
        self.stats.candidates = candidates.len() as u64;
        let mut scored: Vec<(f64, u32, Option<ConvexOccluder>)> = Vec::new();
        for &i in candidates {
            let Some(stored) = self.occluders.get(i as usize) else {
                continue;
            };
            // With a section, only the part it keeps occludes.
            let cut = match view.section() {
                None => None,
                Some(s) => match section_part(stored, s, eye) {
                    SectionPart::Whole => None,
                    SectionPart::Part(c) => Some(c),
                    SectionPart::Gone => continue,
                },
            };
            let o = cut.as_ref().unwrap_or(stored);
            let depth = |v: DVec3| (v - eye).dot(forward);
            let (area, centroid, clipped) = if o.vertices().all(|v| depth(v) > clip_at) {
                match &cut {
                    None => (
                        self.areas.get(i as usize).copied().unwrap_or(0.0),
                        o.centroid(),
                        None,
                    ),
                    Some(c) => (c.area(), c.centroid(), Some(c.clone())),
                }
            } else if !self.clip || o.vertices().all(|v| depth(v) <= clip_at) {
                continue;
            } else {
                let Some(c) = o.clipped(eye + forward * clip_at, forward) else {
                    continue;
                };
                (c.area(), c.centroid(), Some(c))
            };
            let d = centroid - eye;
            let s = area * o.normal().dot(forward).abs() / d.length_squared();
            if s.is_finite() && s > 0.0 {
                scored.push((s, i, clipped));
            }
        }
        let k = self.k.min(scored.len());
        if k < scored.len() {
            scored.select_nth_unstable_by(k, |a, b| b.0.total_cmp(&a.0));
        }
        scored.truncate(k);
        scored.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        self.chosen = scored
            .into_iter()
            .map(|(_, i, c)| c.map_or(Chosen::Stored(i), Chosen::Clipped))
            .collect();
        // The stored occluders carry no object identity: with objects
        // hidden any of them may be one's face, so none is used (culling
        // only less, never wrongly).
        if view.visibility().is_some_and(|v| v.counts().0 > 0) {
            self.chosen.clear();
        }
        self.stats.occluders = self.chosen.len() as u64;
        self.stats.clipped = self
            .chosen
            .iter()
            .filter(|c| matches!(c, Chosen::Clipped(_)))
            .count() as u64;
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
            match self.classify(node, i) {
                Some(Occlusion::Full) => return (Verdict::Occluded, dropped),
                Some(Occlusion::Partial) => partial.push(i),
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

/// What of a convex occluder a section keeps.
enum SectionPart {
    Whole,
    Part(ConvexOccluder),
    Gone,
}

/// The occluder clipped by each of the section's half-spaces: a convex
/// polygon stays convex, and what is left lies on the kept part of the
/// surface it stands for, so it still hides what it covers. Each plane is
/// moved into the kept side by the GPU's rounding slack
/// ([`crate::view::SECTION_REL_SLACK`] of the distances from the eye), so
/// no occluder covers a sliver the GPU discards.
fn section_part(o: &ConvexOccluder, section: &crate::Section, eye: DVec3) -> SectionPart {
    let reach = o.vertices().map(|v| (v - eye).length()).fold(0.0, f64::max);
    let mut cut: Option<ConvexOccluder> = None;
    for h in section.half_spaces() {
        let slack = crate::view::SECTION_REL_SLACK * (h.distance(eye).abs() + reach);
        let current = cut.as_ref().unwrap_or(o);
        if current.vertices().all(|v| h.distance(v) >= slack) {
            continue;
        }
        match current.clipped(h.normal * (slack - h.d), h.normal) {
            Some(c) => cut = Some(c),
            None => return SectionPart::Gone,
        }
    }
    cut.map_or(SectionPart::Whole, SectionPart::Part)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Camera, NoOcclusion, TraversalOptions, Traverser, Viewport};
    use gigawalk_scene::Aabb;

    use crate::test_rng::Lcg;

    fn tree(leaves: &[Aabb]) -> Skeleton {
        crate::test_rng::tree(leaves, 2)
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
            pixel_error: 0.0,
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
            let mut ct = CtCuller::new(&sk, &occ, &areas, None, 32, &mut cache);
            Traverser::new().traverse_culled(
                &sk,
                &view,
                &mut ct,
                &opts,
                &mut |i: crate::DrawItem| drawn.push(i.node),
                &mut |_, _| {},
            );
            let chosen = ct.chosen();
            let mut nocache = PlaneCache::new(0);
            let mut drawn2 = Vec::new();
            let mut ct2 = CtCuller::new(&sk, &occ, &areas, None, 32, &mut nocache);
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
                let hidden = chosen
                    .iter()
                    .any(|o| occlusion(o, &sk.nodes()[n as usize].bounds, eye) == Occlusion::Full);
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

    fn culled(
        sk: &Skeleton,
        occ: &[ConvexOccluder],
        areas: &[f64],
        cells: Option<&OccluderCells>,
        view: &CullView,
    ) -> (Vec<u32>, CtStats) {
        let opts = TraversalOptions {
            occlusion: true,
            hlod: false,
            pixel_error: 0.0,
        };
        let mut cache = PlaneCache::new(1 << 16);
        let mut ct = CtCuller::new(sk, occ, areas, cells, 32, &mut cache);
        let mut drawn = Vec::new();
        Traverser::new().traverse_culled(
            sk,
            view,
            &mut ct,
            &opts,
            &mut |i: crate::DrawItem| drawn.push(i.node),
            &mut |_, _| {},
        );
        drawn.sort();
        (drawn, ct.stats)
    }

    #[test]
    fn an_occluder_through_the_near_plane_hides_only_with_what_the_image_shows() {
        // The eye at the origin looks down -z with the near plane at 1; a
        // wall tilted so that it runs from depth 0.5 (left) to depth 3
        // (right). A box behind its far part is hidden; a box behind the
        // part nearer than the near plane shows (that part is not drawn),
        // though the whole polygon would hide it.
        let wall = ConvexOccluder::new(&[
            DVec3::new(-2.0, -2.0, -0.5),
            DVec3::new(2.0, -2.0, -3.0),
            DVec3::new(2.0, 2.0, -3.0),
            DVec3::new(-2.0, 2.0, -0.5),
        ])
        .unwrap();
        let far = Aabb::new(DVec3::new(1.0, -0.3, -9.0), DVec3::new(1.6, 0.3, -8.5));
        let near = Aabb::new(DVec3::new(-2.6, -0.1, -1.3), DVec3::new(-2.4, 0.1, -1.2));
        let view = CullView::new(
            Camera::look_at(DVec3::ZERO, DVec3::NEG_Z, 140f64.to_radians(), 1.0, 1.0),
            Viewport::new(200, 200),
        );
        assert_eq!(occlusion(&wall, &near, DVec3::ZERO), Occlusion::Full);
        assert_eq!(occlusion(&wall, &far, DVec3::ZERO), Occlusion::Full);
        let sk = tree(&[far, near]);
        let (drawn, stats) = culled(&sk, &[wall], &[20.0], None, &view);
        assert_eq!(stats.clipped, 1);
        let leaf = |b: &Aabb| sk.nodes().iter().position(|n| n.bounds == *b).unwrap() as u32;
        assert_eq!(
            drawn,
            vec![leaf(&near)],
            "the far box is hidden, the near one shows"
        );
    }

    #[test]
    fn view_cells_listing_every_occluder_cull_as_every_occluder() {
        use gigawalk_scene::occluder_cells::CellNode;
        let mut rng = Lcg(9);
        let (sk, occ, areas) = street(&mut rng, DVec3::ZERO);
        // Two cells split across z, both listing everything for all
        // eight diagonal directions, and one cell listing nothing.
        let dirs: Vec<DVec3> = (0..8)
            .map(|i| {
                let s = |b: usize| if i & b == 0 { -1.0 } else { 1.0 };
                DVec3::new(s(1), s(2), s(4)).normalize()
            })
            .collect();
        let every: Vec<u32> = (0..occ.len() as u32).collect();
        let cells = OccluderCells {
            nodes: vec![
                CellNode::Split {
                    axis: 2,
                    at: -100.0,
                    first: 1,
                },
                CellNode::Leaf(0),
                CellNode::Leaf(1),
            ],
            directions: dirs,
            k: occ.len() as u32,
            lists: (0..16)
                .map(|i| if i < 8 { Vec::new() } else { every.clone() })
                .collect(),
        };
        let mut culled_any = false;
        for step in 0..6 {
            let eye = DVec3::new(0.5, 1.7, -12.0 * step as f64);
            let view = CullView::new(
                Camera::look_at(
                    eye,
                    eye + DVec3::new(0.1, 0.0, -1.0),
                    70f64.to_radians(),
                    1.6,
                    0.1,
                ),
                Viewport::new(160, 100),
            );
            let (with, s) = culled(&sk, &occ, &areas, Some(&cells), &view);
            let (without, _) = culled(&sk, &occ, &areas, None, &view);
            assert_eq!(with, without, "step {step}");
            assert_eq!(s.candidates, occ.len() as u64);
            culled_any |= s.nodes_tested > 0 && with.len() < sk.nodes().len() / 2;
            // An eye in the empty cell has no occluders.
            let away = CullView::new(
                Camera::look_at(
                    DVec3::new(0.0, 1.7, -150.0),
                    DVec3::new(0.0, 1.7, -160.0),
                    1.2,
                    1.6,
                    0.1,
                ),
                Viewport::new(160, 100),
            );
            let (_, s) = culled(&sk, &occ, &areas, Some(&cells), &away);
            assert_eq!((s.candidates, s.occluders), (0, 0));
        }
        assert!(culled_any);
    }

    #[test]
    fn hierarchical_culling_equals_flat_culling_of_every_leaf_with_or_without_the_cache() {
        run(DVec3::ZERO);
    }

    #[test]
    fn far_from_the_origin_too() {
        run(DVec3::new(1e7, 2e6, -3e7));
    }

    #[test]
    fn a_section_clips_an_occluder_to_what_it_keeps() {
        let square = ConvexOccluder::new(&[
            DVec3::new(0.0, 0.0, -5.0),
            DVec3::new(4.0, 0.0, -5.0),
            DVec3::new(4.0, 4.0, -5.0),
            DVec3::new(0.0, 4.0, -5.0),
        ])
        .unwrap();
        let eye = DVec3::ZERO;
        let section = |p: &str| crate::Section::parse(&[p.to_string()], None).unwrap();
        assert!(matches!(
            section_part(&square, &section("-1 0 0 10"), eye),
            SectionPart::Whole
        ));
        assert!(matches!(
            section_part(&square, &section("1 0 0 -10"), eye),
            SectionPart::Gone
        ));
        // Keeping x <= 1 leaves a 1 x 4 strip, a hair narrower (the slack).
        let SectionPart::Part(strip) = section_part(&square, &section("-1 0 0 1"), eye) else {
            panic!("the square is cut");
        };
        assert!(strip.vertices().all(|v| v.x <= 1.0));
        assert!((strip.area() - 4.0).abs() < 1e-3, "{}", strip.area());
    }
}
