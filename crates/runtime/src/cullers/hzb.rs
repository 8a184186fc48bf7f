//! GigaWalk's hierarchical Z-buffer (Section 5.2): OR's depth of frame
//! i - lag's visible set, reduced to a pyramid that node boxes are tested
//! against: on OR's device up to the level it reads back, here from
//! there up (or, with `HzbBuild::Cpu`, here from the whole image). Needs
//! OR's depth, so it culls nothing in the startup bypass.

use web_time::Instant;

use gigawalk_cull::{BoxTest, Hzb, HzbOcclusion, TraversalStats};
use gigawalk_gpu::DepthLevel;

use super::{Setup, Traversal};
use crate::ms_since;
use crate::ResolvedOptions;
use crate::RuntimeError;

/// The pyramid, rebuilt every frame from OR's depth.
pub(crate) struct State {
    hzb: Hzb,
    /// OR's device's absolute depth error (`GpuContext::depth_error`):
    /// its depth is lowered by this much before the HZB is built from it,
    /// so the HZB is never nearer than the exact occluders (GL's depth
    /// leaves room for it).
    or_depth_error: f32,
    /// OR's depth so lowered (kept between frames).
    lowered: Vec<f32>,
}

impl State {
    pub fn new(setup: &Setup<'_>) -> Self {
        State {
            hzb: Hzb::new(),
            or_depth_error: setup.gpu.map_or(0.0, |rt| rt.devices[0].depth_error()),
            lowered: Vec::new(),
        }
    }

    /// Builds the HZB from OR's depth (the level of its pyramid OR read
    /// back); without depth (the startup bypass) the frame is not culled.
    pub fn prepare(
        &mut self,
        frame: u64,
        depth: Option<&DepthLevel>,
        opts: &ResolvedOptions,
    ) -> Result<(bool, f64), RuntimeError> {
        let Some(level) = depth else {
            return Ok((false, 0.0));
        };
        let d = &level.image;
        let t = Instant::now();
        let _s = tracing::info_span!("HZB build", frame).entered();
        self.hzb
            .rebuild_from_device(
                level.width,
                level.height,
                level.level,
                &d.depth,
                self.or_depth_error,
                opts.hzb_reduction,
                &mut self.lowered,
            )
            .map_err(|source| RuntimeError::Hzb { frame, source })?;
        Ok((true, ms_since(t)))
    }

    pub fn cull(&mut self, t: &mut Traversal<'_, '_>) -> TraversalStats {
        t.run(&mut BoxTest(&HzbOcclusion::new(&self.hzb)))
    }
}
