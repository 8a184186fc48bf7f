//! LODs and HLODs (GigaWalk Section 4.3), simplified with meshoptimizer,
//! with measured errors.
//!
//! A leaf gets a chain of static LODs of its own geometry: edge collapse
//! for the first levels, then sloppy vertex clustering, halving down to a
//! floor. An inner node gets a chain of HLODs at every scale: its finest
//! is its children's levels cut at a matching error, merged and simplified
//! to a per-node triangle budget (sloppy clustering joins disjoint objects
//! as the paper's GAPS does), then halved down to the floor. So switching
//! from a node to its children at most multiplies the triangles drawn by
//! about 1 / ratio, and a node is drawable as soon as its budget suffices,
//! not only once it is a few pixels wide.
//!
//! Every level's error is measured ([`crate::hausdorff`]): an upper bound
//! on the two-sided Hausdorff distance to the full-detail surface it
//! stands for, non-decreasing along a chain and never below the errors of
//! the child levels an HLOD was built from.

use gigawalk_import::{Model, Object};
use gigawalk_scene::{Colours, LodMesh};
use glam::DVec3;
use meshopt::{SimplifyOptions, VertexDataAdapter};

use crate::hausdorff::{self, Nearest, Sampling, Surface};
use crate::parts::Part;

/// A level is accepted only if it has at most this fraction of the previous
/// level's triangles; otherwise the simplifier has stalled (e.g. on many
/// tiny disconnected pieces that edge collapses cannot remove).
const MIN_SHRINK: f64 = 0.8;

/// Geometry being simplified: f32 positions relative to `origin`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WorkMesh {
    pub origin: DVec3,
    pub positions: Vec<[f32; 3]>,
    pub normals: Vec<[f32; 3]>,
    /// sRGB-encoded RGBA8, one per vertex.
    pub colours: Vec<[u8; 4]>,
    pub indices: Vec<u32>,
}

impl WorkMesh {
    pub fn triangles(&self) -> usize {
        self.indices.len() / 3
    }

    /// The scene file's form: one uniform colour when every vertex agrees.
    pub fn to_lod_mesh(&self) -> LodMesh {
        let colours = match self.colours.first() {
            Some(&c) if self.colours.iter().all(|&x| x == c) => Colours::Uniform(c),
            _ => Colours::PerVertex(self.colours.clone()),
        };
        LodMesh {
            origin: self.origin,
            positions: self.positions.clone(),
            normals: self.normals.clone(),
            colours,
            indices: self.indices.clone(),
        }
    }

    /// The triangle surface, for error measurement.
    pub fn surface(&self) -> Surface<'_> {
        Surface {
            positions: &self.positions,
            indices: &self.indices,
        }
    }
}

/// One level of detail and its error: an upper bound, in model units, on
/// the Hausdorff distance between this level's surface and the
/// full-detail surface it stands for (see [`crate::hausdorff`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Lod {
    pub mesh: WorkMesh,
    pub error: f32,
}

/// How LOD chains are cut and measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChainParams {
    /// Target triangles of a level as a fraction of the previous level's.
    pub ratio: f64,
    /// Stop once a level has at most this many triangles.
    pub floor: usize,
    /// Levels 1..=collapse_levels of a leaf use edge collapse, the rest sloppy.
    pub collapse_levels: usize,
    /// Triangles of an inner node's finest HLOD (at most).
    pub node_budget: usize,
    /// Cover of the error measurement's samples as a fraction of the
    /// distance found ([`Sampling::spacing`]).
    pub bound_spacing: f32,
    /// The finest sample cover aimed for, as a fraction of the node's box
    /// diagonal ([`Sampling::floor`]).
    pub bound_floor: f64,
}

impl ChainParams {
    fn sampling(&self, diagonal: f64) -> Sampling {
        Sampling {
            spacing: self.bound_spacing,
            floor: (self.bound_floor * diagonal) as f32,
        }
    }

    /// Most triangles an inner node's merged children may have: its
    /// finest HLOD is one simplification step (by `ratio`) below them.
    pub fn merge_budget(&self) -> usize {
        ((self.node_budget as f64 / self.ratio).round() as usize).max(self.node_budget)
    }
}

