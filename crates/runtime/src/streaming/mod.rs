//! Out-of-core geometry (GigaWalk Section 7.3's asynchronous fourth
//! process, with the finite memory footprint its Section 8 names): each
//! device keeps LODs in a fixed [`GeometryPool`] under a memory budget; a
//! loader thread reads the LODs the visible render asks for, and every
//! device takes them in between its draws; the least recently drawn LODs
//! make room, and a LOD asked for may displace stand-ins still in use
//! (`DeviceStream::take`). Until a LOD arrives RVG draws the finest
//! resident coarser stand-in (a coarser LOD of the node, else an
//! ancestor's HLOD) and the frame counts it as substituted. OR draws only
//! resident occluders, never a stand-in, so occlusion culling stays
//! conservative.
//!
//! A small pinned set (the coarsest LOD of the nodes nearest the root, up
//! to [`PINNED_SHARE`] of the budget and at most [`PINNED_MAX`]) is loaded
//! before the first frame and
//! never evicted: the first frame draws from it, and a stand-in always
//! exists for every node under it.
//!
//! Files: `plan.rs` what the devices share (owners, the pinned set, who
//! holds what, the frame clock); `pool.rs` one device's pool, its LRU and
//! what goes in and out of it; `stand_ins.rs` what is drawn for a LOD
//! not resident; `loader.rs` the loader thread; `prefetch.rs` STC's
//! requests for what the camera will soon need.

use std::sync::{Arc, Mutex};

use crossbeam_channel::{Receiver, Sender};
use gigawalk_gpu::{DecodedLod, GpuContext, Residency, ResidentGeometry, VertexLayout};
use gigawalk_scene::{LodInfo, LodMesh, ReadAt, ReadError, SceneReader, Skeleton, StoredLod};

mod loader;
mod plan;
mod pool;
mod prefetch;
mod stand_ins;

pub(crate) use loader::{loader, Queue};
pub(crate) use plan::Plan;
pub(crate) use pool::DeviceStream;
pub(crate) use prefetch::Prefetch;

/// Where LODs are read from while a walk runs: a scene file.
pub trait LodSource: Sync {
    fn read_lod(&self, lod: u32) -> Result<LodMesh, ReadError>;
    /// The LOD as stored (an encoded LOD not dequantized: the loader
    /// hands grid coordinates to the devices as they are).
    fn read_lod_stored(&self, lod: u32) -> Result<StoredLod, ReadError> {
        self.read_lod(lod).map(StoredLod::Mesh)
    }
    /// The scene's stored occluders (`None`: the file has none).
    fn occluders(
        &self,
    ) -> Result<Option<Vec<gigawalk_scene::occluders::OccluderRecord>>, ReadError> {
        Ok(None)
    }
    /// The occluders' view cells (`None`: the file has none), checked
    /// against a scene of `occluders` occluders.
    fn occluder_cells(
        &self,
        occluders: usize,
    ) -> Result<Option<gigawalk_scene::occluder_cells::OccluderCells>, ReadError> {
        let _ = occluders;
        Ok(None)
    }
}

impl<R: ReadAt + Sync> LodSource for SceneReader<R> {
    fn read_lod(&self, lod: u32) -> Result<LodMesh, ReadError> {
        SceneReader::read_lod(self, lod)
    }
    fn read_lod_stored(&self, lod: u32) -> Result<StoredLod, ReadError> {
        SceneReader::read_lod_stored(self, lod)
    }
    fn occluders(
        &self,
    ) -> Result<Option<Vec<gigawalk_scene::occluders::OccluderRecord>>, ReadError> {
        SceneReader::occluders(self)
    }
    fn occluder_cells(
        &self,
        occluders: usize,
    ) -> Result<Option<gigawalk_scene::occluder_cells::OccluderCells>, ReadError> {
        SceneReader::occluder_cells(self, occluders)
    }
}

/// Share of the memory budget the pinned set may take ...
pub const PINNED_SHARE: f64 = 0.125;
/// ... and at most this many bytes: it is read before the first frame.
pub const PINNED_MAX: u64 = 32 << 20;

/// Frames after which an unanswered request is asked again, and after
/// which the loader drops a request the camera has moved away from.
const STALE_FRAMES: u64 = 2;

/// Prefetches STC may queue for the loader, in their own queue so they
/// never crowd out RVG's requests (measured: in one shared queue they made
/// 4x the stand-ins after warm-up on the 50M plant).
pub(crate) const PREFETCH_QUEUE: usize = 1024;

/// Requests RVG may queue for the loader; more in one frame wait for the
/// next. A camera that jumps leaves no backlog: the loader drops requests
/// more than [`STALE_FRAMES`] older than the newest. (256 held the 50M
/// plant's first frames to about 300 loads a frame.)
pub(crate) const REQUEST_QUEUE: usize = 4096;

/// Loaded LODs a device may have waiting to be put into its pool. OR
/// empties its inbox once a frame, and the loader waits while an inbox is
/// full: 64 held the loader to about 1.5 MB a frame on the 50M plant.
/// LODs are at most a few tens of KB (`--node-budget` triangles), so this
/// bounds the host memory in flight to tens of MB.
pub(crate) const INBOX: usize = 1024;

/// Device bytes a LOD takes (its vertex layout and index format as the
/// record states them).
fn lod_bytes(l: &LodInfo) -> u64 {
    gigawalk_gpu::device_bytes(l)
}

