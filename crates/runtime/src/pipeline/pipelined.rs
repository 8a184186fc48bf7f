//! The pipelined schedule (paper Section 5.1): OR, STC and RVG on their
//! own threads and devices, joined by queues; frame i's occluders are
//! frame i - lag's visible set.

use crossbeam_channel::unbounded;

use super::*;
use crate::stages::{OrStage, StcOutput, StcStage, Target};
use crate::{CameraSource, Presenter};

pub(crate) fn run_pipelined(
    t: Target,
    opts: &RuntimeOptions,
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
    let StreamLinks {
        loader,
        or: or_link,
        rvg: rvg_link,
        stc: prefetch,
    } = stream_links(t, opts, 0, b);
    std::thread::scope(|s| {
        let stages: Vec<(Stage, StageBody)> = vec![
            (
                Stage::Or,
                Box::new(move || {
                    let or = t.or_stage(opts, or_link);
                    or_thread(or, opts, source, or_tx, feedback_rx, token_rx)
                }),
            ),
            (
                Stage::Stc,
                Box::new(move || {
                    let stc = t.stc_stage(opts, b, prefetch)?;
                    stc_thread(stc, t, opts, or_rx, rvg_tx, feedback_tx)
                }),
            ),
            (
                Stage::Rvg,
                Box::new(move || {
                    let rvg = t.rvg_stage(opts, b, rvg_link);
                    rvg_thread(rvg, rvg_rx, report_tx, token_tx, presenter)
                }),
            ),
        ];
        run_threads(s, stages, loader, report_rx, on_frame)
    })
}

fn or_thread(
    mut or: OrStage,
    opts: &RuntimeOptions,
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
                occluder_items: 0,
                or_ms: 0.0,
            }
        } else {
            let o = or.run(
                frame,
                &sample.view,
                sample.tolerance,
                occluders.for_frame(frame),
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
    t: Target,
    opts: &RuntimeOptions,
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
                let (view, tol) = (&m.sample.view, m.sample.tolerance);
                let s = stc.run(frame, view, tol, m.depth.as_ref(), &mut |_| {})?;
                if send_set(&s, None).is_err() {
                    return Ok(());
                }
                (s, false)
            }
            None => {
                let mut chunk = Vec::with_capacity(opts.chunk);
                let mut closed = false;
                let (view, tol) = (&m.sample.view, m.sample.tolerance);
                let s = stc.run(frame, view, tol, m.depth.as_ref(), &mut |item| {
                    chunk.push(t.skeleton.nodes[item.node as usize].first_lod + item.lod);
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
            StcToRvg::Scissor(rect) => rvg.scissor(rect),
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
