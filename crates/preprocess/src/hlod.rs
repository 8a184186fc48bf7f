//! LODs and HLODs (GigaWalk Section 4.3), simplified with meshoptimizer,
//! with measured errors.
//!
//! A leaf gets a chain of static LODs of its own geometry; an inner node
//! a chain of HLODs made from the union of its children's levels, cut at
//! a matching error so the union holds about twice the node's triangle
//! budget. Both chains are made the same way ([`extend_chain`]): each
//! level is the first simplification of the previous one, at doubling
//! error limits, that keeps at most 65% of its triangles, and never far
//! below the level's target. Edge collapse (which prunes small pieces)
//! and vertex clustering (which joins disjoint pieces, as the paper's
//! GAPS does) are both tried where the pieces are many, and the lower
//! error per triangle kept; pieces that vanished where nothing is left
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

use gigawalk_import::Object;
use gigawalk_scene::{Colours, LodMesh};
use glam::DVec3;
use meshopt::{SimplifyOptions, VertexDataAdapter};
use rustc_hash::FxHashMap;

use crate::hausdorff::{self, Nearest, Sampling, Surface};
use crate::parts::Part;
use crate::source::{Source, SpillError};

use crate::params::MIN_SHRINK;

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
/// measured against the mesh. `diagonal` is the leaf box's.
pub fn leaf_lods(mesh: WorkMesh, diagonal: f64, p: &ChainParams, tally: &Tally) -> Vec<Lod> {
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
        diagonal: diagonal as f32,
        first_budget: usize::MAX,
        keep_pieces: true,
    };
    extend_chain(&mut lods, reference, p, tally);
    lods
}

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
    /// The node box's diagonal: the largest error limit tried before any.
    diagonal: f32,
    /// Most triangles of the first level made (an inner node's budget).
    first_budget: usize,
    /// Whether every piece keeps a triangle (a leaf's few pieces), rather
    /// than vanished pieces being covered where nothing is left near them.
    keep_pieces: bool,
}

impl Reference<'_> {
    /// Whether level `m` is within `limit` of the reference, both ways
    /// ([`hausdorff::symmetric_within`]); `known`: triangles of `m`
    /// already known to be within a distance of it.
    fn within(
        &mut self,
        m: &WorkMesh,
        known: Option<&hausdorff::Known>,
        limit: f32,
    ) -> hausdorff::Within {
        hausdorff::symmetric_within(
            self.mesh.surface(),
            self.queries,
            m.surface(),
            known,
            &self.sampling,
            limit,
        )
    }
}

fn target_triangles(n: usize, p: &ChainParams) -> usize {
    ((n as f64 * p.ratio).round() as usize).clamp(1, n.saturating_sub(1).max(1))
}