/// The full-detail mesh of a final object, relative to `origin`, with
/// only the vertices its triangles use.
pub fn leaf_mesh(model: &Model, part: &Part, origin: DVec3) -> WorkMesh {
    let mut m = WorkMesh {
        origin,
        ..Default::default()
    };
    m.indices.reserve(3 * part.triangles);
    let mut used: Vec<u32> = Vec::new();
    for piece in &part.pieces {
        let o: &Object = &model.objects[piece.object as usize];
        used.clear();
        for &t in &piece.triangles {
            used.extend_from_slice(&o.indices[3 * t as usize..3 * t as usize + 3]);
        }
        used.sort_unstable();
        used.dedup();
        let base = m.positions.len() as u32;
        let uniform = srgb8(o.colour);
        for &v in &used {
            let v = v as usize;
            m.positions
                .push((o.positions[v] - origin).as_vec3().to_array());
            m.normals.push(o.normals[v].to_array());
            m.colours.push(match &o.vertex_colours {
                Some(c) => srgb8(c[v]),
                None => uniform,
            });
        }
        for &t in &piece.triangles {
            for &v in &o.indices[3 * t as usize..3 * t as usize + 3] {
                let local = used
                    .binary_search(&v)
                    .expect("`used` holds every index of these triangles");
                m.indices.push(base + local as u32);
            }
        }
    }
    m
}

/// A leaf's chain: the mesh itself (error 0), then coarser levels, each
/// measured against the mesh. `diagonal` is the leaf box's.
pub fn leaf_lods(mesh: WorkMesh, diagonal: f64, p: &ChainParams) -> Vec<Lod> {
    let mut queries = Nearest::new(mesh.surface());
    let mut lods = vec![Lod {
        mesh: mesh.clone(),
        error: 0.0,
    }];
    let reference = Reference {
        mesh: &mesh,
        queries: &mut queries,
        base: 0.0,
        sampling: p.sampling(diagonal),
    };
    extend_chain(&mut lods, reference, p, true);
    lods
}

/// An inner node's HLOD chain (GigaWalk Section 4.3), re-expressed
/// relative to `origin`. `children` are the children's chains (finest
/// first, errors non-decreasing; a chain may have lost levels too fine for
/// any parent). Each child contributes the coarsest of its levels whose
/// error is within a threshold common to all children, the smallest
/// threshold whose merged triangles fit [`ChainParams::merge_budget`], so
/// the children are cut at a matching error. The merge is simplified to
/// [`ChainParams::node_budget`] triangles and then halved down to the
/// floor. Every level's error is the largest error of the picked child
/// levels plus the measured distance between the merge and the level (by
/// the triangle inequality, a bound on its distance to the original), so
/// it is never below any picked child's.
pub fn inner_lods(children: &[&[Lod]], origin: DVec3, diagonal: f64, p: &ChainParams) -> Vec<Lod> {
    let picked = pick_levels(children, p.merge_budget());
    let parts: Vec<&Lod> = children
        .iter()
        .zip(&picked)
        .filter_map(|(c, &k)| c.get(k))
        .collect();
    let merged = merge(&parts, origin);
    let base = parts.iter().map(|l| l.error).fold(0.0f32, f32::max);
    let mut lods = Vec::new();
    if merged.triangles() > p.node_budget {
        let first =
            step(&merged, p.node_budget, true).or_else(|| step(&merged, p.node_budget, false));
        if let Some(mesh) = first {
            lods.push(Lod { mesh, error: 0.0 });
        }
    }
    let mut queries = Nearest::new(merged.surface());
    let sampling = p.sampling(diagonal);
    match lods.first_mut() {
        Some(first) => {
            first.error = base
                + hausdorff::symmetric(
                    merged.surface(),
                    &mut queries,
                    first.mesh.surface(),
                    &sampling,
                );
        }
        // Already within the budget (or the simplifier stalled): the
        // union itself is the finest HLOD.
        None => lods.push(Lod {
            mesh: merged.clone(),
            error: base,
        }),
    }
    if !lods[0].error.is_finite() {
        lods[0] = Lod {
            mesh: merged.clone(),
            error: base,
        };
    }
    let reference = Reference {
        mesh: &merged,
        queries: &mut queries,
        base,
        sampling,
    };
    extend_chain(&mut lods, reference, p, false);
    lods
}

/// The levels of an inner node's chain worth storing: from the first
/// whose triangles are below what its children would draw instead at the
/// same error (each child's coarsest level within that error, or its
/// finest). Traversal draws a node's coarsest acceptable level as soon as
/// one is acceptable; a finer level that costs more than refining would
/// make a tolerance draw more triangles than full detail. The levels after
/// the first worth storing are coarser still and stay.
pub fn worth_drawing(lods: &[Lod], children: &[&[Lod]]) -> std::ops::Range<usize> {
    let refine = |e: f32| -> usize {
        children
            .iter()
            .map(|c| {
                let k = c.iter().rposition(|l| l.error <= e).unwrap_or(0);
                c.get(k).map_or(0, |l| l.mesh.triangles())
            })
            .sum()
    };
    let first = lods
        .iter()
        .position(|l| l.mesh.triangles() < refine(l.error))
        .unwrap_or(lods.len());
    first..lods.len()
}

