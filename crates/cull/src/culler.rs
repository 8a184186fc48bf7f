//! The occlusion-culler strategy traversal drives: every culler of the
//! five papers fits it (the HZB of GigaWalk, the lazy occlusion grid of Hey
//! et al., Coorg and Teller's object-space occluders, Bartz et al.'s
//! occlusion queries). docs/culling.md has what each needs.

use crate::{CullView, DrawItem, OcclusionTest, RelBox};

/// What a culler says of a node.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Verdict {
    /// No point of the node's box can show: drop the node and its subtree.
    Occluded,
    /// May show: draw it or test its children.
    Visible,
    /// Shows, and so does everything below it: traversal tests none of
    /// its descendants (Coorg and Teller's "fully visible").
    VisibleBelow,
}

/// An occlusion culler, as [`crate::Traverser::traverse_culled`] drives it
/// for one frame:
///
/// 1. [`Culler::begin`] once, with the frame's view;
/// 2. [`Culler::queued`] for every node pushed on the front-to-back queue,
///    with the context its parent's test returned (a culler whose answers
///    come from elsewhere, such as GPU occlusion queries, starts its work
///    here and has it by the time the node is popped);
/// 3. [`Culler::test`] as the node is popped, nearest first; it returns
///    the verdict and the context the node's children are queued with
///    (the way traversal hands down the frustum plane mask);
/// 4. [`Culler::drawn`] for every item traversal emits, in emission order,
///    before the next test (a culler that rasterizes what is drawn, such
///    as the lazy occlusion grid, occludes with it at once).
///
/// Contract for a conservative culler: `Occluded` only when no point of the
/// box can show in the final image, `VisibleBelow` only when nothing below
/// the node could be occluded by it.
pub trait Culler {
    /// What a node hands its children (`()` for most cullers). Traversal
    /// may hand children an ancestor's context instead of their parent's
    /// (past the contexts a frame can index), so a context must only
    /// narrow what later tests look at, never what they may call occluded.
    type Ctx: Clone + Default;

    /// Whether [`Culler::queued`] does anything (traversal skips preparing
    /// its box otherwise).
    const HEARS_QUEUED: bool = false;

    fn begin(&mut self, _view: &CullView) {}

    fn queued(&mut self, _view: &CullView, _node: u32, _b: &RelBox, _ctx: &Self::Ctx) {}

    /// `b` is the node's box relative to `view.camera.position`, rounded
    /// outward.
    fn test(
        &mut self,
        view: &CullView,
        node: u32,
        b: &RelBox,
        ctx: &Self::Ctx,
    ) -> (Verdict, Self::Ctx);

    fn drawn(&mut self, _view: &CullView, _item: DrawItem) {}
}

/// A stateless box test ([`OcclusionTest`]: the HZB, "no occlusion") as a
/// culler.
pub struct BoxTest<'a, O: ?Sized>(pub &'a O);

impl<O: OcclusionTest + ?Sized> Culler for BoxTest<'_, O> {
    type Ctx = ();

    fn test(&mut self, view: &CullView, _: u32, b: &RelBox, _: &()) -> (Verdict, ()) {
        let v = if self.0.is_visible(view, b) {
            Verdict::Visible
        } else {
            Verdict::Occluded
        };
        (v, ())
    }
}
