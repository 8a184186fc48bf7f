//! One simplification step (meshoptimizer's edge collapse or sloppy
//! vertex clustering, or pair contraction across gaps, [`super::gaps`],
//! the paper's GAPS) on a mesh welded and split into connected pieces
//! once for every step tried, and what becomes of the pieces a step made
//! vanish: a leaf keeps a triangle of each, an inner node covers those
//! with nothing left near them.

use meshopt::{SimplifyOptions, VertexDataAdapter};
use rustc_hash::FxHashMap;

use super::WorkMesh;

/// How a step simplifies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Step {
    /// meshoptimizer's edge collapse: keeps topology, prunes pieces
    /// smaller than the error.
    Collapse,
    /// meshoptimizer's sloppy vertex clustering: joins whatever shares a
    /// cell, at a cell size well above the error it measures.
    Sloppy,
    /// Pair contraction across gaps ([`super::gaps`]): edges and close
    /// vertex pairs contracted by quadric error, joining parts and
    /// closing holes as the error allows.
    Gaps,
}

/// One mesh prepared for simplification steps: vertices that share a
/// position are welded (normal or colour seams would otherwise block the
/// simplifier; the output keeps one of the welded vertices' attributes),
/// and its connected pieces found, once for however many steps are tried.
pub(super) struct Simplifier<'a> {
    mesh: &'a WorkMesh,
    welded: Vec<u32>,
    /// Per vertex, the root of its connected piece (over `welded`).
    piece: Vec<u32>,
    /// Pair contraction's every step on the welded mesh, made on the
    /// first [`Step::Gaps`] step asked for: each limit tried after it is
    /// a replay.
    /// (Made again should a later step ask for fewer triangles than it
    /// reached.)
    gaps: std::cell::RefCell<Option<super::gaps::History>>,
    /// A leaf's few pieces each keep a triangle ([`Simplifier::keep_every_piece`]);
    /// an inner node's thousands are covered ([`Simplifier::cover_vanished`]).
    keep_pieces: bool,
}

impl<'a> Simplifier<'a> {
    pub(super) fn new(mesh: &'a WorkMesh, keep_pieces: bool) -> Self {
        crate::spent::timed(crate::spent::Kind::Simplify, || {
            Self::welded(mesh, keep_pieces)
        })
    }

    fn welded(mesh: &'a WorkMesh, keep_pieces: bool) -> Self {
        let welded: Vec<u32> = match Self::adapter(mesh) {
            Some(adapter) => {
                let weld = meshopt::generate_position_remap(&adapter);
                mesh.indices.iter().map(|&i| weld[i as usize]).collect()
            }
            None => Vec::new(),
        };
        let mut parent: Vec<u32> = (0..mesh.positions.len() as u32).collect();
        for t in welded.chunks_exact(3) {
            let a = crate::cluster::find(&mut parent, t[0]);
            for &v in &t[1..] {
                let b = crate::cluster::find(&mut parent, v);
                parent[b as usize] = a;
            }
        }
        let piece = (0..parent.len() as u32)
            .map(|v| crate::cluster::find(&mut parent, v))
            .collect();
        Simplifier {
            mesh,
            welded,
            piece,
            gaps: std::cell::RefCell::new(None),
            keep_pieces,
        }
    }

