//! The two schedules: three threads joined by queues, or one thread.

use std::time::Instant;

use crossbeam_channel::{bounded, unbounded, Receiver, Sender};
use gigawalk_cull::{CullView, DrawItem, TraversalStats, Viewport};
use gigawalk_gpu::DepthImage;

use crate::stages::{lod_ids, OrStage, RvgStage, StcStage};
use crate::{CameraSource, FrameReport, Runtime, RuntimeError, RuntimeOptions, Stage};

/// OR -> STC: one frame's camera and occluder depth.
struct OrToStc {
    frame: u64,
    view: CullView,
    read_back: bool,
    sampled_at: Instant,
    depth: Option<DepthImage>,
    occluder_items: usize,
    or_ms: f64,
}

/// STC -> RVG: a frame is `Begin`, any number of `Items`, then the
/// sentinel `End` carrying the frame number, camera and statistics.
enum StcToRvg {
    Begin { frame: u64, view: Box<CullView> },
    Items(Vec<u32>),
    End(Box<FrameEnd>),
}

struct FrameEnd {
    frame: u64,
    view: CullView,
    read_back: bool,
    sampled_at: Instant,
    occluder_items: usize,
    or_ms: f64,
    hzb_ms: f64,
    stc_ms: f64,
    occlusion_used: bool,
    stats: TraversalStats,
    visible: Vec<DrawItem>,
}

/// The view of camera request `frame`, or `None` at the end of the source.
fn next_view(
    source: &mut dyn CameraSource,
    frame: u64,
    opts: &RuntimeOptions,
) -> Result<Option<(CullView, bool)>, RuntimeError> {
    let Some(req) = source.next_camera(frame).map_err(RuntimeError::Camera)? else {
        return Ok(None);
    };
    let viewport = Viewport::new(opts.width, opts.height);
    let camera = gigawalk_cull::Camera {
        aspect: viewport.aspect(),
        ..req.camera
    };
    if !camera.is_valid() {
        return Err(RuntimeError::Camera(format!("frame {frame}: camera {camera:?} is not valid (non-finite position, bad orientation or field of view)")));
    }
    Ok(Some((CullView::new(camera, viewport), req.read_back)))
}

/// Occluders of frame i: the visible set of frame i - lag, if occlusion is on
/// and that frame exists.
fn wants_occluders(opts: &RuntimeOptions, frame: u64) -> bool {
    opts.traversal.occlusion && frame >= opts.occluder_lag as u64
}

