//! The adaptive occluder budget (`--occluder-budget adaptive`): how many
//! occluder triangles OR draws, chosen frame by frame from what they cost
//! and what they save.
//!
//! OR redraws frame i - lag's visible set as occluders (GigaWalk Section
//! 5.1.1). Where occlusion hides much (plants with walls), that pays; in an
//! open hall of dense parts (a factory floor of CAD assemblies) OR can spend
//! more than RVG saves: 129 ms a frame for 20% fewer triangles on the real
//! CAD bench (docs/results.md, "Occluder budget"). A fixed budget
//! is right for one scene and wrong for the next, and the right budget
//! changes along a walk.
//!
//! The controller climbs a ladder of budgets (0, 1024, 2048, ... triangles,
//! then all) one rung at a time. Every few frames it *probes* a neighbouring
//! rung for [`PROBE_FRAMES`] frames and compares their modelled cost with
//! the frames just before and just after at the current rung (a sandwich,
//! so a camera that drifts does not decide). A probe that is cheaper by
//! [`MARGIN`] is taken and the next probe goes the same way; one that is
//! not flips the direction, and after a failure both ways the probes get
//! rarer (up to one every [`MAX_HOLD`] frames), since the walk may still
//! change what pays.
//!
//! A frame's cost is modelled from counts, which are far less noisy than
//! times on shared cores: `a_or x occluder triangles + a_rvg x drawn
//! triangles`, with the per-triangle rates fitted (least squares, clamped
//! to the mean ratio) over the last [`WINDOW`] frames. On one device, or
//! where a device rasterizes on the CPU, OR's time comes out of RVG's and
//! the costs add; on two GPUs in the pipelined schedule OR runs beside RVG
//! and the frame costs the slower of the two.
//!
//! Culling stays conservative at every budget: fewer occluders only make
//! the HZB farther ([`gigawalk_cull::select_occluders`] keeps those that
//! hide most per triangle). What the controller picks depends on timings,
//! so two runs may draw different triangle counts.

use std::collections::VecDeque;
use std::sync::{Mutex, MutexGuard};

/// Frames a probe lasts, and frames at the current rung after it before
/// the verdict.
pub(crate) const PROBE_FRAMES: u64 = 4;
/// Frames at a rung before the first probe, and after a probe that moved.
const MIN_HOLD: u64 = 4;
/// The longest wait between probes (after failures both ways).
pub(crate) const MAX_HOLD: u64 = 64;
/// A probe is taken when its modelled cost is at least this share lower.
pub(crate) const MARGIN: f64 = 0.03;
/// Frames the cost rates are fitted over.
pub(crate) const WINDOW: usize = 48;
/// The lowest nonzero rung; below it the ladder goes to no occluders.
pub(crate) const MIN_RUNG: u64 = 1024;
/// The rung the controller starts on: all occluders (the paper).
const START: Option<u64> = None;

/// What one finished frame says (`FrameReport`, less what the controller
/// does not use).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Observation {
    pub frame: u64,
    /// The budget OR drew the frame's occluders with (`None`: all).
    pub limit: Option<u64>,
    /// Occluder triangles OR drew, and those it had before the budget.
    pub occluder_triangles: u64,
    pub candidate_triangles: u64,
    pub or_ms: f64,
    pub drawn_triangles: u64,
    pub rvg_ms: f64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Direction {
    Down,
    Up,
}

#[derive(Clone, Copy, Debug)]
struct Probe {
    limit: Option<u64>,
    /// Frames `start..start + PROBE_FRAMES` draw with `limit`.
    start: u64,
    direction: Direction,
}

/// Counts of what the controller did, for tests and reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct ControlStats {
    pub probes: u64,
    pub moves: u64,
    /// Probes given up for want of frames (held culling, reused sets).
    pub abandoned: u64,
}

/// The controller; OR asks it for each frame's budget, and every finished
/// frame is reported to it. Shared between stages behind a mutex.
#[derive(Debug)]
pub(crate) struct AdaptiveBudget {
    /// OR and RVG share the hardware: their costs add.
    shared: bool,
    current: Option<u64>,
    probe: Option<Probe>,
    direction: Direction,
    /// Frames to wait at the current rung before the next probe.
    hold: u64,
    /// No probe starts before a frame past this one has been observed.
    rest_until: u64,
    /// The last probe failed (then one failing the other way backs off).
    failed_last: bool,
    /// The highest frame OR has asked about: a new probe starts after it.
    planned: Option<u64>,
    history: VecDeque<Observation>,
    pub stats: ControlStats,
}