    fn adapter(mesh: &WorkMesh) -> Option<VertexDataAdapter<'_>> {
        let bytes = meshopt::typed_to_bytes(&mesh.positions);
        VertexDataAdapter::new(bytes, std::mem::size_of::<[f32; 3]>(), 0).ok()
    }

    /// One simplification step towards `target` triangles, stopping early
    /// where it would move the surface by more than `max_error` model
    /// units (the simplifier's estimate; `f32::MAX` for none): sloppy
    /// vertex clustering (joins disjoint pieces, as the paper's GAPS does)
    /// or topology-preserving edge collapse, which prunes pieces smaller
    /// than the error. Vanished pieces are kept or covered (`keep_pieces`).
    /// The simplifier's own error estimate only guides: errors are
    /// measured.
    pub(super) fn step(&self, target: usize, max_error: f32, how: Step) -> Option<WorkMesh> {
        crate::spent::timed(crate::spent::Kind::Simplify, || {
            self.simplified(target, max_error, how)
        })
    }

    fn simplified(&self, target: usize, max_error: f32, how: Step) -> Option<WorkMesh> {
        if self.welded.is_empty() {
            return None;
        }
        let adapter = Self::adapter(self.mesh)?;
        let welded = &self.welded;
        let mut result_error = 0.0f32;
        // After pair contraction, per vertex the vertex it became.
        let mut into: Option<Vec<u32>> = None;
        let indices = if how == Step::Gaps {
            let mut history = self.gaps.borrow_mut();
            if !history.as_ref().is_some_and(|h| h.reaches(target)) {
                *history = Some(super::gaps::History::new(
                    &self.mesh.positions,
                    welded,
                    target,
                ));
            }
            let c = history.as_ref().expect("made above").level(
                &self.mesh.positions,
                welded,
                target,
                max_error,
            );
            result_error = c.error;
            into = Some(c.into);
            c.indices
        } else if how == Step::Sloppy {
            // Sloppy takes its error relative to the mesh's extent.
            let scale = meshopt::simplify_scale(&adapter);
            let relative = if max_error == f32::MAX || scale.is_nan() || scale <= 0.0 {
                f32::MAX
            } else {
                max_error / scale
            };
            let out = meshopt::simplify_sloppy(
                welded,
                &adapter,
                3 * target,
                relative,
                Some(&mut result_error),
            );
            result_error *= scale;
            out
        } else {
            meshopt::simplify(
                welded,
                &adapter,
                3 * target,
                max_error,
                SimplifyOptions::ErrorAbsolute | SimplifyOptions::Prune,
                Some(&mut result_error),
            )
        };
        let into = into.as_deref();
        let indices = if self.keep_pieces {
            self.keep_every_piece(indices, into)
        } else {
            // The cell size is the limit: what the level may move
            // surfaces by. Vanished pieces are stood for by about a
            // triangle per cell of it, so a thousand bolts that each
            // collapsed to nothing become a sheet of cells rather than a
            // thousand triangles at every limit. Without a limit, the
            // simplifier's own error.
            let cell = if max_error < f32::MAX {
                max_error
            } else if result_error.is_finite() && result_error > 0.0 {
                result_error
            } else {
                f32::MIN_POSITIVE.sqrt()
            };
            self.cover_vanished(indices, cell, into)
        };
        if indices.is_empty() {
            return None;
        }
        Some(compact(self.mesh, &indices))
    }

    /// Per triangle of the welded mesh: its piece when no triangle of
    /// `simplified` uses any vertex of that piece (nor, after a
    /// contraction, the vertex any of them became), `None` when the piece
    /// survives: a bolt contracted into its flange has not vanished.
    fn vanished_pieces(&self, simplified: &[u32], into: Option<&[u32]>) -> Vec<Option<u32>> {
        let mut survives = vec![false; self.piece.len()];
        match into {
            None => {
                for &v in simplified {
                    survives[self.piece[v as usize] as usize] = true;
                }
            }
            Some(into) => {
                let mut used = vec![false; into.len()];
                for &v in simplified {
                    used[v as usize] = true;
                }
                for (v, &w) in into.iter().enumerate() {
                    if used[w as usize] {
                        survives[self.piece[v] as usize] = true;
                    }
                }
            }
        }
        self.welded
            .chunks_exact(3)
            .map(|t| {
                let root = self.piece[t[0] as usize];
                (!survives[root as usize]).then_some(root)
            })
            .collect()
    }

    /// `simplified` plus triangles of the pieces that lost all their
    /// triangles, where nothing is left near them: a triangle of a
    /// vanished piece is added when one of its corners has no kept vertex
    /// within about a `cell` (same or neighbouring grid cell), so a
    /// vanished piece near kept geometry (a bolt on its flange) costs
    /// nothing and a far one (a pipe across an aisle) keeps about one
    /// triangle per cell it spans: about what it covers on screen at the
    /// error the cell stands for.
    fn cover_vanished(
        &self,
        mut simplified: Vec<u32>,
        cell: f32,
        into: Option<&[u32]>,
    ) -> Vec<u32> {
        let vanished = self.vanished_pieces(&simplified, into);
        let inv = 1.0 / cell;
        // Cell coordinates saturate (`as` from f64), and so do their
        // neighbours, so a tiny cell or a far vertex cannot overflow.
        let key = |i: u32| {
            let p = self.mesh.positions[i as usize];
            [0, 1, 2].map(|k| (p[k] as f64 * inv as f64).floor() as i64)
        };
        let mut occupied: rustc_hash::FxHashSet<[i64; 3]> =
            simplified.iter().map(|&v| key(v)).collect();
        let near = |occupied: &rustc_hash::FxHashSet<[i64; 3]>, c: [i64; 3]| {
            let at = |k: usize, d: i64| c[k].saturating_add(d);
            (-1..=1).any(|x| {
                (-1..=1)
                    .any(|y| (-1..=1).any(|z| occupied.contains(&[at(0, x), at(1, y), at(2, z)])))
            })
        };
        let mut added = Vec::new();
        for (t, gone) in self.welded.chunks_exact(3).zip(&vanished) {
            if gone.is_none() {
                continue;
            }
            if t.iter().any(|&v| !near(&occupied, key(v))) {
                added.extend_from_slice(t);
                for &v in t {
                    occupied.insert(key(v));
                }
            }
        }
        simplified.extend(added);
        simplified
    }

    /// `simplified` plus, for every piece that lost all its triangles, that
    /// piece's largest triangle. Edge collapse prunes small pieces and
    /// sloppy clustering drops thin ones; a vanished piece would cost its
    /// distance to what remains (which may be far), a kept triangle of it
    /// at most its own diameter.
    fn keep_every_piece(&self, mut simplified: Vec<u32>, into: Option<&[u32]>) -> Vec<u32> {
        let vanished = self.vanished_pieces(&simplified, into);
        // Per vanished piece (by root): its largest triangle so far.
        let mut best: FxHashMap<u32, (f32, usize)> = FxHashMap::default();
        for (k, (t, gone)) in self.welded.chunks_exact(3).zip(&vanished).enumerate() {
            let Some(root) = *gone else { continue };
            let p = |i: u32| glam::Vec3::from_array(self.mesh.positions[i as usize]);
            let area = (p(t[1]) - p(t[0]))
                .cross(p(t[2]) - p(t[0]))
                .length_squared();
            let e = best.entry(root).or_insert((-1.0, k));
            if area > e.0 {
                *e = (area, k);
            }
        }
        let mut added: Vec<usize> = best.values().map(|&(_, k)| k).collect();
        added.sort_unstable();
        for k in added {
            simplified.extend_from_slice(&self.welded[3 * k..3 * k + 3]);
        }
        simplified
    }
}