pub(crate) fn run_sequential(
    rt: &Runtime,
    opts: &RuntimeOptions,
    source: &mut dyn CameraSource,
    on_frame: &mut dyn FnMut(FrameReport) -> bool,
) -> Result<u64, RuntimeError> {
    let (ctx, geometry) = (&rt.devices[0], &rt.geometry[0]);
    let mut or = OrStage::new(ctx, geometry, rt.skeleton, opts);
    let mut stc = StcStage::new(rt.skeleton, opts);
    let mut rvg = RvgStage::new(ctx, geometry, opts);
    let mut history: std::collections::VecDeque<Vec<DrawItem>> = Default::default();
    let mut frame = 0u64;
    while let Some((view, read_back)) = next_view(source, frame, opts)? {
        let sampled_at = Instant::now();
        let occluders = wants_occluders(opts, frame)
            .then(|| history.front().map(|v| v.as_slice()).unwrap_or(&[]));
        let o = or.run(frame, &view, occluders)?;
        rvg.begin(frame, &view)?;
        // Same chunking as the pipeline, drawn after traversal.
        let s = stc.run(frame, &view, o.depth.as_ref(), &mut |_| {})?;
        for chunk in lod_ids(rt.skeleton, &s.visible).chunks(opts.chunk) {
            rvg.draw(chunk);
        }
        let (image, rvg_ms) = rvg.finish(read_back)?;
        history.push_back(s.visible.clone());
        if history.len() > opts.occluder_lag as usize {
            history.pop_front();
        }
        let report = FrameReport {
            frame,
            camera: view.camera,
            sampled_at,
            finished_at: Instant::now(),
            occlusion_used: s.occlusion_used,
            occluder_items: o.occluder_items,
            or_ms: o.ms,
            hzb_ms: s.hzb_ms,
            stc_ms: s.ms,
            rvg_ms,
            stats: s.stats,
            visible: s.visible,
            image,
        };
        frame += 1;
        if !on_frame(report) {
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

pub(crate) fn run_pipelined(
    rt: &Runtime,
    opts: &RuntimeOptions,
    source: &mut dyn CameraSource,
    on_frame: &mut dyn FnMut(FrameReport) -> bool,
) -> Result<u64, RuntimeError> {
    let a = 0;
    let b = if opts.devices >= 2 && rt.devices.len() >= 2 {
        1
    } else {
        0
    };
    // Small queues keep latency bounded: OR runs at most one frame ahead of
    // STC; RVG's queue holds a few frames' chunks.
    let (or_tx, or_rx) = bounded::<OrToStc>(1);
    let (rvg_tx, rvg_rx) = bounded::<StcToRvg>(64);
    let (feedback_tx, feedback_rx) = unbounded::<Vec<DrawItem>>();
    let (report_tx, report_rx) = bounded::<FrameReport>(4);

    std::thread::scope(|s| {
        let or = std::thread::Builder::new()
            .name("gigawalk-OR".into())
            .spawn_scoped(s, || or_thread(rt, a, opts, source, or_tx, feedback_rx))
            .expect("spawn OR");
        let stc = std::thread::Builder::new()
            .name("gigawalk-STC".into())
            .spawn_scoped(s, || stc_thread(rt, opts, or_rx, rvg_tx, feedback_tx))
            .expect("spawn STC");
        let rvg = std::thread::Builder::new()
            .name("gigawalk-RVG".into())
            .spawn_scoped(s, || rvg_thread(rt, b, opts, rvg_rx, report_tx))
            .expect("spawn RVG");
        let mut frames = 0;
        for report in report_rx.iter() {
            frames += 1;
            if !on_frame(report) {
                break;
            }
        }
        // Closing the report queue stops RVG, which stops STC, which stops OR.
        drop(report_rx);
        let mut first_error = None;
        for (stage, handle) in [(Stage::Or, or), (Stage::Stc, stc), (Stage::Rvg, rvg)] {
            let result = handle.join().unwrap_or_else(|p| {
                Err(RuntimeError::Panic {
                    stage,
                    message: panic_message(p),
                })
            });
            if let Err(e) = result {
                // Report the root cause: a stage that failed on its own,
                // not one that merely saw its queue close.
                first_error.get_or_insert(e);
            }
        }
        match first_error {
            Some(e) => Err(e),
            None => Ok(frames),
        }
    })
}

fn or_thread(
    rt: &Runtime,
    device: usize,
    opts: &RuntimeOptions,
    source: &mut dyn CameraSource,
    out: Sender<OrToStc>,
    feedback: Receiver<Vec<DrawItem>>,
) -> Result<(), RuntimeError> {
    let mut or = OrStage::new(&rt.devices[device], &rt.geometry[device], rt.skeleton, opts);
    let mut frame = 0u64;
    let mut occluders: Vec<DrawItem> = Vec::new();
    while let Some((view, read_back)) = next_view(source, frame, opts)? {
        let sampled_at = Instant::now();
        // Frame i's occluders are STC(i - lag)'s visible set; with lag 2
        // it was usually finished while OR drew frame i - 1.
        if frame >= opts.occluder_lag as u64 {
            match feedback.recv() {
                Ok(v) => occluders = v,
                Err(_) => return Ok(()), // STC stopped: its error is reported there
            }
        }
        let o = or.run(
            frame,
            &view,
            wants_occluders(opts, frame).then_some(occluders.as_slice()),
        )?;
        let msg = OrToStc {
            frame,
            view,
            read_back,
            sampled_at,
            depth: o.depth,
            occluder_items: o.occluder_items,
            or_ms: o.ms,
        };
        if out.send(msg).is_err() {
            return Ok(());
        }
        frame += 1;
    }
    Ok(())
}

fn stc_thread(
    rt: &Runtime,
    opts: &RuntimeOptions,
    input: Receiver<OrToStc>,
    out: Sender<StcToRvg>,
    feedback: Sender<Vec<DrawItem>>,
) -> Result<(), RuntimeError> {
    let mut stc = StcStage::new(rt.skeleton, opts);
    for m in input.iter() {
        if out
            .send(StcToRvg::Begin {
                frame: m.frame,
                view: Box::new(m.view.clone()),
            })
            .is_err()
        {
            return Ok(());
        }
        let mut chunk = Vec::with_capacity(opts.chunk);
        let mut closed = false;
        let s = stc.run(m.frame, &m.view, m.depth.as_ref(), &mut |item| {
            chunk.push(rt.skeleton.nodes[item.node as usize].first_lod + item.lod);
            if chunk.len() == opts.chunk && !closed {
                closed = out
                    .send(StcToRvg::Items(std::mem::replace(
                        &mut chunk,
                        Vec::with_capacity(opts.chunk),
                    )))
                    .is_err();
            }
        })?;
        if closed || (!chunk.is_empty() && out.send(StcToRvg::Items(chunk)).is_err()) {
            return Ok(());
        }
        // OR may have finished its camera source already: ignore a closed feedback queue.
        let _ = feedback.send(s.visible.clone());
        let end = FrameEnd {
            frame: m.frame,
            view: m.view,
            read_back: m.read_back,
            sampled_at: m.sampled_at,
            occluder_items: m.occluder_items,
            or_ms: m.or_ms,
            hzb_ms: s.hzb_ms,
            stc_ms: s.ms,
            occlusion_used: s.occlusion_used,
            stats: s.stats,
            visible: s.visible,
        };
        if out.send(StcToRvg::End(Box::new(end))).is_err() {
            return Ok(());
        }
    }
    Ok(())
}

fn rvg_thread(
    rt: &Runtime,
    device: usize,
    opts: &RuntimeOptions,
    input: Receiver<StcToRvg>,
    out: Sender<FrameReport>,
) -> Result<(), RuntimeError> {
    let mut rvg = RvgStage::new(&rt.devices[device], &rt.geometry[device], opts);
    let mut span = None;
    for m in input.iter() {
        match m {
            StcToRvg::Begin { frame, view } => {
                span = Some(tracing::info_span!("RVG", frame).entered());
                rvg.begin(frame, &view)?;
            }
            StcToRvg::Items(lods) => rvg.draw(&lods),
            StcToRvg::End(end) => {
                let (image, rvg_ms) = rvg.finish(end.read_back)?;
                span = None;
                let report = FrameReport {
                    frame: end.frame,
                    camera: end.view.camera,
                    sampled_at: end.sampled_at,
                    finished_at: Instant::now(),
                    occlusion_used: end.occlusion_used,
                    occluder_items: end.occluder_items,
                    or_ms: end.or_ms,
                    hzb_ms: end.hzb_ms,
                    stc_ms: end.stc_ms,
                    rvg_ms,
                    stats: end.stats,
                    visible: end.visible,
                    image,
                };
                if out.send(report).is_err() {
                    return Ok(());
                }
            }
        }
    }
    drop(span);
    Ok(())
}