/// Extends the chain down to the floor or until it stops shrinking. Each
/// next level is the first simplification of the last one, at growing
/// error limits (doubling from the sample floor), that keeps at most
/// MIN_SHRINK of its triangles, and never below `ratio` of them: so a
/// level is as fine as the shrink allows, rather than forced to a triangle
/// count whatever that costs (halving 40 small boxes moves surfaces by
/// a third of the node). Its error is `base` plus its measured distance to
/// the reference, and never below the previous level's. Edge collapse is
/// tried first for the chain's simplified levels 1..=collapse_levels
/// (level 0 is a leaf's own mesh, or an inner node's union of its
/// children's levels; the first level made keeps at most
/// `first_budget` triangles), sloppy clustering
/// otherwise or when collapse stalls even at the node's diagonal, and
/// instead of a collapsed level measured more than [`SUSPECT_OVER_LIMIT`]
/// times its limit off when clustering measures nearer.
fn extend_chain(lods: &mut Vec<Lod>, mut r: Reference<'_>, p: &ChainParams, tally: &Tally) {
    // Finite, so the doubling below ends (a diagonal beyond f32's range
    // would make it infinite).
    let cap = if r.diagonal.is_finite() {
        r.diagonal.max(f32::MIN_POSITIVE)
    } else {
        f32::MAX
    };
    let mut limit_error = r.sampling.floor.max(cap * 1e-6).max(f32::MIN_POSITIVE);
    while let Some(last) = lods.last() {
        let n = last.mesh.triangles();
        if n <= p.floor {
            break;
        }
        let mut target = target_triangles(n, p);
        if lods.len() == 1 {
            target = target.min(r.first_budget);
        }
        // The first level made keeps at most `first_budget` triangles
        // even where the limit stalls above the target (an inner node's
        // finest stored level is within the node budget).
        let budget = if lods.len() == 1 {
            r.first_budget
        } else {
            usize::MAX
        };
        let shrunk = |m: &WorkMesh| shrinks(m, n) && m.triangles() <= budget;
        // Welded and split into pieces once for every attempt below.
        let s = Simplifier::new(&last.mesh, r.keep_pieces);
        let collapse = lods.len() <= p.collapse_levels;
        // A level far below the target is a jump, not a step: the limits
        // are bisected towards the target before one is taken.
        let lower = (target as f64 * MAX_UNDERSHOOT).ceil() as usize;
        // The first shrinking simplification at doubling limits from
        // `limit_error`, and the limit that made it.
        let find = |sloppy: bool| -> Option<(WorkMesh, f32)> {
            let mut e = limit_error;
            while e <= cap {
                if let Some(m) = s.step(target, e, sloppy).filter(shrunk) {
                    if m.triangles() >= lower {
                        return Some((m, e));
                    }
                    // Edge collapse at twice a limit that stalled may
                    // prune every piece (395 triangles of an engine's
                    // bolts and covers became 1): a limit between the two
                    // that shrinks to at least `lower`, by bisection, else
                    // the smallest limit found that shrinks.
                    let (mut lo, mut hi) = (e * 0.5, e);
                    let mut best = (m, e);
                    for _ in 0..BISECTIONS {
                        let mid = 0.5 * (lo + hi);
                        match s.step(target, mid, sloppy).filter(shrunk) {
                            Some(m) => {
                                hi = mid;
                                let enough = m.triangles() >= lower;
                                best = (m, mid);
                                if enough {
                                    break;
                                }
                            }
                            None => lo = mid,
                        }
                    }
                    return Some(best);
                }
                e *= 2.0;
            }
            // Stalled within the diagonal: any error it takes.
            s.step(target, f32::MAX, sloppy)
                .filter(shrunk)
                .map(|m| (m, cap))
        };
        // The level's error will be at least the last level's: bounding
        // it tighter than that buys nothing.
        r.sampling.enough = (last.error - r.base).max(0.0);
        // The last level's triangles are within its error (less the
        // reference's own) of the reference: those the next level keeps
        // need no measuring.
        let known = hausdorff::Known::new(last.mesh.surface(), r.sampling.enough);
        let known = Some(&known);
        let measure = |r: &mut Reference<'_>, m: &WorkMesh| {
            match r.within(m, known, f32::INFINITY) {
                hausdorff::Within::Yes(e) => e,
                // Only a NaN bound is not within an infinite limit.
                _ => f32::NAN,
            }
        };
        let collapsed = if collapse { find(false) } else { None };
        let was_collapse = collapsed.is_some();
        let Some((mut mesh, mut e)) = collapsed.or_else(|| find(true)) else {
            break;
        };
        let mut measured = measure(&mut r, &mesh);
        Tally::add(&tally.measured, 1);
        // Edge collapse's quadric error can miss what it moves by far: a
        // thin tube's sides do not resist sliding its end along its axis,
        // so a 17-unit rail of radius 0.03 became half as long at a limit
        // of 0.27. When the measured distance is far above the limit,
        // clustering at the same limits is measured too and the nearer
        // level kept.
        // `measured` includes what earlier levels moved (it is measured
        // against the reference, not the previous level), so later levels
        // may be compared more often than needed: time, not a wrong choice.
        // NaN-safe: a NaN or infinite measurement is suspect too.
        // A level within the last level's error is not suspect: its error
        // will be the last level's.
        let plausible = measured.is_finite()
            && (measured <= SUSPECT_OVER_LIMIT * e || measured <= r.sampling.enough);
        // An inner node's pieces are many and disjoint (a machine's bolts,
        // covers and hoses): whether pruning them (collapse) or joining
        // them (clustering) costs less differs level by level, so both
        // are measured and the lower error per triangle kept.
        // A level below `lower` (collapse pruned nearly everything) gives
        // way to one within it.
        let undershoots = |m: &WorkMesh| m.triangles() < lower;
        if was_collapse && (!plausible || !r.keep_pieces || undershoots(&mesh)) {
            if let Some((alt, e_alt)) = find(true) {
                Tally::add(&tally.rivals, 1);
                if let Some(alt_measured) =
                    rival(&mut r, (&mesh, measured), &alt, (lower, known), tally)
                {
                    Tally::add(&tally.rivals_won, 1);
                    (mesh, e, measured) = (alt, e_alt, alt_measured);
                }
            }
        }
        limit_error = e.min(cap);
        if !measured.is_finite() {
            break;
        }
        let error = (r.base + measured).max(last.error);
        lods.push(Lod { mesh, error });
    }
}

