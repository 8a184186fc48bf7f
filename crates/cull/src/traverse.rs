//! Scene traversal with culling and LOD selection (GigaWalk Algorithm 5.2),
//! and the LOD re-selection the occluder pass runs on an older frame's list.

use std::collections::BinaryHeap;

use gigawalk_scene::Skeleton;
use glam::DVec3;

use crate::lod::{distance_to_rel_box, select_lod};
use crate::nearest::Nearest;
use crate::BoxSide;
use crate::{
    BoxTest, Containment, CullView, Culler, NodeShow, OcclusionTest, PlaneMask, Verdict, ALL_PLANES,
};

/// Traversal settings; the modes of GigaWalk Table 2 are combinations of
/// `occlusion` and `hlod` (VFC: neither, tolerance 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraversalOptions {
    /// Test nodes against the occlusion test (off for the first frames,
    /// before any occluder depth exists).
    pub occlusion: bool,
    /// Stop at inner nodes whose HLOD is acceptable; off = always refine to
    /// the leaves.
    pub hlod: bool,
    /// Largest acceptable screen-space error in pixels. 0 = full detail:
    /// always refine to the leaves and draw their finest LOD.
    pub pixel_error: f64,
}

impl TraversalOptions {
    /// The traversal of a mode (the paper's Table 2 rows, the viewer's
    /// and the page's toggles): frustum culling always, occlusion culling
    /// when `occlusion`, levels of detail at `pixel_error` when `hlod`.
    /// HLOD off is full detail everywhere: no inner node's HLOD and every
    /// leaf at its finest level (pixel error 0), the reference the
    /// approximate modes are measured against.
    pub fn mode(occlusion: bool, hlod: bool, pixel_error: f64) -> TraversalOptions {
        TraversalOptions {
            occlusion,
            hlod,
            pixel_error: if hlod { pixel_error } else { 0.0 },
        }
    }
}

/// The pixel errors `-` and `+` step through: 0 is full detail; then
/// doubling from half a pixel (the paper's Table 2 uses 1 to 20 pixels;
/// 64 is far past visible).
pub const PIXEL_ERROR_STEPS: &[f64] = &[0.0, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0];

/// The next step of [`PIXEL_ERROR_STEPS`] above (`up`) or below
/// `current`; `current` at either end.
pub fn step_pixel_error(current: f64, up: bool) -> f64 {
    let mut steps = PIXEL_ERROR_STEPS.iter().copied();
    let next = if up {
        steps.find(|&s| s > current)
    } else {
        steps.rev().find(|&s| s < current)
    };
    next.unwrap_or(current)
}

impl Default for TraversalOptions {
    fn default() -> Self {
        TraversalOptions {
            occlusion: true,
            hlod: true,
            pixel_error: 1.0,
        }
    }
}

/// One node to draw and which of its LODs (0 = finest; the LodInfo is
/// `skeleton.lods[node.first_lod + lod]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct DrawItem {
    pub node: u32,
    pub lod: u32,
}

/// Receives draw items as traversal finds them, so the runtime can stream
/// them into a queue. Any `FnMut(DrawItem)` is a sink.
pub trait DrawSink {
    fn draw(&mut self, item: DrawItem);
}

impl<F: FnMut(DrawItem)> DrawSink for F {
    fn draw(&mut self, item: DrawItem) {
        self(item)
    }
}

/// Why traversal culled a node.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CullReason {
    /// Outside the view frustum.
    Frustum,
    /// Hidden behind the occluders (the occlusion test said invisible).
    Occlusion,
}

/// What one traversal did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TraversalStats {
    /// Nodes taken off the front-to-back queue and tested.
    pub visited: u64,
    pub frustum_culled: u64,
    pub occlusion_culled: u64,
    pub drawn_nodes: u64,
    pub drawn_triangles: u64,
    /// Nodes whose every object is hidden.
    pub hidden_culled: u64,
    /// Nodes wholly on the removed side of the section.
    pub section_culled: u64,
}

/// What traversal keeps beside a queued node, in one word so that a
/// queue entry is 16 bytes: the frustum planes still to test (5 bits),
/// whether the culler still tests it (false below a node the culler
/// called [`Verdict::VisibleBelow`]), and the index of the culler context
/// it was queued with (the rest).
#[derive(Clone, Copy, Debug)]
struct Queued(u32);

impl Queued {
    const MASK_BITS: u32 = 5;
    const TEST_BIT: u32 = 1 << Self::MASK_BITS;
    const CTX_SHIFT: u32 = Self::MASK_BITS + 1;
    /// Contexts a frame can index; past it a node's children share its
    /// own context (see `traverse_culled`).
    const MAX_CTX: u32 = u32::MAX >> Self::CTX_SHIFT;

