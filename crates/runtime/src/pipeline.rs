//! The schedules: three threads joined by queues (synchronous or with
//! asynchronous RVG), or one thread.

use std::sync::{Arc, Condvar, Mutex};
use std::time::Instant;

use crossbeam_channel::{bounded, unbounded, Receiver, Sender, TryRecvError};
use gigawalk_cull::{CullView, DrawItem, Viewport};
use gigawalk_gpu::{DepthImage, DrawStyle};

use crate::stages::{lod_ids, DeviceGeometry, OrStage, Prefetch, RvgStage, StcOutput, StcStage};
use crate::streaming::{
    self, Link, LodSource, Request, StreamStats, INBOX, PREFETCH_QUEUE, REQUEST_QUEUE,
};
use crate::{
    CameraError, CameraSource, FrameReport, Presenter, Runtime, RuntimeError, RuntimeOptions, Stage,
};

/// A frame's visible set as OR gets it back for a later frame's occluders:
/// shared with the frame's report, never copied.
type VisibleSet = Arc<[DrawItem]>;

/// Messages STC may queue for RVG: enough that STC never waits on RVG
/// within a frame.
const RVG_QUEUE: usize = 64;

/// Frames between OR taking a camera and RVG finishing it: one per stage,
/// as in the paper's Figure 6. More would raise throughput only by queueing,
/// and every queued frame adds a frame of latency.
const MAX_IN_FLIGHT: usize = 3;

/// One camera as OR took it.
#[derive(Clone)]
struct Sample {
    frame: u64,
    view: CullView,
    read_back: bool,
    hold: bool,
    style: DrawStyle,
    sampled_at: Instant,
}

/// OR -> STC: one frame's camera and occluder depth.
struct OrToStc {
    sample: Sample,
    depth: Option<DepthImage>,
    occluder_items: usize,
    or_ms: f64,
}

/// STC -> RVG: a frame is `Begin`, any number of `Items`, then the
/// sentinel `End` carrying the frame number, camera and statistics.
enum StcToRvg {
    Begin(u64, Box<CullView>, DrawStyle),
    Items(Vec<u32>),
    End(Box<FrameEnd>),
}

/// What the sentinel carries.
struct FrameEnd {
    sample: Sample,
    occluder_items: usize,
    or_ms: f64,
    stc: StcOutput,
    reused: bool,
}

/// The view of camera request `frame`, or `None` at the end of the source.
fn next_sample(
    source: &mut dyn CameraSource,
    frame: u64,
    opts: &RuntimeOptions,
) -> Result<Option<Sample>, RuntimeError> {
    let Some(req) = source.next_camera(frame)? else {
        return Ok(None);
    };
    let viewport = Viewport::new(opts.width, opts.height);
    let camera = gigawalk_cull::Camera {
        aspect: viewport.aspect(),
        ..req.camera
    };
    if !camera.is_valid() {
        return Err(CameraError::Invalid { frame, camera }.into());
    }
    Ok(Some(Sample {
        frame,
        view: CullView::new(camera, viewport),
        read_back: req.read_back,
        hold: req.hold_culling,
        style: req.style,
        sampled_at: Instant::now(),
    }))
}

/// Whether frame `frame` culls against occluders (not in the startup bypass).
fn wants_occluders(opts: &RuntimeOptions, frame: u64) -> bool {
    opts.wants_occluder_depth() && frame >= opts.occluder_lag as u64
}

/// The result of a frame that holds culling (`hold`): the last culled set,
/// unchanged. Before any frame was culled there is nothing to hold, so the
/// frame culls normally; a frame that does not hold gets `None`.
fn held(hold: bool, last: &Option<StcOutput>) -> Option<StcOutput> {
    let last = last.as_ref().filter(|_| hold)?;
    Some(StcOutput {
        ms: 0.0,
        hzb_ms: 0.0,
        ..last.clone()
    })
}

