//! Prefetching: STC asks the loader for what the camera will soon need,
//! the next finer LOD of what is close to switching (within
//! [`PREFETCH_BAND`] of the tolerance) and what a ring just outside the
//! frustum would draw. Best effort: a full queue drops a request.

use gigawalk_cull::{
    Camera, Containment, CullView, DrawItem, Frustum, OcclusionTest, RelBox, TraversalOptions,
    Traverser, ALL_PLANES,
};
use gigawalk_scene::Skeleton;

use super::{Plan, Request, PREFETCH_BAND};

/// STC's end of the loader's request queue (streaming with prefetch).
pub(crate) struct Prefetch<'a> {
    pub requests: crossbeam_channel::Sender<Request>,
    pub plan: &'a Plan,
    /// The run's devices (bits of `Plan::held`).
    pub mask: u8,
}

impl Prefetch<'_> {
    /// Asks for what `item` switches to when the camera comes closer, if
    /// its pixel error is within [`PREFETCH_BAND`] of the tolerance: the
    /// node's next finer LOD, or for an inner node's finest HLOD its
    /// children's coarsest LODs.
    pub(crate) fn item(
        &self,
        skeleton: &Skeleton,
        view: &CullView,
        pixel_error: f64,
        frame: u64,
        item: DrawItem,
    ) {
        let n = &skeleton.nodes()[item.node as usize];
        let Some(l) = skeleton.lods().get((n.first_lod + item.lod) as usize) else {
            return;
        };
        let (min, max) = view.rel_f64(&n.bounds);
        let pe = gigawalk_cull::lod::pixel_error(
            l.error,
            view.lod_distance(min, max),
            view.pixels_per_radian,
        );
        if pe <= PREFETCH_BAND * pixel_error {
            return;
        }
        if item.lod > 0 {
            self.ask(frame, n.first_lod + item.lod - 1);
        } else {
            for c in n.children() {
                let c = &skeleton.nodes()[c as usize];
                if c.lod_count > 0 {
                    self.ask(frame, c.first_lod + c.lod_count - 1);
                }
            }
        }
    }

    /// Asks for `lod` unless every device of the run holds it; a full
    /// queue drops the request (prefetching is best effort).
    fn ask(&self, frame: u64, lod: u32) -> bool {
        let ask = !self.plan.held_by(lod, self.mask);
        if ask {
            let _ = self.requests.try_send(Request {
                lod,
                frame: self.plan.frame(frame),
                prefetch: true,
            });
        }
        ask
    }

    /// Asks for what the view would draw in a ring around its frustum
    /// ([`PREFETCH_MARGIN`] wider, at the view's own pixel scale), near
    /// first: what a turn or a sideways step brings into view. Occlusion
    /// is not tested (what a turn reveals is not known yet); subtrees
    /// wholly inside the frustum are skipped (the frame itself asks for
    /// what it draws there).
    pub(crate) fn margin(
        &self,
        traverser: &mut Traverser,
        skeleton: &Skeleton,
        view: &CullView,
        options: &TraversalOptions,
        frame: u64,
    ) {
        let half = (view.camera.fovy * 0.5).tan() * (1.0 + PREFETCH_MARGIN);
        let wide_camera = Camera {
            fovy: 2.0 * half.atan(),
            ..view.camera
        };
        let mut wide = CullView::new(wide_camera, view.viewport);
        wide.pixels_per_radian = view.pixels_per_radian;
        let mut asked = 0;
        let mut sink = |item: DrawItem| {
            let n = &skeleton.nodes()[item.node as usize];
            if asked < PREFETCH_MARGIN_LODS && self.ask(frame, n.first_lod + item.lod) {
                asked += 1;
            }
        };
        let ring = TraversalOptions {
            occlusion: true,
            ..*options
        };
        traverser.traverse(skeleton, &wide, &OutsideOf(&view.frustum), &ring, &mut sink);
    }
}

/// How much wider (in the tangent of the half field of view, both ways)
/// than the view the ring STC prefetches around the frustum is.
pub const PREFETCH_MARGIN: f64 = 0.25;
/// At most this many LODs of that ring are asked for a frame.
const PREFETCH_MARGIN_LODS: usize = 256;

/// "Visible" for a box not wholly inside `frustum`: a traversal with it
/// as its occlusion test visits only the ring outside that frustum.
struct OutsideOf<'a>(&'a Frustum);

impl OcclusionTest for OutsideOf<'_> {
    fn is_visible(&self, _: &CullView, b: &RelBox) -> bool {
        let (min, max) = (b.min.as_dvec3(), b.max.as_dvec3());
        self.0.test(min, max, ALL_PLANES).0 != Containment::Inside
    }
}
