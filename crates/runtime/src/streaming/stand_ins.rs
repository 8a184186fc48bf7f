//! Stand-ins: what RVG draws for a LOD that is not resident yet, the
//! finest resident coarser LOD of its node, else an ancestor's HLOD.

use gigawalk_scene::Skeleton;

use super::DeviceStream;

impl DeviceStream {
    /// The finest resident LOD coarser than `lod` of its node, else the
    /// finest resident LOD of the nearest ancestor, drawn once a frame
    /// however many of its descendants it stands in for.
    pub(super) fn stand_in(&mut self, skeleton: &Skeleton, lod: u32) -> StandIn {
        let mut node = skeleton.owner(lod);
        let n = skeleton.node(node);
        if let Some(l) = (lod + 1..n.first_lod + n.lod_count).find(|&l| self.pool.contains(l)) {
            return StandIn::Draw(l);
        }
        while node != 0 {
            node = skeleton.node(node).parent;
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