fn report(
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
        occluder_items: end.occluder_items,
        or_ms: end.or_ms,
        hzb_ms: end.stc.hzb_ms,
        grid: end.stc.grid,
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
fn finish_frame(
    rvg: &mut RvgStage,
    presenter: &mut dyn Presenter,
    end: FrameEnd,
) -> Result<FrameReport, RuntimeError> {
    let read_back = end.sample.read_back;
    let (_, rvg_ms) = rvg.finish(false)?;
    let mut r = report(end, None, rvg_ms, rvg.stream_stats());
    presenter
        .present(rvg.device.ctx, &rvg.pass, &r)
        .map_err(|source| RuntimeError::Gpu {
            stage: Stage::Rvg,
            source,
        })?;
    if read_back {
        r.image = rvg.read_back()?;
    }
    r.rvg_ms = (Instant::now() - r.finished_at).as_secs_f64() * 1e3 + rvg_ms;
    r.finished_at = Instant::now();
    Ok(r)
}

/// One run's streaming queues: the loader's ends of them.
struct LoaderQueues<'a> {
    source: &'a dyn LodSource,
    requests: Receiver<Request>,
    prefetches: Receiver<Request>,
    devices: Vec<Sender<streaming::Loaded>>,
    plan: &'a streaming::Plan,
    mask: u8,
}

impl LoaderQueues<'_> {
    fn body(self) -> Result<(), RuntimeError> {
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
struct StreamLinks<'a> {
    loader: Option<LoaderQueues<'a>>,
    or: Option<Link>,
    rvg: Option<Link>,
    stc: Option<Prefetch<'a>>,
}

/// When the runtime streams: the loader's queues, and OR's, RVG's and
/// STC's links (OR on device `a`, RVG on `b`; one inbox per device, both
/// stages' when they share one). Made per run, so the loader ends when
/// the stages drop their links.
fn stream_links<'a>(
    rt: &'a Runtime<'_>,
    opts: &RuntimeOptions,
    a: usize,
    b: usize,
) -> StreamLinks<'a> {
    let (source, Some(plan)) = (rt.source, rt.plan.as_ref()) else {
        return StreamLinks::default();
    };
    let mask = (1u8 << a.min(7)) | (1u8 << b.min(7));
    plan.start_run();
    let (requests_tx, requests) = bounded(REQUEST_QUEUE);
    let (a_tx, a_rx) = bounded(INBOX);
    let mut devices = vec![a_tx];
    let or_link = Link {
        requests: None,
        inbox: a_rx.clone(),
    };
    let rvg_inbox = if a == b {
        a_rx
    } else {
        let (b_tx, b_rx) = bounded(INBOX);
        devices.push(b_tx);
        b_rx
    };
    let (prefetch_tx, prefetches) = bounded(PREFETCH_QUEUE);
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

pub(crate) fn run_sequential(
    rt: &Runtime,
    opts: &RuntimeOptions,
    source: &mut dyn CameraSource,
    on_frame: &mut dyn FnMut(FrameReport) -> bool,
    presenter: &mut dyn Presenter,
) -> Result<u64, RuntimeError> {
    let StreamLinks {
        loader,
        or: or_link,
        rvg: rvg_link,
        stc: prefetch,
    } = stream_links(rt, opts, 0, 0);
    let Some(loader) = loader else {
        return sequential_frames(rt, opts, source, on_frame, presenter, None, None, None);
    };
    std::thread::scope(|s| {
        let handle = std::thread::Builder::new()
            .name(format!("gigawalk-{}", Stage::Loader))
            .spawn_scoped(s, move || loader.body())
            .map_err(|source| RuntimeError::Spawn {
                stage: Stage::Loader,
                source,
            })?;
        // The links drop when the frames end, which ends the loader.
        let frames = sequential_frames(
            rt, opts, source, on_frame, presenter, or_link, rvg_link, prefetch,
        );
        let loaded = handle.join().unwrap_or_else(|p| {
            Err(RuntimeError::Panic {
                stage: Stage::Loader,
                message: panic_message(p),
            })
        });
        match (frames, loaded) {
            (Err(RuntimeError::LoaderStopped), Err(e)) | (Ok(_), Err(e)) => Err(e),
            (frames, _) => frames,
        }
    })
}

