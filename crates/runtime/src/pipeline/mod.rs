//! The schedules: three threads joined by queues (`pipelined`), the same
//! with asynchronous RVG (`asynchronous`), or one thread (`sequential`).
//! What they share is here: the frame messages, the occluder-lag and
//! frozen-culling bookkeeping, the streaming links and the threads' join.

mod asynchronous;
mod pipelined;
mod sequential;
mod stepped;

pub(crate) use asynchronous::run_async;
pub(crate) use pipelined::run_pipelined;
pub(crate) use sequential::run_sequential;
pub use stepped::{Stepped, SteppedOptions, OR_IN_FLIGHT};

use std::collections::VecDeque;
use std::sync::Arc;
use web_time::Instant;

use crossbeam_channel::{bounded, Receiver, Sender};
use gigawalk_cull::{CullView, DrawItem, Viewport};
use gigawalk_gpu::DepthLevel;

use crate::stages::{
    lod_ids, FrameStyle, OrFigures, OrStage, RvgStage, StcOutput, StcStage, Target,
};
use crate::streaming::Prefetch;
use crate::streaming::{
    self, Link, LodSource, Request, StreamStats, INBOX, PREFETCH_QUEUE, REQUEST_QUEUE,
};
use crate::ResolvedOptions;
use crate::{
    CameraError, CameraSource, FrameReport, OccluderSelection, Presenter, RuntimeError,
    RuntimeOptions, Stage,
};

/// A frame's visible set as OR gets it back for a later frame's occluders:
/// shared with the frame's report, never copied.
pub(super) type VisibleSet = Arc<[DrawItem]>;

/// Messages STC may queue for RVG: enough that STC never waits on RVG
/// within a frame.
pub(super) const RVG_QUEUE: usize = 64;

/// Frames between OR taking a camera and RVG finishing it: one per stage,
/// as in the paper's Figure 6. More would raise throughput only by queueing,
/// and every queued frame adds a frame of latency.
pub(super) const MAX_IN_FLIGHT: usize = 3;

/// One camera as OR took it.
#[derive(Clone)]
pub(super) struct Sample {
    pub(super) frame: u64,
    pub(super) view: CullView,
    pub(super) read_back: bool,
    pub(super) hold: bool,
    pub(super) style: FrameStyle,
    pub(super) sampled_at: Instant,
    /// The request's pixel error for this frame (`None`: the options').
    pub(super) pixel_error: Option<f64>,
}

/// OR -> STC: one frame's camera and occluder depth.
pub(super) struct OrToStc {
    pub(super) sample: Sample,
    pub(super) depth: Option<DepthLevel>,
    pub(super) or: OrFigures,
}

/// STC -> RVG: a frame is `Begin`, any number of `Items` (each drawn under
/// the last `Scissor`: a tile, or none), then the sentinel `End` carrying
/// the frame number, camera and statistics.
pub(super) enum StcToRvg {
    Begin(u64, Box<CullView>, FrameStyle),
    Scissor(Option<[u32; 4]>),
    Items(Vec<u32>),
    End(Box<FrameEnd>),
}

/// The chunks RVG draws for a finished visible set, each with the scissor
/// rectangle it is drawn under: without tiles, the LOD ids in STC's order
/// (no scissor); with tiles, each tile's list under its rectangle. A set
/// drawn with another camera than it was culled for (held culling,
/// asynchronous RVG) is sent to that camera's tiles again (`retile`).
pub(super) fn draw_plan(
    skeleton: &gigawalk_scene::Skeleton,
    s: &StcOutput,
    chunk: usize,
    retile: Option<(&CullView, &ResolvedOptions)>,
) -> Vec<(Option<[u32; 4]>, Vec<u32>)> {
    let ids = lod_ids(skeleton, &s.visible);
    let again = match (&s.tiles, retile) {
        (Some(t), Some((view, opts))) => Some(Arc::new(crate::stages::TileFrame::new(
            skeleton,
            view,
            t.grid,
            opts.tile_culling,
            &s.visible,
        ))),
        _ => None,
    };
    match again.as_ref().or(s.tiles.as_ref()) {
        None => ids.chunks(chunk).map(|c| (None, c.to_vec())).collect(),
        Some(t) => t
            .rects
            .iter()
            .zip(&t.lists)
            .flat_map(|(r, list)| {
                let lods: Vec<u32> = list.iter().map(|&i| ids[i as usize]).collect();
                lods.chunks(chunk)
                    .map(|c| (Some(*r), c.to_vec()))
                    .collect::<Vec<_>>()
            })
            .collect(),
    }
}