/// For each child chain, the index of the level to merge: the coarsest
/// level with error <= E, for the smallest E (among the chains' errors)
/// whose total triangles fit `budget`; the coarsest levels when nothing fits.
pub fn pick_levels(children: &[&[Lod]], budget: usize) -> Vec<usize> {
    let level = |c: &[Lod], e: f32| c.iter().rposition(|l| l.error <= e).unwrap_or(0);
    let total = |e: f32| -> usize {
        children
            .iter()
            .map(|c| c.get(level(c, e)).map_or(0, |l| l.mesh.triangles()))
            .sum()
    };
    let mut errors: Vec<f32> = children
        .iter()
        .flat_map(|c| c.iter().map(|l| l.error))
        .collect();
    errors.sort_by(f32::total_cmp);
    errors.dedup();
    // `total` does not grow with E: the first fitting E is found by bisection.
    let at = errors.partition_point(|&e| total(e) > budget);
    match errors.get(at).or(errors.last()) {
        Some(&e) => children.iter().map(|c| level(c, e)).collect(),
        None => vec![0; children.len()],
    }
}

/// What a chain's levels are measured against.
struct Reference<'a> {
    mesh: &'a WorkMesh,
    queries: &'a mut Nearest,
    /// Error of the reference itself against the original.
    base: f32,
    sampling: Sampling,
}

fn target_triangles(n: usize, p: &ChainParams) -> usize {
    ((n as f64 * p.ratio).round() as usize).clamp(1, n.saturating_sub(1).max(1))
}

/// Halves the last level repeatedly until the floor or until it stops
/// shrinking; each new level's error is `base` plus its measured distance
/// to the reference, and never below the previous level's. Edge collapse
/// is tried first for levels 1..=collapse_levels when `collapse` (leaves),
/// sloppy otherwise or when collapse stalls.
fn extend_chain(lods: &mut Vec<Lod>, r: Reference<'_>, p: &ChainParams, collapse: bool) {
    while let Some(last) = lods.last() {
        let n = last.mesh.triangles();
        if n <= p.floor {
            break;
        }
        let target = target_triangles(n, p);
        let limit = (MIN_SHRINK * n as f64) as usize;
        let shrunk = |m: &WorkMesh| m.triangles() <= limit && m.triangles() > 0;
        let mut next = if collapse && lods.len() <= p.collapse_levels {
            step(&last.mesh, target, false).filter(shrunk)
        } else {
            None
        };
        if next.is_none() {
            next = step(&last.mesh, target, true).filter(shrunk);
        }
        let Some(mesh) = next else { break };
        let measured =
            hausdorff::symmetric(r.mesh.surface(), r.queries, mesh.surface(), &r.sampling);
        if !measured.is_finite() {
            break;
        }
        let error = (r.base + measured).max(last.error);
        lods.push(Lod { mesh, error });
    }
}

