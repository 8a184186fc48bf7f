//! Pair contraction across gaps: GAPS (Erikson and Manocha 1999, the
//! simplifier of GigaWalk Section 4.3) on Garland and Heckbert's
//! quadrics (1997, section 3: pairs beyond edges).
//!
//! The candidate pairs are the mesh's edges plus *virtual edges*: pairs
//! of vertices closer than a gap threshold that share no edge, found with
//! a grid. Contracting a virtual pair joins two disjoint parts (a bolt
//! and its flange, two panels of a satellite) or closes a hole (a LEGO
//! beam's); contracting an edge whose triangles then degenerate removes
//! them. No contraction is refused for changing topology, so a small
//! closed part can shrink to a point and vanish, and a hole to a ring and
//! shut; what a level loses that way is caught by its measured error
//! ([`crate::hausdorff`]) and by the pieces the caller keeps or covers
//! ([`super::simplify`]).
//!
//! Each vertex holds the quadric of its triangles' planes, area-weighted,
//! plus a plane through each open edge at right angles to its triangle
//! (boundary quadrics), so open sheets keep their outline. A pair's cost
//! is the larger of its two vertices' mean squared distances to their own
//! planes at the end the pair keeps (pairs meet at an end, as in edge
//! collapse, so vertices keep their positions and normals): a distance
//! in model units, so the caller's error limit stops contraction. The gap
//! threshold grows with the cost of the cheapest pair left, so small gaps
//! and holes close at the fine levels of a chain and larger ones only at
//! the coarse ones, as GAPS's adaptive threshold does ([`History::new`]).
//!
//! GAPS's surface-area term, which keeps thin parts from vanishing or
//! ballooning, is here a guard on each contraction: one that would shrink
//! the area of the triangles around the pair below [`MIN_AREA_KEPT`] of
//! what it was, or flip one of them, waits (the pair is tried again
//! after one of its vertices moves). Flat arrays throughout (positions,
//! quadrics, each vertex's triangles) and one binary heap of pairs, whose
//! stale entries are skipped by a version per vertex.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::DVec3;
use rustc_hash::FxHashMap;

/// A mesh simplified to a level: triangles over the input's vertex
/// indices (at the input's positions: pairs meet at an end).
pub(super) struct Contracted {
    pub(super) indices: Vec<u32>,
    /// Per vertex, the vertex it became (itself when not contracted).
    pub(super) into: Vec<u32>,
    /// The largest cost of a contraction made (model units).
    pub(super) error: f32,
}

/// Every contraction of one mesh, in order, down to nothing: a level at
/// any error limit and triangle target is a prefix of it
/// ([`History::level`]), so the many limits a chain tries cost one
/// contraction run and a replay each.
pub(super) struct History {
    steps: Vec<Contraction>,
    /// Contraction stopped once this many triangles were left: levels
    /// of fewer are not in the history.
    floor: usize,
}

/// One contraction: `b` into `a`, which stays where it is, at a cost of
/// `error` model units, leaving `live` triangles.
#[derive(Clone, Copy, Debug)]
struct Contraction {
    a: u32,
    b: u32,
    error: f32,
    live: u32,
}

impl History {
    /// Contracts `indices` (triangles over `positions`, welded: one index
    /// per position) in order of cost until no pair is left or at most
    /// `floor` triangles are. Pairs are the edges and virtual pairs:
    /// vertex pairs closer than a threshold that share no edge, each
    /// vertex's [`VIRTUAL_PER_VERTEX`] nearest. The threshold adapts as
    /// GAPS's does: from a thousandth of the mesh's extent, grown
    /// [`GAP_GROWTH`]-fold whenever the cheapest pair left costs more
    /// than half of it (about what a pair that far apart costs), up to
    /// [`MAX_GAP_OF_EXTENT`] of the extent; so small gaps and holes close
    /// first, larger ones only as the error grows. Degenerate and
    /// repeated triangles (the same three vertices in any order) are
    /// dropped as they appear.
    pub(super) fn new(positions: &[[f32; 3]], indices: &[u32], floor: usize) -> History {
        let mut g = Gaps::new(positions, indices);
        let extent = g.extent();
        let max_gap = MAX_GAP_OF_EXTENT * extent;
        let mut gap = (extent * 1e-3).max(f64::MIN_POSITIVE);
        g.add_virtual_pairs(gap);
        g.seed_heap();
        let steps = g.run(&mut gap, max_gap, floor);
        History { steps, floor }
    }