/// The vertices `indices` use, in first-use order.
fn compact(mesh: &WorkMesh, indices: &[u32]) -> WorkMesh {
    let mut remap = vec![u32::MAX; mesh.positions.len()];
    let mut out = WorkMesh {
        origin: mesh.origin,
        ..Default::default()
    };
    out.indices.reserve(indices.len());
    for &i in indices {
        let slot = &mut remap[i as usize];
        if *slot == u32::MAX {
            *slot = out.positions.len() as u32;
            out.positions.push(mesh.positions[i as usize]);
            out.normals.push(mesh.normals[i as usize]);
            out.colours.push(mesh.colours[i as usize]);
        }
        out.indices.push(*slot);
    }
    out
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::hlod::tests::mesh_of;
    use crate::test_models::{box_object, grid_object, pipe_object};
    use glam::DVec3;

    /// Pieces of `m`, counting vertices with equal positions as one.
    pub(in crate::hlod) fn pieces(m: &WorkMesh) -> usize {
        let s = Simplifier::new(m, true);
        let mut roots: Vec<u32> = s.welded.iter().map(|&v| s.piece[v as usize]).collect();
        roots.sort_unstable();
        roots.dedup();
        roots.len()
    }

    #[test]
    fn vanished_pieces_are_covered_only_where_nothing_is_left() {
        // A plate, a bolt on it and a long pipe 3 units above it: with
        // only the plate kept, the bolt is within a cell of it and stays
        // gone; the pipe gets about one triangle per cell along it.
        let mut all = grid_object(DVec3::ZERO, 4.0, 8, 0.0);
        let plate = all.indices.len();
        let mut add = |o: gigawalk_import::Object| {
            let base = all.positions.len() as u32;
            all.positions.extend(o.positions);
            all.normals.extend(o.normals);
            all.indices.extend(o.indices.iter().map(|i| i + base));
        };
        add(box_object(
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(1.1, 0.1, 1.1),
        ));
        add(pipe_object(DVec3::new(0.0, 3.0, 8.0), 20.0, 0.05, 40, 6));
        let mesh = mesh_of(all);
        let s = Simplifier::new(&mesh, false);
        let kept: Vec<u32> = s.welded[..plate].to_vec();
        let out = s.cover_vanished(kept.clone(), 0.5, None);
        let added = &out[kept.len()..];
        let pos = |i: u32| glam::Vec3::from_array(mesh.positions[i as usize]);
        let origin = mesh.origin.as_vec3();
        // Nothing of the bolt (its corners are within a cell of the plate).
        assert!(added.iter().all(|&i| (pos(i) + origin).z > 6.0));
        let n = added.len() / 3;
        assert!(
            (10..=200).contains(&n),
            "{n} triangles cover a 20-unit pipe at cell 0.5"
        );
        // Every pipe vertex now has a kept vertex within two cells.
        for &i in &mesh.indices[plate..] {
            let p = pos(i);
            if (p + origin).z < 6.0 {
                continue;
            }
            let d = added
                .iter()
                .map(|&j| (pos(j) - p).length())
                .fold(f32::MAX, f32::min);
            assert!(
                d <= 2.0 * 0.5 * 3f32.sqrt(),
                "pipe vertex {p} is {d} from any kept vertex"
            );
        }
    }
}