    fn new(mask: PlaneMask, test: bool, ctx: u32) -> Queued {
        debug_assert!(u32::from(mask) < Self::TEST_BIT && ctx <= Self::MAX_CTX);
        let test = if test { Self::TEST_BIT } else { 0 };
        Queued(u32::from(mask) | test | ctx << Self::CTX_SHIFT)
    }

    fn mask(self) -> PlaneMask {
        (self.0 & (Self::TEST_BIT - 1)) as PlaneMask
    }

    fn test(self) -> bool {
        self.0 & Self::TEST_BIT != 0
    }

    fn ctx(self) -> u32 {
        self.0 >> Self::CTX_SHIFT
    }
}

const _: () = assert!(ALL_PLANES as u32 >> Queued::MASK_BITS == 0);

/// A queued node, nearest first.
type Entry = Nearest<Queued>;

const _: () = assert!(std::mem::size_of::<Entry>() == 16);

/// What to do with a node that survived culling.
enum Choice {
    Draw(u32),
    Refine,
    /// Every object below is hidden.
    Skip,
}

/// The one LOD rule, shared by traversal and re-selection so both pick the
/// same LODs for the same camera (the condition for conservative culling,
/// GigaWalk Section 5.3).
///
/// `(min, max)` is the node's box relative to the camera
/// ([`CullView::rel_f64`]) and `nearest` the distance to its nearest
/// point ([`distance_to_rel_box`]), which both callers already hold.
fn choose(
    skeleton: &Skeleton,
    node: u32,
    (min, max): (DVec3, DVec3),
    nearest: f64,
    view: &CullView,
    o: &TraversalOptions,
) -> Choice {
    let n = skeleton.node(node);
    match view.show(node) {
        NodeShow::Whole => {}
        NodeShow::Hidden => return Choice::Skip,
        // No LOD of the node leaves out or tints one object alone: a
        // leaf draws its full detail in pieces, an inner node refines.
        NodeShow::Partial if n.is_leaf() => return Choice::Draw(0),
        NodeShow::Partial => return Choice::Refine,
    }
    // In the table, and at least one for a leaf: the skeleton is valid.
    let lods = &skeleton.lods()[n.lods()];
    let full_detail = o.pixel_error.is_nan() || o.pixel_error <= 0.0;
    let distance = || view.lod_distance(min, max);
    if n.is_leaf() {
        if full_detail {
            return Choice::Draw(0);
        }
        let l = select_lod(lods, distance(), view.pixels_per_radian, o.pixel_error);
        // Too coarse even at its finest: draw the finest, there is no finer.
        return Choice::Draw(l.unwrap_or(0) as u32);
    }
    if o.hlod && !full_detail && !refines_at(lods, nearest, view, o) {
        if let Some(l) = select_lod(lods, distance(), view.pixels_per_radian, o.pixel_error) {
            return Choice::Draw(l as u32);
        }
    }
    Choice::Refine
}

/// Whether even the finest of `lods` is too coarse at the box's nearest
/// distance, so that [`select_lod`] at [`CullView::lod_distance`] (the
/// nearest distance times a squared cosine, at most it) would find none:
/// the common case of a node near the eye, decided without the off-axis
/// factor. The slack of 1e-9 covers a cosine rounded above 1, so this
/// says yes only where `select_lod` says none.
fn refines_at(
    lods: &[gigawalk_scene::LodInfo],
    nearest: f64,
    view: &CullView,
    o: &TraversalOptions,
) -> bool {
    lods.first().is_none_or(|finest| {
        finest.error as f64 * view.pixels_per_radian > o.pixel_error * (nearest * (1.0 + 1e-9))
    })
}

/// Traverses a skeleton for one view; keeps its queue between calls so a
/// frame allocates nothing once warm.
#[derive(Debug, Default)]
pub struct Traverser {
    heap: BinaryHeap<Entry>,
}

impl Traverser {
    pub fn new() -> Self {
        Traverser::default()
    }

    /// GigaWalk Algorithm 5.2: visits nodes front to back (by distance from
    /// the eye to the nearest point of the node's box; a child is never
    /// nearer than its parent, so the emitted items come out in
    /// non-decreasing distance). A node is dropped when outside the frustum
    /// or occluded; emitted with its LOD when that LOD's pixel error is
    /// acceptable (always for a leaf, at its finest when nothing is);
    /// otherwise its children are queued.
    pub fn traverse<O, S>(
        &mut self,
        skeleton: &Skeleton,
        view: &CullView,
        occlusion: &O,
        options: &TraversalOptions,
        sink: &mut S,
    ) -> TraversalStats
    where
        O: OcclusionTest + ?Sized,
        S: DrawSink + ?Sized,
    {
        self.traverse_recording(skeleton, view, occlusion, options, sink, &mut |_, _| {})
    }

