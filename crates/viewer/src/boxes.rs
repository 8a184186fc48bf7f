//! Node bounding boxes for the overlay, coloured by what culling did with
//! them, as in Figure 13 of Coorg and Teller's paper: drawn, culled by the
//! view frustum, culled by occlusion.

use gigawalk_gpu::OverlayBox;
use gigawalk_scene::Skeleton;
use glam::DVec3;

/// Linear RGBA of each kind of box; culled boxes are dimmer so the drawn
/// set stands out.
pub const DRAWN: [f32; 4] = [0.1, 0.9, 0.2, 0.9];
pub const FRUSTUM_CULLED: [f32; 4] = [0.2, 0.4, 1.0, 0.45];
pub const OCCLUSION_CULLED: [f32; 4] = [1.0, 0.15, 0.1, 0.7];

/// Beyond this many boxes the overlay is a solid tangle and costs more to
/// draw than the scene on lavapipe (24 vertices a box); nearest first is
/// what STC's front-to-back order gives, so the cut drops the far ones.
pub const MAX_BOXES: usize = 20_000;

/// What culling did with a set of nodes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CullSets {
    pub drawn: Vec<u32>,
    pub frustum_culled: Vec<u32>,
    pub occlusion_culled: Vec<u32>,
}

/// Boxes relative to `eye` (subtracted in f64, then rounded, like every
/// draw). Unknown node indices are skipped.
pub fn overlay_boxes(skeleton: &Skeleton, sets: &CullSets, eye: DVec3) -> Vec<OverlayBox> {
    let mut out = Vec::new();
    for (nodes, colour) in [
        (&sets.drawn, DRAWN),
        (&sets.occlusion_culled, OCCLUSION_CULLED),
        (&sets.frustum_culled, FRUSTUM_CULLED),
    ] {
        for &n in nodes {
            if out.len() >= MAX_BOXES {
                return out;
            }
            let Some(node) = skeleton.nodes().get(n as usize) else {
                continue;
            };
            let b = node.bounds;
            // Empty (or NaN) boxes have nothing to outline.
            if b.min.x.partial_cmp(&b.max.x).is_none_or(|o| o.is_gt()) {
                continue;
            }
            out.push(OverlayBox {
                min: (b.min - eye).as_vec3(),
                max: (b.max - eye).as_vec3(),
                colour,
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use gigawalk_scene::{Aabb, IndexFormat, LodInfo, Node, Provenance, NO_NODE};

    /// A root (0..3 along x) over unit boxes at x = 1 and 2.
    fn skeleton() -> Skeleton {
        let node =
            |x: f64, size: f64, parent, first_child, child_count, first_lod, lod_count| Node {
                bounds: Aabb::new(DVec3::new(x, 0.0, 0.0), DVec3::new(x + size, 1.0, 1.0)),
                parent,
                first_child,
                child_count,
                first_lod,
                lod_count,
            };
        let lod = LodInfo {
            error: 0.0,
            triangles: 1,
            vertices: 3,
            origin: DVec3::ZERO,
            index_format: IndexFormat::U16,
            uniform_colour: None,
            encoded: false,
            grid: None,
            compressed: false,
            offset: 0,
            len: 0,
            checksum: 0,
        };
        Skeleton::new(
            DVec3::ZERO,
            Aabb::new(DVec3::ZERO, DVec3::new(3.0, 1.0, 1.0)),
            vec![
                node(0.0, 3.0, NO_NODE, 1, 2, 0, 0),
                node(1.0, 1.0, 0, 0, 0, 0, 1),
                node(2.0, 1.0, 0, 0, 0, 1, 1),
            ],
            vec![lod, lod],
            Provenance::default(),
        )
        .expect("a valid skeleton")
    }

    #[test]
    fn one_box_per_node_coloured_by_what_culling_did() {
        let sets = CullSets {
            drawn: vec![0],
            frustum_culled: vec![1],
            occlusion_culled: vec![2, 99],
        };
        let b = overlay_boxes(&skeleton(), &sets, DVec3::new(1e7, 0.0, 0.0));
        assert_eq!(b.len(), 3, "node 99 does not exist");
        assert_eq!(b[0].colour, DRAWN);
        assert_eq!(b[1].colour, OCCLUSION_CULLED);
        assert_eq!(b[2].colour, FRUSTUM_CULLED);
        // Camera-relative, far from the origin, still exact to a unit.
        assert_eq!(b[0].min.x, -1e7);
        assert_eq!(b[0].max.x - b[0].min.x, 3.0);
    }
}
