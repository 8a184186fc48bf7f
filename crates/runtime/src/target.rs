//! A target frame rate (the GigaWalk paper's future work, Section 8; after
//! Cesium's dynamic screen-space error): the pixel-error tolerance is
//! chosen per frame to hold the frame time.
//!
//! The model: a frame's time is about proportional to the triangles it
//! draws (what dominates on a rasterizer-bound device), and the triangles
//! an HLOD traversal draws fall as a power of the tolerance,
//! `T(p) = T(p0) (p0 / p)^alpha`. Each finished frame gives the time and
//! triangles at the tolerance it was drawn with; `alpha` is fitted from
//! successive frames (log-log slope, smoothed, kept in [0.3, 3]); the
//! next tolerance is the one whose predicted triangles fit the target:
//! `p = p0 (ms / target)^(1 / alpha)`. So the controller predicts from
//! the triangles a candidate tolerance would draw and corrects from the
//! measured time.
//!
//! Not oscillating: measured times are smoothed (exponentially, weight
//! [`SMOOTHING`]); within a dead band of [`DEAD_BAND`] around the target
//! the tolerance is kept (hysteresis); one step changes it by at most
//! [`MAX_STEP`] times; the pipeline's latency (a frame's time is known a
//! few frames after its tolerance was chosen) is why steps are damped.

/// Weight of the newest frame time in the smoothed time.
pub const SMOOTHING: f64 = 0.3;
/// The smoothed time may be this fraction off the target before the
/// tolerance changes.
pub const DEAD_BAND: f64 = 0.06;
/// Largest factor one frame changes the tolerance by.
pub const MAX_STEP: f64 = 1.25;
/// The tolerance never goes below this (pixels): at 0 the power law has
/// no meaning, and full detail is what `--pixel-error 0` is for.
pub const MIN_PIXEL_ERROR: f64 = 0.125;

/// Chooses each frame's pixel-error tolerance to hold a frame time.
#[derive(Clone, Debug)]
pub struct FrameRateController {
    target_ms: f64,
    max: f64,
    pixel_error: f64,
    alpha: f64,
    smoothed_ms: Option<f64>,
    /// The last frame fed: its tolerance and triangles.
    last: Option<(f64, f64)>,
}

impl FrameRateController {
    /// `start` is the first frames' tolerance; `max` the most it may reach.
    pub fn new(target_ms: f64, start: f64, max: f64) -> Self {
        let max = max.max(MIN_PIXEL_ERROR);
        FrameRateController {
            target_ms,
            max,
            pixel_error: start.clamp(MIN_PIXEL_ERROR, max),
            alpha: 1.0,
            smoothed_ms: None,
            last: None,
        }
    }

    /// The tolerance for the next frame.
    pub fn pixel_error(&self) -> f64 {
        self.pixel_error
    }