    /// Like [`Traverser::traverse`], and also tells `culled` about every
    /// node it culls and why (the viewer colours their boxes).
    pub fn traverse_recording<O, S, C>(
        &mut self,
        skeleton: &Skeleton,
        view: &CullView,
        occlusion: &O,
        options: &TraversalOptions,
        sink: &mut S,
        culled: &mut C,
    ) -> TraversalStats
    where
        O: OcclusionTest + ?Sized,
        S: DrawSink + ?Sized,
        C: FnMut(u32, CullReason) + ?Sized,
    {
        self.traverse_culled(
            skeleton,
            view,
            &mut BoxTest(occlusion),
            options,
            sink,
            culled,
        )
    }

    /// Algorithm 5.2 with any [`Culler`]: it hears every queued node, tests
    /// each popped one (unless an ancestor was [`Verdict::VisibleBelow`])
    /// and every emitted item; the context its test returns goes to the
    /// node's children. With `options.occlusion` off the culler is not
    /// asked at all.
    pub fn traverse_culled<K, S, C>(
        &mut self,
        skeleton: &Skeleton,
        view: &CullView,
        culler: &mut K,
        options: &TraversalOptions,
        sink: &mut S,
        culled: &mut C,
    ) -> TraversalStats
    where
        K: Culler + ?Sized,
        S: DrawSink + ?Sized,
        C: FnMut(u32, CullReason) + ?Sized,
    {
        let mut stats = TraversalStats::default();
        self.heap.clear();
        let occlusion = options.occlusion;
        // Contexts by index; a node's children share their parent's.
        let mut contexts: Vec<K::Ctx> = vec![K::Ctx::default()];
        if occlusion {
            culler.begin(view);
        }
        let queue = |heap: &mut BinaryHeap<Entry>,
                     culler: &mut K,
                     contexts: &[K::Ctx],
                     node: u32,
                     mask: PlaneMask,
                     test: bool,
                     ctx: u32,
                     replace_top: bool| {
            let (min, max) = view.rel_f64(&skeleton.node(node).bounds);
            if K::HEARS_QUEUED && occlusion && test {
                let b = crate::RelBox::from_f64(min, max);
                culler.queued(view, node, &b, &contexts[ctx as usize]);
            }
            let entry = Entry::new(
                distance_to_rel_box(min, max),
                node,
                Queued::new(mask, test, ctx),
            );
            if replace_top {
                if let Some(mut top) = heap.peek_mut() {
                    *top = entry;
                    return;
                }
            }
            heap.push(entry);
        };
        queue(
            &mut self.heap,
            culler,
            &contexts,
            0,
            ALL_PLANES,
            true,
            0,
            false,
        );
        // The nearest node stays at the top of the queue while it is
        // visited: refined, its first child takes its place (one sift
        // down instead of a pop and a push); otherwise it is popped. The
        // order nodes come out in is the same: (distance, node) is a total
        // order on distinct nodes.
        while let Some(&entry) = self.heap.peek() {
            let node = entry.node;
            let n = skeleton.node(node);
            let refine = 'visit: {
                let (mask, test, ctx) = (entry.item.mask(), entry.item.test(), entry.item.ctx());
                stats.visited += 1;
                if view.show(node) == NodeShow::Hidden {
                    stats.hidden_culled += 1;
                    break 'visit None;
                }
                let (min, max) = view.rel_f64(&n.bounds);
                if view.section_side(min, max) == BoxSide::Removed {
                    stats.section_culled += 1;
                    break 'visit None;
                }
                let (containment, child_mask) = if mask == 0 {
                    (Containment::Inside, 0)
                } else {
                    view.frustum.test(min, max, mask)
                };
                if containment == Containment::Outside {
                    stats.frustum_culled += 1;
                    culled(node, CullReason::Frustum);
                    break 'visit None;
                }
                let (mut child_test, mut child_ctx) = (test, ctx);
                if occlusion && test {
                    let b = crate::RelBox::from_f64(min, max);
                    let (verdict, next) = culler.test(view, node, &b, &contexts[ctx as usize]);
                    match verdict {
                        Verdict::Occluded => {
                            stats.occlusion_culled += 1;
                            culled(node, CullReason::Occlusion);
                            break 'visit None;
                        }
                        Verdict::Visible => {}
                        Verdict::VisibleBelow => child_test = false,
                    }
                    // A culler whose context is empty hands its children
                    // nothing: no context a node. Past the contexts a queue
                    // entry can index, children keep their parent's context,
                    // what it knew before this test: a context only narrows
                    // what later tests look at, so an older one is as safe.
                    if !n.is_leaf()
                        && child_test
                        && std::mem::size_of::<K::Ctx>() > 0
                        && contexts.len() <= Queued::MAX_CTX as usize
                    {
                        child_ctx = contexts.len() as u32;
                        contexts.push(next);
                    }
                }
                match choose(skeleton, node, (min, max), entry.distance(), view, options) {
                    Choice::Draw(lod) => {
                        stats.drawn_nodes += 1;
                        stats.drawn_triangles +=
                            match view.visibility().and_then(|v| v.pieces(n.first_lod + lod)) {
                                Some(p) => p.iter().map(|p| p.triangles as u64).sum(),
                                None => skeleton.lod(n.first_lod + lod).triangles as u64,
                            };
                        let item = DrawItem { node, lod };
                        sink.draw(item);
                        if occlusion {
                            culler.drawn(view, item);
                        }
                        None
                    }
                    Choice::Skip => None,
                    Choice::Refine => Some((child_mask, child_test, child_ctx)),
                }
            };
            match refine {
                Some((mask, test, ctx)) if n.child_count > 0 => {
                    for (i, child) in n.children().enumerate() {
                        queue(
                            &mut self.heap,
                            culler,
                            &contexts,
                            child,
                            mask,
                            test,
                            ctx,
                            i == 0,
                        );
                    }
                }
                _ => {
                    self.heap.pop();
                }
            }
        }
        stats
    }
}