#[allow(clippy::too_many_arguments)]
fn sequential_frames<'a>(
    rt: &'a Runtime,
    opts: &'a RuntimeOptions,
    source: &mut dyn CameraSource,
    on_frame: &mut dyn FnMut(FrameReport) -> bool,
    presenter: &mut dyn Presenter,
    or_link: Option<Link>,
    rvg_link: Option<Link>,
    prefetch: Option<Prefetch<'a>>,
) -> Result<u64, RuntimeError> {
    let mut or = OrStage::new(DeviceGeometry::new(rt, 0, or_link), opts);
    let mut stc = StcStage::new(rt.skeleton, rt.source, opts, prefetch);
    let mut rvg = RvgStage::new(DeviceGeometry::new(rt, 0, rvg_link), opts);
    let mut history: std::collections::VecDeque<VisibleSet> = Default::default();
    let mut last: Option<StcOutput> = None;
    let mut frame = 0u64;
    while let Some(sample) = next_sample(source, frame, opts)? {
        let view = sample.view.clone();
        let (stc_out, o, reused) = match held(sample.hold, &last) {
            Some(s) => (s, None, true),
            None => {
                let occluders = wants_occluders(opts, frame)
                    .then(|| history.front().map(|v| &v[..]).unwrap_or(&[]));
                let o = or.run(frame, &view, occluders)?;
                let s = stc.run(frame, &view, o.depth.as_ref(), &mut |_| {})?;
                (s, Some(o), false)
            }
        };
        rvg.begin(frame, &view, sample.style)?;
        // The same chunks as the pipeline, drawn after traversal.
        for chunk in lod_ids(rt.skeleton, &stc_out.visible).chunks(opts.chunk) {
            rvg.draw(chunk)?;
        }
        history.push_back(stc_out.visible.clone());
        if history.len() > opts.occluder_lag as usize {
            history.pop_front();
        }
        last = Some(stc_out.clone());
        let end = FrameEnd {
            sample,
            occluder_items: o.as_ref().map_or(0, |o| o.occluder_items),
            or_ms: o.as_ref().map_or(0.0, |o| o.ms),
            stc: stc_out,
            reused,
        };
        let r = finish_frame(&mut rvg, presenter, end)?;
        frame += 1;
        if !on_frame(r) {
            break;
        }
    }
    Ok(frame)
}

fn panic_message(p: Box<dyn std::any::Any + Send>) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}

/// One stage's thread body.
type StageBody<'scope> = Box<dyn FnOnce() -> Result<(), RuntimeError> + Send + 'scope>;