impl AdaptiveBudget {
    pub fn new(shared: bool) -> Self {
        AdaptiveBudget {
            shared,
            current: START,
            probe: None,
            direction: Direction::Down,
            hold: MIN_HOLD,
            rest_until: MIN_HOLD,
            failed_last: false,
            planned: None,
            history: VecDeque::with_capacity(WINDOW + 1),
            stats: ControlStats::default(),
        }
    }

    /// The budget for `frame`'s occluders (`None`: all of them).
    pub fn limit_for(&mut self, frame: u64) -> Option<u64> {
        self.planned = Some(self.planned.map_or(frame, |p| p.max(frame)));
        match self.probe {
            Some(p) if (p.start..p.start + PROBE_FRAMES).contains(&frame) => p.limit,
            _ => self.current,
        }
    }

    /// The rung frames are drawn with outside probes.
    #[cfg(test)]
    pub fn current(&self) -> Option<u64> {
        self.current
    }

    /// Takes a finished frame into account (frames arrive in order).
    pub fn observe(&mut self, o: Observation) {
        self.history.push_back(o);
        while self.history.len() > WINDOW {
            self.history.pop_front();
        }
        match self.probe {
            Some(p) => self.judge(p, o.frame),
            None if o.frame >= self.rest_until => self.start_probe(),
            None => {}
        }
    }

    /// Mean triangles OR had before the budget in the recent frames.
    fn candidates(&self) -> f64 {
        let recent: Vec<f64> = self
            .history
            .iter()
            .rev()
            .take(PROBE_FRAMES as usize * 2)
            .map(|o| o.candidate_triangles as f64)
            .collect();
        recent.iter().sum::<f64>() / recent.len().max(1) as f64
    }

    /// The rung next to the current one in `d` (`None` when there is none
    /// that would draw differently).
    fn neighbour(&self, d: Direction) -> Option<Option<u64>> {
        let candidates = self.candidates();
        // Rungs at or above what OR has are all occluders.
        let current = self.current.filter(|&b| (b as f64) < candidates);
        match (d, current) {
            (Direction::Up, None) => None,
            (Direction::Up, Some(0)) => Some(Some(MIN_RUNG).filter(|&r| (r as f64) < candidates)),
            (Direction::Up, Some(b)) => {
                let up = b.saturating_mul(2);
                Some(Some(up).filter(|&r| (r as f64) < candidates))
            }
            (Direction::Down, Some(0)) => None,
            (Direction::Down, Some(b)) if b <= MIN_RUNG => Some(Some(0)),
            (Direction::Down, Some(b)) => Some(Some(b / 2)),
            (Direction::Down, None) if candidates <= MIN_RUNG as f64 => Some(Some(0)),
            (Direction::Down, None) => {
                // The largest power of two below what OR draws now.
                let c = candidates as u64;
                Some(Some(
                    1u64 << (63 - c.saturating_sub(1).max(1).leading_zeros()),
                ))
            }
        }
    }

    fn start_probe(&mut self) {
        let mut direction = self.direction;
        let mut next = self.neighbour(direction);
        if next.is_none() {
            direction = match direction {
                Direction::Down => Direction::Up,
                Direction::Up => Direction::Down,
            };
            next = self.neighbour(direction);
        }
        let Some(limit) = next else {
            return;
        };
        let start = self.planned.map_or(0, |p| p + 1);
        self.direction = direction;
        self.stats.probes += 1;
        self.probe = Some(Probe {
            limit,
            start,
            direction,
        });
    }