/// [`Traverser::traverse`] with a fresh queue.
pub fn traverse<O, S>(
    skeleton: &Skeleton,
    view: &CullView,
    occlusion: &O,
    options: &TraversalOptions,
    sink: &mut S,
) -> TraversalStats
where
    O: OcclusionTest + ?Sized,
    S: DrawSink + ?Sized,
{
    Traverser::new().traverse(skeleton, view, occlusion, options, sink)
}

/// Re-selects LODs of an older frame's draw list for a new view: the
/// occluder pass of frame i draws frame i-2's visible nodes with LODs chosen
/// for camera i (GigaWalk Algorithm 5.1, Section 5.2).
///
/// Each node gets the LOD traversal would give it for this view. A node
/// whose own LOD is no longer acceptable (the camera came closer) is
/// replaced by its descendants down to the cut traversal would draw, so the
/// occluders are always geometry of this frame's LOD cut, never a stand-in
/// nearer than it (conservative mode, GigaWalk Section 5.3). Nodes outside
/// the new frustum are dropped: they cannot write depth. Returns how many
/// items went to the sink.
pub fn reselect_lods<S: DrawSink + ?Sized>(
    skeleton: &Skeleton,
    view: &CullView,
    options: &TraversalOptions,
    items: &[DrawItem],
    sink: &mut S,
) -> usize {
    let mut count = 0;
    let mut stack = Vec::new();
    for item in items {
        if (item.node as usize) >= skeleton.nodes().len() {
            continue;
        }
        stack.push(item.node);
        while let Some(node) = stack.pop() {
            let n = skeleton.node(node);
            let (min, max) = view.rel_f64(&n.bounds);
            if view.frustum.test(min, max, ALL_PLANES).0 == Containment::Outside
                || view.section_side(min, max) == BoxSide::Removed
            {
                continue;
            }
            let nearest = distance_to_rel_box(min, max);
            match choose(skeleton, node, (min, max), nearest, view, options) {
                Choice::Draw(lod) => {
                    count += 1;
                    sink.draw(DrawItem { node, lod });
                }
                Choice::Refine => stack.extend(n.children()),
                Choice::Skip => {}
            }
        }
    }
    count
}

/// Keeps the occluders that hide most per triangle, within a budget of
/// `max_triangles`: items are ranked by their node box's apparent size
/// (face area over squared distance from the eye; a box the eye is inside
/// ranks first) per triangle of the chosen LOD, and taken greedily while
/// they fit. Big, cheap occluders (walls, floors, tanks) come first; dense
/// small parts (bolts, valves) last. Drawing fewer occluders is always
/// conservative: the HZB only gets farther, so it culls less, never wrongly.
/// Returns the triangles kept. Items naming a node or LOD the skeleton does
/// not have are dropped.
pub fn select_occluders(
    skeleton: &Skeleton,
    view: &CullView,
    items: &mut Vec<DrawItem>,
    max_triangles: u64,
) -> u64 {
    let triangles = |i: &DrawItem| -> Option<u64> {
        let n = skeleton.nodes().get(i.node as usize)?;
        if i.lod >= n.lod_count {
            return None;
        }
        let lod = skeleton.lods().get((n.first_lod + i.lod) as usize)?;
        Some(lod.triangles.max(1) as u64)
    };
    let mut ranked: Vec<(f64, u64, DrawItem)> = items
        .iter()
        .filter_map(|&i| {
            let t = triangles(&i)?;
            let (min, max) = view.rel_f64(&skeleton.nodes()[i.node as usize].bounds);
            let e = max - min;
            let area = e.x * e.y + e.y * e.z + e.z * e.x;
            let d = crate::lod::distance_to_rel_box(min, max);
            let apparent = if d > 0.0 {
                area / (d * d)
            } else {
                f64::INFINITY
            };
            let key = apparent / t as f64;
            // A NaN (a degenerate box) ranks last, whatever its sign bit.
            Some((if key.is_nan() { f64::NEG_INFINITY } else { key }, t, i))
        })
        .collect();
    // Best first; ties in node order.
    ranked.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.2.node.cmp(&b.2.node)));
    items.clear();
    let mut kept = 0u64;
    for (_, t, item) in ranked {
        if kept.saturating_add(t) <= max_triangles {
            kept += t;
            items.push(item);
        }
    }
    kept
}

