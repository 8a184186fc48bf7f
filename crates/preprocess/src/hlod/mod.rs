//! LODs and HLODs (GigaWalk Section 4.3), simplified with meshoptimizer,
//! with measured errors.
//!
//! A leaf gets a chain of static LODs of its own geometry (or two kinds
//! of chain, [`LeafChain`], and keeps the one that draws fewer triangles
//! over the distances it may be seen from); an inner node a chain of
//! HLODs made from the union of its children's levels, cut at a matching
//! error so the union holds about twice the node's triangle budget. Both
//! are made the same way ([`extend_chain`]): each
//! level is the first simplification of the previous one, at doubling
//! error limits, that keeps at most 65% of its triangles, and never far
//! below the level's target. Edge collapse (which prunes small pieces)
//! and vertex clustering (which joins disjoint pieces at coarse cells)
//! are both tried where the pieces are many, and pair contraction across
//! gaps (the paper's GAPS, [`gaps`]: joins parts and closes holes at the
//! error a level allows) wherever collapse stalls; the lower error per
//! triangle is kept. Pieces that vanished where nothing is left
//! near them are stood for by about a triangle per cell of the error.
//! So a machine's thousands of bolts, covers and hoses aggregate into
//! blobs, a node's finest HLOD stands for its children near the error
//! where they would be drawn, and switching from a node to its children
//! multiplies the triangles drawn by a small factor (`gigawalk info`
//! reports the distribution).
//!
//! Every level's error is measured ([`crate::hausdorff`]): an upper bound
//! on the two-sided Hausdorff distance to the full-detail surface it
//! stands for, non-decreasing along a chain and never below the errors of
//! the child levels an HLOD was built from. Below a node of at most
//! 65,536 triangles that surface itself is the reference; above, the
//! union of the children's levels, plus their errors (the triangle
//! inequality), which compounds with every level of the tree.
//!
//! In parts: `chain` makes a chain's levels one after another and
//! certifies each, `simplify` makes one simplification step, `gaps` is
//! the pair-contraction simplifier; this file
//! holds the meshes, a leaf's and an inner node's chains, and which
//! levels an inner node stores.

use gigawalk_import::Object;
use gigawalk_scene::{Colours, LodMesh};
use glam::DVec3;

use crate::hausdorff::{Nearest, Sampling, Surface};
use crate::parts::Part;
use crate::source::{Source, SpillError};

mod chain;
mod gaps;
mod proxy;
mod simplify;

