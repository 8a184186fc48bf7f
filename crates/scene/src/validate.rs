//! Structural validation of a skeleton: what every [`Skeleton`] holds
//! (`check_tree`, run by [`Skeleton::new`]), and where its geometry lies
//! in a file (`validate`, run by the reader before any use and the
//! writer before the file is renamed into place).

use glam::DVec3;

use crate::error::ReadErrorKind;
use crate::format::{geometry_len, LOD_LEN, NODE_LEN};
use crate::{Aabb, LodInfo, Node, Skeleton, NO_NODE};

/// Where the skeleton's records and the geometry live in the file, so that
/// errors can name byte offsets.
#[derive(Clone, Copy, Debug)]
pub struct Layout {
    pub nodes_at: u64,
    pub lods_at: u64,
    pub geometry_at: u64,
    pub geometry_len: u64,
}

/// Why parts do not make a [`Skeleton`]: the scene record, a node or a
/// LOD, and what is wrong with it.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SkeletonError {
    #[error("scene: {0}")]
    Scene(String),
    #[error("node {node}: {detail}")]
    Node { node: u32, detail: String },
    #[error("LOD {lod} of node {node}: {detail}")]
    Lod { lod: u32, node: u32, detail: String },
}

impl SkeletonError {
    /// The same flaw, located in a file laid out as `at`.
    pub(crate) fn located(self, at: &Layout) -> ReadErrorKind {
        match self {
            SkeletonError::Scene(detail) => ReadErrorKind::Corrupt {
                section: "SCNE".into(),
                offset: 0,
                detail,
            },
            SkeletonError::Node { node, detail } => ReadErrorKind::Node {
                node,
                offset: at.nodes_at + node as u64 * NODE_LEN as u64,
                detail,
            },
            SkeletonError::Lod { lod, node, detail } => ReadErrorKind::Lod {
                lod,
                node,
                offset: at.lods_at + lod as u64 * LOD_LEN as u64,
                detail,
            },
        }
    }
}

/// Checks every invariant of docs/scene-format.md that holds wherever the
/// geometry lies (see [`Skeleton`]). Returns the owning node of every LOD.
pub(crate) fn check_tree(
    origin: DVec3,
    bounds: &Aabb,
    nodes: &[Node],
    lods: &[LodInfo],
) -> Result<Vec<u32>, SkeletonError> {
    let n_nodes = nodes.len() as u64;
    let n_lods = lods.len() as u64;
    let node_err = |i: usize, detail: String| SkeletonError::Node {
        node: i as u32,
        detail,
    };
    let scene_err = SkeletonError::Scene;
    if nodes.is_empty() {
        return Err(scene_err("the scene has no nodes".into()));
    }
    if !origin.is_finite() {
        return Err(scene_err(format!("origin {} is not finite", origin)));
    }
    if !bounds.is_valid() {
        return Err(scene_err(format!(
            "bounds {:?} are not a finite box",
            bounds
        )));
    }
    if !bounds.contains_box(&nodes[0].bounds) {
        return Err(scene_err(
            "scene bounds do not contain the root's box".into(),
        ));
    }

    let mut lod_owner = vec![NO_NODE; lods.len()];
    for (i, n) in nodes.iter().enumerate() {
        if !n.bounds.is_valid() {
            return Err(node_err(
                i,
                format!("box {:?} is not a finite box", n.bounds),
            ));
        }
        if i == 0 {
            if n.parent != NO_NODE {
                return Err(node_err(i, "the root has a parent".into()));
            }
        } else {
            let p = n.parent as usize;
            if n.parent == NO_NODE || p >= i {
                return Err(node_err(
                    i,
                    format!("parent {} must be an earlier node", n.parent as i64),
                ));
            }
            if !nodes[p].children().contains(&(i as u32)) {
                return Err(node_err(
                    i,
                    format!("is not among the children of its parent {p}"),
                ));
            }
        }
        if n.child_count > 0 {
            let end = n.first_child as u64 + n.child_count as u64;
            if n.first_child as usize <= i || end > n_nodes {
                return Err(node_err(
                    i,
                    format!(
                        "children {}..{end} must be later nodes below {n_nodes}",
                        n.first_child
                    ),
                ));
            }
            for c in n.children() {
                let child = &nodes[c as usize];
                if child.parent as usize != i {
                    return Err(node_err(
                        c as usize,
                        format!("is a child of {i} but names parent {}", child.parent),
                    ));
                }
                if !n.bounds.contains_box(&child.bounds) {
                    return Err(node_err(
                        c as usize,
                        format!("box is not inside its parent {i}'s box"),
                    ));
                }
            }
        } else if n.lod_count == 0 {
            return Err(node_err(i, "is a leaf without geometry (no LODs)".into()));
        }
        let lod_end = n.first_lod as u64 + n.lod_count as u64;
        if lod_end > n_lods {
            return Err(node_err(
                i,
                format!(
                    "LODs {}..{lod_end} are beyond the {n_lods} LODs",
                    n.first_lod
                ),
            ));
        }
        for l in n.lods() {
            if lod_owner[l] != NO_NODE {
                return Err(node_err(
                    i,
                    format!("LOD {l} already belongs to node {}", lod_owner[l]),
                ));
            }
            lod_owner[l] = i as u32;
        }
    }

    // Finest error of the nearest ancestor that has LODs (inf if none).
    let mut bound = vec![f32::INFINITY; nodes.len()];
    for (li, l) in lods.iter().enumerate() {
        let node = lod_owner[li];
        let lod_err = |detail: String| SkeletonError::Lod {
            lod: li as u32,
            node,
            detail,
        };
        if node == NO_NODE {
            return Err(lod_err("belongs to no node".into()));
        }
        if !(l.error.is_finite() && l.error >= 0.0) {
            return Err(lod_err(format!(
                "error {} is not a finite non-negative number",
                l.error
            )));
        }
        if !l.origin.is_finite() {
            return Err(lod_err(format!("origin {} is not finite", l.origin)));
        }
    }
    for (i, n) in nodes.iter().enumerate() {
        let own = &lods[n.lods()];
        for w in own.windows(2) {
            if w[1].error < w[0].error {
                return Err(node_err(
                    i,
                    format!(
                        "LOD errors must not decrease from finest to coarsest ({} then {})",
                        w[0].error, w[1].error
                    ),
                ));
            }
        }
        let inherited = if i == 0 {
            f32::INFINITY
        } else {
            bound[n.parent as usize]
        };
        bound[i] = match own.first() {
            Some(finest) if finest.error > inherited => {
                return Err(node_err(i, format!(
                    "finest LOD error {} exceeds its ancestor's {inherited}: errors must not decrease from child to parent",
                    finest.error
                )))
            }
            Some(finest) => finest.error,
            None => inherited,
        };
    }
    Ok(lod_owner)
}