/// Runs the stage bodies (OR, STC, RVG, and the loader when streaming) on
/// their own threads, feeds reports to
/// `on_frame` on this thread, and returns the first stage error. A thread
/// the system cannot start is an error too: its body is dropped unrun,
/// which closes its queues, so the stages already started stop as they
/// would after a stage error.
fn run_threads<'scope, 'env>(
    s: &'scope std::thread::Scope<'scope, 'env>,
    stages: Vec<(Stage, StageBody<'scope>)>,
    reports: Receiver<FrameReport>,
    on_frame: &mut dyn FnMut(FrameReport) -> bool,
) -> Result<u64, RuntimeError> {
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
            frames += 1;
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

fn rvg_device(rt: &Runtime, opts: &RuntimeOptions) -> usize {
    if opts.devices >= 2 && rt.devices.len() >= 2 {
        1
    } else {
        0
    }
}

pub(crate) fn run_pipelined(
    rt: &Runtime,
    opts: &RuntimeOptions,
    source: &mut dyn CameraSource,
    on_frame: &mut dyn FnMut(FrameReport) -> bool,
    presenter: &mut dyn Presenter,
) -> Result<u64, RuntimeError> {
    // OR takes a token per frame and RVG returns it when the frame is done,
    // so at most MAX_IN_FLIGHT frames are between camera and screen.
    let (or_tx, or_rx) = bounded::<OrToStc>(1);
    let (rvg_tx, rvg_rx) = bounded::<StcToRvg>(RVG_QUEUE);
    let (feedback_tx, feedback_rx) = unbounded::<VisibleSet>();
    let (report_tx, report_rx) = bounded::<FrameReport>(1);
    let (token_tx, token_rx) = bounded::<()>(MAX_IN_FLIGHT);
    for _ in 0..MAX_IN_FLIGHT {
        token_tx.send(()).expect("room for every token");
    }
    let b = rvg_device(rt, opts);
    let StreamLinks {
        loader,
        or: or_link,
        rvg: rvg_link,
        stc: prefetch,
    } = stream_links(rt, opts, 0, b);
    std::thread::scope(|s| {
        let mut stages: Vec<(Stage, StageBody)> = vec![
            (
                Stage::Or,
                Box::new(move || {
                    let or = OrStage::new(DeviceGeometry::new(rt, 0, or_link), opts);
                    or_thread(or, opts, source, or_tx, feedback_rx, token_rx)
                }),
            ),
            (
                Stage::Stc,
                Box::new(move || {
                    let stc = StcStage::new(rt.skeleton, rt.source, opts, prefetch);
                    stc_thread(stc, rt, opts, or_rx, rvg_tx, feedback_tx)
                }),
            ),
            (
                Stage::Rvg,
                Box::new(move || {
                    let rvg = RvgStage::new(DeviceGeometry::new(rt, b, rvg_link), opts);
                    rvg_thread(rvg, rvg_rx, report_tx, token_tx, presenter)
                }),
            ),
        ];
        if let Some(l) = loader {
            stages.push((Stage::Loader, Box::new(move || l.body())));
        }
        run_threads(s, stages, report_rx, on_frame)
    })
}

fn or_thread(
    mut or: OrStage,
    opts: &RuntimeOptions,
    source: &mut dyn CameraSource,
    out: Sender<OrToStc>,
    feedback: Receiver<VisibleSet>,
    tokens: Receiver<()>,
) -> Result<(), RuntimeError> {
    let mut frame = 0u64;
    let mut occluders: VisibleSet = Arc::new([]);
    loop {
        // Wait until fewer than MAX_IN_FLIGHT frames are on their way to
        // the screen; RVG gone means the run is over.
        if tokens.recv().is_err() {
            return Ok(());
        }
        let Some(sample) = next_sample(source, frame, opts)? else {
            break;
        };
        // Frame i's occluders are STC(i - lag)'s visible set; with lag 2
        // it was usually finished while OR drew frame i - 1.
        if frame >= opts.occluder_lag as u64 {
            match feedback.recv() {
                Ok(v) => occluders = v,
                Err(_) => return Ok(()), // STC stopped: its error is reported there
            }
        }
        let msg = if sample.hold {
            OrToStc {
                sample,
                depth: None,
                occluder_items: 0,
                or_ms: 0.0,
            }
        } else {
            let o = or.run(
                frame,
                &sample.view,
                wants_occluders(opts, frame).then_some(&occluders[..]),
            )?;
            OrToStc {
                sample,
                depth: o.depth,
                occluder_items: o.occluder_items,
                or_ms: o.ms,
            }
        };
        if out.send(msg).is_err() {
            return Ok(());
        }
        frame += 1;
    }
    Ok(())
}

fn stc_thread(
    mut stc: StcStage,
    rt: &Runtime,
    opts: &RuntimeOptions,
    input: Receiver<OrToStc>,
    out: Sender<StcToRvg>,
    feedback: Sender<VisibleSet>,
) -> Result<(), RuntimeError> {
    let mut last: Option<StcOutput> = None;
    for m in input.iter() {
        let frame = m.sample.frame;
        if out
            .send(StcToRvg::Begin(
                frame,
                Box::new(m.sample.view.clone()),
                m.sample.style,
            ))
            .is_err()
        {
            return Ok(());
        }
        let (s, reused) = match held(m.sample.hold, &last) {
            Some(s) => {
                for chunk in lod_ids(rt.skeleton, &s.visible).chunks(opts.chunk) {
                    if out.send(StcToRvg::Items(chunk.to_vec())).is_err() {
                        return Ok(());
                    }
                }
                (s, true)
            }
            None => {
                let mut chunk = Vec::with_capacity(opts.chunk);
                let mut closed = false;
                let s = stc.run(frame, &m.sample.view, m.depth.as_ref(), &mut |item| {
                    chunk.push(rt.skeleton.nodes[item.node as usize].first_lod + item.lod);
                    if chunk.len() == opts.chunk && !closed {
                        let full = std::mem::replace(&mut chunk, Vec::with_capacity(opts.chunk));
                        closed = out.send(StcToRvg::Items(full)).is_err();
                    }
                })?;
                if closed || (!chunk.is_empty() && out.send(StcToRvg::Items(chunk)).is_err()) {
                    return Ok(());
                }
                (s, false)
            }
        };
        // OR may have finished its camera source already: ignore a closed feedback queue.
        let _ = feedback.send(s.visible.clone());
        last = Some(s.clone());
        let end = FrameEnd {
            sample: m.sample,
            occluder_items: m.occluder_items,
            or_ms: m.or_ms,
            stc: s,
            reused,
        };
        if out.send(StcToRvg::End(Box::new(end))).is_err() {
            return Ok(());
        }
    }
    Ok(())
}

fn rvg_thread(
    mut rvg: RvgStage,
    input: Receiver<StcToRvg>,
    out: Sender<FrameReport>,
    tokens: Sender<()>,
    presenter: &mut dyn Presenter,
) -> Result<(), RuntimeError> {
    let mut span = None;
    for m in input.iter() {
        match m {
            StcToRvg::Begin(frame, view, style) => {
                span = Some(tracing::info_span!("RVG", frame).entered());
                rvg.begin(frame, &view, style)?;
            }
            StcToRvg::Items(lods) => rvg.draw(&lods)?,
            StcToRvg::End(end) => {
                let r = finish_frame(&mut rvg, presenter, *end)?;
                span = None;
                // OR may have ended already; a closed token queue is fine.
                let _ = tokens.send(());
                if out.send(r).is_err() {
                    return Ok(());
                }
            }
        }
    }
    drop(span);
    Ok(())
}

/// The newest camera, handed from RVG (which owns the camera source in
/// asynchronous mode) to OR, which skips cameras it is too slow for.
#[derive(Default)]
struct Latest {
    sample: Option<Sample>,
    closed: bool,
}

struct LatestSlot {
    slot: Mutex<Latest>,
    changed: Condvar,
}

impl LatestSlot {
    fn put(&self, s: Sample) {
        self.slot.lock().expect("camera slot").sample = Some(s);
        self.changed.notify_all();
    }
    fn close(&self) {
        self.slot.lock().expect("camera slot").closed = true;
        self.changed.notify_all();
    }
    /// Waits for a camera newer than `after`; `None` once closed.
    fn take_newer(&self, after: Option<u64>) -> Option<Sample> {
        let mut g = self.slot.lock().expect("camera slot");
        loop {
            if g.closed {
                return None;
            }
            if let Some(s) = g
                .sample
                .as_ref()
                .filter(|s| after.is_none_or(|a| s.frame > a))
            {
                return Some(s.clone());
            }
            g = self.changed.wait(g).expect("camera slot");
        }
    }
}

/// Closes the slot when RVG ends for any reason (including a panic), so OR
/// never waits for a camera that will not come.
struct CloseOnDrop<'a>(&'a LatestSlot);
impl Drop for CloseOnDrop<'_> {
    fn drop(&mut self) {
        self.0.close();
    }
}