pub use chain::Tally;
use chain::{extend_chain, Reference};

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
    /// Whether a leaf's covering chain is made beside its kept-pieces
    /// chain, and the one that draws less kept ([`leaf_lods`]).
    pub leaf_best: bool,
    /// Whether every level of a chain meets a pair contraction across
    /// gaps ([`gaps`]) as a rival, the better kept.
    pub gaps: bool,
    /// Whether merged proxies are made and measured beside the chain's
    /// levels, and kept where they draw less ([`with_proxies`]).
    pub proxies: bool,
    /// The finest proxies' cells across a reference's longest side.
    pub proxy_cells: u32,
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
    /// The chain settings of a run's parameters.
    pub fn of(params: &crate::Params) -> Self {
        ChainParams {
            ratio: params.lod_ratio,
            floor: params.lod_floor as usize,
            leaf_best: params.leaf_chains == crate::LeafChains::Best,
            gaps: params.gaps,
            proxies: params.proxies,
            proxy_cells: params.proxy_cells,
            collapse_levels: params.collapse_levels as usize,
            node_budget: params.node_budget as usize,
            bound_spacing: params.bound_spacing as f32,
            bound_floor: params.bound_floor,
        }
    }

    fn sampling(&self, diagonal: f64) -> Sampling {
        Sampling {
            spacing: self.bound_spacing,
            floor: (self.bound_floor * diagonal) as f32,
            enough: 0.0,
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
pub fn leaf_mesh(model: &dyn Source, part: &Part, origin: DVec3) -> Result<WorkMesh, SpillError> {
    let mut m = WorkMesh {
        origin,
        ..Default::default()
    };
    m.indices.reserve(3 * part.triangles);
    let mut used: Vec<u32> = Vec::new();
    for piece in &part.pieces {
        let o = model.object(piece.object)?;
        let o: &Object = &o;
        used.clear();
        for t in piece.triangles.iter() {
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
        for t in piece.triangles.iter() {
            for &v in &o.indices[3 * t as usize..3 * t as usize + 3] {
                let local = used
                    .binary_search(&v)
                    .expect("`used` holds every index of these triangles");
                m.indices.push(base + local as u32);
            }
        }
    }
    Ok(m)
}

/// A leaf's chain: the mesh itself (error 0), then coarser levels, each
/// measured against the mesh. `diagonal` is the leaf box's. The
/// kept-pieces chain ([`LeafChain`]); with `leaf_best` the covering one
/// too, and whichever draws fewer triangles over the tolerances the leaf
/// may be drawn at ([`draw_cost`]; the kept-pieces chain on a tie).
pub fn leaf_lods(mesh: WorkMesh, diagonal: f64, p: &ChainParams, tally: &Tally) -> Vec<Lod> {
    let mut queries = Nearest::new(mesh.surface());
    let kept = leaf_chain(
        &mesh,
        &mut queries,
        diagonal,
        LeafChain::KeepPieces,
        p,
        tally,
    );
    let chain = if !p.leaf_best {
        kept
    } else {
        let covered = leaf_chain(&mesh, &mut queries, diagonal, LeafChain::Cover, p, tally);
        if draw_cost(&covered, diagonal) < draw_cost(&kept, diagonal) {
            tally.add_cover_chosen();
            covered
        } else {
            kept
        }
    };
    if !p.proxies {
        return chain;
    }
    let reference = ProxyReference {
        mesh: &mesh,
        queries: &mut queries,
        base: 0.0,
        sampling: p.sampling(diagonal),
        children: &[],
        finest: p.proxy_cells,
    };
    with_proxies(chain, reference, tally)
}

/// What proxies are made of and measured against: a leaf's full detail,
/// or an inner node's reference (its full detail, or the union of its
/// children's levels, whose own error is `base`).
struct ProxyReference<'a> {
    mesh: &'a WorkMesh,
    queries: &'a mut Nearest,
    base: f32,
    sampling: Sampling,
    /// An inner node's children's chains: a proxy of the node is kept
    /// only where switching to them multiplies what is drawn by at most
    /// [`MAX_SWITCH`] (a plate's 200 rivets would otherwise go from a
    /// 2-triangle slab to 450 triangles at a hair's less error).
    children: &'a [&'a [Lod]],
    /// Cells across the longest side of the finest proxy tried.
    finest: u32,
}

/// The chain `lods` (finest first, errors non-decreasing) with merged
/// proxies ([`proxy`]) of the reference put in where they draw less: each
/// proxy, on cells of [`PROXY_RESOLUTIONS`] fractions of the reference's
/// longest side (up to `--proxy-cells`), is measured (two-sided, as every
/// level) only as far as it takes to know whether it beats every level
/// of at most its triangles, and the chain is then the lower envelope of
/// the levels and the winning proxies (in order of error, each with
/// fewer triangles than the one before): at every tolerance it draws the
/// fewest triangles of any of them within it, never more than the chain
/// alone. Level 0 (a leaf's full detail, an inner node's union) stays
/// first; no proxy's error is below it. References of fewer than
/// [`PROXY_MIN_TRIANGLES`] are left as they are.
fn with_proxies(lods: Vec<Lod>, r: ProxyReference<'_>, tally: &Tally) -> Vec<Lod> {
    use crate::hausdorff::{symmetric_within, Within};
    let Some(first) = lods.first() else {
        return lods;
    };
    if r.mesh.triangles() < PROXY_MIN_TRIANGLES {
        return lods;
    }
    let floor_error = first.error;
    let Some(bounds) = proxy::bounds(r.mesh) else {
        return lods;
    };
    let longest = (bounds.1 - bounds.0).max_element();
    if !(longest.is_finite() && longest > 0.0) {
        return lods;
    }
    let mut proxies: Vec<Lod> = Vec::new();
    for cells in PROXY_RESOLUTIONS
        .into_iter()
        .filter(|&c| c <= r.finest as f32)
    {
        let Some(mesh) = proxy::proxy(r.mesh, bounds, longest / cells) else {
            // Past the grid's cap: finer cells are too.
            break;
        };
        tally.add_proxy();
        // It wins only below the error of every level (or proxy kept) of
        // at most its triangles; one ulp above that, so a bound past it
        // loses for certain.
        let t = mesh.triangles();
        let beat = lods
            .iter()
            .chain(&proxies)
            .filter(|l| l.mesh.triangles() <= t)
            .map(|l| l.error)
            .fold(f32::INFINITY, f32::min);
        let limit = if beat.is_finite() {
            (beat - r.base).max(0.0).next_up()
        } else {
            f32::INFINITY
        };
        let w = symmetric_within(
            r.mesh.surface(),
            r.queries,
            mesh.surface(),
            None,
            &r.sampling,
            limit,
        );
        // At least the error this proxy has (or the one it lost to).
        let mut at_least = beat;
        if let Within::Yes(e) = w {
            let error = (r.base + e).max(floor_error);
            at_least = error;
            let switch_ok =
                r.children.is_empty() || refined(r.children, error) <= MAX_SWITCH * t.max(1);
            if error < beat && error.is_finite() && switch_ok {
                tally.add_proxy_kept();
                proxies.push(Lod { mesh, error });
            }
        }
        // Halving the cell about doubles a proxy's triangles at least,
        // and at best halves its error: the next can win only if no level
        // (or proxy kept) of at most twice these triangles is within
        // that. Nor is a proxy of a quarter of the reference's triangles
        // or more a real step.
        let hope = (at_least * PROXY_HOPE).max(floor_error);
        let dominated = lods
            .iter()
            .chain(&proxies)
            .any(|l| l.mesh.triangles() <= 2 * t && l.error <= hope);
        if dominated || 4 * t >= r.mesh.triangles() {
            break;
        }
    }
    if proxies.is_empty() {
        return lods;
    }
    let mut rest: Vec<Lod> = lods.into_iter().chain(proxies).collect();
    let first = rest.remove(0);
    rest.sort_by(|a, b| {
        a.error
            .total_cmp(&b.error)
            .then(a.mesh.triangles().cmp(&b.mesh.triangles()))
    });
    let mut chain = vec![first];
    for l in rest {
        let last = chain.last().map_or(usize::MAX, |l| l.mesh.triangles());
        if l.mesh.triangles() < last {
            chain.push(l);
        }
    }
    chain
}

/// Proxies are made on cells of these fractions of a reference's longest
/// side: errors from about a quarter of it down to about a sixtieth (the
/// offset, the sampling and the simplifier each move the shell by up to
/// about a cell), where a machine seen from 16-64 m is drawn at 1 px.
const PROXY_RESOLUTIONS: [f32; 5] = [8.0, 16.0, 32.0, 64.0, 128.0];

/// The most an inner node's proxy may be outnumbered by what its
/// children draw at its error (the switch factor `gigawalk info` and
/// `preprocess --stats` report, and the tests bound).
const MAX_SWITCH: usize = 8;

/// The most a proxy on cells half the size may shrink the error by (a
/// half, and some hope), to decide whether making it is worth the time.
const PROXY_HOPE: f32 = 0.375;

/// References of fewer triangles get no proxies: their chains end within
/// a few hundred triangles anyway.
const PROXY_MIN_TRIANGLES: usize = 1024;

/// How a leaf's chain treats the pieces a level makes vanish.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LeafChain {
    /// Each vanished piece keeps its largest triangle, and a collapsed
    /// level meets clustering only when measured far off (by error
    /// alone). Serves parts whose pieces are few and far apart.
    KeepPieces,
    /// As an inner node's: vanished pieces covered by about a triangle
    /// per error-sized cell where nothing is left near them, and every
    /// collapsed level compared with clustering by error x
    /// sqrt(triangles). Serves parts of many small pieces (bolts on a
    /// casing), which a kept triangle each would hold at the pieces'
    /// size: a real gearbox's 7.7k-triangle leaves had every level at
    /// 0.20 m, covered 185 triangles at 0.07 m.
    Cover,
}