    /// Whether levels of `target` triangles are in the history.
    pub(super) fn reaches(&self, target: usize) -> bool {
        target >= self.floor
    }

    /// The level of at most `target` triangles, or as near as contractions
    /// of cost at most `max_error` (model units; `f32::MAX` for none) go:
    /// the history's longest prefix within both, replayed on the mesh
    /// the history was made of.
    pub(super) fn level(
        &self,
        positions: &[[f32; 3]],
        indices: &[u32],
        target: usize,
        max_error: f32,
    ) -> Contracted {
        let mut into: Vec<u32> = (0..positions.len() as u32).collect();
        let mut error = 0.0f32;
        let mut live = indices.len() / 3;
        for c in &self.steps {
            if live <= target || c.error > max_error {
                break;
            }
            into[c.b as usize] = c.a;
            error = error.max(c.error);
            live = c.live as usize;
        }
        for v in 0..into.len() as u32 {
            let r = crate::cluster::find(&mut into, v);
            into[v as usize] = r;
        }
        let mut seen: rustc_hash::FxHashSet<[u32; 3]> = rustc_hash::FxHashSet::default();
        let mut out = Vec::with_capacity(3 * live);
        for t in indices.chunks_exact(3) {
            let m = [
                into[t[0] as usize],
                into[t[1] as usize],
                into[t[2] as usize],
            ];
            if m[0] == m[1] || m[1] == m[2] || m[0] == m[2] {
                continue;
            }
            let mut key = m;
            key.sort_unstable();
            if seen.insert(key) {
                out.extend_from_slice(&m);
            }
        }
        Contracted {
            indices: out,
            into,
            error,
        }
    }
}

/// A symmetric 4x4 quadric (10 coefficients) and the weight (area) its
/// planes carry.
#[derive(Clone, Copy, Debug, Default)]
struct Quadric {
    a: [f64; 10],
    w: f64,
}

impl Quadric {
    /// The plane n.x + d = 0 (n unit), weighted by `w`.
    fn plane(n: DVec3, d: f64, w: f64) -> Quadric {
        let (a, b, c) = (n.x, n.y, n.z);
        Quadric {
            a: [
                a * a * w,
                a * b * w,
                a * c * w,
                a * d * w,
                b * b * w,
                b * c * w,
                b * d * w,
                c * c * w,
                c * d * w,
                d * d * w,
            ],
            w,
        }
    }

    fn add(&mut self, o: &Quadric) {
        for (x, y) in self.a.iter_mut().zip(&o.a) {
            *x += y;
        }
        self.w += o.w;
    }

    /// The weighted sum of squared distances of `p` to the planes.
    fn eval(&self, p: DVec3) -> f64 {
        let q = &self.a;
        let (x, y, z) = (p.x, p.y, p.z);
        let v = q[0] * x * x
            + 2.0 * q[1] * x * y
            + 2.0 * q[2] * x * z
            + 2.0 * q[3] * x
            + q[4] * y * y
            + 2.0 * q[5] * y * z
            + 2.0 * q[6] * y
            + q[7] * z * z
            + 2.0 * q[8] * z
            + q[9];
        v.max(0.0)
    }

    /// The mean squared distance (per unit of weight) of `p` to the planes.
    fn mean(&self, p: DVec3) -> f64 {
        if self.w > 0.0 {
            self.eval(p) / self.w
        } else {
            0.0
        }
    }
}

/// A pair on the heap: its cost (as ordered bits of a non-negative f64),
/// its vertices and their versions when it was priced.
type Entry = Reverse<(u64, u32, u32, u32, u32)>;

struct Gaps {
    pos: Vec<DVec3>,
    /// The box of the vertices in use at the start: no vertex leaves it
    /// (a node's box must hold its levels).
    bounds: (DVec3, DVec3),
    quadric: Vec<Quadric>,
    /// Per vertex: the triangles using it (some dead, skipped).
    vtris: Vec<Vec<u32>>,
    /// Per vertex: its virtual partners (some dead, skipped).
    virtual_pairs: Vec<Vec<u32>>,
    tris: Vec<[u32; 3]>,
    tri_alive: Vec<bool>,
    live_tris: usize,
    /// Per vertex: bumped whenever it moves; dead vertices have `alive` false.
    version: Vec<u32>,
    alive: Vec<bool>,
    /// Per vertex, the vertex it was contracted into (a union-find forest).
    parent: Vec<u32>,
    heap: BinaryHeap<Entry>,
}