/// Checks what a file adds to a valid skeleton: each LOD has geometry,
/// its length matches its counts, and it lies inside the GEOM section
/// `at` names.
pub fn validate(s: &Skeleton, at: &Layout) -> Result<(), ReadErrorKind> {
    let geom_end = at.geometry_at + at.geometry_len;
    for (li, l) in s.lods().iter().enumerate() {
        let lod_err = |detail: String| ReadErrorKind::Lod {
            lod: li as u32,
            node: s.owner(li as u32),
            offset: at.lods_at + li as u64 * LOD_LEN as u64,
            detail,
        };
        if l.triangles == 0 || l.vertices == 0 {
            return Err(lod_err("has no triangles or no vertices".into()));
        }
        if l.compressed && !l.encoded {
            return Err(lod_err("flags state a compressed raw blob".into()));
        }
        if let Some(g) = l.grid {
            if !l.encoded
                || !crate::codec::POSITION_BITS.contains(&g.position)
                || !crate::codec::NORMAL_BITS.contains(&g.normal)
            {
                return Err(lod_err(format!(
                    "flags state {} position bits and {} normal bits for {} LOD",
                    g.position,
                    g.normal,
                    if l.encoded { "an encoded" } else { "a raw" }
                )));
            }
        }
        if l.encoded && !l.compressed && l.len < crate::codec::HEADER_LEN as u64 {
            return Err(lod_err(format!(
                "encoded geometry of {} bytes is shorter than its header",
                l.len
            )));
        }
        if !l.encoded && l.len != geometry_len(l) {
            return Err(lod_err(format!(
                "geometry length {} does not match {} vertices and {} triangles ({} bytes)",
                l.len,
                l.vertices,
                l.triangles,
                geometry_len(l)
            )));
        }
        if l.offset < at.geometry_at || l.offset.checked_add(l.len).is_none_or(|e| e > geom_end) {
            return Err(lod_err(format!(
                "geometry bytes {}..+{} lie outside the GEOM section {}..{geom_end}",
                l.offset, l.len, at.geometry_at
            )));
        }
    }
    Ok(())
}