/// A leaf's chain of one kind, `queries` answering for `mesh`.
pub fn leaf_chain(
    mesh: &WorkMesh,
    queries: &mut Nearest,
    diagonal: f64,
    kind: LeafChain,
    p: &ChainParams,
    tally: &Tally,
) -> Vec<Lod> {
    let mut lods = vec![Lod {
        mesh: mesh.clone(),
        error: 0.0,
    }];
    let reference = Reference {
        mesh,
        queries,
        base: 0.0,
        sampling: p.sampling(diagonal),
        diagonal: diagonal as f32,
        first_budget: usize::MAX,
        keep_pieces: kind == LeafChain::KeepPieces,
    };
    extend_chain(&mut lods, reference, p, tally);
    lods
}

/// What drawing a chain costs over the tolerances it may be drawn at:
/// the triangles of its coarsest level within each of [`COST_TOLERANCES`]
/// tolerances, halving from `diagonal`, summed with equal weights. Each
/// halving of the tolerance is a doubling of the distance, so this is
/// the triangles a walk draws of the leaf from every distance band
/// (weighting far bands by how many leaves they hold, as an open floor
/// would, chose chains that drew 4.9% more on the generated plant:
/// parents take over the far bands).
pub fn draw_cost(lods: &[Lod], diagonal: f64) -> u64 {
    let mut tolerance = diagonal;
    let mut cost = 0u64;
    for _ in 0..COST_TOLERANCES {
        let k = lods
            .iter()
            .rposition(|l| l.error as f64 <= tolerance)
            .unwrap_or(0);
        cost += lods.get(k).map_or(0, |l| l.mesh.triangles() as u64);
        tolerance *= 0.5;
    }
    cost
}