/// One simplification step towards `target` triangles: sloppy vertex
/// clustering (joins disjoint pieces, as the paper's GAPS does) or
/// topology-preserving edge collapse. The simplifier's own error estimate
/// is not used: errors are measured.
fn step(mesh: &WorkMesh, target: usize, sloppy: bool) -> Option<WorkMesh> {
    if mesh.indices.is_empty() {
        return None;
    }
    let bytes = meshopt::typed_to_bytes(&mesh.positions);
    let adapter = VertexDataAdapter::new(bytes, std::mem::size_of::<[f32; 3]>(), 0).ok()?;
    // Weld vertices that share a position (normal or colour seams) so the
    // simplifier sees one connected surface; the output keeps one of the
    // welded vertices' attributes.
    let weld = meshopt::generate_position_remap(&adapter);
    let welded: Vec<u32> = mesh.indices.iter().map(|&i| weld[i as usize]).collect();
    let indices = if sloppy {
        meshopt::simplify_sloppy(&welded, &adapter, 3 * target, f32::MAX, None)
    } else {
        meshopt::simplify(
            &welded,
            &adapter,
            3 * target,
            f32::MAX,
            SimplifyOptions::ErrorAbsolute,
            None,
        )
    };
    if indices.is_empty() {
        return None;
    }
    Some(compact(mesh, &indices))
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

fn merge(children: &[&Lod], origin: DVec3) -> WorkMesh {
    let mut m = WorkMesh {
        origin,
        ..Default::default()
    };
    for c in children {
        let base = m.positions.len() as u32;
        let shift = c.mesh.origin - origin;
        m.positions.extend(c.mesh.positions.iter().map(|p| {
            (shift + glam::Vec3::from_array(*p).as_dvec3())
                .as_vec3()
                .to_array()
        }));
        m.normals.extend_from_slice(&c.mesh.normals);
        m.colours.extend_from_slice(&c.mesh.colours);
        m.indices.extend(c.mesh.indices.iter().map(|&i| base + i));
    }
    m
}

/// Linear RGBA in 0..=1 to sRGB-encoded RGBA8 (alpha stays linear).
pub fn srgb8(c: [f32; 4]) -> [u8; 4] {
    let enc = |x: f32| {
        let x = if x.is_finite() {
            x.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let s = if x <= 0.003_130_8 {
            12.92 * x
        } else {
            1.055 * x.powf(1.0 / 2.4) - 0.055
        };
        (s * 255.0).round() as u8
    };
    let a = if c[3].is_finite() {
        c[3].clamp(0.0, 1.0)
    } else {
        1.0
    };
    [enc(c[0]), enc(c[1]), enc(c[2]), (a * 255.0).round() as u8]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::parts::initial_parts;
    use crate::test_models::{grid_object, pipe_object};

    const P: ChainParams = ChainParams {
        ratio: 0.5,
        floor: 64,
        collapse_levels: 1,
        node_budget: 256,
        bound_spacing: 0.25,
        bound_floor: 1e-3,
    };

    fn mesh_of(o: gigawalk_import::Object) -> WorkMesh {
        let m = Model {
            objects: vec![o],
            ..Default::default()
        };
        let (parts, _) = initial_parts(&m).unwrap();
        leaf_mesh(&m, &parts[0], parts[0].bounds.center())
    }

    #[test]
    fn srgb_endpoints_and_midpoint() {
        assert_eq!(srgb8([0.0, 1.0, 0.5, 0.5]), [0, 255, 188, 128]);
        assert_eq!(srgb8([f32::NAN, -1.0, 2.0, 1.0]), [0, 0, 255, 255]);
    }

    #[test]
    fn leaf_chain_halves_down_to_the_floor_with_growing_error() {
        let mesh = mesh_of(grid_object(DVec3::ZERO, 10.0, 64, 0.3));
        let full = mesh.triangles();
        let lods = leaf_lods(mesh, 15.0, &P);
        assert!(lods.len() >= 4, "{} levels", lods.len());
        assert_eq!(lods[0].error, 0.0);
        assert_eq!(lods[0].mesh.triangles(), full);
        for w in lods.windows(2) {
            assert!(w[1].mesh.triangles() as f64 <= MIN_SHRINK * w[0].mesh.triangles() as f64);
            assert!(w[1].error >= w[0].error);
        }
        assert!(lods[1].error > 0.0);
        let last = lods.last().unwrap();
        assert!(last.mesh.triangles() <= P.floor || lods.len() > 8);
    }

    #[test]
    fn sloppy_fallback_reduces_many_disconnected_pieces() {
        // 300 separate tiny pipes: edge collapse cannot remove components.
        let mut all = pipe_object(DVec3::ZERO, 0.5, 0.05, 1, 3);
        for i in 1..300 {
            let p = pipe_object(
                DVec3::new((i % 20) as f64, (i / 20) as f64, 0.0),
                0.5,
                0.05,
                1,
                3,
            );
            let base = all.positions.len() as u32;
            all.positions.extend(p.positions);
            all.normals.extend(p.normals);
            all.indices.extend(p.indices.iter().map(|i| i + base));
        }
        let lods = leaf_lods(mesh_of(all), 25.0, &P);
        assert!(lods.len() >= 2);
        assert!(lods.last().unwrap().mesh.triangles() < lods[0].mesh.triangles() / 2);
    }

    #[test]
    fn inner_hlod_error_is_at_least_every_picked_child_level() {
        let a = leaf_lods(mesh_of(grid_object(DVec3::ZERO, 10.0, 32, 0.2)), 15.0, &P);
        let b = leaf_lods(
            mesh_of(grid_object(DVec3::new(12.0, 0.0, 0.0), 10.0, 32, 0.5)),
            15.0,
            &P,
        );
        let children = [a.as_slice(), b.as_slice()];
        let origin = DVec3::new(11.0, 0.0, 5.0);
        let picked = pick_levels(&children, P.merge_budget());
        let lods = inner_lods(&children, origin, 30.0, &P);
        assert!(!lods.is_empty());
        assert!(lods[0].mesh.triangles() <= P.node_budget);
        for l in &lods {
            assert!(l.error >= a[picked[0]].error && l.error >= b[picked[1]].error);
            assert_eq!(l.mesh.origin, origin);
        }
        for w in lods.windows(2) {
            assert!(w[1].error >= w[0].error);
        }
    }

    #[test]
    fn uniform_colour_is_detected() {
        let m = mesh_of(grid_object(DVec3::ZERO, 1.0, 4, 0.0));
        assert!(matches!(m.to_lod_mesh().colours, Colours::Uniform(_)));
        let mut m2 = m.clone();
        m2.colours[0] = [1, 2, 3, 4];
        assert!(matches!(m2.to_lod_mesh().colours, Colours::PerVertex(_)));
    }
}