/// Asynchronous RVG (Section 5.3): RVG samples every camera and draws the
/// newest finished visible set with it at once; OR and STC work on the
/// newest camera whenever they are free.
pub(crate) fn run_async(
    rt: &Runtime,
    opts: &RuntimeOptions,
    source: &mut dyn CameraSource,
    on_frame: &mut dyn FnMut(FrameReport) -> bool,
    presenter: &mut dyn Presenter,
) -> Result<u64, RuntimeError> {
    let latest = LatestSlot {
        slot: Mutex::new(Latest::default()),
        changed: Condvar::new(),
    };
    let (or_tx, or_rx) = bounded::<OrToStc>(1);
    let (sets_tx, sets_rx) = bounded::<Box<FrameEnd>>(2);
    let (feedback_tx, feedback_rx) = unbounded::<VisibleSet>();
    let (report_tx, report_rx) = bounded::<FrameReport>(1);
    let b = rvg_device(rt, opts);
    let latest = &latest;
    // Owned by RVG's body, so the slot closes when RVG ends for any reason,
    // or when its body is dropped without running.
    let close = CloseOnDrop(latest);
    let StreamLinks {
        loader,
        or: or_link,
        rvg: rvg_link,
        stc: prefetch,
    } = stream_links(rt, opts, 0, b);
    std::thread::scope(|s| {
        let mut stages: Vec<(Stage, StageBody)> = vec![
            (
                Stage::Or,
                Box::new(move || {
                    let or = OrStage::new(DeviceGeometry::new(rt, 0, or_link), opts);
                    async_or_thread(or, opts, latest, or_tx, feedback_rx)
                }),
            ),
            (
                Stage::Stc,
                Box::new(move || {
                    let stc = StcStage::new(rt.skeleton, rt.source, opts, prefetch);
                    async_stc_thread(stc, or_rx, sets_tx, feedback_tx)
                }),
            ),
            (
                Stage::Rvg,
                Box::new(move || {
                    let _close = close;
                    let rvg = RvgStage::new(DeviceGeometry::new(rt, b, rvg_link), opts);
                    async_rvg_thread(rvg, rt, opts, source, latest, sets_rx, report_tx, presenter)
                }),
            ),
        ];
        if let Some(l) = loader {
            stages.push((Stage::Loader, Box::new(move || l.body())));
        }
        run_threads(s, stages, report_rx, on_frame)
    })
}