    /// Feeds a finished frame: its time, the triangles it drew and the
    /// tolerance it was drawn with. Returns the next frame's tolerance.
    pub fn update(&mut self, frame_ms: f64, triangles: u64, pixel_error: f64) -> f64 {
        if !(frame_ms.is_finite() && frame_ms > 0.0 && pixel_error > 0.0) {
            return self.pixel_error;
        }
        let t = triangles.max(1) as f64;
        // The triangles' response to the tolerance, from the last frame.
        if let Some((p0, t0)) = self.last {
            let dp = (pixel_error / p0).ln();
            if dp.abs() > 0.05 {
                let a = -(t / t0).ln() / dp;
                if a.is_finite() {
                    self.alpha = (0.7 * self.alpha + 0.3 * a).clamp(0.3, 3.0);
                }
            }
        }
        self.last = Some((pixel_error, t));
        let ms = match self.smoothed_ms {
            Some(s) => s + SMOOTHING * (frame_ms - s),
            None => frame_ms,
        };
        self.smoothed_ms = Some(ms);
        let off = ms / self.target_ms;
        if (off - 1.0).abs() <= DEAD_BAND {
            return self.pixel_error;
        }
        let wanted = pixel_error * off.powf(1.0 / self.alpha);
        // Move from the tolerance in use now, at most MAX_STEP a frame.
        let next = wanted
            .clamp(self.pixel_error / MAX_STEP, self.pixel_error * MAX_STEP)
            .clamp(MIN_PIXEL_ERROR, self.max);
        self.pixel_error = next;
        next
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A synthetic device: `base` triangles at tolerance 1 falling as
    /// p^-alpha, `ns` nanoseconds a triangle plus a fixed `fixed_ms`,
    /// `noise` relative jitter, and the frame's time known `lag` frames
    /// later (a pipeline).
    struct Model {
        base: f64,
        alpha: f64,
        ns: f64,
        fixed_ms: f64,
        noise: f64,
        lag: usize,
    }

    fn run(
        m: &Model,
        c: &mut FrameRateController,
        frames: usize,
        step_at: Option<(usize, f64)>,
    ) -> Vec<(f64, f64)> {
        let mut rng = 12345u64;
        let mut jitter = || {
            rng = rng
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((rng >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        let mut pending: std::collections::VecDeque<(f64, u64, f64)> = Default::default();
        let mut out = Vec::new();
        for f in 0..frames {
            let scale = match step_at {
                Some((at, s)) if f >= at => s,
                _ => 1.0,
            };
            let p = c.pixel_error();
            let tris = m.base * scale * p.powf(-m.alpha);
            let ms = (m.fixed_ms + tris * m.ns * 1e-6) * (1.0 + m.noise * jitter());
            pending.push_back((ms, tris as u64, p));
            if pending.len() > m.lag {
                let (ms, t, p) = pending.pop_front().unwrap();
                c.update(ms, t, p);
            }
            out.push((p, ms));
        }
        out
    }

    fn median(mut v: Vec<f64>) -> f64 {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    }

    #[test]
    fn it_converges_on_the_target_without_oscillating_through_steps_and_noise() {
        for (alpha, lag, noise) in [(1.0, 0, 0.0), (1.5, 2, 0.05), (0.7, 3, 0.1), (2.0, 1, 0.02)] {
            let m = Model {
                base: 400_000.0,
                alpha,
                ns: 50.0,
                fixed_ms: 3.0,
                noise,
                lag,
            };
            for target in [8.0, 12.0, 16.0] {
                let mut c = FrameRateController::new(target, 1.0, 64.0);
                let trace = run(&m, &mut c, 400, Some((200, 3.0)));
                let what = format!("alpha {alpha} lag {lag} noise {noise} target {target}");
                for (from, to) in [(100, 200), (300, 400)] {
                    let ms: Vec<f64> = trace[from..to].iter().map(|x| x.1).collect();
                    let med = median(ms.clone());
                    assert!(
                        (med / target - 1.0).abs() < 0.1,
                        "{what}: median {med} at {from}..{to}"
                    );
                    // Overshoot bounded: no frame after settling is 40% past
                    // the target beyond its noise.
                    let worst = ms.iter().cloned().fold(0.0, f64::max);
                    assert!(worst < target * (1.4 + noise), "{what}: worst {worst}");
                    // No oscillation: the tolerance changes direction rarely.
                    let p: Vec<f64> = trace[from..to].iter().map(|x| x.0).collect();
                    let mut turns = 0;
                    let mut dir = 0i32;
                    for w in p.windows(2) {
                        let d = (w[1] - w[0]).partial_cmp(&0.0).map_or(0, |o| o as i32);
                        if d != 0 && dir != 0 && d != dir {
                            turns += 1;
                        }
                        if d != 0 {
                            dir = d;
                        }
                    }
                    assert!(
                        turns <= 12,
                        "{what}: {turns} direction changes in 100 frames"
                    );
                }
                // After the step (3x the triangles) it is back within 10%
                // within 40 frames.
                let back = trace[200..]
                    .iter()
                    .position(|x| (x.1 / target - 1.0).abs() < 0.1 + noise)
                    .unwrap();
                assert!(back < 40, "{what}: {back} frames to recover");
            }
        }
    }

    #[test]
    fn it_stays_within_its_range_and_ignores_bad_input() {
        let mut c = FrameRateController::new(10.0, 1.0, 4.0);
        // An impossible target: the tolerance rises to the maximum, no more.
        for _ in 0..100 {
            let p = c.pixel_error();
            c.update(100.0, 1_000_000, p);
        }
        assert_eq!(c.pixel_error(), 4.0);
        // A trivially met target: down to the minimum, no less.
        for _ in 0..200 {
            let p = c.pixel_error();
            c.update(0.01, 10, p);
        }
        assert_eq!(c.pixel_error(), MIN_PIXEL_ERROR);
        let before = c.pixel_error();
        c.update(f64::NAN, 5, 1.0);
        c.update(-3.0, 5, 1.0);
        c.update(5.0, 5, 0.0);
        assert_eq!(c.pixel_error(), before);
    }
}
