//! Measured LOD errors: an upper bound on the Hausdorff distance between two
//! triangle surfaces, from points sampled on them and a nearest-triangle
//! query through a BVH (obvhs).
//!
//! A simplifier's own error figure is an estimate (meshopt: a quadric
//! distance, or a grid cell for sloppy clustering), not a bound: a thin
//! sheet collapses to nothing with the error of its thickness. What the
//! runtime's pixel tolerance needs is a bound on how far a LOD's surface is
//! from the surface it stands for, both ways: no original point farther
//! from the LOD than the error (nothing vanished), no LOD point farther
//! from the original (nothing appeared).
//!
//! The bound. Every point p of a triangle T of surface A lies within
//! `cover(T)` of one of the samples s taken on T, and the distance to B is
//! 1-Lipschitz, so d(p, B) <= d(s, B) + cover(T). Hence
//! H(A -> B) <= max over samples of d(s, B) + max over triangles of
//! cover(T). Samples are the vertices, plus, for a triangle whose vertices
//! alone cover it too coarsely, the midpoints of a recursive longest-edge
//! bisection. Any point of a triangle with longest edge L lies within
//! L / sqrt(3) of one of its vertices (at most the circumradius,
//! L / (2 sin C) with C >= 60 degrees the angle opposite L, for a
//! non-obtuse triangle; at most L / 2 for an obtuse one), so a triangle's
//! cover is the largest L / sqrt(3) of its pieces.
//!
//! A second bound needs no cover: the distance to one triangle t of B is
//! convex, so over a triangle it is largest at a corner, and T is within
//! max over corners of d(corner, t) of B. Where B's triangle nearest a
//! corner spans T (the sides of a pipe and of its simplified pipe, a
//! plane re-triangulated), this certifies T without any sample inside it.
//!
//! Bisection is adaptive: with M the largest distance measured so far, a
//! piece is split only while both its bounds exceed (1 + spacing) M + floor (`spacing` a relative
//! sampling density, `floor` an absolute length: an exactly kept surface
//! has M = 0 and would otherwise need infinitely many samples), and never
//! past [`MAX_SPLITS`] midpoints (a huge triangle then keeps a larger
//! bound, which the result includes). So the bound is at most about
//! (1 + spacing) x the true distance, plus the floor. Triangles B holds
//! exactly are at distance 0 and need no samples.
//!
//! Whole clusters first: a BVH node of `A` whose box (centre c,
//! half-diagonal r) has d(c, B) + r within the goal is bounded by that
//! without visiting its triangles, since every point of the box is within
//! r of c. Coarse levels, and fine levels away from what changed, settle
//! most of `A` this way with a query per cluster.
//!
//! Queries run in f32 on positions relative to a nearby origin; the bound
//! adds [`ROUNDING`] x the surfaces' extent for the arithmetic's rounding.

use glam::{DVec3, Vec3A};
use obvhs::{
    aabb::Aabb as BvhAabb,
    bvh2::{builder::build_bvh2, Bvh2},
    BvhBuildParams,
};
use rustc_hash::FxHashSet;

use crate::planar::Planar;

/// Most midpoints measured on one triangle; past them the remaining
/// pieces' own cover counts (a larger, still honest bound).
pub const MAX_SPLITS: u32 = 4096;

/// Every this many indices, a vertex is measured before all the others.
const PRE_PASS_STRIDE: usize = 97;

/// Relative slack for f32 rounding in the closest-point arithmetic (about
/// 10 ulps of the largest coordinate).
pub const ROUNDING: f32 = 1e-6;

/// How densely surfaces are sampled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sampling {
    /// Cover of a triangle's samples, as a fraction of the largest vertex
    /// distance found (the bound exceeds the truth by at most about this
    /// fraction).
    pub spacing: f32,
    /// The finest cover aimed for, in model units.
    pub floor: f32,
    /// A bound that is good enough whatever the distance: a piece within
    /// it is settled (0: none). The caller's figure will be at least this
    /// anyway (a level's error never falls below the previous level's),
    /// so bounding a piece more tightly than this buys nothing.
    pub enough: f32,
}

impl Sampling {
    /// The bound a piece must reach to be settled, with `max` the largest
    /// distance measured so far: (1 + spacing) max + floor, or `enough`
    /// when that is larger.
    fn goal(&self, max: f32) -> f32 {
        ((1.0 + self.spacing) * max + self.floor).max(self.enough)
    }
}

/// A triangle surface: positions (relative to some origin) and indices.
#[derive(Clone, Copy, Debug)]
pub struct Surface<'a> {
    pub positions: &'a [[f32; 3]],
    pub indices: &'a [u32],
}

impl Surface<'_> {
    fn triangle(&self, t: usize) -> [Vec3A; 3] {
        let p = |k: usize| Vec3A::from_array(self.positions[self.indices[3 * t + k] as usize]);
        [p(0), p(1), p(2)]
    }

    fn triangles(&self) -> usize {
        self.indices.len() / 3
    }

    /// The largest absolute coordinate, for the rounding slack.
    fn magnitude(&self) -> f32 {
        max_abs(self.positions.iter().map(|&p| Vec3A::from_array(p)))
    }
}