/// Tolerances [`draw_cost`] sums over: from the leaf's diagonal down to
/// 1/32768 of it, finer than the sample floor.
const COST_TOLERANCES: usize = 16;

/// An inner node's HLOD chain (GigaWalk Section 4.3), re-expressed
/// relative to `origin`. `children` are the children's chains (finest
/// first, errors non-decreasing; a chain may have lost levels too fine for
/// any parent). Each child contributes the coarsest of its levels whose
/// error is within a threshold common to all children, the smallest
/// threshold whose merged triangles fit [`ChainParams::merge_budget`], so
/// the children are cut at a matching error. The union is the chain's
/// level 0 (stored only within [`ChainParams::node_budget`]); the levels
/// below it are made as a leaf's are, the first within the budget. Each
/// level's error is its measured distance to `original` (the full detail
/// below the node) when given, else the largest error of the picked child
/// levels plus its measured distance to the union (by the triangle
/// inequality, a bound on its distance to the original); never below any
/// picked child's.
pub fn inner_lods(
    children: &[&[Lod]],
    original: Option<&WorkMesh>,
    origin: DVec3,
    diagonal: f64,
    p: &ChainParams,
    tally: &Tally,
) -> Vec<Lod> {
    let picked = pick_levels(children, p.merge_budget());
    let parts: Vec<&Lod> = children
        .iter()
        .zip(&picked)
        .filter_map(|(c, &k)| c.get(k))
        .collect();
    let meshes: Vec<&WorkMesh> = parts.iter().map(|l| &l.mesh).collect();
    let merged = merge(&meshes, origin);
    let base = parts.iter().map(|l| l.error).fold(0.0f32, f32::max);
    // Measured against the full detail where the node keeps it: the
    // bound is then the distance itself, not the picked levels' errors
    // plus the distance to them, which compounds up the tree (each
    // level's own distance added onto its children's).
    let (reference_mesh, reference_base) = match original {
        Some(o) => (o, 0.0),
        None => (&merged, base),
    };
    let mut queries = Nearest::new(reference_mesh.surface());
    // The union itself is level 0 of the chain the levels are made from;
    // it is kept only when it is within the budget, or when nothing
    // coarser could be made.
    let mut lods = vec![Lod {
        mesh: merged.clone(),
        error: base,
    }];
    let reference = Reference {
        mesh: reference_mesh,
        queries: &mut queries,
        base: reference_base,
        sampling: p.sampling(diagonal),
        diagonal: diagonal as f32,
        first_budget: p.node_budget,
        keep_pieces: false,
    };
    extend_chain(&mut lods, reference, p, tally);
    if p.proxies {
        let reference = ProxyReference {
            mesh: reference_mesh,
            queries: &mut queries,
            base: reference_base,
            sampling: p.sampling(diagonal),
            children,
            finest: p.proxy_cells,
        };
        lods = with_proxies(lods, reference, tally);
    }
    if lods.len() > 1 && lods[0].mesh.triangles() > p.node_budget {
        lods.remove(0);
    }
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
    let refine = |e: f32| refined(children, e);
    let first = lods
        .iter()
        .position(|l| l.mesh.triangles() < refine(l.error))
        .unwrap_or(lods.len());
    first..lods.len()
}