impl Gaps {
    fn new(positions: &[[f32; 3]], indices: &[u32]) -> Gaps {
        let n = positions.len();
        let pos: Vec<DVec3> = positions
            .iter()
            .map(|p| glam::Vec3::from_array(*p).as_dvec3())
            .collect();
        let mut tris = Vec::with_capacity(indices.len() / 3);
        for t in indices.chunks_exact(3) {
            if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                tris.push([t[0], t[1], t[2]]);
            }
        }
        let mut quadric = vec![Quadric::default(); n];
        let mut counts = vec![0u32; n];
        for t in &tris {
            for &v in t {
                counts[v as usize] += 1;
            }
        }
        let mut vtris: Vec<Vec<u32>> = counts
            .iter()
            .map(|&c| Vec::with_capacity(c as usize))
            .collect();
        // Edges used once are open: a plane through each, at right angles
        // to its triangle, keeps the outline (Garland and Heckbert's
        // boundary constraint). Weighted as a triangle of the edge's
        // length squared would be.
        let mut edge_uses: FxHashMap<(u32, u32), u32> = FxHashMap::default();
        for (k, t) in tris.iter().enumerate() {
            for &v in t {
                vtris[v as usize].push(k as u32);
            }
            for e in 0..3 {
                let (a, b) = (t[e], t[(e + 1) % 3]);
                *edge_uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
            let (p0, p1, p2) = (pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]);
            let c = (p1 - p0).cross(p2 - p0);
            let len = c.length();
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            let nrm = c / len;
            let q = Quadric::plane(nrm, -nrm.dot(p0), 0.5 * len);
            for &v in t {
                quadric[v as usize].add(&q);
            }
        }
        for t in &tris {
            let (p0, p1, p2) = (pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]);
            let face = (p1 - p0).cross(p2 - p0).normalize_or_zero();
            if face == DVec3::ZERO {
                continue;
            }
            for e in 0..3 {
                let (a, b) = (t[e], t[(e + 1) % 3]);
                if edge_uses[&(a.min(b), a.max(b))] != 1 {
                    continue;
                }
                let (pa, pb) = (pos[a as usize], pos[b as usize]);
                let along = pb - pa;
                let n = along.cross(face).normalize_or_zero();
                if n == DVec3::ZERO {
                    continue;
                }
                let q = Quadric::plane(n, -n.dot(pa), BOUNDARY_WEIGHT * along.length_squared());
                quadric[a as usize].add(&q);
                quadric[b as usize].add(&q);
            }
        }
        let live_tris = tris.len();
        let mut bounds = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for t in &tris {
            for &v in t {
                bounds.0 = bounds.0.min(pos[v as usize]);
                bounds.1 = bounds.1.max(pos[v as usize]);
            }
        }
        Gaps {
            bounds,
            pos,
            quadric,
            vtris,
            virtual_pairs: vec![Vec::new(); n],
            tri_alive: vec![true; tris.len()],
            tris,
            live_tris,
            version: vec![0; n],
            alive: vec![true; n],
            parent: (0..n as u32).collect(),
            heap: BinaryHeap::new(),
        }
    }

    /// The longest side of the used vertices' box.
    fn extent(&self) -> f64 {
        let e = (self.bounds.1 - self.bounds.0).max_element();
        if e.is_finite() {
            e
        } else {
            0.0
        }
    }

    /// Whether `v` is alive and some live triangle uses it.
    fn in_use(&self, v: usize) -> bool {
        self.alive[v] && self.vtris[v].iter().any(|&t| self.tri_alive[t as usize])
    }

    /// Each vertex in use gets up to [`VIRTUAL_PER_VERTEX`] new partners:
    /// its nearest vertices within `gap` (of higher index, so each pair
    /// is found once) that share no live edge with it and are not its
    /// partners yet, found on a grid of cells of `gap`. Returns the pairs
    /// added.
    fn add_virtual_pairs(&mut self, gap: f64) -> Vec<(u32, u32)> {
        let mut added = Vec::new();
        if !(gap > 0.0 && gap.is_finite()) {
            return added;
        }
        let inv = 1.0 / gap;
        // Cell coordinates saturate (`as` from f64), so a far vertex
        // cannot overflow its neighbours' keys.
        let cell = |p: DVec3| [p.x, p.y, p.z].map(|c| (c * inv).floor() as i64);
        // A cell as one number: its place from the box's lowest cell, 21
        // bits an axis (the box spans about 1,000 cells an axis at most:
        // `History::new`'s first gap is a thousandth of its extent, and
        // the gap only grows). A cell beyond that is none: its vertex
        // would get no partner this time.
        let low = cell(self.bounds.0);
        let pack = |c: [i64; 3]| -> Option<u64> {
            let mut key = 0u64;
            for (c, low) in c.into_iter().zip(low) {
                let d = c.checked_sub(low)?;
                if !(0..1 << 21).contains(&d) {
                    return None;
                }
                key = key << 21 | d as u64;
            }
            Some(key)
        };
        // The vertices in use by cell, ascending within each (a cell's
        // first vertices are what a crowded cell is sampled by), and
        // where each cell's run starts: one sort, no list per cell.
        let mut keyed: Vec<(u64, u32)> = (0..self.pos.len())
            .filter(|&v| self.in_use(v))
            .filter_map(|v| Some((pack(cell(self.pos[v]))?, v as u32)))
            .collect();
        keyed.sort_unstable();
        let mut runs: FxHashMap<u64, (u32, u32)> = FxHashMap::default();
        let mut start = 0;
        while start < keyed.len() {
            let key = keyed[start].0;
            let end = start + keyed[start..].partition_point(|e| e.0 == key);
            runs.insert(key, (start as u32, end as u32));
            start = end;
        }
        let gap2 = gap * gap;
        // The nearest partners so far, nearest first (ties by index).
        let mut near: Vec<(f64, u32)> = Vec::with_capacity(VIRTUAL_PER_VERTEX + 1);
        let mut neighbours: Vec<u32> = Vec::new();
        // A cell's neighbourhood, its 27 cells' first vertices, found once
        // for all the cell's vertices. Which vertex goes first does not
        // change what any finds: each looks only at higher indices, and
        // a lower vertex's new partners are lower than it.
        let mut around: Vec<(DVec3, u32)> = Vec::new();
        let mut i = 0;
        while i < keyed.len() {
            let (_, end) = runs[&keyed[i].0];
            let c = cell(self.pos[keyed[i].1 as usize]);
            around.clear();
            for dx in -1..=1i64 {
                for dy in -1..=1i64 {
                    for dz in -1..=1i64 {
                        let key = [
                            c[0].saturating_add(dx),
                            c[1].saturating_add(dy),
                            c[2].saturating_add(dz),
                        ];
                        let Some(&(a, b)) = pack(key).and_then(|k| runs.get(&k)) else {
                            continue;
                        };
                        // A crowded cell is sampled, not scanned: its
                        // first vertices stand for it (the gap is then
                        // far above the mesh's spacing, and any partner
                        // closes it).
                        let b = b.min(a + MAX_SCANNED_PER_CELL as u32);
                        around.extend(
                            keyed[a as usize..b as usize]
                                .iter()
                                .map(|e| (self.pos[e.1 as usize], e.1)),
                        );
                    }
                }
            }
            for &(_, v) in &keyed[i..end as usize] {
                let v = v as usize;
                let p = self.pos[v];
                neighbours.clear();
                for &t in &self.vtris[v] {
                    if self.tri_alive[t as usize] {
                        neighbours.extend_from_slice(&self.tris[t as usize]);
                    }
                }
                neighbours.extend_from_slice(&self.virtual_pairs[v]);
                near.clear();
                for &(q, u) in &around {
                    if u as usize <= v {
                        continue;
                    }
                    let d2 = q.distance_squared(p);
                    // Only a pair that would be among the nearest kept is
                    // checked against the neighbours (the costly test).
                    let better = || {
                        near.len() < VIRTUAL_PER_VERTEX || {
                            let (e, w) = near[VIRTUAL_PER_VERTEX - 1];
                            e.total_cmp(&d2).then(w.cmp(&u)).is_gt()
                        }
                    };
                    if d2 <= gap2 && better() && !neighbours.contains(&u) {
                        let at = near
                            .partition_point(|&(e, w)| e.total_cmp(&d2).then(w.cmp(&u)).is_lt());
                        near.insert(at, (d2, u));
                        near.truncate(VIRTUAL_PER_VERTEX);
                    }
                }
                for &(_, u) in &near {
                    self.virtual_pairs[v].push(u);
                    self.virtual_pairs[u as usize].push(v as u32);
                    added.push((v as u32, u));
                }
            }
            i = end as usize;
        }
        added
    }

    /// Every edge and virtual pair, priced, each once.
    fn seed_heap(&mut self) {
        let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(3 * self.tris.len());
        for t in &self.tris {
            for e in 0..3 {
                let (a, b) = (t[e], t[(e + 1) % 3]);
                pairs.push((a.min(b), a.max(b)));
            }
        }
        for (v, list) in self.virtual_pairs.iter().enumerate() {
            pairs.extend(
                list.iter()
                    .filter(|&&u| (v as u32) < u)
                    .map(|&u| (v as u32, u)),
            );
        }
        pairs.sort_unstable();
        pairs.dedup();
        let entries: Vec<Entry> = pairs.into_iter().map(|(a, b)| self.entry(a, b)).collect();
        self.heap = BinaryHeap::from(entries);
    }

    /// Which of `a` and `b` the pair keeps (`true`: `b`) and the cost of
    /// meeting there: the larger of their mean squared distances to their
    /// own planes at the kept vertex's position. The pair meets at one of
    /// its ends, as edge collapse does, so every vertex of a level is a
    /// vertex of the mesh with its own position and normal (a vertex
    /// moved to the quadrics' minimizer would keep a normal of where it
    /// was: a smooth sphere's level then showed facets).
    fn price(&self, a: u32, b: u32) -> (bool, f64) {
        let (qa, qb) = (&self.quadric[a as usize], &self.quadric[b as usize]);
        let (pa, pb) = (self.pos[a as usize], self.pos[b as usize]);
        let cost = |p: DVec3| qa.mean(p).max(qb.mean(p));
        let (ca, cb) = (cost(pa), cost(pb));
        if cb < ca {
            (true, cb)
        } else {
            (false, ca)
        }
    }

    fn entry(&self, a: u32, b: u32) -> Entry {
        let (_, c) = self.price(a, b);
        Reverse((
            c.to_bits(),
            a,
            b,
            self.version[a as usize],
            self.version[b as usize],
        ))
    }

    /// Contracts pairs in order of cost until none is left or at most
    /// `floor` triangles are, growing the virtual pairs' threshold `gap`
    /// (up to `max_gap`) whenever the cheapest pair costs more than half
    /// of it; returns the contractions.
    fn run(&mut self, gap: &mut f64, max_gap: f64, floor: usize) -> Vec<Contraction> {
        let mut steps = Vec::new();
        let mut ring: Vec<u32> = Vec::new();
        while self.live_tris > floor {
            // The cheapest pair left is farther than half the gap: pairs
            // across wider gaps may be cheaper now.
            while *gap < max_gap {
                let cheapest = self.heap.peek().map(|e| f64::from_bits(e.0 .0));
                if cheapest.is_some_and(|c| c <= 0.25 * *gap * *gap) {
                    break;
                }
                *gap = (*gap * GAP_GROWTH).min(max_gap);
                let added = self.add_virtual_pairs(*gap);
                for (a, b) in added {
                    let e = self.entry(a, b);
                    self.heap.push(e);
                }
            }
            let Some(Reverse((bits, a, b, va, vb))) = self.heap.pop() else {
                break;
            };
            let (ai, bi) = (a as usize, b as usize);
            if !self.alive[ai]
                || !self.alive[bi]
                || self.version[ai] != va
                || self.version[bi] != vb
            {
                continue;
            }
            let (keep_b, _) = self.price(a, b);
            let (a, b) = if keep_b { (b, a) } else { (a, b) };
            let ai = a as usize;
            if !self.acceptable(a, b) {
                continue;
            }
            self.collapse(a, b);
            steps.push(Contraction {
                a,
                b,
                error: f64::from_bits(bits).sqrt() as f32,
                live: self.live_tris as u32,
            });
            // Reprice every pair of the survivor.
            ring.clear();
            for &t in &self.vtris[ai] {
                if self.tri_alive[t as usize] {
                    ring.extend(self.tris[t as usize].iter().copied().filter(|&v| v != a));
                }
            }
            ring.extend(
                self.virtual_pairs[ai]
                    .iter()
                    .copied()
                    .filter(|&v| v != a && self.alive[v as usize]),
            );
            ring.sort_unstable();
            ring.dedup();
            for &v in &ring {
                let e = self.entry(a.min(v), a.max(v));
                self.heap.push(e);
            }
        }
        steps
    }

    /// Whether moving `b` onto `a` flips none of their other triangles
    /// and keeps at least [`MIN_AREA_KEPT`] of their area (GAPS's area
    /// term: a thin part must not fold flat or vanish in one step).
    fn acceptable(&self, a: u32, b: u32) -> bool {
        let p = self.pos[a as usize];
        let mut before = 0.0;
        let mut after = 0.0;
        for &v in &[a, b] {
            for &t in &self.vtris[v as usize] {
                if !self.tri_alive[t as usize] {
                    continue;
                }
                let tri = self.tris[t as usize];
                let corner = |k: usize| self.pos[tri[k] as usize];
                let n_old = (corner(1) - corner(0)).cross(corner(2) - corner(0));
                // A triangle with both is counted once (from `a`) and
                // degenerates.
                let both = tri.contains(&a) && tri.contains(&b);
                if both && v == b {
                    continue;
                }
                before += 0.5 * n_old.length();
                if both {
                    continue;
                }
                let moved = |k: usize| {
                    if tri[k] == a || tri[k] == b {
                        p
                    } else {
                        corner(k)
                    }
                };
                let n_new = (moved(1) - moved(0)).cross(moved(2) - moved(0));
                if n_new.dot(n_old) < 0.0 {
                    return false;
                }
                after += 0.5 * n_new.length();
            }
        }
        after >= MIN_AREA_KEPT * before
    }

    /// Gives `a` `b`'s triangles, quadric and virtual partners, and drops
    /// the triangles that degenerate or repeat.
    fn collapse(&mut self, a: u32, b: u32) {
        let (ai, bi) = (a as usize, b as usize);
        let qb = self.quadric[bi];
        self.quadric[ai].add(&qb);
        self.alive[bi] = false;
        self.parent[bi] = a;
        self.version[ai] = self.version[ai].wrapping_add(1);
        let moved = std::mem::take(&mut self.vtris[bi]);
        for t in moved {
            let tu = t as usize;
            if !self.tri_alive[tu] {
                continue;
            }
            let tri = &mut self.tris[tu];
            for v in tri.iter_mut() {
                if *v == b {
                    *v = a;
                }
            }
            if tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] {
                self.kill(tu);
            } else {
                self.vtris[ai].push(t);
            }
        }
        let partners = std::mem::take(&mut self.virtual_pairs[bi]);
        for u in partners {
            if u != a && self.alive[u as usize] {
                self.virtual_pairs[ai].push(u);
                self.virtual_pairs[u as usize].push(a);
            }
        }
        // Live triangles of `a`, each once; repeats (the same three
        // vertices in any order: a thin plate whose sides met) dropped.
        let mut list = std::mem::take(&mut self.vtris[ai]);
        list.retain(|&t| self.tri_alive[t as usize]);
        list.sort_unstable();
        list.dedup();
        let mut keys: Vec<([u32; 3], u32)> = list
            .iter()
            .map(|&t| {
                let mut k = self.tris[t as usize];
                k.sort_unstable();
                (k, t)
            })
            .collect();
        keys.sort_unstable();
        for w in keys.windows(2) {
            if w[0].0 == w[1].0 {
                self.kill(w[1].1 as usize);
            }
        }
        list.retain(|&t| self.tri_alive[t as usize]);
        self.vtris[ai] = list;
    }

    fn kill(&mut self, t: usize) {
        if self.tri_alive[t] {
            self.tri_alive[t] = false;
            self.live_tris -= 1;
        }
    }
}