#[cfg(test)]
mod tests {
    use gigawalk_scene::{Aabb, Node, Provenance, NO_NODE};
    use glam::DVec3;

    use super::*;
    use crate::{Camera, NoOcclusion, RelBox, Viewport};

    /// A node for [`tree`]: its box, its children (indices, contiguous and
    /// after it) and its LOD errors (finest first; triangles = 1000 >> level).
    struct N {
        bounds: Aabb,
        children: std::ops::Range<u32>,
        errors: Vec<f32>,
    }

    fn n(min: [f64; 3], max: [f64; 3], children: std::ops::Range<u32>, errors: &[f32]) -> N {
        N {
            bounds: Aabb::new(DVec3::from(min), DVec3::from(max)),
            children,
            errors: errors.to_vec(),
        }
    }

    fn tree(spec: Vec<N>) -> Skeleton {
        let mut nodes = Vec::new();
        let mut lods = Vec::new();
        let mut parents = vec![NO_NODE; spec.len()];
        for (i, s) in spec.iter().enumerate() {
            for c in s.children.clone() {
                parents[c as usize] = i as u32;
            }
        }
        for (i, s) in spec.iter().enumerate() {
            nodes.push(Node {
                bounds: s.bounds,
                parent: parents[i],
                first_child: s.children.start,
                child_count: s.children.len() as u32,
                first_lod: lods.len() as u32,
                lod_count: s.errors.len() as u32,
            });
            for (level, &error) in s.errors.iter().enumerate() {
                lods.push(crate::test_rng::lod(error, 1000 >> level));
            }
        }
        let bounds = nodes.first().map_or(Aabb::EMPTY, |n: &Node| n.bounds);
        Skeleton::new(DVec3::ZERO, bounds, nodes, lods, Provenance::default())
            .expect("a valid skeleton")
    }

    /// 90 degree square view from `eye` down -Z, 100x100 pixels: pixel error
    /// = error x 50 / distance.
    fn view_from(eye: [f64; 3]) -> CullView {
        let eye = DVec3::from(eye);
        CullView::new(
            Camera::look_at(eye, eye + DVec3::NEG_Z, 90f64.to_radians(), 1.0, 0.1),
            Viewport::new(100, 100),
        )
    }

    fn run(s: &Skeleton, view: &CullView, o: TraversalOptions) -> (Vec<DrawItem>, TraversalStats) {
        let mut items = Vec::new();
        let stats = traverse(s, view, &NoOcclusion, &o, &mut |i| items.push(i));
        (items, stats)
    }

    /// Root (HLOD errors 0.125, 1) over two leaves (0, 0.0625) side by side
    /// at z -10..-12. Binary fractions keep the pixel errors exact.
    fn two_leaves() -> Skeleton {
        tree(vec![
            n([-2.0, -1.0, -12.0], [2.0, 1.0, -10.0], 1..3, &[0.125, 1.0]),
            n(
                [-2.0, -1.0, -12.0],
                [-0.5, 1.0, -10.0],
                0..0,
                &[0.0, 0.0625],
            ),
            n([0.5, -1.0, -12.0], [2.0, 1.0, -10.0], 0..0, &[0.0, 0.0625]),
        ])
    }

    #[test]
    fn hlod_off_is_full_detail_and_pixel_error_steps_clamp() {
        let t = TraversalOptions::mode(true, false, 4.0);
        assert!(t.occlusion && !t.hlod && t.pixel_error == 0.0);
        assert_eq!(TraversalOptions::mode(false, true, 4.0).pixel_error, 4.0);
        assert_eq!(step_pixel_error(0.0, false), 0.0);
        assert_eq!(step_pixel_error(0.0, true), 0.5);
        assert_eq!(step_pixel_error(3.0, true), 4.0);
        assert_eq!(step_pixel_error(3.0, false), 2.0);
        assert_eq!(step_pixel_error(64.0, true), 64.0);
    }

