//! The HUD's text: frame rate, each stage's milliseconds, latency, what was
//! drawn and culled, the mode and the toggles; and the frame-rate clock.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use gigawalk_cull::TraversalStats;
pub use gigawalk_review::group;

use crate::settings::Settings;

/// The frame rate is averaged over this window: long enough to be steady
/// to read, short enough to follow a walk into a denser area.
pub const FPS_WINDOW: Duration = Duration::from_millis(500);

/// Frame finish times over the last [`FPS_WINDOW`].
#[derive(Debug, Default)]
pub struct FrameClock {
    finished: VecDeque<Instant>,
}

impl FrameClock {
    pub fn tick(&mut self, at: Instant) {
        self.finished.push_back(at);
        while let Some(&first) = self.finished.front() {
            if at.duration_since(first) > FPS_WINDOW && self.finished.len() > 2 {
                self.finished.pop_front();
            } else {
                break;
            }
        }
    }

    /// Frames per second over the window; 0 before two frames.
    pub fn fps(&self) -> f64 {
        match (self.finished.front(), self.finished.back()) {
            (Some(&a), Some(&b)) if self.finished.len() >= 2 && b > a => {
                (self.finished.len() - 1) as f64 / b.duration_since(a).as_secs_f64()
            }
            _ => 0.0,
        }
    }
}

/// One frame's numbers, as the runtime reported them.
#[derive(Clone, Debug, Default)]
pub struct FrameNumbers {
    pub frame: u64,
    pub or_ms: f64,
    pub hzb_ms: f64,
    pub stc_ms: f64,
    pub rvg_ms: f64,
    pub latency_ms: f64,
    pub occlusion_used: bool,
    /// Occluder triangles OR drew.
    pub occluder_triangles: u64,
    pub stats: TraversalStats,
    /// Streaming figures (zeros when the scene is resident).
    pub streaming: gigawalk_runtime::StreamStats,
    /// Tiled display: the grid, the busiest tile's triangles, and the
    /// adaptive and naive methods' ms.
    pub tiles: Option<(String, u64, f64, f64)>,
    /// The pixel error the frame was culled with.
    pub pixel_error: f64,
    /// What the culler did beyond traversal (none for the HZB).
    pub culler_work: Option<gigawalk_runtime::CullerWork>,
}

/// The viewer's state the HUD shows besides the frame's numbers.
#[derive(Clone, Debug, Default)]
pub struct ViewerState {
    pub walking: bool,
    pub speed: f64,
    pub recording: Option<usize>,
    pub devices: String,
    /// A short-lived message (screenshot written, path saved, error).
    pub message: Option<String>,
    /// How many occluder triangles OR draws a frame.
    pub occluder_budget: gigawalk_runtime::OccluderSelection,
    /// The selection, hidden count and search, as HUD lines.
    pub objects: Vec<String>,
    /// The search prompt's text while it is open.
    pub prompt: Option<String>,
    /// The saved views' names, for the help.
    pub views: Vec<String>,
    /// The measurement, and the units its label is in: the presenter
    /// projects it with each frame's own camera.
    pub measure: gigawalk_review::measure::Measure,
    pub units: gigawalk_scene::units::Units,
}

pub fn hud_lines(fps: f64, n: &FrameNumbers, s: &Settings, v: &ViewerState) -> Vec<String> {
    let st = &n.stats;
    let mut lines = vec![
        format!(
            "{fps:6.1} fps   frame {}   latency {:.1} ms",
            n.frame, n.latency_ms
        ),
        format!(
            "OR {:.1}  HZB {:.1}  STC {:.1}  RVG {:.1} ms",
            n.or_ms, n.hzb_ms, n.stc_ms, n.rvg_ms
        ),
        format!(
            "drawn {} tris in {} nodes ({} visited)",
            group(st.drawn_triangles),
            group(st.drawn_nodes),
            group(st.visited)
        ),
        format!(
            "culled: {} frustum, {} occlusion{}",
            group(st.frustum_culled),
            group(st.occlusion_culled),
            if s.occlusion && !n.occlusion_used {
                " (startup bypass)"
            } else {
                ""
            }
        ),
        match (
            s.occlusion && s.culler.needs_occluder_depth(),
            v.occluder_budget,
        ) {
            (true, gigawalk_runtime::OccluderSelection::Triangles(t)) => {
                format!("mode: {}, occluders <= {} tris", s.mode(), group(t))
            }
            (true, gigawalk_runtime::OccluderSelection::Adaptive) => format!(
                "mode: {}, occluders {} tris (adaptive)",
                s.mode(),
                group(n.occluder_triangles)
            ),
            _ => format!("mode: {}", s.mode()),
        },
    ];
    if s.target {
        lines.push(format!(
            "target {:.0} fps (K): {fps:.1} fps at pixel error {:.2}",
            s.target_fps, n.pixel_error
        ));
    }
    if let Some(w) = &n.culler_work {
        lines.push(culler_line(w));
    }
    if let Some((grid, busiest, adaptive, naive)) = &n.tiles {
        lines.push(format!(
            "tiles {grid}: busiest {} tris; to tiles {adaptive:.2} ms adaptive, {naive:.2} ms naive",
            group(*busiest)
        ));
    }
    let sm = &n.streaming;
    if sm.pool_bytes > 0 {
        let mb = |b: u64| b as f64 / (1u64 << 20) as f64;
        lines.push(format!(
            "stream: {:.0}/{:.0} MB resident, {} loads asked, {} stand-ins{}",
            mb(sm.resident_bytes),
            mb(sm.pool_bytes),
            sm.requests,
            sm.substituted,
            if sm.missing > 0 {
                format!(", {} missing", sm.missing)
            } else {
                String::new()
            }
        ));
    }
    let mut flags = Vec::new();
    if s.async_rvg {
        flags.push("async");
    }
    if s.frozen {
        flags.push("FROZEN culling");
    }
    if s.boxes {
        flags.push("boxes");
    }
    if s.wireframe {
        flags.push("wireframe");
    }
    if s.look.edges {
        flags.push("edges");
    }
    if s.look.ao {
        flags.push("AO");
    }
    if s.look.aa != gigawalk_gpu::Antialias::Off {
        flags.push("FXAA");
    }
    if s.xray {
        flags.push("x-ray");
    }
    lines.push(format!(
        "{} {:.3} u/s{}{}",
        if v.walking { "walk" } else { "fly" },
        v.speed,
        if flags.is_empty() { "" } else { "   " },
        flags.join(", ")
    ));
    if let Some(poses) = v.recording {
        lines.push(format!("* REC path: {poses} poses (R stops)"));
    }
    lines.extend(v.objects.iter().cloned());
    if let Some(m) = &v.message {
        lines.push(m.clone());
    }
    lines.push(format!("{}   F1: help", v.devices));
    lines
}