/// Boundary planes weigh this many times a triangle of the edge's
/// length squared: enough that an open sheet's outline moves less than
/// its interior, as Garland and Heckbert's constraint planes do.
const BOUNDARY_WEIGHT: f64 = 4.0;

/// Virtual partners kept per vertex (its nearest): enough to join two
/// parts along a seam, few enough that a crowded neighbourhood does not
/// make the heap quadratic.
const VIRTUAL_PER_VERTEX: usize = 3;

/// How much the virtual pairs' threshold grows at a time: each growth
/// searches every vertex's neighbourhood again, so a few large steps
/// cost less than many small ones, and the heap still takes the
/// cheapest pairs first within each.
const GAP_GROWTH: f64 = 4.0;

/// Vertices of one grid cell examined per neighbour search.
const MAX_SCANNED_PER_CELL: usize = 16;

/// The largest gap closed, as a fraction of the mesh's extent: beyond a
/// quarter of it, contraction is joining the mesh's far ends.
const MAX_GAP_OF_EXTENT: f64 = 0.25;

/// A contraction must keep at least this fraction of the area of the
/// triangles around its pair that do not degenerate.
const MIN_AREA_KEPT: f64 = 0.5;

#[cfg(test)]
mod tests {
    use super::*;

    /// The level of `target` triangles within `max_error`, from a fresh
    /// history.
    fn contract(p: &[[f32; 3]], i: &[u32], target: usize, max_error: f32) -> Contracted {
        History::new(p, i, target).level(p, i, target, max_error)
    }

