//! The work of each stage for one frame, shared by the pipelined and the
//! sequential schedule (so both run the same algorithms).

#[cfg(feature = "testing")]
mod cpu;
mod or;
mod rvg;
mod stc;
mod tile_frame;

use or::{GpuOccluders, OccluderTarget};
pub(crate) use or::{OrFigures, OrOutput, OrStage, OrSubmitted};
pub(crate) use rvg::{FrameStyle, RvgStage};
use rvg::{GpuVisible, VisibleTarget};
pub(crate) use stc::{StcOutput, StcStage};
pub use tile_frame::TileFrame;

use std::sync::Mutex;

use gigawalk_cull::DrawItem;

use crate::streaming::Prefetch;
use crate::ResolvedOptions;
use gigawalk_gpu::{DepthPass, GpuContext, VisiblePass};
use gigawalk_scene::Skeleton;

use crate::occluders::AdaptiveBudget;
use crate::streaming::{Geometry, Link, LodSource, Plan, StreamStats, Use};
use crate::{Runtime, RuntimeError};
/// A stage's device, its geometry there, and (streaming) its end of the
/// run's loader queues.
pub(crate) struct DeviceGeometry<'a> {
    pub ctx: &'a GpuContext,
    pub geometry: &'a Geometry,
    pub skeleton: &'a Skeleton,
    pub plan: Option<&'a Plan>,
    pub link: Option<Link>,
}

impl<'a> DeviceGeometry<'a> {
    pub fn new(rt: &'a Runtime, device: usize, link: Option<Link>) -> Self {
        DeviceGeometry {
            ctx: &rt.devices[device],
            geometry: &rt.geometry[device],
            skeleton: rt.skeleton,
            plan: rt.plan.as_ref(),
            link,
        }
    }

    /// Runs `f` with what to draw for `lods` (see `Geometry::with`); an
    /// error when the loader has stopped (its own error is the cause).
    fn with<T>(
        &self,
        frame: u64,
        lods: &[u32],
        usage: Use,
        f: impl FnOnce(&dyn gigawalk_gpu::Residency, &[u32]) -> T,
    ) -> Result<T, RuntimeError> {
        self.geometry
            .with(
                self.ctx,
                self.skeleton,
                self.plan,
                self.link.as_ref(),
                frame,
                lods,
                usage,
                f,
            )
            .ok_or(RuntimeError::LoaderStopped)
    }

    pub fn take_stats(&self) -> StreamStats {
        self.geometry.take_stats()
    }
}

/// Absolute LOD ids (indices into `Skeleton::lods`) of draw items.
pub(crate) fn lod_ids(skeleton: &Skeleton, items: &[DrawItem]) -> Vec<u32> {
    items
        .iter()
        .map(|i| skeleton.nodes()[i.node as usize].first_lod + i.lod)
        .collect()
}

/// What the stages draw on: the runtime's wgpu devices, or (the
/// `testing` feature's `run_on_cpu`) the CPU's software depth
/// rasterizer, so the schedules can be tested without an adapter.
#[derive(Clone, Copy)]
pub(crate) struct Target<'a> {
    pub skeleton: &'a Skeleton,
    pub source: &'a dyn LodSource,
    pub plan: Option<&'a Plan>,
    pub(super) devices: Devices<'a>,
    /// How many occluders OR draws (set by the schedule).
    pub occluders: OrBudget<'a>,
}

/// What OR and RVG draw on.
#[derive(Clone, Copy)]
pub(super) enum Devices<'a> {
    Gpu(&'a Runtime<'a>),
    /// The CPU's software depth (`Target::cpu`, for tests).
    #[cfg(feature = "testing")]
    Cpu,
}

/// The occluder budget as OR applies it.
#[derive(Clone, Copy)]
pub(crate) enum OrBudget<'a> {
    All,
    Triangles(u64),
    Adaptive(&'a Mutex<AdaptiveBudget>),
}

impl<'a> Target<'a> {
    pub fn gpu(rt: &'a Runtime<'a>) -> Self {
        Target {
            skeleton: rt.skeleton,
            source: rt.source,
            plan: rt.plan.as_ref(),
            devices: Devices::Gpu(rt),
            occluders: OrBudget::All,
        }
    }