    #[test]
    fn recording_names_every_frustum_culled_node() {
        // Looking away (+Z) from the two leaves: the root is outside.
        let eye = DVec3::ZERO;
        let away = CullView::new(
            Camera::look_at(eye, eye + DVec3::Z, 90f64.to_radians(), 1.0, 0.1),
            Viewport::new(100, 100),
        );
        let mut culled = Vec::new();
        let stats = Traverser::new().traverse_recording(
            &two_leaves(),
            &away,
            &NoOcclusion,
            &TraversalOptions::default(),
            &mut |_| {},
            &mut |node, why| culled.push((node, why)),
        );
        assert_eq!(culled, [(0, CullReason::Frustum)]);
        assert_eq!(stats.frustum_culled, 1);
    }

    #[test]
    fn a_section_drops_what_it_removes_wholly_and_keeps_what_it_cuts() {
        let s = two_leaves();
        let cut = |planes: &[&str]| {
            let planes: Vec<String> = planes.iter().map(|p| p.to_string()).collect();
            view_from([0.0; 3]).with_section(Some(std::sync::Arc::new(
                crate::Section::parse(&planes, None).unwrap(),
            )))
        };
        // Keeping x <= 0 removes the right leaf (x 0.5..2) whole; the root
        // is cut, so refined; the left leaf is drawn.
        let full = TraversalOptions {
            pixel_error: 0.0,
            ..Default::default()
        };
        let (items, stats) = run(&s, &cut(&["-1 0 0 0"]), full);
        assert_eq!(items, [DrawItem { node: 1, lod: 0 }]);
        assert_eq!(stats.section_culled, 1);
        // A plane a hair inside the right leaf's box (by less than the
        // GPU's rounding slack) keeps it: only certain removals count.
        let (items, stats) = run(&s, &cut(&["-1 0 0 0.5000000001"]), full);
        assert_eq!((items.len(), stats.section_culled), (2, 0));
        // Keeping z >= 0 removes everything, the root first.
        let (items, stats) = run(&s, &cut(&["0 0 1 0"]), full);
        assert!(items.is_empty());
        assert_eq!((stats.section_culled, stats.visited), (1, 1));
        // Re-selection drops removed occluders too.
        let mut kept = Vec::new();
        let n = reselect_lods(
            &s,
            &cut(&["-1 0 0 0"]),
            &full,
            &[DrawItem { node: 0, lod: 0 }],
            &mut |i| kept.push(i),
        );
        assert_eq!((n, kept), (1, vec![DrawItem { node: 1, lod: 0 }]));
    }

    #[test]
    fn acceptable_hlod_is_emitted_and_children_not_visited() {
        // Distance 10: root's errors are 0.625 and 5 pixels; tolerance 1 takes level 0.
        let (items, stats) = run(
            &two_leaves(),
            &view_from([0.0; 3]),
            TraversalOptions::default(),
        );
        assert_eq!(items, [DrawItem { node: 0, lod: 0 }]);
        assert_eq!(stats.visited, 1);
        assert_eq!((stats.drawn_nodes, stats.drawn_triangles), (1, 1000));
    }

    #[test]
    fn coarser_hlod_when_farther() {
        // Distance 100: root's coarse level is 0.5 pixels.
        let (items, _) = run(
            &two_leaves(),
            &view_from([0.0, 0.0, 90.0]),
            TraversalOptions::default(),
        );
        assert_eq!(items, [DrawItem { node: 0, lod: 1 }]);
    }

    #[test]
    fn unacceptable_hlod_refines_to_leaves() {
        // Tolerance 0.5: root (0.625 pixels at best) refines; leaves' level 1 is 0.3125.
        let o = TraversalOptions {
            pixel_error: 0.5,
            ..Default::default()
        };
        let (items, stats) = run(&two_leaves(), &view_from([0.0; 3]), o);
        assert_eq!(stats.visited, 3);
        assert_eq!(items.len(), 2);
        assert!(items.iter().all(|i| i.lod == 1 && i.node != 0));
        assert_eq!(stats.drawn_triangles, 1000);
    }

    #[test]
    fn hlod_off_always_refines() {
        let o = TraversalOptions {
            hlod: false,
            ..Default::default()
        };
        let (items, _) = run(&two_leaves(), &view_from([0.0; 3]), o);
        assert_eq!(items.len(), 2);
        assert!(items.iter().all(|i| i.node != 0));
    }

    #[test]
    fn zero_tolerance_draws_finest_leaves() {
        let o = TraversalOptions {
            pixel_error: 0.0,
            ..Default::default()
        };
        let (items, stats) = run(&two_leaves(), &view_from([0.0, 0.0, 1e6]), o);
        assert_eq!(items.len(), 2);
        assert!(items.iter().all(|i| i.lod == 0 && i.node != 0));
        assert_eq!(stats.drawn_triangles, 2000);
    }