/// Nearest-triangle queries on one surface.
pub struct Nearest {
    tris: Vec<[Vec3A; 3]>,
    /// Per triangle: measured in f64 ([`is_sliver`]).
    sliver: Vec<bool>,
    /// The triangles' corner keys, for exact matches.
    exact: FxHashSet<[[u32; 3]; 3]>,
    bvh: Bvh2,
    stack: Vec<u32>,
    /// The triangle that answered the last query: neighbouring samples are
    /// usually answered by it again, without a traversal.
    hint: usize,
    /// Flat regions the triangles cover exactly ([`crate::planar`]),
    /// found when first needed.
    planar: Option<Planar>,
}

impl Nearest {
    pub fn new(s: Surface<'_>) -> Self {
        crate::spent::timed(crate::spent::Kind::Bvh, || Self::build(s))
    }

    fn build(s: Surface<'_>) -> Self {
        let tris: Vec<[Vec3A; 3]> = (0..s.triangles()).map(|t| s.triangle(t)).collect();
        let boxes: Vec<BvhAabb> = tris
            .iter()
            .map(|t| BvhAabb::new(t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2])))
            .collect();
        let bvh = if boxes.is_empty() {
            Bvh2::default()
        } else {
            build_bvh2(
                &boxes,
                BvhBuildParams::fast_build(),
                &mut Default::default(),
            )
        };
        Nearest {
            exact: tris.iter().map(corner_key).collect(),
            sliver: tris.iter().map(is_sliver).collect(),
            planar: None,
            tris,
            bvh,
            stack: Vec::new(),
            hint: 0,
        }
    }

    /// An upper bound on the distance from `p` to the surface: exact when
    /// it exceeds `r` (the caller's running maximum), otherwise the
    /// distance to some triangle within `r` (infinite for an empty
    /// surface). Most samples are near a surface within `r`: the last
    /// answer's triangle, or a search that only opens boxes within `r`,
    /// settles them; the full nearest-triangle search runs only for the few
    /// that raise the maximum.
    pub fn upper(&mut self, p: Vec3A, r: f32) -> (f32, u32) {
        if self.tris.is_empty() {
            return (f32::INFINITY, u32::MAX);
        }
        let r2 = r * r;
        let mut d = self.sq(p, self.hint);
        if d > r2 {
            let found = if r2 > 0.0 {
                self.search(p, r2, true)
            } else {
                None
            };
            d = match found {
                Some(f) => f,
                None => self.search(p, d, false).unwrap_or(d),
            };
        }
        (d.sqrt(), self.hint as u32)
    }

    /// The distance from `p` to some triangle within `r` of it, `None`
    /// when there is none.
    fn within(&mut self, p: Vec3A, r: f32) -> Option<f32> {
        // NaN-safe: a NaN radius finds nothing.
        if r.is_nan() || r < 0.0 {
            return None;
        }
        let r2 = r * r;
        let d = self.sq(p, self.hint);
        if d <= r2 {
            return Some(d.sqrt());
        }
        self.search(p, r2, true).map(f32::sqrt)
    }

    /// [`Planar::bound`] on this surface's flat regions.
    fn flat(&mut self, corners: &[Vec3A; 3], near: &[u32], limit: f32) -> f64 {
        let tris = &self.tris;
        self.planar
            .get_or_insert_with(|| {
                crate::spent::timed(crate::spent::Kind::Planar, || Planar::new(tris))
            })
            .bound(corners, near, f64::from(limit))
    }

    /// Distance from `p` to triangle `t`.
    fn to(&self, p: Vec3A, t: u32) -> f32 {
        self.sq(p, t as usize).sqrt()
    }

    /// Squared distance from `p` to triangle `t`, in f64 for slivers.
    fn sq(&self, p: Vec3A, t: usize) -> f32 {
        if self.sliver[t] {
            point_triangle_sq(p, &self.tris[t])
        } else {
            point_triangle_sq32(p, self.tris[t])
        }
    }

    /// The squared distance of a triangle within `bound` (the nearest
    /// when `any` is false; the first found when it is true), `None` when
    /// none is; sets the hint to its triangle.
    fn search(&mut self, p: Vec3A, bound: f32, any: bool) -> Option<f32> {
        let nodes = &self.bvh.nodes;
        let mut best = bound;
        let mut found = None;
        self.stack.clear();
        self.stack.push(0);
        while let Some(ni) = self.stack.pop() {
            let node = &nodes[ni as usize];
            if box_sq(p, node.aabb()) > best {
                continue;
            }
            if node.is_leaf() {
                for k in node.first_index..node.first_index + node.prim_count {
                    let t = self.bvh.primitive_indices[k as usize] as usize;
                    let tri = &self.tris[t];
                    // The triangle's own box first: f32 and cheap.
                    let lo = tri[0].min(tri[1]).min(tri[2]);
                    let hi = tri[0].max(tri[1]).max(tri[2]);
                    let d = (lo - p).max(p - hi).max(Vec3A::ZERO).length_squared();
                    if d > best {
                        continue;
                    }
                    let d = self.sq(p, t);
                    if d <= best {
                        best = d;
                        found = Some(d);
                        self.hint = t;
                        if any {
                            return found;
                        }
                    }
                }
            } else {
                // Visit the nearer child first (pushed last).
                let (a, b) = (node.first_index, node.first_index + 1);
                let (da, db) = (
                    box_sq(p, nodes[a as usize].aabb()),
                    box_sq(p, nodes[b as usize].aabb()),
                );
                if da <= db {
                    self.stack.push(b);
                    self.stack.push(a);
                } else {
                    self.stack.push(a);
                    self.stack.push(b);
                }
            }
        }
        found
    }
}

