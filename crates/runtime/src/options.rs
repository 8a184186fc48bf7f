//! Runtime options: every speed/accuracy knob of the pipeline.

use gigawalk_cull::{Reduction, TraversalOptions};

/// How the three stages run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Schedule {
    /// OR, STC and RVG on their own threads (and devices), joined by
    /// queues: the paper's pipeline (Section 5.1).
    Pipelined,
    /// One thread, one device, the same algorithms one after another: the
    /// baseline the pipeline is measured against.
    Sequential,
}

/// A stage of the pipeline, for statistics, tracing and errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Occluder render (GPU device A).
    Or,
    /// Scene traversal, culling and LOD selection (CPU).
    Stc,
    /// Render visible geometry (GPU device B).
    Rvg,
}

impl std::fmt::Display for Stage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Stage::Or => "OR",
            Stage::Stc => "STC",
            Stage::Rvg => "RVG",
        })
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct RuntimeOptions {
    pub schedule: Schedule,
    /// Viewport size of the visible render.
    pub width: u32,
    pub height: u32,
    /// Occlusion culling, HLOD and the pixel-error tolerance.
    pub traversal: TraversalOptions,
    /// Frame i's occluders are the visible set of frame i - lag (paper:
    /// 2, so OR never waits for the previous frame's STC; 1 is tighter but
    /// serialises OR behind STC). The first `lag` frames run without
    /// occlusion (startup bypass, Section 5.1.1).
    pub occluder_lag: u32,
    /// Occluder depth resolution as a fraction of the viewport (Section
    /// 5.3: lower is faster and approximate). 1 = conservative.
    pub occluder_scale: f64,
    /// At most this many triangles of occluders per frame, chosen by
    /// apparent size per triangle (`gigawalk_cull::select_occluders`).
    /// `None`: all of frame i - lag's visible set (the paper). Conservative
    /// either way: fewer occluders cull less, never wrongly. Where OR and
    /// RVG share a processor (lavapipe on the CPU) OR's cost comes out of
    /// RVG's time, and a budget trades culling for it.
    pub occluder_budget: Option<u64>,
    /// How the HZB reduces depth: farthest (conservative) or n-th farthest
    /// (approximate, Section 5.3).
    pub hzb_reduction: Reduction,
    /// Number of wgpu devices in pipelined mode (1 or 2).
    pub devices: usize,
    /// Visible items per RVG submission: RVG starts drawing a frame while
    /// STC is still traversing it.
    pub chunk: usize,
    /// Near plane distance in model units.
    pub near: f64,
    /// Asynchronous RVG (Section 5.3): RVG does not wait for STC's list of
    /// the current camera; it draws the newest finished list with the
    /// newest camera. Removes a frame of latency; may show brief occlusion
    /// errors when the camera moves fast. Pipelined schedule only.
    pub async_rvg: bool,
    /// Fill `FrameReport::culled` with every culled node (for the viewer's
    /// box overlay); off by default since big scenes cull many nodes.
    pub record_culled: bool,
    /// Test hook: make a stage fail at a frame, to check that any stage's
    /// error stops every stage.
    pub inject_failure: Option<(Stage, u64)>,
}

impl Default for RuntimeOptions {
    fn default() -> Self {
        RuntimeOptions {
            schedule: Schedule::Pipelined,
            width: 640,
            height: 360,
            traversal: TraversalOptions::default(),
            occluder_lag: 2,
            occluder_scale: 1.0,
            occluder_budget: None,
            hzb_reduction: Reduction::Farthest,
            devices: 2,
            chunk: 256,
            near: 0.05,
            async_rvg: false,
            record_culled: false,
            inject_failure: None,
        }
    }
}

impl RuntimeOptions {
    /// Checks the options; returns a message naming the bad one.
    pub fn validate(&self) -> Result<(), String> {
        if self.width == 0 || self.height == 0 || self.width > 16384 || self.height > 16384 {
            return Err(format!(
                "viewport {}x{} must be 1..=16384 on each side",
                self.width, self.height
            ));
        }
        if !(1..=2).contains(&self.occluder_lag) {
            return Err(format!("occluder lag {} must be 1 or 2", self.occluder_lag));
        }
        if !(self.occluder_scale > 0.0 && self.occluder_scale <= 1.0) {
            return Err(format!(
                "occluder scale {} must be in (0, 1]",
                self.occluder_scale
            ));
        }
        if !(1..=2).contains(&self.devices) {
            return Err(format!("devices {} must be 1 or 2", self.devices));
        }
        if !(self.traversal.pixel_tolerance >= 0.0 && self.traversal.pixel_tolerance.is_finite()) {
            return Err(format!(
                "pixel error {} must be a finite number >= 0",
                self.traversal.pixel_tolerance
            ));
        }
        if !(self.near > 0.0 && self.near.is_finite()) {
            return Err(format!("near plane {} must be > 0", self.near));
        }
        if let Reduction::NthFarthest(n) = self.hzb_reduction {
            if !(1..=4).contains(&n) {
                return Err(format!("n-th farthest HZB needs n in 1..=4, got {n}"));
            }
        }
        if self.async_rvg && self.schedule == Schedule::Sequential {
            return Err("asynchronous RVG needs the pipelined schedule".into());
        }
        if self.chunk == 0 {
            return Err("chunk must be at least 1".into());
        }
        Ok(())
    }

    /// The occluder depth image size.
    pub fn occluder_size(&self) -> (u32, u32) {
        let s = |v: u32| ((v as f64 * self.occluder_scale).round() as u32).max(1);
        (s(self.width), s(self.height))
    }
}