    /// Decides probe `p` once the frames after it are in.
    fn judge(&mut self, p: Probe, frame: u64) {
        let end = p.start + PROBE_FRAMES;
        if frame + 1 < end + PROBE_FRAMES {
            return;
        }
        let at = |o: &&Observation, limit: Option<u64>| o.limit == limit;
        let probed: Vec<Observation> = self
            .history
            .iter()
            .filter(|o| (p.start..end).contains(&o.frame) && at(o, p.limit))
            .copied()
            .collect();
        // Neighbours only: frames far from the probe saw another view.
        let near = p.start.saturating_sub(4 * PROBE_FRAMES)..end + 2 * PROBE_FRAMES;
        let before: Vec<Observation> = self
            .history
            .iter()
            .rev()
            .filter(|o| near.contains(&o.frame) && o.frame < p.start && at(o, self.current))
            .take(PROBE_FRAMES as usize)
            .copied()
            .collect();
        let after: Vec<Observation> = self
            .history
            .iter()
            .filter(|o| near.contains(&o.frame) && o.frame >= end && at(o, self.current))
            .take(PROBE_FRAMES as usize)
            .copied()
            .collect();
        self.probe = None;
        if probed.len() < 2 || before.is_empty() || after.is_empty() {
            self.stats.abandoned += 1;
            self.rest_until = frame + self.hold;
            return;
        }
        let model = CostModel::fit(self.history.iter(), self.shared);
        let mean =
            |v: &[Observation]| v.iter().map(|o| model.cost(o)).sum::<f64>() / v.len() as f64;
        let reference = (mean(&before) + mean(&after)) / 2.0;
        if mean(&probed) < reference * (1.0 - MARGIN) {
            self.current = p.limit;
            self.stats.moves += 1;
            self.failed_last = false;
            self.hold = MIN_HOLD;
        } else {
            if self.failed_last {
                self.hold = (self.hold * 2).min(MAX_HOLD);
            }
            self.failed_last = true;
            self.direction = match p.direction {
                Direction::Down => Direction::Up,
                Direction::Up => Direction::Down,
            };
        }
        self.rest_until = frame + self.hold;
    }
}

/// The controller, whatever a stage that panicked while holding it left:
/// its state is a budget and counts, never inconsistent.
pub(crate) fn lock(c: &Mutex<AdaptiveBudget>) -> MutexGuard<'_, AdaptiveBudget> {
    c.lock().unwrap_or_else(|p| p.into_inner())
}

/// A stage's time as `intercept + rate x triangles`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Line {
    intercept: f64,
    rate: f64,
}

impl Line {
    /// Least squares over `(triangles, ms)`, the rate clamped to
    /// `[0, mean ms / mean triangles]`: a fixed cost makes the mean ratio
    /// an upper bound of the rate, and a noisy fit is never negative.
    fn fit(points: impl Iterator<Item = (f64, f64)>) -> Line {
        let (mut n, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (x, y) in points.filter(|(x, y)| x.is_finite() && y.is_finite()) {
            n += 1.0;
            sx += x;
            sy += y;
            sxx += x * x;
            sxy += x * y;
        }
        if n == 0.0 || sx <= 0.0 {
            return Line {
                intercept: if n > 0.0 { sy / n } else { 0.0 },
                rate: 0.0,
            };
        }
        let ratio = sy / sx;
        let var = sxx - sx * sx / n;
        let rate = if n >= 4.0 && var > 1e-9 * sxx {
            ((sxy - sx * sy / n) / var).clamp(0.0, ratio)
        } else {
            ratio
        };
        Line {
            intercept: (sy - rate * sx) / n,
            rate,
        }
    }

    fn at(&self, x: u64) -> f64 {
        self.intercept + self.rate * x as f64
    }
}

/// The modelled cost of a frame, from its counts.
#[derive(Clone, Copy, Debug)]
struct CostModel {
    or: Line,
    rvg: Line,
    shared: bool,
}

impl CostModel {
    fn fit<'o>(history: impl Iterator<Item = &'o Observation> + Clone, shared: bool) -> Self {
        CostModel {
            or: Line::fit(
                history
                    .clone()
                    .map(|o| (o.occluder_triangles as f64, o.or_ms)),
            ),
            rvg: Line::fit(history.map(|o| (o.drawn_triangles as f64, o.rvg_ms))),
            shared,
        }
    }