/// Triangles already known to lie within a distance of the other
/// surface: those of a level that was measured against the same
/// reference, which the next level keeps unchanged (bit-identical
/// corners). A measurement bounds them by that distance without a query.
pub struct Known {
    keys: FxHashSet<[[u32; 3]; 3]>,
    within: f32,
}

impl Known {
    /// The triangles of `s`, each within `within` of the other surface.
    pub fn new(s: Surface<'_>, within: f32) -> Self {
        Known {
            keys: (0..s.triangles())
                .map(|t| corner_key(&s.triangle(t)))
                .collect(),
            within,
        }
    }

    fn bound(&self, t: &[Vec3A; 3]) -> Option<f32> {
        self.keys.contains(&corner_key(t)).then_some(self.within)
    }
}

/// A piece of a triangle being bounded: its corners, and each corner's
/// distance bound and nearest triangle of the other surface.
type Piece = ([Vec3A; 3], [(f32, u32); 3]);

/// Upper bound on the one-sided Hausdorff distance from `a` to the surface
/// `b` answers for: every point of `a` is within the result of `b`.
/// Infinite when `b` is empty and `a` is not; 0 when `a` is empty.
/// Triangles of `a` that `b` holds exactly (bit-identical corners, as a
/// simplifier's untouched triangles are) are at distance 0 and skipped.
pub fn one_sided(a: Surface<'_>, b: &mut Nearest, sampling: &Sampling) -> f32 {
    let tree = Nearest::new(a);
    one_sided_in(a, &tree.bvh, b, sampling, f32::INFINITY, None).bound
}

/// The answer to "is every point of `a` within `limit` of `b`?"
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Within {
    /// Yes: the measured bound, at most `limit` (and, as [`one_sided`]'s,
    /// within about (1 + spacing) of the true distance plus the floor).
    Yes(f32),
    /// No: a point of `a` (relative to the surfaces' origin) whose
    /// distance to `b`, measured exactly up to rounding, is above
    /// `limit` by more than the rounding slack.
    Beyond { point: Vec3A, distance: f32 },
    /// Not certified: the bound could not be brought to `limit` or
    /// below (a point's distance is within the sampling's tolerance of
    /// it), though no point was found farther than `limit`.
    Undecided,
}

/// Decides whether `a` is within `limit` of `b` (one way), stopping at the
/// first point found farther than `limit`, or as soon as the bound passes
/// it. The same measurement as [`one_sided`] otherwise: a `Yes` carries
/// the bound [`one_sided`] would return, so deciding instead of measuring
/// never changes a stored figure, only saves the rest of a measurement
/// whose answer is already known.
pub fn one_sided_within(
    a: Surface<'_>,
    b: &mut Nearest,
    sampling: &Sampling,
    limit: f32,
) -> Within {
    let tree = Nearest::new(a);
    one_sided_in(a, &tree.bvh, b, sampling, limit, None).decision(limit)
}

/// [`one_sided`] with a BVH over `a`'s triangles (primitive i = triangle
/// i), such as the one its [`Nearest`] holds.
///
/// The BVH lets a whole cluster of `a` be bounded at once: every point p
/// in a box with centre c and half-diagonal r has d(p, b) <= d(c, b) + r.
/// Where the goal is large next to a cluster (coarse levels, and most of a
/// fine level away from its changes) one query settles hundreds of
/// triangles; elsewhere the traversal reaches the triangles, bounded one
/// by one as below. Also returns how many clusters were bounded whole.
///
/// `stop` ends the measurement early: once a point of `a` is found
/// farther than it from `b`, or the bound passes it, the outcome is
/// marked stopped (its bound is then at least `stop`, not the full
/// measurement). `f32::INFINITY` measures to the end.
fn one_sided_in(
    a: Surface<'_>,
    a_bvh: &Bvh2,
    b: &mut Nearest,
    sampling: &Sampling,
    stop: f32,
    known: Option<&Known>,
) -> Outcome {
    if a.triangles() == 0 {
        return Outcome::done(0.0, 0);
    }
    if b.tris.is_empty() {
        return Outcome::done(f32::INFINITY, 0);
    }
    let slack = ROUNDING * a.magnitude().max(b.magnitude());
    // Every measurement starts from the same hint, so its figure does not
    // depend on what was measured before (or stopped early) with `b`.
    b.hint = 0;
    // A spread-out few vertices first, so the running maximum is near its
    // final value early and the goal below is not needlessly tight.
    let mut run = Run {
        at: vec![(f32::NAN, u32::MAX); a.positions.len()],
        max: 0.0,
        bound: 0.0,
        stack: Vec::new(),
        // The bound is compared with `stop` before the slack is added.
        stop: stop - slack,
        witness: None,
        stopped: false,
    };
    for t in (0..a.triangles()).step_by(PRE_PASS_STRIDE) {
        if !b.holds(&a.triangle(t)) {
            let p = Vec3A::from_array(a.positions[a.indices[3 * t] as usize]);
            let d = b.upper(p, run.max).0;
            run.measured(p, d, slack);
            if run.stopped {
                return run.outcome(slack, 0);
            }
        }
    }
    // The pre-pass points are in `a`: the bound includes them.
    run.bound = run.max;
    let mut clusters = 0;
    let complete = a_bvh.primitive_indices.len() == a.triangles() && !a_bvh.nodes.is_empty();
    if !complete {
        // Not every triangle is in the tree: bound them one by one.
        for t in 0..a.triangles() {
            run.triangle(a, t, b, sampling, slack, known);
            if run.stopped {
                break;
            }
        }
    } else {
        let mut nodes = vec![0u32];
        while let Some(ni) = nodes.pop() {
            if run.stopped {
                break;
            }
            let node = &a_bvh.nodes[ni as usize];
            let bx = node.aabb();
            let r = (bx.max - bx.min).length() * 0.5;
            let g = sampling.goal(run.max);
            if r < g {
                let c = (bx.min + bx.max) * 0.5;
                if let Some(d) = b.within(c, g - r) {
                    run.bounded(d + r);
                    clusters += 1;
                    continue;
                }
            }
            if node.is_leaf() {
                for k in node.first_index..node.first_index + node.prim_count {
                    let t = a_bvh.primitive_indices[k as usize] as usize;
                    run.triangle(a, t, b, sampling, slack, known);
                    if run.stopped {
                        break;
                    }
                }
            } else {
                nodes.push(node.first_index + 1);
                nodes.push(node.first_index);
            }
        }
    }
    run.outcome(slack, clusters)
}