/// Whether `alt` makes a better level than `main` (a level and its
/// measured error) and, when it does, its measured error. The better
/// level does not undershoot (fewer than `lower` triangles) where the
/// other does, else has the lower error per triangle: the error itself
/// for a leaf (its pieces all stay), the error x sqrt(triangles) for an
/// inner node (a level of half the triangles may move surfaces 1.41x as
/// far). `alt` is measured only as far as it takes to know: a losing
/// rival stops at the first point found beyond the winning error, so
/// the choice, and every stored error, is what measuring both in full
/// would give.
fn rival(
    r: &mut Reference<'_>,
    (main, measured): (&WorkMesh, f32),
    alt: &WorkMesh,
    (lower, known): (usize, Option<&hausdorff::Known>),
    tally: &Tally,
) -> Option<f32> {
    let (u_main, u_alt) = (main.triangles() < lower, alt.triangles() < lower);
    let keep_pieces = r.keep_pieces;
    let per_triangle = |e: f32, m: &WorkMesh| {
        if keep_pieces {
            e as f64
        } else {
            e as f64 * (m.triangles() as f64).sqrt()
        }
    };
    let limit = if !measured.is_finite() || (u_main && !u_alt) {
        // Whatever it measures, `alt` wins.
        f32::INFINITY
    } else if u_alt && !u_main {
        return None;
    } else {
        // `alt` wins below this; one ulp above it, so that a bound past
        // the limit loses for certain whatever the f64 rounding.
        let t = if keep_pieces {
            measured as f64
        } else {
            measured as f64 * (main.triangles() as f64 / alt.triangles() as f64).sqrt()
        };
        (t as f32).next_up()
    };
    match r.within(alt, known, limit) {
        hausdorff::Within::Yes(e) => {
            let wins = !measured.is_finite()
                || (u_main && !u_alt)
                || per_triangle(e, alt) < per_triangle(measured, main);
            wins.then_some(e)
        }
        _ if limit == f32::INFINITY => {
            // A NaN measurement: taken as the old code took it, in place
            // of a level that was not finite either.
            Some(f32::NAN)
        }
        _ => {
            Tally::add(&tally.rivals_stopped, 1);
            None
        }
    }
}

/// Counts of the certifier's work over a run, shared by the threads
/// building levels (`--stats`).
#[derive(Debug, Default)]
pub struct Tally {
    /// Levels measured in full.
    pub measured: std::sync::atomic::AtomicU64,
    /// Rival levels (clustering beside edge collapse) compared.
    pub rivals: std::sync::atomic::AtomicU64,
    /// Rivals that won.
    pub rivals_won: std::sync::atomic::AtomicU64,
    /// Rivals whose measurement stopped as soon as they had lost.
    pub rivals_stopped: std::sync::atomic::AtomicU64,
}