    fn cost(&self, o: &Observation) -> f64 {
        let (or, rvg) = (
            self.or.at(o.occluder_triangles),
            self.rvg.at(o.drawn_triangles),
        );
        if self.shared {
            or + rvg
        } else {
            or.max(rvg)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scene for the controller: `candidates` occluder triangles a frame;
    /// `hidden(budget)` the triangles occlusion hides with that many
    /// occluders (concave: the best occluders first); `visible` drawn
    /// without occlusion; OR and RVG cost `or_rate` and `rvg_rate` ms a
    /// triangle plus fixed costs. Runs `frames` frames with `lag` frames in
    /// flight (OR asks `lag` frames ahead of the last finished one) and
    /// returns the controller and the mean modelled ms per frame.
    #[derive(Clone, Copy)]
    struct Sim {
        candidates: u64,
        visible: u64,
        hidden: fn(u64) -> u64,
        or_rate: f64,
        rvg_rate: f64,
        noise: f64,
    }

    impl Sim {
        fn frame(&self, frame: u64, limit: Option<u64>) -> Observation {
            let o = limit.map_or(self.candidates, |b| b.min(self.candidates));
            let drawn = self.visible - (self.hidden)(o).min(self.visible);
            // Deterministic jitter, +-noise of each time.
            let j = |k: u64| {
                let h = (frame.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ k)
                    .wrapping_mul(0xBF58_476D_1CE4_E5B9);
                1.0 + self.noise * ((h >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0)
            };
            Observation {
                frame,
                limit,
                occluder_triangles: o,
                candidate_triangles: self.candidates,
                or_ms: (1.0 + self.or_rate * o as f64) * j(1),
                drawn_triangles: drawn,
                rvg_ms: (2.0 + self.rvg_rate * drawn as f64) * j(2),
            }
        }

        fn run(&self, frames: u64, lag: u64, shared: bool) -> (AdaptiveBudget, Vec<Observation>) {
            let mut c = AdaptiveBudget::new(shared);
            let mut asked = VecDeque::new();
            let mut seen = Vec::new();
            for f in 0..frames + lag {
                if f < frames {
                    asked.push_back((f, c.limit_for(f)));
                }
                if f >= lag {
                    let (g, limit) = asked.pop_front().unwrap();
                    let o = self.frame(g, limit);
                    c.observe(o);
                    seen.push(o);
                }
            }
            (c, seen)
        }

        /// Modelled ms (the simulation's own costs) of a frame at `limit`.
        fn cost(&self, limit: Option<u64>) -> f64 {
            let o = Sim {
                noise: 0.0,
                ..*self
            }
            .frame(0, limit);
            o.or_ms + o.rvg_ms
        }
    }

    /// Occlusion with diminishing returns: the first 32k occluder
    /// triangles hide most (like the CAD floor's walls of cabinets).
    fn saturating(o: u64) -> u64 {
        (60_000.0 * (1.0 - (-(o as f64) / 16_000.0).exp())) as u64
    }

    /// The real-CAD floor's shape: 246k occluder triangles, 311k drawn
    /// without occlusion, 0.45 us a drawn triangle; OR's rate and the
    /// noise vary by test.
    const CAD_FLOOR: Sim = Sim {
        candidates: 246_000,
        visible: 311_000,
        hidden: saturating,
        or_rate: 6e-4,
        rvg_rate: 4.5e-4,
        noise: 0.05,
    };

    #[test]
    fn an_expensive_or_comes_down_to_the_budget_that_pays() {
        // The CAD floor's shape: 246k occluder triangles at 0.6 us each
        // against 0.45 us per drawn triangle.
        let sim = Sim {
            or_rate: 6e-4,
            noise: 0.05,
            ..CAD_FLOOR
        };
        let (c, seen) = sim.run(240, 2, true);
        let b = c.current().expect("came down from all");
        // The best rung: cost is minimal where the marginal occluder
        // triangle hides 0.6/0.45 triangles, near 2^14-2^15.
        assert!((8_192..=65_536).contains(&b), "settled at {b}");
        let last: f64 = seen[120..].iter().map(|o| o.or_ms + o.rvg_ms).sum::<f64>() / 120.0;
        assert!(
            last < 0.8 * sim.cost(None),
            "{last} ms against {} at all",
            sim.cost(None)
        );
        assert!(
            c.stats.moves >= 3 && c.stats.abandoned == 0,
            "{:?}",
            c.stats
        );
    }

    #[test]
    fn cheap_occluders_that_hide_much_stay_all() {
        // A plant: each of 40k occluder triangles hides 4 of a 200k visible
        // set.
        let sim = Sim {
            candidates: 40_000,
            visible: 200_000,
            hidden: |o| (4 * o).min(160_000),
            or_rate: 2e-4,
            rvg_rate: 4.5e-4,
            noise: 0.05,
        };
        let (c, seen) = sim.run(240, 2, true);
        // Down-probes cost more, so nothing moved, and they got rarer.
        assert_eq!(c.current(), None, "{:?}", c.stats);
        assert_eq!(c.stats.moves, 0);
        let probing = seen[120..].iter().filter(|o| o.limit.is_some()).count();
        assert!(probing <= 16, "{probing} of the last 120 frames probed");
    }

    #[test]
    fn occlusion_that_hides_nothing_sheds_its_occluders() {
        let sim = Sim {
            candidates: 100_000,
            visible: 300_000,
            hidden: |_| 0,
            or_rate: 5e-4,
            rvg_rate: 4.5e-4,
            noise: 0.05,
        };
        let (c, _) = sim.run(400, 2, true);
        // Each halving saves less; below 16k it is under the margin.
        assert!(
            c.current().is_some_and(|b| b <= 16_384),
            "{:?} {:?}",
            c.current(),
            c.stats
        );
    }

    #[test]
    fn on_two_gpus_or_beside_rvg_costs_nothing_until_it_is_slower() {
        // OR at 1/4 of RVG's rate: drawing all occluders never makes OR the
        // slower stage, and every one of them saves RVG time.
        let sim = Sim {
            or_rate: 1e-4,
            noise: 0.05,
            ..CAD_FLOOR
        };
        let (separate, _) = sim.run(240, 2, false);
        assert_eq!(separate.current(), None, "{:?}", separate.stats);
    }

    #[test]
    fn a_climb_back_up_when_occluders_start_to_pay() {
        // First an open hall (occlusion hides nothing), then walls.
        let mut c = AdaptiveBudget::new(true);
        let open = Sim {
            candidates: 100_000,
            visible: 300_000,
            hidden: |_| 0,
            or_rate: 5e-4,
            rvg_rate: 4.5e-4,
            noise: 0.02,
        };
        let walls = Sim {
            hidden: |o| (290_000.0 * (1.0 - (-(o as f64) / 30_000.0).exp())) as u64,
            or_rate: 1e-4,
            ..open
        };
        for f in 0..600 {
            let sim = if f < 300 { open } else { walls };
            let limit = c.limit_for(f);
            c.observe(sim.frame(f, limit));
            if f == 299 {
                assert!(
                    c.current().is_some_and(|b| b <= 16_384),
                    "{:?}",
                    c.current()
                );
            }
        }
        let b = c.current();
        assert!(b.is_none_or(|b| b >= 32_768), "stayed at {b:?}");
    }

    #[test]
    fn frames_that_never_arrive_abandon_the_probe_not_the_run() {
        let mut c = AdaptiveBudget::new(true);
        let sim = Sim {
            or_rate: 6e-4,
            noise: 0.0,
            ..CAD_FLOOR
        };
        for f in 0..100 {
            let limit = c.limit_for(f);
            // Frames 8-40 held their culling: OR drew nothing, no report.
            if !(8..40).contains(&f) {
                c.observe(sim.frame(f, limit));
            }
        }
        assert!(c.stats.abandoned >= 1, "{:?}", c.stats);
        assert!(c.stats.moves >= 1, "{:?}", c.stats);
    }

    #[test]
    fn the_ladder_and_the_fit() {
        let mut c = AdaptiveBudget::new(true);
        let o = |candidates| Observation {
            frame: 0,
            limit: None,
            occluder_triangles: candidates,
            candidate_triangles: candidates,
            or_ms: 1.0,
            drawn_triangles: 10,
            rvg_ms: 1.0,
        };
        c.history.push_back(o(100_000));
        assert_eq!(c.neighbour(Direction::Down), Some(Some(65_536)));
        assert_eq!(c.neighbour(Direction::Up), None);
        c.current = Some(65_536);
        assert_eq!(c.neighbour(Direction::Up), Some(None));
        assert_eq!(c.neighbour(Direction::Down), Some(Some(32_768)));
        c.current = Some(MIN_RUNG);
        assert_eq!(c.neighbour(Direction::Down), Some(Some(0)));
        c.current = Some(0);
        assert_eq!(c.neighbour(Direction::Down), None);
        assert_eq!(c.neighbour(Direction::Up), Some(Some(MIN_RUNG)));
        c.history.clear();
        c.history.push_back(o(65_536));
        c.current = None;
        assert_eq!(c.neighbour(Direction::Down), Some(Some(32_768)));
        c.history.clear();
        c.history.push_back(o(500));
        assert_eq!(c.neighbour(Direction::Down), Some(Some(0)));

        // A fixed cost: the fit finds the slope, not the ratio.
        let l = Line::fit((1..=10).map(|i| (i as f64 * 1000.0, 5.0 + i as f64)));
        assert!(
            (l.rate - 1e-3).abs() < 1e-9 && (l.intercept - 5.0).abs() < 1e-6,
            "{l:?}"
        );
        // One x: the ratio. A negative slope (noise): zero.
        let l = Line::fit([(1000.0, 2.0), (1000.0, 3.0)].into_iter());
        assert!((l.rate - 2.5e-3).abs() < 1e-12, "{l:?}");
        let l = Line::fit((1..=10).map(|i| (i as f64, 20.0 - i as f64)));
        assert_eq!(l.rate, 0.0);
        // Nothing drawn: no rate, the mean time.
        let l = Line::fit([(0.0, 2.0), (0.0, 4.0)].into_iter());
        assert_eq!(
            l,
            Line {
                intercept: 3.0,
                rate: 0.0
            }
        );
    }
}