/// What one [`one_sided_in`] measurement found.
#[derive(Clone, Copy, Debug)]
struct Outcome {
    /// The bound (rounding slack included); when `stopped`, only what was
    /// reached, at least the stop.
    bound: f32,
    /// Clusters of `a` bounded whole (tests check that some are).
    #[cfg_attr(not(test), allow(dead_code))]
    clusters: usize,
    /// Whether the measurement ended at its stop.
    stopped: bool,
    /// A point farther from `b` than the stop, and its distance.
    witness: Option<(Vec3A, f32)>,
}

impl Outcome {
    fn done(bound: f32, clusters: usize) -> Self {
        Outcome {
            bound,
            clusters,
            stopped: false,
            witness: None,
        }
    }

    fn decision(&self, limit: f32) -> Within {
        match (self.stopped, self.witness) {
            (false, _) if self.bound <= limit => Within::Yes(self.bound),
            (_, Some((point, distance))) => Within::Beyond { point, distance },
            _ => Within::Undecided,
        }
    }
}

/// The state of one [`one_sided`] measurement.
struct Run {
    /// Per vertex of `a`: its distance bound and nearest triangle of `b`
    /// (NaN until measured).
    at: Vec<(f32, u32)>,
    /// The largest distance measured from a point of `a`.
    max: f32,
    /// The bound so far.
    bound: f32,
    stack: Vec<Piece>,
    /// The measurement stops once the bound passes this (the caller's
    /// stop less the rounding slack).
    stop: f32,
    /// The first point found farther than the stop, with its distance.
    witness: Option<(Vec3A, f32)>,
    stopped: bool,
}

impl Run {
    fn outcome(&self, slack: f32, clusters: usize) -> Outcome {
        Outcome {
            // A stopped run's bound is at least the farthest point found.
            bound: if self.stopped {
                self.bound.max(self.max)
            } else {
                self.bound
            } + slack,
            clusters,
            stopped: self.stopped,
            witness: self.witness,
        }
    }

    /// A piece of `a` is within `bound` of `b`.
    fn bounded(&mut self, bound: f32) {
        // NaN-safe: a NaN bound is kept and poisons the result (`max`
        // alone would drop it).
        self.bound = if bound.is_nan() || self.bound.is_nan() {
            f32::NAN
        } else {
            self.bound.max(bound)
        };
        // A NaN bound stops too.
        if self.bound.is_nan() || self.bound > self.stop {
            self.stopped = true;
        }
    }

    /// Point `p` of `a` was measured `d` from `b` (exact when above the
    /// running maximum: see [`Nearest::upper`]).
    fn measured(&mut self, p: Vec3A, d: f32, slack: f32) {
        self.max = self.max.max(d);
        if self.witness.is_none() && d - slack > self.stop + slack {
            self.witness = Some((p, d));
        }
        // The bound will include `d` (the piece holding `p` is bounded by
        // at least its distance), so it has passed the stop already.
        if d.is_nan() || d > self.stop {
            self.stopped = true;
        }
    }

