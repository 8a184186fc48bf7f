//! The pipelined schedule (paper Section 5.1): OR, STC and RVG on their
//! own threads and devices, joined by queues; frame i's occluders are
//! frame i - lag's visible set.

use std::time::Duration;

use crossbeam_channel::{unbounded, RecvTimeoutError};

use super::*;
use crate::stages::{OrFigures, OrStage, StcOutput, StcStage, Target};
use crate::ResolvedOptions;
use crate::{CameraSource, Presenter};

pub(crate) fn run_pipelined(
    t: Target,
    opts: &ResolvedOptions,
    source: &mut dyn CameraSource,
    on_frame: &mut dyn FnMut(FrameReport) -> bool,
    presenter: &mut dyn Presenter,
) -> Result<u64, RuntimeError> {
    // OR takes a token per frame and RVG returns it when the frame is done,
    // so at most MAX_IN_FLIGHT frames are between camera and screen.
    let (or_tx, or_rx) = bounded::<OrToStc>(1);
    let (rvg_tx, rvg_rx) = bounded::<StcToRvg>(RVG_QUEUE);
    let (feedback_tx, feedback_rx) = unbounded::<(u64, VisibleSet)>();
    let (report_tx, report_rx) = bounded::<FrameReport>(1);
    let (token_tx, token_rx) = bounded::<()>(MAX_IN_FLIGHT);
    for _ in 0..MAX_IN_FLIGHT {
        token_tx.send(()).expect("room for every token");
    }
    let b = t.rvg_device(opts);
    std::thread::scope(|s| {
        let (stages, loader) = stage_bodies(
            t,
            opts,
            b,
            move |or| or_thread(or, opts, source, or_tx, feedback_rx, token_rx),
            move |stc| stc_thread(stc, t, opts, or_rx, rvg_tx, feedback_tx),
            move |rvg| {
                let spec = opts.speculative_rvg.then_some(Speculative {
                    skeleton: t.skeleton,
                    opts,
                });
                rvg_thread(rvg, rvg_rx, report_tx, token_tx, presenter, spec)
            },
        );
        run_threads(s, stages, loader, report_rx, on_frame)
    })
}