    #[test]
    fn eye_inside_refines_and_leaf_gets_finest() {
        let (items, _) = run(
            &two_leaves(),
            &view_from([-1.0, 0.0, -11.0]),
            TraversalOptions::default(),
        );
        // The eye is in the root and in leaf 1: both refine, so leaf 1 draws
        // its finest and the root is not drawn.
        assert!(items.contains(&DrawItem { node: 1, lod: 0 }));
        assert!(!items.iter().any(|i| i.node == 0));
    }

    #[test]
    fn inner_node_without_lods_refines() {
        let s = tree(vec![
            n([-1.0, -1.0, -12.0], [1.0, 1.0, -10.0], 1..2, &[]),
            n([-1.0, -1.0, -12.0], [1.0, 1.0, -10.0], 0..0, &[0.0]),
        ]);
        let (items, _) = run(&s, &view_from([0.0; 3]), TraversalOptions::default());
        assert_eq!(items, [DrawItem { node: 1, lod: 0 }]);
    }

    #[test]
    fn order_is_front_to_back() {
        // Five leaves along the view axis, stored in scrambled distance order.
        let zs = [30.0, 10.0, 50.0, 20.0, 40.0];
        let mut spec = vec![n([-1.0, -1.0, -51.0], [1.0, 1.0, -10.0], 1..6, &[])];
        for z in zs {
            spec.push(n([-1.0, -1.0, -z - 1.0], [1.0, 1.0, -z], 0..0, &[0.0]));
        }
        let (items, stats) = run(
            &tree(spec),
            &view_from([0.0; 3]),
            TraversalOptions::default(),
        );
        let order: Vec<u32> = items.iter().map(|i| i.node).collect();
        assert_eq!(order, [2, 4, 1, 5, 3]);
        assert_eq!(stats.visited, 6);
    }

    #[test]
    fn frustum_culled_nodes_are_counted_and_not_refined() {
        let s = tree(vec![
            n([-2.0, -1.0, -12.0], [30.0, 1.0, -10.0], 1..3, &[]),
            n([-2.0, -1.0, -12.0], [-0.5, 1.0, -10.0], 0..0, &[0.0]),
            // Right of the x = -z plane (x > 12 at z -12).
            n([20.0, -1.0, -12.0], [30.0, 1.0, -10.0], 3..4, &[]),
            n([20.0, -1.0, -12.0], [30.0, 1.0, -10.0], 0..0, &[0.0]),
        ]);
        let (items, stats) = run(&s, &view_from([0.0; 3]), TraversalOptions::default());
        assert_eq!(items, [DrawItem { node: 1, lod: 0 }]);
        assert_eq!((stats.visited, stats.frustum_culled), (3, 1));
    }

    /// Culls every box whose nearest point is beyond a distance: any
    /// occlusion method plugs in through the trait.
    struct FarWall(f32);
    impl OcclusionTest for FarWall {
        fn is_visible(&self, _: &CullView, b: &RelBox) -> bool {
            -b.max.z < self.0
        }
    }

    #[test]
    fn occlusion_test_plugs_in() {
        let zs = [10.0, 20.0, 30.0];
        let mut spec = vec![n([-1.0, -1.0, -31.0], [1.0, 1.0, -10.0], 1..4, &[])];
        for z in zs {
            spec.push(n([-1.0, -1.0, -z - 1.0], [1.0, 1.0, -z], 0..0, &[0.0]));
        }
        let s = tree(spec);
        let view = view_from([0.0; 3]);
        let mut items = Vec::new();
        let o = TraversalOptions::default();
        let stats = traverse(&s, &view, &FarWall(25.0), &o, &mut |i| items.push(i));
        assert_eq!(items.len(), 2);
        assert_eq!(stats.occlusion_culled, 1);
        let off = TraversalOptions {
            occlusion: false,
            ..o
        };
        let stats = traverse(&s, &view, &FarWall(25.0), &off, &mut |_| {});
        assert_eq!((stats.occlusion_culled, stats.drawn_nodes), (0, 3));
    }

    #[test]
    fn reselect_keeps_acceptable_and_expands_closer() {
        let s = two_leaves();
        let far = view_from([0.0, 0.0, 90.0]);
        let o = TraversalOptions::default();
        let (items, _) = run(&s, &far, o);
        assert_eq!(items, [DrawItem { node: 0, lod: 1 }]);
        // Same camera: same LOD.
        let mut same = Vec::new();
        reselect_lods(&s, &far, &o, &items, &mut |i| same.push(i));
        assert_eq!(same, items);
        // Closer (distance 10): root level 0 is 0.625 pixels, acceptable.
        let mut near = Vec::new();
        reselect_lods(&s, &view_from([0.0; 3]), &o, &items, &mut |i| near.push(i));
        assert_eq!(near, [DrawItem { node: 0, lod: 0 }]);
        // Closer still (distance 2): the root refines into its two leaves,
        // exactly what traversal draws for that camera.
        let close = view_from([0.0, 0.0, -8.0]);
        let mut expanded = Vec::new();
        reselect_lods(&s, &close, &o, &items, &mut |i| expanded.push(i));
        let (mut drawn, _) = run(&s, &close, o);
        expanded.sort_by_key(|i| i.node);
        drawn.sort_by_key(|i| i.node);
        assert_eq!(expanded, drawn);
        assert_eq!(expanded.len(), 2);
    }