    /// Bounds triangle `t` of `a`, splitting it where the bound is above
    /// the goal. Two bounds of a piece hold: the distance to one triangle
    /// of `b` is convex, so its largest value over the piece is at a
    /// corner, and the piece is within max_i d(corner_i, t) of `b` for any
    /// triangle t (tried: those nearest to each corner); and the distance
    /// to `b` is 1-Lipschitz, so the piece is within max_i d_i + L / sqrt(3).
    /// A piece above the goal is split at the midpoint of its longest edge
    /// and the midpoint measured.
    fn triangle(
        &mut self,
        a: Surface<'_>,
        t: usize,
        b: &mut Nearest,
        sampling: &Sampling,
        slack: f32,
        known: Option<&Known>,
    ) {
        let corners = a.triangle(t);
        if b.holds(&corners) {
            return;
        }
        if let Some(k) = known.and_then(|k| k.bound(&corners)) {
            self.bounded(k);
            return;
        }
        let idx = &a.indices[3 * t..3 * t + 3];
        let mut d = [(0.0, 0); 3];
        for (k, &i) in idx.iter().enumerate() {
            if self.at[i as usize].0.is_nan() {
                let m = b.upper(corners[k], self.max);
                self.at[i as usize] = m;
                self.measured(corners[k], m.0, slack);
            }
            d[k] = self.at[i as usize];
        }
        if self.stopped {
            return;
        }
        let inv_sqrt3 = 1.0 / 3.0f32.sqrt();
        let mut stack = std::mem::take(&mut self.stack);
        stack.push((corners, d));
        let mut splits = 0;
        while let Some((q, d)) = stack.pop() {
            let e = [
                (q[1] - q[0]).length_squared(),
                (q[2] - q[1]).length_squared(),
                (q[0] - q[2]).length_squared(),
            ];
            let k = if e[0] >= e[1] && e[0] >= e[2] {
                0
            } else if e[1] >= e[2] {
                1
            } else {
                2
            };
            let goal = sampling.goal(self.max);
            let mut piece = d[0].0.max(d[1].0).max(d[2].0) + e[k].sqrt() * inv_sqrt3;
            if piece > goal {
                for (c, &(_, tri)) in d.iter().enumerate() {
                    if d[..c].iter().any(|x| x.1 == tri) {
                        continue;
                    }
                    // Corners answered by `tri` are at their known
                    // distance; a corner beyond the goal rules `tri` out.
                    let mut convex = 0.0f32;
                    for (&p, &(dc, tc)) in q.iter().zip(&d) {
                        let x = if tc == tri { dc } else { b.to(p, tri) };
                        convex = convex.max(x);
                        if convex > goal {
                            // Not a bound: the other corners are unmeasured.
                            convex = f32::INFINITY;
                            break;
                        }
                    }
                    piece = piece.min(convex);
                    if piece <= goal {
                        break;
                    }
                }
            }
            if piece > goal {
                // A flat region of `b` around the corners' nearest
                // triangles bounds the whole piece by its corners.
                let flat = b.flat(&q, &d.map(|x| x.1), goal) as f32;
                piece = piece.min(flat);
            }
            // NaN-safe: a NaN bound is kept (and poisons the result).
            if piece.is_nan() || piece <= goal || splits >= MAX_SPLITS {
                self.bounded(piece);
                if self.stopped {
                    break;
                }
                continue;
            }
            splits += 1;
            // The longest edge is q[k]-q[k+1].
            let (k1, k2) = ((k + 1) % 3, (k + 2) % 3);
            let m = (q[k] + q[k1]) * 0.5;
            let dm = b.upper(m, self.max);
            self.measured(m, dm.0, slack);
            if self.stopped {
                break;
            }
            stack.push(([q[k], m, q[k2]], [d[k], dm, d[k2]]));
            stack.push(([m, q[k1], q[k2]], [dm, d[k1], d[k2]]));
        }
        stack.clear();
        self.stack = stack;
    }
}

impl Nearest {
    /// Whether the surface has a triangle with exactly these corners (in
    /// any order).
    fn holds(&self, t: &[Vec3A; 3]) -> bool {
        self.exact.contains(&corner_key(t))
    }

    fn magnitude(&self) -> f32 {
        max_abs(self.tris.iter().flatten().copied())
    }
}

/// The largest absolute coordinate of `points` (0 for none).
fn max_abs(points: impl Iterator<Item = Vec3A>) -> f32 {
    points.map(|p| p.abs().max_element()).fold(0.0, f32::max)
}

/// Upper bound on the symmetric Hausdorff distance between `reference`
/// (with its prepared queries) and `lod`.
pub fn symmetric(
    reference: Surface<'_>,
    reference_queries: &mut Nearest,
    lod: Surface<'_>,
    sampling: &Sampling,
) -> f32 {
    match symmetric_within(
        reference,
        reference_queries,
        lod,
        None,
        sampling,
        f32::INFINITY,
    ) {
        Within::Yes(bound) => bound,
        // Only a NaN bound is not within an infinite limit.
        _ => f32::NAN,
    }
}

/// [`symmetric`] decided against `limit`: the cheaper way (from the LOD,
/// usually the smaller surface) first, and the other only when the first
/// is within the limit. `known`: triangles of the LOD already known to be
/// within a distance of the reference.
pub fn symmetric_within(
    reference: Surface<'_>,
    reference_queries: &mut Nearest,
    lod: Surface<'_>,
    known: Option<&Known>,
    sampling: &Sampling,
    limit: f32,
) -> Within {
    use crate::spent::{timed, Kind};
    let mut to_lod = Nearest::new(lod);
    let backward = timed(Kind::Backward, || {
        one_sided_in(lod, &to_lod.bvh, reference_queries, sampling, limit, known)
    });
    let backward = match backward.decision(limit) {
        Within::Yes(b) => b,
        no => return no,
    };
    let forward = timed(Kind::Forward, || {
        one_sided_in(
            reference,
            &reference_queries.bvh,
            &mut to_lod,
            sampling,
            limit,
            None,
        )
    });
    match forward.decision(limit) {
        Within::Yes(f) => Within::Yes(f.max(backward)),
        no => no,
    }
}

/// A triangle's corners as bit patterns, sorted, so the same triangle in
/// any vertex order has one key.
fn corner_key(t: &[Vec3A; 3]) -> [[u32; 3]; 3] {
    let mut k = t.map(|p| p.to_array().map(f32::to_bits));
    k.sort_unstable();
    k
}

/// Squared distance from `p` to a box (0 inside).
fn box_sq(p: Vec3A, b: &BvhAabb) -> f32 {
    let d = (b.min - p).max(p - b.max).max(Vec3A::ZERO);
    d.length_squared()
}

/// Squared distance from `p` to a triangle (Ericson, Real-Time Collision
/// Detection, 5.1.5: the Voronoi regions of the vertices, edges and face).
/// In f64: on a sliver (a 10 x 0.01 box face) the f32 products of the
/// region tests lose about a tenth of the sliver's width.
pub(crate) fn point_triangle_sq(p: Vec3A, t: &[Vec3A; 3]) -> f32 {
    point_triangle_sq64(
        p.as_dvec3(),
        [t[0].as_dvec3(), t[1].as_dvec3(), t[2].as_dvec3()],
    ) as f32
}