fn or_thread(
    mut or: OrStage,
    opts: &ResolvedOptions,
    source: &mut dyn CameraSource,
    out: Sender<OrToStc>,
    feedback: Receiver<(u64, VisibleSet)>,
    tokens: Receiver<()>,
) -> Result<(), RuntimeError> {
    let mut frame = 0u64;
    let mut occluders = Occluders::new(opts);
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
                Ok((f, v)) => occluders.push(f, v),
                Err(_) => return Ok(()), // STC stopped: its error is reported there
            }
        }
        let msg = if sample.hold {
            OrToStc {
                sample,
                depth: None,
                or: OrFigures::default(),
            }
        } else {
            let o = or.run(
                frame,
                &sample.view,
                sample.pixel_error,
                occluders.for_frame(frame),
            )?;
            OrToStc {
                sample,
                depth: o.depth,
                or: o.figures,
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
    t: Target,
    opts: &ResolvedOptions,
    input: Receiver<OrToStc>,
    out: Sender<StcToRvg>,
    feedback: Sender<(u64, VisibleSet)>,
) -> Result<(), RuntimeError> {
    let mut frozen = Frozen::default();
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
        // A finished set (held, or tiles: drawn once STC has sent every
        // item to its tiles), chunk by chunk under each chunk's scissor.
        let send_set = |s: &StcOutput, retile| {
            let mut scissor = None;
            for (rect, lods) in draw_plan(t.skeleton, s, opts.chunk, retile) {
                if rect != scissor {
                    scissor = rect;
                    out.send(StcToRvg::Scissor(rect)).map_err(|_| ())?;
                }
                out.send(StcToRvg::Items(lods)).map_err(|_| ())?;
            }
            if scissor.is_some() {
                out.send(StcToRvg::Scissor(None)).map_err(|_| ())?;
            }
            Ok::<(), ()>(())
        };
        let (s, reused) = match frozen.held(m.sample.hold) {
            Some(s) => {
                if send_set(&s, Some((&m.sample.view, opts))).is_err() {
                    return Ok(());
                }
                (s, true)
            }
            None if opts.tiles.is_some() => {
                let (view, tol) = (&m.sample.view, m.sample.pixel_error);
                let s = stc.run(frame, view, tol, m.depth.as_ref(), &mut |_| {})?;
                if send_set(&s, None).is_err() {
                    return Ok(());
                }
                (s, false)
            }
            None => {
                let mut chunk = Vec::with_capacity(opts.chunk);
                let mut closed = false;
                let (view, tol) = (&m.sample.view, m.sample.pixel_error);
                let s = stc.run(frame, view, tol, m.depth.as_ref(), &mut |item| {
                    chunk.push(t.skeleton.nodes()[item.node as usize].first_lod + item.lod);
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
        let _ = feedback.send((frame, s.visible.clone()));
        frozen.record(&s);
        let end = FrameEnd {
            sample: m.sample,
            or: m.or,
            stc: s,
            reused,
        };
        if out.send(StcToRvg::End(Box::new(end))).is_err() {
            return Ok(());
        }
    }
    Ok(())
}

/// What speculative RVG needs to draw a set.
struct Speculative<'a> {
    skeleton: &'a gigawalk_scene::Skeleton,
    opts: &'a ResolvedOptions,
}

/// RVG: draws each frame as STC's items arrive. A frame begins on its
/// first items (or its end), not on `Begin`, so that with speculative RVG
/// a late STC can be covered first: when nothing of the frame has come
/// within the last frame's own drawing time, the last finished set is
/// drawn with this frame's camera as an extra, speculative frame.
fn rvg_thread(
    mut rvg: RvgStage,
    input: Receiver<StcToRvg>,
    out: Sender<FrameReport>,
    tokens: Sender<()>,
    presenter: &mut dyn Presenter,
    spec: Option<Speculative>,
) -> Result<(), RuntimeError> {
    let mut span = None;
    // The frame announced by `Begin` and not begun yet.
    let mut pending: Option<(u64, Box<CullView>, FrameStyle)> = None;
    // When RVG last finished drawing, and how long it waited for STC.
    let mut idle_since = Instant::now();
    let mut wait_ms = 0.0;
    // The last finished set, its frame's drawing ms, and when this
    // frame's drawing started.
    let mut last: Option<(StcOutput, f64)> = None;
    let mut drawing_since = Instant::now();
    let mut speculated: Option<u64> = None;
    // The frame begun and not ended yet: STC sends `Begin`, then the
    // frame's scissors and items, then its `End`, one frame at a time.
    let mut open: Option<u64> = None;
    loop {
        let late = match (&spec, &last, &pending) {
            (Some(_), Some((_, draw_ms)), Some((frame, ..))) if speculated != Some(*frame) => {
                Some(Duration::from_secs_f64((draw_ms / 1e3).clamp(1e-3, 1.0)))
            }
            _ => None,
        };
        let m = match late {
            Some(grace) => match input.recv_timeout(grace) {
                Ok(m) => m,
                Err(RecvTimeoutError::Disconnected) => break,
                Err(RecvTimeoutError::Timeout) => {
                    let (Some(sp), Some((set, _)), Some((frame, view, style))) =
                        (&spec, &last, &pending)
                    else {
                        continue;
                    };
                    speculated = Some(*frame);
                    let _s = tracing::info_span!("RVG speculative", frame).entered();
                    let waited = idle_since.elapsed().as_secs_f64() * 1e3;
                    rvg.begin(*frame, view, *style)?;
                    draw_set(
                        &mut rvg,
                        sp.skeleton,
                        set,
                        sp.opts.chunk,
                        Some((view, sp.opts)),
                    )?;
                    let end = FrameEnd {
                        sample: Sample {
                            frame: *frame,
                            view: (**view).clone(),
                            read_back: false,
                            hold: false,
                            style: *style,
                            sampled_at: Instant::now(),
                            pixel_error: Some(set.pixel_error),
                        },
                        or: OrFigures::default(),
                        stc: StcOutput {
                            ms: 0.0,
                            hzb_ms: 0.0,
                            ..set.clone()
                        },
                        reused: true,
                    };
                    let mut r = finish_frame(&mut rvg, presenter, end)?;
                    r.speculative = true;
                    r.rvg_wait_ms = waited;
                    if out.send(r).is_err() {
                        return Ok(());
                    }
                    idle_since = Instant::now();
                    continue;
                }
            },
            None => match input.recv() {
                Ok(m) => m,
                Err(_) => break,
            },
        };
        if !matches!(m, StcToRvg::Begin(..)) {
            if let Some((frame, view, style)) = pending.take() {
                span = Some(tracing::info_span!("RVG", frame).entered());
                wait_ms = idle_since.elapsed().as_secs_f64() * 1e3;
                drawing_since = Instant::now();
                rvg.begin(frame, &view, style)?;
                open = Some(frame);
            }
        }
        match m {
            StcToRvg::Begin(frame, view, style) => {
                debug_assert!(
                    open.is_none() && pending.is_none(),
                    "frame {frame} begun while {open:?} is open"
                );
                pending = Some((frame, view, style));
            }
            StcToRvg::Scissor(rect) => rvg.scissor(rect),
            StcToRvg::Items(lods) => rvg.draw(&lods)?,
            StcToRvg::End(end) => {
                debug_assert_eq!(
                    open.take(),
                    Some(end.sample.frame),
                    "a frame's End closes the frame its Begin opened"
                );
                let set = spec.as_ref().map(|_| end.stc.clone());
                let mut r = finish_frame(&mut rvg, presenter, *end)?;
                r.rvg_wait_ms = wait_ms;
                if let Some(set) = set {
                    last = Some((set, drawing_since.elapsed().as_secs_f64() * 1e3));
                }
                idle_since = Instant::now();
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