/// Device bytes the whole scene takes resident on one device, at most: a
/// memory budget at least this large loads it whole. (The resident
/// geometry starts a LOD's vertices on a whole vertex of its layout, so
/// where the layout changes from one LOD to the next it may pad by up to
/// a wide vertex less 4 bytes.)
pub fn scene_device_bytes(skeleton: &Skeleton) -> u64 {
    let lods = skeleton.lods();
    let switches = lods
        .windows(2)
        .filter(|w| VertexLayout::of(&w[0]) != VertexLayout::of(&w[1]))
        .count() as u64;
    lods.iter().map(lod_bytes).sum::<u64>() + switches * (VertexLayout::Wide.stride() - 4)
}

/// Per-frame streaming figures of the device that draws the visible set
/// (when OR shares it, loads OR took in count for the frame RVG ends next).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StreamStats {
    /// Device bytes the resident LODs take after the frame.
    pub resident_bytes: u64,
    /// Device bytes of the pool (fixed: the budget, rounded down).
    pub pool_bytes: u64,
    /// LODs that arrived on the device during the frame, and their bytes.
    pub loaded_lods: u64,
    pub loaded_bytes: u64,
    /// LODs evicted during the frame.
    pub evicted_lods: u64,
    /// ...of which stand-ins in use, displaced by a LOD asked for (see
    /// `DeviceStream::take`).
    pub displaced_stand_ins: u64,
    /// Requests sent to the loader during the frame.
    pub requests: u64,
    /// Draws of a coarser stand-in because the chosen LOD was not resident.
    pub substituted: u64,
    /// Chosen LODs with no resident stand-in at all (nothing drawn).
    pub missing: u64,
}

/// A request for one LOD, from the frame that wanted it: RVG's for a LOD
/// it had to stand in for, or STC's prefetch of one it will soon need.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Request {
    pub lod: u32,
    pub frame: u64,
    pub prefetch: bool,
}

/// A chosen LOD whose pixel error is above this share of the tolerance is
/// close to switching to its next finer level (or, for an inner node's
/// finest HLOD, to its children) as the camera approaches: STC prefetches
/// what it will switch to.
pub const PREFETCH_BAND: f64 = 0.5;

/// A LOD the loader read, for every device.
pub(crate) type Loaded = Arc<(u32, DecodedLod)>;

/// One device's geometry: all of it, or a streamed pool.
pub(crate) enum Geometry {
    Resident(ResidentGeometry),
    Streamed(Box<Mutex<DeviceStream>>),
}

/// How a stage uses the LODs it draws.
#[derive(Clone, Copy)]
pub(crate) enum Use<'v> {
    /// OR: resident LODs only, no requests, no stand-ins.
    Occluders,
    /// RVG: stand-ins for what is missing, requests for it. With hidden
    /// or highlighted objects (`shown`), no stand-in comes from a node
    /// that is not whole (see [`stand_ins`]).
    Visible {
        shown: Option<&'v gigawalk_cull::Visibility>,
    },
}

impl Use<'_> {
    /// RVG with every object shown whole.
    #[cfg(test)]
    pub const VISIBLE: Use<'static> = Use::Visible { shown: None };

    pub fn is_visible(&self) -> bool {
        matches!(self, Use::Visible { .. })
    }
}

/// A stage's end of one run's streaming queues.
#[derive(Clone)]
pub(crate) struct Link {
    pub requests: Option<Sender<Request>>,
    pub inbox: Receiver<Loaded>,
}

impl Geometry {
    /// Runs `f` with the residency to draw from and the LODs to draw for
    /// `lods`: as they are when everything is resident; streamed, after
    /// taking in what the loader delivered, with stand-ins (see
    /// [`DeviceStream::prepare`]). `None` when the loader has stopped.
    #[allow(clippy::too_many_arguments)]
    pub fn with<T>(
        &self,
        ctx: &GpuContext,
        skeleton: &Skeleton,
        plan: Option<&Plan>,
        link: Option<&Link>,
        frame: u64,
        lods: &[u32],
        usage: Use,
        f: impl FnOnce(&dyn Residency, &[u32]) -> T,
    ) -> Option<T> {
        match (self, plan, link) {
            (Geometry::Streamed(s), Some(plan), Some(link)) => {
                let mut s = s.lock().unwrap_or_else(|p| p.into_inner());
                let draw = s.prepare(ctx, skeleton, plan, link, frame, lods, usage)?;
                Some(f(s.pool(), &draw))
            }
            (Geometry::Resident(g), _, _) => Some(f(g, lods)),
            // Streamed without this run's queues: what is resident.
            (Geometry::Streamed(s), _, _) => {
                let s = s.lock().unwrap_or_else(|p| p.into_inner());
                let draw: Vec<u32> = lods
                    .iter()
                    .copied()
                    .filter(|&l| s.pool().contains(l))
                    .collect();
                Some(f(s.pool(), &draw))
            }
        }
    }

    /// The streaming figures since the last call: the frame's, when RVG
    /// calls it as the frame ends (zeros when all is resident).
    pub fn take_stats(&self) -> StreamStats {
        match self {
            Geometry::Resident(_) => StreamStats::default(),
            Geometry::Streamed(s) => s.lock().unwrap_or_else(|p| p.into_inner()).take_stats(),
        }
    }
}