/// Whether f32 loses too much on this triangle: its height over its
/// longest edge is below 0.1 (f32's error there is about
/// 6e-8 x L^2 / height, kept under [`ROUNDING`] x L).
fn is_sliver(t: &[Vec3A; 3]) -> bool {
    let twice_area = (t[1] - t[0]).cross(t[2] - t[0]).length();
    let l2 = (t[1] - t[0])
        .length_squared()
        .max((t[2] - t[1]).length_squared())
        .max((t[0] - t[2]).length_squared());
    twice_area.is_nan() || twice_area < 0.1 * l2
}

/// One body, two precisions: Ericson's closest point on a triangle.
macro_rules! closest_sq {
    ($name:ident, $v:ty, $f:ty, $seg:ident) => {
        fn $name(p: $v, t: [$v; 3]) -> $f {
            let [a, b, c] = t;
            let (ab, ac, ap) = (b - a, c - a, p - a);
            let (d1, d2) = (ab.dot(ap), ac.dot(ap));
            if d1 <= 0.0 && d2 <= 0.0 {
                return ap.length_squared();
            }
            let bp = p - b;
            let (d3, d4) = (ab.dot(bp), ac.dot(bp));
            if d3 >= 0.0 && d4 <= d3 {
                return bp.length_squared();
            }
            let vc = d1 * d4 - d3 * d2;
            if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
                let v = d1 / (d1 - d3);
                return (p - (a + ab * v)).length_squared();
            }
            let cp = p - c;
            let (d5, d6) = (ab.dot(cp), ac.dot(cp));
            if d6 >= 0.0 && d5 <= d6 {
                return cp.length_squared();
            }
            let vb = d5 * d2 - d1 * d6;
            if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
                let w = d2 / (d2 - d6);
                return (p - (a + ac * w)).length_squared();
            }
            let va = d3 * d6 - d5 * d4;
            if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
                let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
                return (p - (b + (c - b) * w)).length_squared();
            }
            let denom = va + vb + vc;
            if denom == 0.0 || !denom.is_finite() {
                // Degenerate (zero-area) triangle: nearest of its edges.
                return $seg(p, a, b).min($seg(p, b, c)).min($seg(p, c, a));
            }
            let (v, w) = (vb / denom, vc / denom);
            (p - (a + ab * v + ac * w)).length_squared()
        }
    };
}
closest_sq!(point_triangle_sq64, DVec3, f64, seg_sq64);
closest_sq!(point_triangle_sq32, Vec3A, f32, seg_sq32);