    /// A near big wall (node 1: 1000 triangles at LOD 0, 500 at LOD 1), a
    /// far small part (node 2) and a near small part (node 3).
    fn occluder_scene() -> Skeleton {
        tree(vec![
            n([-50.0, -5.0, -60.0], [50.0, 5.0, -2.0], 1..4, &[0.0]),
            n([-50.0, -5.0, -6.0], [50.0, 5.0, -5.0], 0..0, &[0.0, 0.5]),
            n([0.0, 0.0, -60.0], [0.2, 0.2, -59.8], 0..0, &[0.0]),
            n([1.0, 0.0, -3.0], [1.2, 0.2, -2.8], 0..0, &[0.0]),
        ])
    }

    #[test]
    fn occluders_rank_by_apparent_size_per_triangle_within_the_budget() {
        let s = occluder_scene();
        let v = view_from([0.0, 0.0, 0.0]);
        let all = [
            DrawItem { node: 2, lod: 0 },
            DrawItem { node: 3, lod: 0 },
            DrawItem { node: 1, lod: 1 },
        ];
        // Everything fits: all kept, best first (the wall, 500 triangles).
        let mut items = all.to_vec();
        assert_eq!(select_occluders(&s, &v, &mut items, u64::MAX), 2500);
        assert_eq!(items[0], DrawItem { node: 1, lod: 1 });
        assert_eq!(items[1], DrawItem { node: 3, lod: 0 });
        assert_eq!(items[2], DrawItem { node: 2, lod: 0 });
        // 1600 triangles: the wall and the near part; the far part does not fit.
        let mut items = all.to_vec();
        assert_eq!(select_occluders(&s, &v, &mut items, 1600), 1500);
        assert_eq!(items.len(), 2);
        assert!(!items.contains(&DrawItem { node: 2, lod: 0 }));
        // 999: the wall (500) fits; neither 1000-triangle part does.
        let mut items = all.to_vec();
        assert_eq!(select_occluders(&s, &v, &mut items, 999), 500);
        assert_eq!(items, vec![DrawItem { node: 1, lod: 1 }]);
        // A budget of 0 keeps nothing; nothing is never an error.
        let mut items = all.to_vec();
        assert_eq!(select_occluders(&s, &v, &mut items, 0), 0);
        assert!(items.is_empty());
        let mut none = Vec::new();
        assert_eq!(select_occluders(&s, &v, &mut none, 10), 0);
    }

    #[test]
    fn occluder_selection_drops_bad_items_and_ranks_a_box_around_the_eye_first() {
        let s = occluder_scene();
        // Eye inside the root's box only; inside node 1's box.
        let v = view_from([0.0, 0.0, -5.5]);
        let mut items = vec![
            DrawItem { node: 3, lod: 0 },
            DrawItem { node: 1, lod: 0 },
            DrawItem { node: 99, lod: 0 },
            DrawItem { node: 2, lod: 7 },
        ];
        assert_eq!(select_occluders(&s, &v, &mut items, u64::MAX), 2000);
        assert_eq!(
            items,
            vec![DrawItem { node: 1, lod: 0 }, DrawItem { node: 3, lod: 0 }]
        );
        // Far from the origin: the same ranking (boxes are camera-relative).
        let shift = DVec3::new(3.0e7, -1.0e7, 2.0e7);
        let far = {
            let (origin, bounds, mut nodes, lods, provenance) = occluder_scene().into_parts();
            for n in &mut nodes {
                n.bounds = Aabb::new(n.bounds.min + shift, n.bounds.max + shift);
            }
            let bounds = Aabb::new(bounds.min + shift, bounds.max + shift);
            Skeleton::new(origin + shift, bounds, nodes, lods, provenance).unwrap()
        };
        let v = view_from((shift + DVec3::new(0.0, 0.0, 0.0)).to_array());
        let mut items = vec![
            DrawItem { node: 2, lod: 0 },
            DrawItem { node: 3, lod: 0 },
            DrawItem { node: 1, lod: 1 },
        ];
        assert_eq!(select_occluders(&far, &v, &mut items, 1600), 1500);
        assert_eq!(items[0], DrawItem { node: 1, lod: 1 });
    }
}
