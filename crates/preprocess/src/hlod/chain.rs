//! Extending a chain one level at a time, each level certified: the
//! first simplification of the last level, at doubling error limits, that
//! shrinks it enough without falling far below its target; its distance
//! to the reference measured ([`crate::hausdorff`]); where it measured
//! far off its limit, a gentler collapse, kept when it measures nearer;
//! and where edge collapse made it, clustering as a rival, kept when its
//! error per triangle is lower. [`Tally`] counts the certifier's work.

use crate::hausdorff::{self, Nearest, Sampling};
use crate::params::MIN_SHRINK;

use super::simplify::{Simplifier, Step};
use super::{ChainParams, Lod, WorkMesh};

/// What a chain's levels are measured against.
pub(super) struct Reference<'a> {
    pub(super) mesh: &'a WorkMesh,
    pub(super) queries: &'a mut Nearest,
    /// Error of the reference itself against the original.
    pub(super) base: f32,
    pub(super) sampling: Sampling,
    /// The node box's diagonal: the largest error limit tried before any.
    pub(super) diagonal: f32,
    /// Most triangles of the first level made (an inner node's budget).
    pub(super) first_budget: usize,
    /// Whether every piece keeps a triangle and collapsed levels meet
    /// clustering only when suspect, by error alone (a leaf's kept-pieces
    /// chain), rather than vanished pieces being covered where nothing is
    /// left near them and every collapsed level compared with clustering
    /// by error x sqrt(triangles) (an inner node's chain, and a leaf's
    /// covering one).
    pub(super) keep_pieces: bool,
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
/// otherwise or when collapse stalls even at the node's diagonal. A
/// level measured more than [`SUSPECT_OVER_LIMIT`] times its limit off
/// gives way to a gentler collapse (to MIN_SHRINK of the triangles) that
/// measures nearer, and a collapsed one so far off to clustering when
/// that measures nearer.
pub(super) fn extend_chain(
    lods: &mut Vec<Lod>,
    mut r: Reference<'_>,
    p: &ChainParams,
    tally: &Tally,
) {
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
        let find = |how: Step| -> Option<(WorkMesh, f32)> {
            let mut e = limit_error;
            while e <= cap {
                if let Some(m) = s.step(target, e, how).filter(shrunk) {
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
                        match s.step(target, mid, how).filter(shrunk) {
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
            s.step(target, f32::MAX, how)
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
        let collapsed = if collapse { find(Step::Collapse) } else { None };
        let was_collapse = collapsed.is_some();
        let Some((mut mesh, mut e)) = collapsed.or_else(|| find(Step::Sloppy)) else {
            break;
        };
        let mut measured = measure(&mut r, &mesh);
        Tally::add(&tally.measured, 1);
        // A step to `ratio` of the triangles can take an edge whose
        // collapse moves far more than the simplifier's error says (see
        // below); on real CAD that left a machine's chain at 0.50 from
        // 3,756 triangles down (its limit was 0.035). The same collapse
        // asked for less, MIN_SHRINK of the triangles, often stops before
        // that edge: tried at doubling limits from the last level's, the
        // first that shrinks is measured and kept when it is nearer (that
        // chain then fell to 713 triangles at 0.10). NaN-safe: a NaN
        // measurement is retried, and kept only against a finite one.
        let near_enough = measured <= SUSPECT_OVER_LIMIT * e.max(r.sampling.enough);
        if !near_enough {
            let gentle = (MIN_SHRINK * n as f64) as usize;
            let mut limit = limit_error;
            while limit <= cap {
                if let Some(m) = s.step(gentle, limit, Step::Collapse).filter(shrunk) {
                    Tally::add(&tally.gentler, 1);
                    // Measured only as far as it takes to know it loses
                    // (a `Yes` carries the full measurement's figure).
                    let beat = if measured.is_finite() {
                        measured
                    } else {
                        f32::INFINITY
                    };
                    if let hausdorff::Within::Yes(m_measured) = r.within(&m, known, beat) {
                        if m_measured < measured || (measured.is_nan() && !m_measured.is_nan()) {
                            Tally::add(&tally.gentler_won, 1);
                            (mesh, e, measured) = (m, limit, m_measured);
                        }
                    }
                    break;
                }
                limit *= 2.0;
            }
        }
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
            if let Some((alt, e_alt)) = find(Step::Sloppy) {
                Tally::add(&tally.rivals, 1);
                if let Some(alt_measured) =
                    rival(&mut r, (&mesh, measured), &alt, (lower, known), tally)
                {
                    Tally::add(&tally.rivals_won, 1);
                    (mesh, e, measured) = (alt, e_alt, alt_measured);
                }
            }
        }
        // Pair contraction across gaps (the paper's GAPS) joins parts and
        // closes holes at the error a level allows, where collapse keeps
        // every piece and hole and clustering needs cells far above the
        // error: a rival to whichever level won above where collapse
        // stalls: every level of an inner node's chain (and a leaf's
        // covering one), a leaf's first coarser level, and any level
        // measured far off its limit.
        let first_coarser = lods.len() == 1;
        if p.gaps && (!r.keep_pieces || first_coarser || !plausible) {
            // A contraction's cost is about how far it moved surfaces: a
            // level whose limit is above the error measured of the level
            // it would replace would lose, and is not measured.
            let hopeful = |&(_, e_alt): &(WorkMesh, f32)| {
                !measured.is_finite() || e_alt <= measured || undershoots(&mesh)
            };
            if let Some((alt, e_alt)) = find(Step::Gaps).filter(hopeful) {
                Tally::add(&tally.gaps, 1);
                if let Some(alt_measured) =
                    rival(&mut r, (&mesh, measured), &alt, (lower, known), tally)
                {
                    Tally::add(&tally.gaps_won, 1);
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
    /// Gentler collapses tried in place of a level measured far off.
    pub gentler: std::sync::atomic::AtomicU64,
    /// Gentler collapses that measured nearer and were kept.
    pub gentler_won: std::sync::atomic::AtomicU64,
    /// Leaves whose covering chain was kept (it draws less).
    pub cover_chosen: std::sync::atomic::AtomicU64,
    /// Pair-contraction levels (GAPS) made and compared.
    pub gaps: std::sync::atomic::AtomicU64,
    /// Pair-contraction levels that won.
    pub gaps_won: std::sync::atomic::AtomicU64,
    /// Merged proxies made and measured.
    pub proxies: std::sync::atomic::AtomicU64,
    /// Proxies that beat every level of at most their triangles.
    pub proxies_kept: std::sync::atomic::AtomicU64,
}

impl Tally {
    fn add(counter: &std::sync::atomic::AtomicU64, n: u64) {
        counter.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
    }

    pub(super) fn add_cover_chosen(&self) {
        Self::add(&self.cover_chosen, 1);
    }

    pub(super) fn add_proxy(&self) {
        Self::add(&self.proxies, 1);
    }

    pub(super) fn add_proxy_kept(&self) {
        Self::add(&self.proxies_kept, 1);
    }

    /// The counts as plain numbers.
    pub fn snapshot(&self) -> crate::stats::Certification {
        let get = |c: &std::sync::atomic::AtomicU64| c.load(std::sync::atomic::Ordering::Relaxed);
        crate::stats::Certification {
            levels_measured: get(&self.measured),
            rivals: get(&self.rivals),
            rivals_won: get(&self.rivals_won),
            rivals_stopped: get(&self.rivals_stopped),
            gentler: get(&self.gentler),
            gentler_won: get(&self.gentler_won),
            leaf_cover_chosen: get(&self.cover_chosen),
            gaps: get(&self.gaps),
            gaps_won: get(&self.gaps_won),
            proxies: get(&self.proxies),
            proxies_kept: get(&self.proxies_kept),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hlod::simplify::tests::pieces;
    use crate::hlod::tests::{mesh_of, P};
    use crate::hlod::{draw_cost, leaf_chain, leaf_lods, LeafChain};
    use crate::test_models::{box_object, grid_object, pipe_object};
    use glam::DVec3;

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

    /// A leaf's mesh from the one object of an OBJ file.
    fn obj_leaf(text: &str) -> WorkMesh {
        let model = gigawalk_import::import_obj_str(text, "leaf.obj").unwrap();
        mesh_of(model.objects.into_iter().next().unwrap())
    }

    #[test]
    fn a_level_that_shortens_thin_tubes_gives_way_to_clustering() {
        // Edge collapse's quadric error barely sees a thin tube's end
        // sliding along its axis: on this ladder from the generated plant
        // the first level that kept at most 65% of the triangles (at an
        // error limit of 0.27) had halved both rails, measured 8.95 units
        // off in a 17-unit leaf. Clustering at the same limits keeps them.
        let mesh = obj_leaf(include_str!("../../testdata/ladder_leaf.obj"));
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

    #[test]
    fn a_level_far_off_its_limit_gives_way_to_a_gentler_collapse() {
        // A leaf of the generated demo plant whose first halving measured
        // 0.74 units off (and every level after it as far): edge collapse
        // to 65% of the triangles measures 0.03, and is kept.
        let mesh = obj_leaf(include_str!("../../testdata/gentler_leaf.obj"));
        assert_eq!(mesh.triangles(), 608);
        // The leaf's box (a 608-triangle leaf of the 4M plant, seed 1).
        let diagonal = 29.71;
        let tally = Tally::default();
        let lods = leaf_lods(mesh, diagonal, &P, &tally);
        let c = tally.snapshot();
        assert!(c.gentler_won >= 1, "{c:?}");
        assert!(c.gentler >= c.gentler_won);
        // Halving moved a surface 0.74 units (2.5% of the leaf's box);
        // the level kept is within a tenth of that.
        assert!(
            lods[1].error < 0.074,
            "level 1: {} triangles at error {}",
            lods[1].mesh.triangles(),
            lods[1].error
        );
        for w in lods.windows(2) {
            assert!(w[1].error >= w[0].error);
            assert!(w[1].mesh.triangles() as f64 <= MIN_SHRINK * w[0].mesh.triangles() as f64);
        }
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
        let mut queries = Nearest::new(mesh.surface());
        let lods = leaf_chain(
            &mesh,
            &mut queries,
            21.0,
            LeafChain::KeepPieces,
            &P,
            &Tally::default(),
        );
        assert!(lods.len() >= 3, "{} levels", lods.len());
        for l in &lods {
            assert_eq!(pieces(&l.mesh), n, "a level lost a piece");
        }
        // The first level only smooths the plate's bumps, far below the
        // gaps between boxes and rows (0.4 and 1 unit).
        assert!(lods[1].error < 0.3, "level 1 error {}", lods[1].error);
    }

    /// Both kinds of a leaf's chain, and what `leaf_lods` kept.
    fn both_chains(mesh: WorkMesh, diagonal: f64) -> [Vec<Lod>; 3] {
        let mut queries = Nearest::new(mesh.surface());
        let tally = Tally::default();
        let best = ChainParams {
            leaf_best: true,
            ..P
        };
        let mut chain = |kind| leaf_chain(&mesh, &mut queries, diagonal, kind, &best, &tally);
        let (kept, covered) = (chain(LeafChain::KeepPieces), chain(LeafChain::Cover));
        let chosen = leaf_lods(mesh.clone(), diagonal, &best, &tally);
        // Without `leaf_best`, the kept-pieces chain alone.
        assert_eq!(leaf_lods(mesh, diagonal, &P, &tally), kept);
        [kept, covered, chosen]
    }

    #[test]
    fn a_leaf_of_many_small_pieces_keeps_the_chain_that_covers_them() {
        // 400 bolt heads on a plate: a kept triangle each holds every
        // level of the kept-pieces chain at 400 triangles or more; covered
        // where the plate is near, they cost the coarse levels nothing.
        let mut all = grid_object(DVec3::ZERO, 10.0, 20, 0.0);
        for i in 0..400 {
            let lo = DVec3::new(
                0.25 + 0.5 * (i % 20) as f64,
                0.0,
                0.25 + 0.5 * (i / 20) as f64,
            );
            let b = box_object(lo, lo + DVec3::splat(0.08));
            let base = all.positions.len() as u32;
            all.positions.extend(b.positions);
            all.normals.extend(b.normals);
            all.indices.extend(b.indices.iter().map(|i| i + base));
        }
        let diagonal = 14.2;
        let [kept, covered, chosen] = both_chains(mesh_of(all), diagonal);
        let cost = |c: &[Lod]| draw_cost(c, diagonal);
        assert!(
            kept.last().unwrap().mesh.triangles() >= 400,
            "{} triangles",
            kept.last().unwrap().mesh.triangles()
        );
        assert!(
            cost(&covered) < cost(&kept),
            "{} {}",
            cost(&covered),
            cost(&kept)
        );
        assert_eq!(chosen, covered);
        for w in chosen.windows(2) {
            assert!(w[1].error >= w[0].error);
        }
    }

    #[test]
    fn a_leaf_keeps_the_chain_that_draws_less_and_the_kept_pieces_on_a_tie() {
        for (mesh, diagonal) in [
            (mesh_of(grid_object(DVec3::ZERO, 10.0, 32, 0.3)), 15.0),
            (
                obj_leaf(include_str!("../../testdata/gentler_leaf.obj")),
                29.71,
            ),
            (
                obj_leaf(include_str!("../../testdata/ladder_leaf.obj")),
                17.02,
            ),
        ] {
            let [kept, covered, chosen] = both_chains(mesh, diagonal);
            let cost = |c: &[Lod]| draw_cost(c, diagonal);
            let best = if cost(&covered) < cost(&kept) {
                covered
            } else {
                kept
            };
            assert_eq!(chosen, best);
        }
    }

    #[test]
    fn draw_cost_counts_the_coarsest_level_within_each_halving_tolerance() {
        let level = |n: u32, error: f32| Lod {
            mesh: mesh_of(grid_object(DVec3::ZERO, 1.0, n, 0.0)),
            error,
        };
        // Grids of n x n cells: 32, 8 and 2 triangles.
        let chain = [level(4, 0.0), level(2, 0.3), level(1, 3.0)];
        // Tolerances 8, 4, 2, 1, 0.5, 0.25, ...: the coarsest level at
        // 8 and 4 (2 triangles), level 1 at 2 down to 0.5 (8), full
        // detail below 0.3 (32) for the 11 tolerances left.
        assert_eq!(draw_cost(&chain, 8.0), 2 * 2 + 3 * 8 + 11 * 32);
        assert_eq!(draw_cost(&[], 8.0), 0);
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
}