macro_rules! segment_sq {
    ($name:ident, $v:ty, $f:ty) => {
        fn $name(p: $v, a: $v, b: $v) -> $f {
            let ab = b - a;
            let l = ab.length_squared();
            let t = if l > 0.0 {
                ((p - a).dot(ab) / l).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (p - (a + ab * t)).length_squared()
        }
    };
}
segment_sq!(seg_sq64, DVec3, f64);
segment_sq!(seg_sq32, Vec3A, f32);

#[cfg(test)]
mod tests {
    use super::*;

    const S: Sampling = Sampling {
        spacing: 0.25,
        floor: 1e-3,
        enough: 0.0,
    };

    fn quad(z: f32, size: f32) -> (Vec<[f32; 3]>, Vec<u32>) {
        (
            vec![
                [0.0, 0.0, z],
                [size, 0.0, z],
                [size, size, z],
                [0.0, size, z],
            ],
            vec![0, 1, 2, 0, 2, 3],
        )
    }

    fn surface<'a>(m: &'a (Vec<[f32; 3]>, Vec<u32>)) -> Surface<'a> {
        Surface {
            positions: &m.0,
            indices: &m.1,
        }
    }

    #[test]
    fn point_triangle_regions() {
        let t = [Vec3A::ZERO, Vec3A::X, Vec3A::Y];
        let check = |p: Vec3A, want: f32| {
            let got = point_triangle_sq(p, &t).sqrt();
            assert!((got - want).abs() < 1e-6, "{p:?}: {got} vs {want}");
        };
        check(Vec3A::new(0.2, 0.2, 1.0), 1.0); // face
        check(Vec3A::new(-1.0, -1.0, 0.0), 2.0f32.sqrt()); // vertex a
        check(Vec3A::new(0.5, -2.0, 0.0), 2.0); // edge ab
        check(Vec3A::new(1.0, 1.0, 0.0), 0.5f32.sqrt()); // edge bc
        check(Vec3A::new(3.0, 0.0, 0.0), 2.0); // vertex b
                                               // Degenerate triangle: a segment.
        let seg = [Vec3A::ZERO, Vec3A::X, Vec3A::X * 2.0];
        assert!((point_triangle_sq(Vec3A::new(1.0, 1.0, 0.0), &seg) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn point_on_a_sliver_is_on_it() {
        // A 10 x 0.01 face of a thin box, far from the origin's scale.
        let t = [
            Vec3A::new(5.0, -5.0, -0.005),
            Vec3A::new(5.0, 5.0, -0.005),
            Vec3A::new(5.0, 5.0, 0.005),
        ];
        let p = t[0] + (t[1] - t[0]) * 0.7 + (t[2] - t[0]) * 0.2;
        assert!(point_triangle_sq(p, &t).sqrt() < 1e-6);
    }

    #[test]
    fn identical_surfaces_are_within_the_floor() {
        let m = quad(0.0, 10.0);
        let mut q = Nearest::new(surface(&m));
        let h = symmetric(surface(&m), &mut q, surface(&m), &S);
        // Split until pieces are within the floor (1e-3), or the cap.
        assert!(h <= 0.02, "{h}");
    }

    #[test]
    fn parallel_sheets_are_their_gap_apart() {
        let a = quad(0.0, 1.0);
        let b = quad(0.5, 1.0);
        let mut qa = Nearest::new(surface(&a));
        let h = symmetric(surface(&a), &mut qa, surface(&b), &S);
        assert!((0.5..=0.5 * 1.25 + 1e-3).contains(&h), "{h}");
    }

    #[test]
    fn a_hole_in_the_middle_is_found_by_interior_samples() {
        // B: a ring around a 2 x 2 hole in a 6 x 6 square; A: the full
        // square, whose corners B keeps. The hole's centre is 1 from B.
        let ring: (Vec<[f32; 3]>, Vec<u32>) = {
            let xs = [0.0, 2.0, 4.0, 6.0];
            let mut p = Vec::new();
            for y in xs {
                for x in xs {
                    p.push([x, y, 0.0]);
                }
            }
            let mut idx = Vec::new();
            for cy in 0..3u32 {
                for cx in 0..3u32 {
                    if (cx, cy) == (1, 1) {
                        continue;
                    }
                    let v = cy * 4 + cx;
                    idx.extend([v, v + 1, v + 5, v, v + 5, v + 4]);
                }
            }
            (p, idx)
        };
        let full = quad(0.0, 6.0);
        let mut q = Nearest::new(surface(&ring));
        let h = one_sided(surface(&full), &mut q, &S);
        assert!(h >= 1.0, "{h}");
        // The other way nothing is missing.
        let mut qf = Nearest::new(surface(&full));
        assert!(one_sided(surface(&ring), &mut qf, &S) < 0.1);
    }

    #[test]
    fn vanished_piece_costs_its_distance() {
        let a = quad(0.0, 1.0);
        let mut both = quad(0.0, 1.0);
        let far = quad(7.0, 1.0);
        both.1.extend(far.1.iter().map(|i| i + 4));
        both.0.extend(far.0);
        let mut qa = Nearest::new(surface(&a));
        let h = symmetric(surface(&both), &mut qa, surface(&a), &S);
        assert!((7.0..7.0 * 1.25 + 1e-3).contains(&h), "{h}");
    }

    /// A bumpy heightfield over [0, 8]^2 as an n x n grid of quads, less
    /// the quads `drop` rejects.
    fn heightfield(
        n: u32,
        lift: f32,
        drop: impl Fn(u32, u32) -> bool,
    ) -> (Vec<[f32; 3]>, Vec<u32>) {
        let h = |x: f32, y: f32| (x * 0.9).sin() * (y * 0.7).cos() + lift;
        let step = 8.0 / n as f32;
        let mut p = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (i as f32 * step, j as f32 * step);
                p.push([x, y, h(x, y)]);
            }
        }
        let mut idx = Vec::new();
        for j in 0..n {
            for i in 0..n {
                if drop(i, j) {
                    continue;
                }
                let v = j * (n + 1) + i;
                idx.extend([v, v + 1, v + n + 2, v, v + n + 2, v + n + 1]);
            }
        }
        (p, idx)
    }

    /// The largest distance from dense random points (and every vertex)
    /// of `a` to `b`, by brute force over `b`'s triangles.
    fn brute(a: &(Vec<[f32; 3]>, Vec<u32>), b: &(Vec<[f32; 3]>, Vec<u32>)) -> f32 {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand::rngs::SmallRng::seed_from_u64(3);
        let (sa, sb) = (surface(a), surface(b));
        let to_b = |p: Vec3A| {
            (0..sb.triangles())
                .map(|t| point_triangle_sq(p, &sb.triangle(t)))
                .fold(f32::INFINITY, f32::min)
                .sqrt()
        };
        let mut worst = 0.0f32;
        for t in 0..sa.triangles() {
            let [p, q, r] = sa.triangle(t);
            worst = worst.max(to_b(p)).max(to_b(q)).max(to_b(r));
            for _ in 0..12 {
                let (u, v): (f32, f32) = (rng.random(), rng.random());
                let (u, v) = if u + v > 1.0 {
                    (1.0 - u, 1.0 - v)
                } else {
                    (u, v)
                };
                worst = worst.max(to_b(p + (q - p) * u + (r - p) * v));
            }
        }
        worst
    }

    #[test]
    fn cluster_bounds_hold_against_brute_force() {
        // A fine bumpy surface against coarser versions of itself: lifted,
        // with a hole, and with a far corner gone. Clusters of the fine
        // surface are certified whole where the goal allows; the result
        // must still bound every sampled point, and stay within the
        // sampling's (1 + spacing) of the truth.
        let fine = heightfield(24, 0.0, |_, _| false);
        let cases = [
            heightfield(6, 0.0, |_, _| false),
            heightfield(6, 0.3, |_, _| false),
            heightfield(8, 0.0, |i, j| (3..5).contains(&i) && (3..5).contains(&j)),
            heightfield(8, 0.0, |i, j| i + j > 12),
        ];
        let mut clusters = 0;
        for (k, coarse) in cases.iter().enumerate() {
            for (a, b) in [(&fine, coarse), (coarse, &fine)] {
                let mut q = Nearest::new(surface(b));
                let tree = Nearest::new(surface(a));
                let o = one_sided_in(surface(a), &tree.bvh, &mut q, &S, f32::INFINITY, None);
                let (bound, whole) = (o.bound, o.clusters);
                clusters += whole;
                let truth = brute(a, b);
                assert!(bound >= truth, "case {k}: bound {bound} < sampled {truth}");
                assert!(
                    bound <= (1.0 + S.spacing) * truth * 1.05 + S.floor,
                    "case {k}: bound {bound} far above sampled {truth}"
                );
            }
        }
        assert!(clusters > 0, "no cluster was bounded whole");
    }

    /// Distance from `p` to `b`, brute force over its triangles in f64.
    fn brute_point(p: Vec3A, b: &(Vec<[f32; 3]>, Vec<u32>)) -> f64 {
        let sb = surface(b);
        (0..sb.triangles())
            .map(|t| {
                let [x, y, z] = sb.triangle(t);
                point_triangle_sq64(p.as_dvec3(), [x.as_dvec3(), y.as_dvec3(), z.as_dvec3()])
            })
            .fold(f64::INFINITY, f64::min)
            .sqrt()
    }

    #[test]
    fn decisions_agree_with_brute_force_on_random_meshes() {
        // Random bumpy sheets against coarser, shifted, holed or cut
        // versions of themselves, both ways, decided at limits around the
        // densely sampled distance: "within e" never has a sampled point
        // beyond e, a witness really lies beyond e, and an undecided
        // answer comes only where e is within the sampling's tolerance of
        // the distance.
        use rand::{RngExt, SeedableRng};
        let mut rng = rand::rngs::SmallRng::seed_from_u64(17);
        let (mut yes, mut beyond, mut undecided) = (0, 0, 0);
        for case in 0..24 {
            let fine_n = rng.random_range(6..20u32);
            let coarse_n = rng.random_range(2..fine_n);
            let lift: f32 = rng.random_range(-0.4..0.4);
            let (hole, cut) = (rng.random_range(0..4u32), rng.random_range(6..40u32));
            let fine = heightfield(fine_n, 0.0, |_, _| false);
            let coarse = heightfield(coarse_n, lift, |i, j| {
                (i == hole && j == hole) || i + j > cut * coarse_n / 20
            });
            for (a, b) in [(&fine, &coarse), (&coarse, &fine)] {
                let mut q = Nearest::new(surface(b));
                let full = one_sided(surface(a), &mut q, &S);
                assert_eq!(
                    one_sided_within(surface(a), &mut q, &S, f32::INFINITY),
                    Within::Yes(full),
                    "case {case}: an unbounded decision is the measurement"
                );
                let truth = brute(a, b);
                for f in [0.3f32, 0.7, 0.95, 1.05, 1.3, 2.0] {
                    let e = truth * f;
                    match one_sided_within(surface(a), &mut q, &S, e) {
                        Within::Yes(bound) => {
                            yes += 1;
                            assert!(bound <= e, "case {case}: yes at {bound} > {e}");
                            assert!(truth <= bound, "case {case}: {truth} sampled, yes at {e}");
                        }
                        Within::Beyond { point, distance } => {
                            beyond += 1;
                            let d = brute_point(point, b);
                            assert!(d > e as f64, "case {case}: witness at {d}, not beyond {e}");
                            assert!((d - distance as f64).abs() <= 1e-4 * (1.0 + d));
                        }
                        Within::Undecided => {
                            undecided += 1;
                            assert!(
                                e <= (1.0 + S.spacing) * truth * 1.05 + S.floor,
                                "case {case}: undecided at {e}, sampled {truth}"
                            );
                        }
                    }
                }
            }
        }
        assert!(
            yes > 0 && beyond > 0,
            "{yes} yes, {beyond} beyond, {undecided} undecided"
        );
    }

    #[test]
    fn known_triangles_are_bounded_by_what_is_known() {
        // A sheet 0.2 above another, its triangles known to be within 0.5
        // (a looser figure than the truth, as a previous level's error
        // is): the bound stays a bound, and never exceeds what is known.
        let sheet = heightfield(12, 0.0, |_, _| false);
        let lifted = heightfield(12, 0.2, |_, _| false);
        let mut q = Nearest::new(surface(&sheet));
        let tree = Nearest::new(surface(&lifted));
        let known = Known::new(surface(&lifted), 0.5);
        let with = one_sided_in(
            surface(&lifted),
            &tree.bvh,
            &mut q,
            &S,
            f32::INFINITY,
            Some(&known),
        );
        let without = one_sided_in(surface(&lifted), &tree.bvh, &mut q, &S, f32::INFINITY, None);
        let truth = brute(&lifted, &sheet);
        assert!(
            truth <= without.bound && without.bound <= with.bound,
            "{truth} {without:?} {with:?}"
        );
        assert!(with.bound <= 0.5 + 1e-5, "{with:?}");
    }

    #[test]
    fn empty_surfaces() {
        let a = quad(0.0, 1.0);
        let empty: (Vec<[f32; 3]>, Vec<u32>) = (vec![], vec![]);
        let mut qe = Nearest::new(surface(&empty));
        assert_eq!(one_sided(surface(&a), &mut qe, &S), f32::INFINITY);
        let mut qa = Nearest::new(surface(&a));
        assert_eq!(one_sided(surface(&empty), &mut qa, &S), 0.0);
    }
}