impl Tally {
    fn add(counter: &std::sync::atomic::AtomicU64, n: u64) {
        counter.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
    }

    /// The counts as plain numbers.
    pub fn snapshot(&self) -> crate::stats::Certification {
        let get = |c: &std::sync::atomic::AtomicU64| c.load(std::sync::atomic::Ordering::Relaxed);
        crate::stats::Certification {
            levels_measured: get(&self.measured),
            rivals: get(&self.rivals),
            rivals_won: get(&self.rivals_won),
            rivals_stopped: get(&self.rivals_stopped),
        }
    }
}

/// A collapsed level measured farther from its reference than this many
/// times the simplifier's error limit is compared with clustering.
const SUSPECT_OVER_LIMIT: f32 = 4.0;

/// A level with fewer than this fraction of its target's triangles is
/// searched for at a finer limit ([`BISECTIONS`] tries).
const MAX_UNDERSHOOT: f64 = 0.25;
const BISECTIONS: usize = 8;

/// Whether `m` is a level worth making from one of `n` triangles: not
/// empty, and at most MIN_SHRINK of them.
fn shrinks(m: &WorkMesh, n: usize) -> bool {
    m.triangles() > 0 && m.triangles() <= (MIN_SHRINK * n as f64) as usize
}

/// One mesh prepared for simplification steps: vertices that share a
/// position are welded (normal or colour seams would otherwise block the
/// simplifier; the output keeps one of the welded vertices' attributes),
/// and its connected pieces found, once for however many steps are tried.
struct Simplifier<'a> {
    mesh: &'a WorkMesh,
    welded: Vec<u32>,
    /// Per vertex, the root of its connected piece (over `welded`).
    piece: Vec<u32>,
    /// A leaf's few pieces each keep a triangle ([`Simplifier::keep_every_piece`]);
    /// an inner node's thousands are covered ([`Simplifier::cover_vanished`]).
    keep_pieces: bool,
}