    /// An axis-aligned box's 8 corners and 12 triangles, outward.
    fn cube(lo: [f32; 3], hi: [f32; 3], out_p: &mut Vec<[f32; 3]>, out_i: &mut Vec<u32>) {
        let base = out_p.len() as u32;
        for k in 0..8 {
            out_p.push([
                if k & 1 == 0 { lo[0] } else { hi[0] },
                if k & 2 == 0 { lo[1] } else { hi[1] },
                if k & 4 == 0 { lo[2] } else { hi[2] },
            ]);
        }
        let faces = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        for f in faces {
            out_i.extend([f[0], f[1], f[2], f[0], f[2], f[3]].map(|v| base + v));
        }
    }

    fn live(c: &Contracted) -> usize {
        c.indices.len() / 3
    }

    #[test]
    fn empty_and_degenerate_input_give_nothing() {
        let c = contract(&[], &[], 0, 1.0);
        assert!(c.indices.is_empty());
        let p = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let c = contract(&p, &[0, 0, 1], 0, 1.0);
        assert!(c.indices.is_empty());
    }

    #[test]
    fn a_zero_limit_changes_nothing_that_is_not_flat() {
        let (mut p, mut i) = (Vec::new(), Vec::new());
        cube([0.0; 3], [1.0; 3], &mut p, &mut i);
        let c = contract(&p, &i, 0, 0.0);
        assert_eq!(live(&c), 12);
    }

