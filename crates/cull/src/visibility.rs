//! Hidden and highlighted objects, as traversal and the passes see them.
//!
//! A node's LODs stand for every object in its subtree
//! ([`ObjectTable::node_objects`]); merged into an HLOD, or into a leaf's
//! coarser levels, one object cannot be left out or tinted alone. So a
//! node with a hidden or highlighted object below it is *partial*: an
//! inner one is always refined, a leaf always draws its full detail, in
//! pieces (the runs of the objects shown, each plain or highlighted). A
//! node whose objects are all hidden is culled with its subtree. No drawn
//! LOD then holds a hidden object, so none is drawn nor used as an
//! occluder, and what is drawn is exactly the full-detail surface of the
//! objects shown wherever a partial node is.

use std::sync::Arc;

use gigawalk_scene::objects::ObjectTable;
pub use gigawalk_scene::objects::{LodPieces, Piece};
use gigawalk_scene::Skeleton;

/// What of a node's subtree shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeShow {
    /// Every object, none highlighted: its LODs may be drawn.
    Whole,
    /// Some objects are hidden or highlighted: refine it (draw a leaf's
    /// full detail in pieces).
    Partial,
    /// Every object is hidden: cull it.
    Hidden,
}

/// Which objects show, per node and per leaf piece, for one set of hidden
/// and highlighted objects.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Visibility {
    /// Per node; empty when nothing is hidden or highlighted.
    show: Vec<NodeShow>,
    /// A partial leaf's finest LOD -> the pieces to draw.
    pieces: Arc<LodPieces>,
    hidden: usize,
    highlighted: usize,
}

impl Visibility {
    /// Everything shows, nothing highlighted.
    pub fn all() -> Visibility {
        Visibility::default()
    }

    /// `hidden(o)` and `highlight(o)` for each object `o` of `table`; a
    /// hidden object is not highlighted.
    pub fn new(
        skeleton: &Skeleton,
        table: &ObjectTable,
        hidden: &dyn Fn(u32) -> bool,
        highlight: &dyn Fn(u32) -> bool,
    ) -> Visibility {
        let objects = table.objects().len() as u32;
        let hidden_set: Vec<bool> = (0..objects).map(hidden).collect();
        let lit: Vec<bool> = (0..objects)
            .map(|o| !hidden_set[o as usize] && highlight(o))
            .collect();
        let n_hidden = hidden_set.iter().filter(|&&h| h).count();
        let n_lit = lit.iter().filter(|&&h| h).count();
        if n_hidden == 0 && n_lit == 0 {
            return Visibility::all();
        }
        let nodes = skeleton.nodes();
        // Per node: whether any object below shows, and whether any is
        // hidden or highlighted.
        let mut shows = vec![false; nodes.len()];
        let mut marked = vec![false; nodes.len()];
        let mut pieces = LodPieces::new();
        for (i, n) in nodes.iter().enumerate() {
            if !n.is_leaf() || n.lod_count == 0 {
                continue;
            }
            let Some(runs) = table.runs(n.first_lod) else {
                // A leaf without runs has no named objects: it shows whole.
                shows[i] = true;
                continue;
            };
            let mut list: Vec<Piece> = Vec::new();
            let mut first = 0u32;
            for r in runs {
                let (h, l) = (hidden_set[r.object as usize], lit[r.object as usize]);
                marked[i] |= h || l;
                if !h {
                    shows[i] = true;
                    match list.last_mut() {
                        Some(p) if p.highlight == l && p.first_triangle + p.triangles == first => {
                            p.triangles += r.triangles
                        }
                        _ => list.push(Piece {
                            first_triangle: first,
                            triangles: r.triangles,
                            highlight: l,
                        }),
                    }
                }
                first += r.triangles;
            }
            if marked[i] && shows[i] {
                pieces.insert(n.first_lod, list);
            }
        }
        for i in (1..nodes.len()).rev() {
            let p = nodes[i].parent as usize;
            shows[p] |= shows[i];
            marked[p] |= marked[i];
        }
        let show = shows
            .iter()
            .zip(&marked)
            .map(|(&s, &m)| match (s, m) {
                (false, _) => NodeShow::Hidden,
                (true, true) => NodeShow::Partial,
                (true, false) => NodeShow::Whole,
            })
            .collect();
        Visibility {
            show,
            pieces: Arc::new(pieces),
            hidden: n_hidden,
            highlighted: n_lit,
        }
    }

    /// X-ray's ghosts for the objects `hidden` leaves out: a visibility that
    /// shows exactly those (none highlighted) and hides every other, so a
    /// traversal with it draws what the frame's own leaves out, by the
    /// same rules (a node whose objects are all ghosts draws its LODs, a
    /// leaf with some draws its ghosts' pieces at full detail). `None`
    /// when nothing is hidden.
    pub fn ghosts(
        skeleton: &Skeleton,
        table: &ObjectTable,
        hidden: &dyn Fn(u32) -> bool,
    ) -> Option<Visibility> {
        let objects = table.objects().len() as u32;
        if !(0..objects).any(hidden) {
            return None;
        }
        Some(Visibility::new(skeleton, table, &|o| !hidden(o), &|_| {
            false
        }))
    }

    /// Whether everything shows whole (no hidden or highlighted object).
    pub fn is_all(&self) -> bool {
        self.show.is_empty()
    }

    pub fn node(&self, node: u32) -> NodeShow {
        self.show
            .get(node as usize)
            .copied()
            .unwrap_or(NodeShow::Whole)
    }

    /// The pieces of a partial leaf's finest LOD (`None`: draw it whole).
    pub fn pieces(&self, lod: u32) -> Option<&[Piece]> {
        if self.pieces.is_empty() {
            return None;
        }
        self.pieces.get(&lod).map(Vec::as_slice)
    }

    /// Every LOD drawn in pieces, for the passes (`None`: none is).
    pub fn lod_pieces(&self) -> Option<Arc<LodPieces>> {
        (!self.pieces.is_empty()).then(|| self.pieces.clone())
    }

    /// Objects hidden, and highlighted.
    pub fn counts(&self) -> (usize, usize) {
        (self.hidden, self.highlighted)
    }
}