    /// Depth only, no colour, no streaming (see `cpu::CpuRaster`).
    #[cfg(feature = "testing")]
    pub fn cpu(skeleton: &'a Skeleton, source: &'a dyn LodSource) -> Self {
        Target {
            skeleton,
            source,
            plan: None,
            devices: Devices::Cpu,
            occluders: OrBudget::All,
        }
    }

    /// The runtime whose devices the stages draw on (`None`: the CPU).
    pub fn runtime(&self) -> Option<&'a Runtime<'a>> {
        match self.devices {
            Devices::Gpu(rt) => Some(rt),
            #[cfg(feature = "testing")]
            Devices::Cpu => None,
        }
    }

    /// The same target, OR drawing occluders by `occluders`.
    pub fn with_occluders<'b>(self, occluders: OrBudget<'b>) -> Target<'b>
    where
        'a: 'b,
    {
        Target { occluders, ..self }
    }

    /// Whether OR's time comes out of RVG's: one device, a CPU rasterizer
    /// (its cores are RVG's), or the sequential schedule.
    pub fn or_shares_rvg(&self, opts: &ResolvedOptions) -> bool {
        match self.runtime() {
            None => true,
            Some(rt) => {
                opts.schedule == crate::Schedule::Sequential
                    || self.rvg_device(opts) == 0
                    || rt.rasterizes_on_cpu()
            }
        }
    }

    /// The device RVG draws on: the second when there are two and the
    /// options ask for two.
    pub fn rvg_device(&self, opts: &ResolvedOptions) -> usize {
        match self.runtime() {
            Some(rt) if opts.devices >= 2 && rt.devices.len() >= 2 => 1,
            _ => 0,
        }
    }

    /// STC, with the culler the options ask for when occlusion is on (an
    /// occlusion-query culler on RVG's device `rvg_device`).
    pub fn stc_stage(
        &self,
        opts: &'a ResolvedOptions,
        rvg_device: usize,
        prefetch: Option<Prefetch<'a>>,
    ) -> Result<StcStage<'a>, RuntimeError> {
        let mut stc = StcStage::new(self.skeleton, opts, prefetch);
        if opts.traversal.occlusion {
            let setup = crate::cullers::Setup {
                source: self.source,
                gpu: self.runtime(),
                rvg_device,
            };
            stc.culler = Some(crate::cullers::State::new(&setup, opts)?);
        }
        Ok(stc)
    }

    /// OR on device 0.
    pub fn or_stage(&self, opts: &'a ResolvedOptions, link: Option<Link>) -> OrStage<'a> {
        let (w, h) = opts.occluder_size();
        let render: Box<dyn OccluderTarget + 'a> = match self.devices {
            Devices::Gpu(rt) => {
                let device = DeviceGeometry::new(rt, 0, link);
                let pass = DepthPass::new(device.ctx, w, h);
                Box::new(GpuOccluders { device, pass })
            }
            #[cfg(feature = "testing")]
            Devices::Cpu => Box::new(cpu::CpuRaster::new(self.source, w, h)),
        };
        OrStage {
            skeleton: self.skeleton,
            opts,
            budget: self.occluders,
            render,
        }
    }

    /// RVG on `device`.
    pub fn rvg_stage(
        &self,
        opts: &'a ResolvedOptions,
        device: usize,
        link: Option<Link>,
    ) -> RvgStage<'a> {
        let render: Box<dyn VisibleTarget + 'a> = match self.devices {
            Devices::Gpu(rt) => {
                let device = DeviceGeometry::new(rt, device, link);
                let pass = VisiblePass::new(device.ctx, opts.width, opts.height);
                Box::new(GpuVisible {
                    device,
                    pass,
                    shown: Default::default(),
                })
            }
            #[cfg(feature = "testing")]
            Devices::Cpu => Box::new(cpu::CpuRaster::new(self.source, opts.width, opts.height)),
        };
        RvgStage {
            render,
            opts,
            started: None,
            frame: 0,
        }
    }
}