/// Draws a finished visible set on RVG ([`draw_plan`]).
pub(super) fn draw_set(
    rvg: &mut RvgStage,
    skeleton: &gigawalk_scene::Skeleton,
    s: &StcOutput,
    chunk: usize,
    retile: Option<(&CullView, &ResolvedOptions)>,
) -> Result<(), RuntimeError> {
    for (rect, lods) in draw_plan(skeleton, s, chunk, retile) {
        rvg.scissor(rect);
        rvg.draw(&lods)?;
    }
    rvg.scissor(None);
    Ok(())
}

/// What the sentinel carries.
pub(super) struct FrameEnd {
    pub(super) sample: Sample,
    pub(super) or: OrFigures,
    pub(super) stc: StcOutput,
    pub(super) reused: bool,
}

/// The view of camera request `frame`, or `None` at the end of the source.
pub(super) fn next_sample(
    source: &mut dyn CameraSource,
    frame: u64,
    opts: &ResolvedOptions,
) -> Result<Option<Sample>, RuntimeError> {
    match source.next_camera(frame)? {
        Some(req) => sample_of(req, frame, opts).map(Some),
        None => Ok(None),
    }
}

/// Camera request `req` as frame `frame`'s sample: its camera checked and
/// fitted to the options' viewport.
pub(super) fn sample_of(
    req: crate::CameraRequest,
    frame: u64,
    opts: &ResolvedOptions,
) -> Result<Sample, RuntimeError> {
    let viewport = Viewport::new(opts.width, opts.height);
    let camera = gigawalk_cull::Camera {
        aspect: viewport.aspect(),
        ..req.camera
    };
    if !camera.is_valid() {
        return Err(CameraError::Invalid { frame, camera }.into());
    }
    if let Some(value) = req.pixel_error.filter(|p| !(p.is_finite() && *p >= 0.0)) {
        return Err(CameraError::PixelError { frame, value }.into());
    }
    Ok(Sample {
        frame,
        view: CullView::new(camera, viewport)
            .with_visibility(req.visibility)
            .with_ghosts(req.ghosts)
            .with_section(req.section),
        read_back: req.read_back,
        hold: req.hold_culling,
        style: FrameStyle {
            draw: req.style,
            look: req.look,
        },
        sampled_at: Instant::now(),
        pixel_error: req.pixel_error,
    })
}

pub(super) fn report(
    end: FrameEnd,
    image: Option<gigawalk_gpu::FrameImage>,
    rvg_ms: f64,
    streaming: StreamStats,
) -> FrameReport {
    FrameReport {
        frame: end.sample.frame,
        camera: end.sample.view.camera,
        sampled_at: end.sample.sampled_at,
        finished_at: Instant::now(),
        occlusion_used: end.stc.occlusion_used,
        occluder_items: end.or.items,
        occluder_triangles: end.or.triangles,
        occluder_candidates: end.or.candidates,
        occluder_limit: end.or.limit,
        or_ms: end.or.ms,
        hzb_ms: end.stc.hzb_ms,
        hzb_level: end.or.level,
        traversal_ms: end.stc.traversal_ms,
        cull_test_ms: end.stc.test_ms,
        or_pass: end.or.pass,
        rvg_pass: Default::default(),
        culler_work: end.stc.culler_work,
        tiles: end.stc.tiles.clone(),
        pixel_error: end.stc.pixel_error,
        speculative: false,
        rvg_wait_ms: 0.0,
        stc_ms: end.stc.ms,
        rvg_ms,
        stats: end.stc.stats,
        streaming,
        visible: end.stc.visible,
        culled: end.stc.culled,
        reused_visible_set: end.reused,
        image,
    }
}