    #[test]
    fn a_flat_grid_contracts_far_without_moving_off_its_plane_or_outline() {
        // A 16 x 16 grid of cells on y = 0: interior vertices slide in the
        // plane at no cost; boundary planes hold the square's outline.
        let n = 16;
        let mut p = Vec::new();
        for z in 0..=n {
            for x in 0..=n {
                p.push([x as f32, 0.0, z as f32]);
            }
        }
        let mut i = Vec::new();
        let at = |x: u32, z: u32| z * (n + 1) + x;
        for z in 0..n {
            for x in 0..n {
                i.extend([at(x, z), at(x, z + 1), at(x + 1, z + 1)]);
                i.extend([at(x, z), at(x + 1, z + 1), at(x + 1, z)]);
            }
        }
        let c = contract(&p, &i, 8, 0.01);
        assert!(live(&c) <= 64, "{} triangles left", live(&c));
        assert!(c.error <= 0.01);
        let mut area = 0.0;
        for t in c.indices.chunks_exact(3) {
            let v = |k: usize| glam::Vec3::from_array(p[t[k] as usize]);
            for k in 0..3 {
                assert!(v(k).y.abs() < 1e-4);
                assert!((-1e-3..=n as f32 + 1e-3).contains(&v(k).x));
            }
            area += 0.5 * (v(1) - v(0)).cross(v(2) - v(0)).length();
        }
        // The outline held: the square's area within a few percent.
        let full = (n * n) as f32;
        assert!((area - full).abs() < 0.05 * full, "area {area} of {full}");
    }