fn async_or_thread(
    mut or: OrStage,
    opts: &RuntimeOptions,
    latest: &LatestSlot,
    out: Sender<OrToStc>,
    feedback: Receiver<VisibleSet>,
) -> Result<(), RuntimeError> {
    let mut done: Option<u64> = None;
    let mut runs = 0u64;
    // The newest visible sets, most recent last; occluders lag by `lag` runs.
    let mut sets: std::collections::VecDeque<VisibleSet> = Default::default();
    while let Some(sample) = latest.take_newer(done) {
        done = Some(sample.frame);
        loop {
            match feedback.try_recv() {
                Ok(v) => sets.push_back(v),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => return Ok(()),
            }
        }
        while sets.len() > opts.occluder_lag as usize {
            sets.pop_front();
        }
        let occluders = (opts.wants_occluder_depth() && runs >= opts.occluder_lag as u64)
            .then(|| sets.front().map(|v| &v[..]).unwrap_or(&[]));
        let o = or.run(sample.frame, &sample.view, occluders)?;
        runs += 1;
        let msg = OrToStc {
            sample,
            depth: o.depth,
            occluder_items: o.occluder_items,
            or_ms: o.ms,
        };
        if out.send(msg).is_err() {
            return Ok(());
        }
    }
    Ok(())
}

fn async_stc_thread(
    mut stc: StcStage,
    input: Receiver<OrToStc>,
    out: Sender<Box<FrameEnd>>,
    feedback: Sender<VisibleSet>,
) -> Result<(), RuntimeError> {
    for m in input.iter() {
        let s = stc.run(
            m.sample.frame,
            &m.sample.view,
            m.depth.as_ref(),
            &mut |_| {},
        )?;
        let _ = feedback.send(s.visible.clone());
        let end = FrameEnd {
            sample: m.sample,
            occluder_items: m.occluder_items,
            or_ms: m.or_ms,
            stc: s,
            reused: false,
        };
        if out.send(Box::new(end)).is_err() {
            return Ok(());
        }
    }
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn async_rvg_thread(
    mut rvg: RvgStage,
    rt: &Runtime,
    opts: &RuntimeOptions,
    source: &mut dyn CameraSource,
    latest: &LatestSlot,
    sets: Receiver<Box<FrameEnd>>,
    out: Sender<FrameReport>,
    presenter: &mut dyn Presenter,
) -> Result<(), RuntimeError> {
    let mut newest: Option<Box<FrameEnd>> = None;
    let mut frame = 0u64;
    while let Some(sample) = next_sample(source, frame, opts)? {
        let _span = tracing::info_span!("RVG", frame).entered();
        if !sample.hold || newest.is_none() {
            latest.put(sample.clone());
        }
        // The newest finished set (none newer while culling is held); wait
        // only when there is none yet.
        while !sample.hold || newest.is_none() {
            match sets.try_recv() {
                Ok(s) => newest = Some(s),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => return Ok(()),
            }
        }
        if newest.is_none() {
            match sets.recv() {
                Ok(s) => newest = Some(s),
                Err(_) => return Ok(()),
            }
        }
        let set = newest.as_ref().expect("a visible set");
        let reused = set.sample.frame != frame;
        rvg.begin(frame, &sample.view, sample.style)?;
        for chunk in lod_ids(rt.skeleton, &set.stc.visible).chunks(opts.chunk) {
            rvg.draw(chunk)?;
        }
        let end = FrameEnd {
            sample,
            occluder_items: set.occluder_items,
            or_ms: set.or_ms,
            stc: set.stc.clone(),
            reused,
        };
        let r = finish_frame(&mut rvg, presenter, end)?;
        if out.send(r).is_err() {
            return Ok(());
        }
        frame += 1;
    }
    Ok(())
}