/// Finishes RVG's frame: presents, then reads back if asked.
pub(super) fn finish_frame(
    rvg: &mut RvgStage,
    presenter: &mut dyn Presenter,
    end: FrameEnd,
) -> Result<FrameReport, RuntimeError> {
    let read_back = end.sample.read_back;
    rvg.ghosts(&end.stc.ghosts)?;
    let rvg_ms = rvg.finish()?;
    let mut r = report(end, None, rvg_ms, rvg.stream_stats());
    rvg.present(presenter, &r)?;
    if read_back {
        r.image = rvg.read_back()?;
    }
    r.rvg_pass = rvg.take_figures();
    r.rvg_ms = (Instant::now() - r.finished_at).as_secs_f64() * 1e3 + rvg_ms;
    r.finished_at = Instant::now();
    Ok(r)
}

/// One run's streaming queues: the loader's ends of them.
pub(super) struct LoaderQueues<'a> {
    source: &'a dyn LodSource,
    requests: Receiver<Request>,
    prefetches: Receiver<Request>,
    devices: Vec<Sender<streaming::Loaded>>,
    plan: &'a streaming::Plan,
    mask: u8,
}

impl LoaderQueues<'_> {
    pub(super) fn body(self) -> Result<(), RuntimeError> {
        streaming::loader(
            self.source,
            self.requests,
            self.prefetches,
            self.devices,
            self.plan,
            self.mask,
        )
    }
}

/// One run's streaming ends: the loader's, OR's, RVG's and STC's
/// (prefetch, when on); all `None` when the scene is resident.
#[derive(Default)]
pub(super) struct StreamLinks<'a> {
    pub(super) loader: Option<LoaderQueues<'a>>,
    pub(super) or: Option<Link>,
    pub(super) rvg: Option<Link>,
    pub(super) stc: Option<Prefetch<'a>>,
}

/// When the runtime streams: the loader's queues, and OR's, RVG's and
/// STC's links (OR on device `a`, RVG on `b`; one inbox per device, both
/// stages' when they share one). Made per run, so the loader ends when
/// the stages drop their links.
pub(super) fn stream_links<'a>(
    t: Target<'a>,
    opts: &ResolvedOptions,
    a: usize,
    b: usize,
) -> StreamLinks<'a> {
    let (source, Some(plan)) = (t.source, t.plan) else {
        return StreamLinks::default();
    };
    let mask = (1u8 << a.min(7)) | (1u8 << b.min(7));
    plan.start_run();
    let (requests_tx, requests) = bounded(REQUEST_QUEUE);
    let (a_tx, a_rx) = bounded(INBOX);
    let mut devices = vec![a_tx];
    let (prefetch_tx, prefetches) = bounded(PREFETCH_QUEUE);
    // OR on a device of its own asks for the occluders it keeps there, as
    // prefetches (RVG's stand-ins first). On RVG's device it asks for
    // nothing: its asking would hold back RVG's demands for the same LODs.
    let or_link = Link {
        requests: (a != b).then(|| prefetch_tx.clone()),
        inbox: a_rx.clone(),
    };
    let rvg_inbox = if a == b {
        a_rx
    } else {
        let (b_tx, b_rx) = bounded(INBOX);
        devices.push(b_tx);
        b_rx
    };
    let stc = opts.prefetch.any().then(|| Prefetch {
        requests: prefetch_tx,
        plan,
        mask,
    });
    let rvg_link = Link {
        requests: Some(requests_tx),
        inbox: rvg_inbox,
    };
    StreamLinks {
        loader: Some(LoaderQueues {
            source,
            requests,
            prefetches,
            devices,
            plan,
            mask,
        }),
        or: Some(or_link),
        rvg: Some(rvg_link),
        stc,
    }
}