    #[test]
    fn two_cubes_across_a_small_gap_merge_but_not_across_a_large_one() {
        let (mut p, mut i) = (Vec::new(), Vec::new());
        cube([0.0; 3], [1.0; 3], &mut p, &mut i);
        cube([1.02, 0.0, 0.0], [2.02, 1.0, 1.0], &mut p, &mut i);
        // At a limit of 0.05 the facing corners (0.02 apart) are virtual
        // pairs, and meet.
        let c = contract(&p, &i, 0, 0.05);
        let joined = c
            .indices
            .chunks_exact(3)
            .any(|t| t.iter().any(|&v| v < 8) && t.iter().any(|&v| v >= 8));
        assert!(joined, "no triangle spans the two cubes");
        // At a tenth of the gap no pair across costs little enough (each
        // corner's cost is its mean squared distance to its three faces,
        // so meeting at either end costs at least 0.02 / sqrt(5)).
        let c = contract(&p, &i, 0, 0.002);
        for t in c.indices.chunks_exact(3) {
            assert!(t.iter().all(|&v| v < 8) || t.iter().all(|&v| v >= 8));
        }
    }

    #[test]
    fn a_thin_plate_closes_into_one_sheet() {
        // A 4 x 4 plate 0.01 thick: at a limit of 0.01 its two faces'
        // corners pair up and the plate becomes a sheet (repeated
        // triangles dropped) of at most the 12 triangles it had.
        let (mut p, mut i) = (Vec::new(), Vec::new());
        cube([0.0; 3], [4.0, 0.01, 4.0], &mut p, &mut i);
        let c = contract(&p, &i, 0, 0.01);
        assert!(live(&c) < 12, "{} triangles left", live(&c));
        for t in c.indices.chunks_exact(3) {
            for &v in t {
                let y = p[v as usize][1];
                assert!((-1e-4..=0.0101).contains(&y), "y {y}");
            }
        }
    }