impl<'a> Simplifier<'a> {
    fn new(mesh: &'a WorkMesh, keep_pieces: bool) -> Self {
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
    fn step(&self, target: usize, max_error: f32, sloppy: bool) -> Option<WorkMesh> {
        if self.welded.is_empty() {
            return None;
        }
        let adapter = Self::adapter(self.mesh)?;
        let welded = &self.welded;
        let mut result_error = 0.0f32;
        let indices = if sloppy {
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
        let indices = if self.keep_pieces {
            self.keep_every_piece(indices)
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
            self.cover_vanished(indices, cell)
        };
        if indices.is_empty() {
            return None;
        }
        Some(compact(self.mesh, &indices))
    }

    /// Per triangle of the welded mesh: its piece when no triangle of
    /// `simplified` uses any vertex of that piece, `None` when the piece
    /// survives.
    fn vanished_pieces(&self, simplified: &[u32]) -> Vec<Option<u32>> {
        let mut survives = vec![false; self.piece.len()];
        for &v in simplified {
            survives[self.piece[v as usize] as usize] = true;
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
    fn cover_vanished(&self, mut simplified: Vec<u32>, cell: f32) -> Vec<u32> {
        let vanished = self.vanished_pieces(&simplified);
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
    fn keep_every_piece(&self, mut simplified: Vec<u32>) -> Vec<u32> {
        let vanished = self.vanished_pieces(&simplified);
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
    use crate::test_models::{box_object, grid_object, pipe_object};
    use gigawalk_import::Model;

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
        leaf_mesh(&m, &parts[0], parts[0].bounds.center()).unwrap()
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
        let lods = leaf_lods(mesh, 15.0, &P, &Tally::default());
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
        let lods = leaf_lods(mesh_of(all), 25.0, &P, &Tally::default());
        assert!(lods.len() >= 2);
        assert!(lods.last().unwrap().mesh.triangles() < lods[0].mesh.triangles() / 2);
    }

    #[test]
    fn a_level_that_shortens_thin_tubes_gives_way_to_clustering() {
        // Edge collapse's quadric error barely sees a thin tube's end
        // sliding along its axis: on this ladder from the generated plant
        // the first level that kept at most 65% of the triangles (at an
        // error limit of 0.27) had halved both rails, measured 8.95 units
        // off in a 17-unit leaf. Clustering at the same limits keeps them.
        let model = gigawalk_import::import_obj_str(
            include_str!("../testdata/ladder_leaf.obj"),
            "ladder_leaf.obj",
        )
        .unwrap();
        let mesh = mesh_of(model.objects.into_iter().next().unwrap());
        assert_eq!(mesh.triangles(), 888);
        // The leaf's box (0.5 x 17 x 0.5).
        let diagonal = 17.02;
        let lods = leaf_lods(mesh, diagonal, &P, &Tally::default());
        assert!(lods.len() >= 3, "{} levels", lods.len());
        // Far below the 8.95 of the halved rails; the levels found are
        // within 0.1 (a rung's length is 0.44).
        assert!(
            lods[1].error < 1.0,
            "level 1: {} triangles at error {}",
            lods[1].mesh.triangles(),
            lods[1].error
        );
    }

    /// Pieces of `m`, counting vertices with equal positions as one.
    fn pieces(m: &WorkMesh) -> usize {
        let s = Simplifier::new(m, true);
        let mut roots: Vec<u32> = s.welded.iter().map(|&v| s.piece[v as usize]).collect();
        roots.sort_unstable();
        roots.dedup();
        roots.len()
    }

    #[test]
    fn leaf_levels_keep_every_piece_and_grow_error_gently() {
        // 40 small boxes spread over a 20-unit row, plus a dense plate:
        // halving the triangles would have to drop boxes (each is 12
        // triangles, a tetrahedron at least), moving surface by up to the
        // gap between boxes.
        let mut all = grid_object(DVec3::ZERO, 20.0, 24, 0.2);
        for i in 0..40 {
            let lo = DVec3::new(0.5 * i as f64, 3.0 + (i % 3) as f64, 0.0);
            let b = box_object(lo, lo + DVec3::splat(0.1));
            let base = all.positions.len() as u32;
            all.positions.extend(b.positions);
            all.normals.extend(b.normals);
            all.indices.extend(b.indices.iter().map(|i| i + base));
        }
        let mesh = mesh_of(all);
        let n = pieces(&mesh);
        assert_eq!(n, 41);
        let lods = leaf_lods(mesh, 21.0, &P, &Tally::default());
        assert!(lods.len() >= 3, "{} levels", lods.len());
        for l in &lods {
            assert_eq!(pieces(&l.mesh), n, "a level lost a piece");
        }
        // The first level only smooths the plate's bumps, far below the
        // gaps between boxes and rows (0.4 and 1 unit).
        assert!(lods[1].error < 0.3, "level 1 error {}", lods[1].error);
    }

    #[test]
    fn chains_end_for_extreme_diagonals() {
        // The error limits double up to the diagonal: an infinite one must
        // still end, a zero one must still simplify.
        for diagonal in [f64::INFINITY, 0.0, 1e-30, 1e30] {
            let lods = leaf_lods(
                mesh_of(grid_object(DVec3::ZERO, 10.0, 16, 0.3)),
                diagonal,
                &P,
                &Tally::default(),
            );
            assert_eq!(lods[0].error, 0.0, "diagonal {diagonal}");
            for w in lods.windows(2) {
                assert!(w[1].error >= w[0].error, "diagonal {diagonal}");
                assert!(w[1].mesh.triangles() < w[0].mesh.triangles());
            }
        }
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
        let out = s.cover_vanished(kept.clone(), 0.5);
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

    #[test]
    fn uniform_colour_is_detected() {
        let m = mesh_of(grid_object(DVec3::ZERO, 1.0, 4, 0.0));
        assert!(matches!(m.to_lod_mesh().colours, Colours::Uniform(_)));
        let mut m2 = m.clone();
        m2.colours[0] = [1, 2, 3, 4];
        assert!(matches!(m2.to_lod_mesh().colours, Colours::PerVertex(_)));
    }
}