/// The culler's counts a frame, named as it names them without its own
/// prefix: "grid: raster ms 1.200, pixel reads 12,345, ...".
fn culler_line(w: &gigawalk_runtime::CullerWork) -> String {
    let c = w.culler();
    let prefix = format!("{c}_");
    let counts: Vec<String> = c
        .counters()
        .iter()
        .zip(w.counts())
        .map(|(k, v)| {
            let name = k
                .name
                .strip_prefix(&prefix)
                .unwrap_or(k.name)
                .replace('_', " ");
            let d = k.decimals;
            if d == 0 {
                format!("{name} {}", group(v.max(0.0) as u64))
            } else {
                format!("{name} {v:.d$}")
            }
        })
        .collect();
    format!("{c}: {}", counts.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fps_over_evenly_spaced_frames() {
        let mut c = FrameClock::default();
        let t0 = Instant::now();
        assert_eq!(c.fps(), 0.0);
        for i in 0..=10 {
            c.tick(t0 + Duration::from_millis(20 * i));
        }
        assert!((c.fps() - 50.0).abs() < 1e-6, "{}", c.fps());
        // Old frames leave the window.
        c.tick(t0 + Duration::from_millis(2000));
        c.tick(t0 + Duration::from_millis(2100));
        assert!((c.fps() - 10.0).abs() < 1e-6, "{}", c.fps());
    }

    #[test]
    fn hud_shows_stages_counts_mode_and_flags() {
        let n = FrameNumbers {
            frame: 7,
            or_ms: 1.0,
            stc_ms: 2.5,
            stats: TraversalStats {
                drawn_triangles: 1_500_000,
                occlusion_culled: 42,
                ..Default::default()
            },
            streaming: gigawalk_runtime::StreamStats {
                resident_bytes: 300 << 20,
                pool_bytes: 1 << 30,
                requests: 12,
                substituted: 5,
                ..Default::default()
            },
            culler_work: Some(gigawalk_runtime::CullerWork::Oq(
                gigawalk_runtime::OqStats {
                    queries: 1234,
                    round_trips: 40,
                    ms: 1.5,
                    ..Default::default()
                },
            )),
            ..Default::default()
        };
        let s = Settings {
            frozen: true,
            ..Default::default()
        };
        let v = ViewerState {
            recording: Some(3),
            objects: vec!["selected: Pump (12 tris; F frames it)".into()],
            occluder_budget: gigawalk_runtime::OccluderSelection::Triangles(30_000),
            ..Default::default()
        };
        let text = hud_lines(60.0, &n, &s, &v).join("\n");
        for want in [
            "60.0 fps",
            "STC 2.5",
            "1,500,000 tris",
            "stream: 300/1024 MB resident, 12 loads asked, 5 stand-ins",
            "42 occlusion",
            "occlusion (hzb) + HLOD",
            "FROZEN",
            "REC",
            "startup bypass",
            "occluders <= 30,000 tris",
            "oq: queries 1,234, round trips 40, ms 1.500, untested 0",
            "selected: Pump",
            "F1: help",
        ] {
            assert!(text.contains(want), "{want:?} missing from\n{text}");
        }
        assert!(text.is_ascii());
    }
}