pub(super) fn panic_message(p: Box<dyn std::any::Any + Send>) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}

/// The stage bodies of a threaded schedule: OR on device 0, STC and RVG
/// for device `b`, each building its stage (with its streaming link) on
/// its own thread and handing it to `or`, `stc` and `rvg`; with the
/// loader's queues when the scene streams. For [`run_threads`].
pub(super) fn stage_bodies<'s>(
    t: Target<'s>,
    opts: &'s ResolvedOptions,
    b: usize,
    or: impl FnOnce(OrStage<'s>) -> Result<(), RuntimeError> + Send + 's,
    stc: impl FnOnce(StcStage<'s>) -> Result<(), RuntimeError> + Send + 's,
    rvg: impl FnOnce(RvgStage<'s>) -> Result<(), RuntimeError> + Send + 's,
) -> (Vec<(Stage, StageBody<'s>)>, Option<LoaderQueues<'s>>) {
    let links = stream_links(t, opts, 0, b);
    let (or_link, rvg_link, prefetch) = (links.or, links.rvg, links.stc);
    let stages: Vec<(Stage, StageBody<'s>)> = vec![
        (Stage::Or, Box::new(move || or(t.or_stage(opts, or_link)))),
        (
            Stage::Stc,
            Box::new(move || stc(t.stc_stage(opts, b, prefetch)?)),
        ),
        (
            Stage::Rvg,
            Box::new(move || rvg(t.rvg_stage(opts, b, rvg_link))),
        ),
    ];
    (stages, links.loader)
}

/// One stage's thread body.
pub(super) type StageBody<'scope> = Box<dyn FnOnce() -> Result<(), RuntimeError> + Send + 'scope>;

/// Runs the stage bodies (OR, STC, RVG, and the loader when streaming) on
/// their own threads, feeds reports to
/// `on_frame` on this thread, and returns the first stage error. A thread
/// the system cannot start is an error too: its body is dropped unrun,
/// which closes its queues, so the stages already started stop as they
/// would after a stage error.
pub(super) fn run_threads<'scope, 'env>(
    s: &'scope std::thread::Scope<'scope, 'env>,
    mut stages: Vec<(Stage, StageBody<'scope>)>,
    loader: Option<LoaderQueues<'scope>>,
    reports: Receiver<FrameReport>,
    on_frame: &mut dyn FnMut(FrameReport) -> bool,
) -> Result<u64, RuntimeError> {
    if let Some(l) = loader {
        stages.push((Stage::Loader, Box::new(move || l.body())));
    }
    let mut handles = Vec::with_capacity(stages.len());
    let mut first_error = None;
    for (stage, body) in stages {
        if first_error.is_some() {
            continue; // dropping the body closes its queues
        }
        match std::thread::Builder::new()
            .name(format!("gigawalk-{stage}"))
            .spawn_scoped(s, body)
        {
            Ok(h) => handles.push((stage, h)),
            Err(source) => first_error = Some(RuntimeError::Spawn { stage, source }),
        }
    }
    let mut frames = 0;
    let mut stopped = false;
    if first_error.is_none() {
        for report in reports.iter() {
            // Speculative frames are extra: the count is of cameras.
            frames += u64::from(!report.speculative);
            if !on_frame(report) {
                break;
            }
        }
    }
    // Closing the report queue stops RVG, whose queues closing stop the rest.
    drop(reports);
    for (stage, handle) in handles {
        let result = handle.join().unwrap_or_else(|p| {
            Err(RuntimeError::Panic {
                stage,
                message: panic_message(p),
            })
        });
        // A stage that merely saw its queue close returns Ok, so the error
        // kept is the root cause; one that saw the loader stop defers to
        // the loader's error.
        match result {
            Err(RuntimeError::LoaderStopped) => {
                stopped = true;
            }
            Err(e) => {
                first_error.get_or_insert(e);
            }
            Ok(()) => {}
        }
    }
    if stopped && first_error.is_none() {
        first_error = Some(RuntimeError::LoaderStopped);
    }
    match first_error {
        Some(e) => Err(e),
        None => Ok(frames),
    }
}

/// Frame i's occluders: the visible set of frame i - lag (paper Section
/// 5.1.1). Every schedule keeps them here, by frame number: the first
/// `lag` frames, and in the asynchronous schedule any frame with no
/// finished set that old, have none (the startup bypass).
pub(super) struct Occluders {
    /// (frame, visible set), oldest first.
    sets: VecDeque<(u64, VisibleSet)>,
    lag: u64,
    wanted: bool,
}

impl Occluders {
    pub(super) fn new(opts: &ResolvedOptions) -> Self {
        Occluders {
            sets: VecDeque::new(),
            lag: opts.occluder_lag as u64,
            wanted: opts.wants_occluder_depth(),
        }
    }

    /// Frame `frame`'s visible set, once culled.
    pub(super) fn push(&mut self, frame: u64, set: VisibleSet) {
        self.sets.push_back((frame, set));
        // Bounded whatever the caller asks for.
        while self.sets.len() > 64 {
            self.sets.pop_front();
        }
    }

    /// The occluders of frame `frame`: the newest set of a frame at least
    /// `lag` older; `None` when OR is not wanted or there is none yet.
    pub(super) fn for_frame(&mut self, frame: u64) -> Option<&[DrawItem]> {
        let cutoff = frame.checked_sub(self.lag).filter(|_| self.wanted)?;
        while self.sets.len() >= 2 && self.sets[1].0 <= cutoff {
            self.sets.pop_front();
        }
        self.sets
            .front()
            .filter(|(f, _)| *f <= cutoff)
            .map(|(_, s)| &s[..])
    }
}

/// Frozen culling: a frame that holds culling gets the last culled set,
/// unchanged. Before any frame was culled there is nothing to hold, so the
/// frame culls normally.
#[derive(Default)]
pub(super) struct Frozen {
    last: Option<StcOutput>,
}

impl Frozen {
    /// The held result for a frame that holds (`hold`), else `None`.
    pub(super) fn held(&self, hold: bool) -> Option<StcOutput> {
        let last = self.last.as_ref().filter(|_| hold)?;
        // A held frame did no culling work of its own.
        Some(StcOutput {
            ms: 0.0,
            hzb_ms: 0.0,
            culler_work: None,
            ..last.clone()
        })
    }

    pub(super) fn record(&mut self, s: &StcOutput) {
        self.last = Some(s.clone());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::RuntimeOptions;

    fn set(n: u32) -> VisibleSet {
        vec![DrawItem { node: n, lod: 0 }].into()
    }

    #[test]
    fn occluders_are_frame_i_minus_lag_and_none_in_the_startup_bypass() {
        let opts = RuntimeOptions::default().resolve(false).unwrap();
        let mut o = Occluders::new(&opts);
        assert!(o.for_frame(0).is_none() && o.for_frame(1).is_none());
        for f in 0..10u64 {
            if f >= 2 {
                assert_eq!(o.for_frame(f).unwrap()[0].node as u64, f - 2, "frame {f}");
            }
            o.push(f, set(f as u32));
        }
        // Frames skipped (asynchronous): the newest set at least lag older.
        let mut o = Occluders::new(&opts);
        o.push(3, set(3));
        o.push(7, set(7));
        assert!(o.for_frame(4).is_none());
        assert_eq!(o.for_frame(8).unwrap()[0].node, 3);
        assert_eq!(o.for_frame(9).unwrap()[0].node, 7);
        assert_eq!(o.for_frame(20).unwrap()[0].node, 7);
        // A culler that reads no occluder depth gets none.
        let grid = RuntimeOptions {
            culler: crate::CullMethod::Grid,
            ..Default::default()
        }
        .resolve(false)
        .unwrap();
        let mut o = Occluders::new(&grid);
        o.push(0, set(0));
        assert!(o.for_frame(5).is_none());
    }
}
