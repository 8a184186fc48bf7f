//! Stand-ins: what RVG draws for a LOD that is not resident yet, the
//! finest resident coarser LOD of its node, else an ancestor's HLOD. A
//! stand-in never holds a hidden object: a node with hidden or
//! highlighted objects below it (not [`NodeShow::Whole`]) merges them into
//! its coarser levels and its HLODs, so such a node gets no stand-in of
//! its own, and the walk up to ancestors stops at the first one that is
//! not whole. The native runtime and the page stream by this one rule.

use gigawalk_cull::{NodeShow, Visibility};
use gigawalk_scene::Skeleton;

use super::DeviceStream;

/// Whether `node`'s LODs show every object below it as it is (a stand-in
/// from it holds nothing hidden and nothing left untinted).
fn whole(shown: Option<&Visibility>, node: u32) -> bool {
    shown.is_none_or(|v| v.node(node) == NodeShow::Whole)
}

impl DeviceStream {
    /// The finest resident LOD coarser than `lod` of its node, else the
    /// finest resident LOD of the nearest ancestor, drawn once a frame
    /// however many of its descendants it stands in for; only from nodes
    /// `shown` leaves whole.
    pub(super) fn stand_in(
        &mut self,
        skeleton: &Skeleton,
        lod: u32,
        shown: Option<&Visibility>,
    ) -> StandIn {
        let mut node = skeleton.owner(lod);
        if !whole(shown, node) {
            return StandIn::None;
        }
        let n = skeleton.node(node);
        if let Some(l) = (lod + 1..n.first_lod + n.lod_count).find(|&l| self.pool.contains(l)) {
            return StandIn::Draw(l);
        }
        while node != 0 {
            node = skeleton.node(node).parent;
            if !whole(shown, node) {
                return StandIn::None;
            }
            let p = skeleton.node(node);
            if let Some(l) = p.lods().map(|l| l as u32).find(|&l| self.pool.contains(l)) {
                return if self.standins.insert(l) {
                    StandIn::Draw(l)
                } else {
                    StandIn::Drawn
                };
            }
        }
        StandIn::None
    }
}

/// What stands in for a LOD that is not resident.
pub(super) enum StandIn {
    Draw(u32),
    /// An ancestor's LOD this frame already drew.
    Drawn,
    None,
}