/// Triangles `children` draw at `error`: each its coarsest level within
/// it, or its finest.
fn refined(children: &[&[Lod]], error: f32) -> usize {
    children
        .iter()
        .map(|c| {
            let k = c.iter().rposition(|l| l.error <= error).unwrap_or(0);
            c.get(k).map_or(0, |l| l.mesh.triangles())
        })
        .sum()
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

/// The union of `meshes`, relative to `origin`.
pub fn merge(meshes: &[&WorkMesh], origin: DVec3) -> WorkMesh {
    let mut m = WorkMesh {
        origin,
        ..Default::default()
    };
    for c in meshes {
        let base = m.positions.len() as u32;
        let shift = c.origin - origin;
        m.positions.extend(c.positions.iter().map(|p| {
            (shift + glam::Vec3::from_array(*p).as_dvec3())
                .as_vec3()
                .to_array()
        }));
        m.normals.extend_from_slice(&c.normals);
        m.colours.extend_from_slice(&c.colours);
        m.indices.extend(c.indices.iter().map(|&i| base + i));
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
    use crate::test_models::grid_object;
    use gigawalk_import::Model;

    pub(super) const P: ChainParams = ChainParams {
        ratio: 0.5,
        floor: 64,
        collapse_levels: 1,
        leaf_best: false,
        gaps: false,
        proxies: false,
        proxy_cells: 128,
        node_budget: 256,
        bound_spacing: 0.25,
        bound_floor: 1e-3,
    };

    pub(super) fn mesh_of(o: gigawalk_import::Object) -> WorkMesh {
        let m = Model {
            objects: vec![o],
            ..Default::default()
        };
        let (parts, _) = initial_parts(&m).unwrap();
        leaf_mesh(&m, &parts[0], parts[0].bounds.center()).unwrap()
    }

    #[test]
    fn srgb_endpoints_and_midpoint() {
        assert_eq!(srgb8([0.0, 1.0, 0.5, 0.5]), [0, 255, 188, 128]);
        assert_eq!(srgb8([f32::NAN, -1.0, 2.0, 1.0]), [0, 0, 255, 255]);
    }

    #[test]
    fn inner_hlod_error_is_at_least_every_picked_child_level() {
        let a = leaf_lods(
            mesh_of(grid_object(DVec3::ZERO, 10.0, 32, 0.2)),
            15.0,
            &P,
            &Tally::default(),
        );
        let b = leaf_lods(
            mesh_of(grid_object(DVec3::new(12.0, 0.0, 0.0), 10.0, 32, 0.5)),
            15.0,
            &P,
            &Tally::default(),
        );
        let children = [a.as_slice(), b.as_slice()];
        let origin = DVec3::new(11.0, 0.0, 5.0);
        let picked = pick_levels(&children, P.merge_budget());
        let lods = inner_lods(&children, None, origin, 30.0, &P, &Tally::default());
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

    /// 400 cubes of 0.4 a gap of 0.1 apart on a 10-unit square: 4,800
    /// triangles of disjoint parts, which edge collapse cannot join.
    pub(super) fn cubes() -> WorkMesh {
        let mut all = crate::test_models::box_object(DVec3::ZERO, DVec3::splat(0.4));
        for i in 1..400 {
            let lo = DVec3::new(0.5 * (i % 20) as f64, 0.0, 0.5 * (i / 20) as f64);
            let b = crate::test_models::box_object(lo, lo + DVec3::splat(0.4));
            let base = all.positions.len() as u32;
            all.positions.extend(b.positions);
            all.normals.extend(b.normals);
            all.indices.extend(b.indices.iter().map(|i| i + base));
        }
        mesh_of(all)
    }

    /// Triangles of the coarsest level within `tolerance` (the finest when
    /// none is), as traversal draws a leaf.
    fn drawn(lods: &[Lod], tolerance: f64) -> usize {
        let k = lods
            .iter()
            .rposition(|l| l.error as f64 <= tolerance)
            .unwrap_or(0);
        lods[k].mesh.triangles()
    }

    #[test]
    fn proxies_join_a_chain_only_where_it_then_draws_less() {
        let mesh = cubes();
        let diagonal = 14.2;
        let chain = leaf_lods(mesh.clone(), diagonal, &P, &Tally::default());
        let tally = Tally::default();
        let with = ChainParams { proxies: true, ..P };
        let lods = leaf_lods(mesh, diagonal, &with, &tally);
        let c = tally.snapshot();
        assert!(c.proxies_kept > 0 && c.proxies >= c.proxies_kept, "{c:?}");
        assert_eq!(lods[0], chain[0]);
        for w in lods.windows(2) {
            assert!(w[1].error >= w[0].error);
            assert!(w[1].mesh.triangles() < w[0].mesh.triangles());
        }
        // Never more at any tolerance, and fewer at some.
        let mut fewer = 0;
        for k in 0..24 {
            let tolerance = diagonal * 0.5f64.powi(k);
            let (a, b) = (drawn(&lods, tolerance), drawn(&chain, tolerance));
            assert!(a <= b, "{tolerance}: {a} against {b}");
            fewer += usize::from(a < b);
        }
        assert!(fewer > 0);
    }

    #[test]
    fn small_references_get_no_proxies() {
        let mesh = mesh_of(grid_object(DVec3::ZERO, 1.0, 8, 0.1));
        assert!(mesh.triangles() < PROXY_MIN_TRIANGLES);
        let tally = Tally::default();
        let with = ChainParams { proxies: true, ..P };
        let lods = leaf_lods(mesh.clone(), 1.5, &with, &tally);
        assert_eq!(tally.snapshot().proxies, 0);
        assert_eq!(lods, leaf_lods(mesh, 1.5, &P, &Tally::default()));
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