    #[test]
    fn the_target_stops_contraction() {
        let (mut p, mut i) = (Vec::new(), Vec::new());
        for k in 0..10 {
            let x = 2.0 * k as f32;
            cube([x, 0.0, 0.0], [x + 1.0, 1.0, 1.0], &mut p, &mut i);
        }
        let c = contract(&p, &i, 60, f32::MAX);
        assert!(live(&c) <= 60 && live(&c) >= 50, "{}", live(&c));
    }

    /// The virtual pairs' grid search finds what a search of every pair
    /// finds: each vertex's nearest (ties by index) higher vertices
    /// within the gap that share no triangle and are not its partners
    /// yet, at most [`VIRTUAL_PER_VERTEX`]; also on a second, wider pass.
    #[test]
    fn the_grid_finds_the_nearest_partners_a_full_search_finds() {
        // 300 scattered triangles in a box of 10 (a fixed sequence).
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let (mut p, mut i) = (Vec::new(), Vec::new());
        for t in 0..300u32 {
            let c = [10.0 * next(), 10.0 * next(), 10.0 * next()];
            for _ in 0..3 {
                p.push([
                    c[0] + 0.2 * next(),
                    c[1] + 0.2 * next(),
                    c[2] + 0.2 * next(),
                ]);
            }
            i.extend([3 * t, 3 * t + 1, 3 * t + 2]);
        }
        let mut g = Gaps::new(&p, &i);
        for gap in [0.5, 1.0] {
            // Every cell holds few enough vertices to be scanned whole.
            let mut cells: FxHashMap<[i64; 3], usize> = FxHashMap::default();
            for q in &g.pos {
                *cells
                    .entry([q.x, q.y, q.z].map(|c| (c / gap).floor() as i64))
                    .or_default() += 1;
            }
            assert!(cells.values().all(|&n| n <= MAX_SCANNED_PER_CELL));
            let mut want = Vec::new();
            for v in 0..g.pos.len() {
                let mut near: Vec<(f64, u32)> = (v + 1..g.pos.len())
                    .map(|u| (g.pos[u].distance_squared(g.pos[v]), u as u32))
                    .filter(|&(d2, u)| {
                        d2 <= gap * gap && u / 3 != v as u32 / 3 && !g.virtual_pairs[v].contains(&u)
                    })
                    .collect();
                near.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                want.extend(
                    near.iter()
                        .take(VIRTUAL_PER_VERTEX)
                        .map(|&(_, u)| (v as u32, u)),
                );
            }
            let mut got = g.add_virtual_pairs(gap);
            got.sort_unstable();
            want.sort_unstable();
            assert!(!want.is_empty());
            assert_eq!(got, want, "gap {gap}");
        }
    }
}
