//! The pipelined schedule with asynchronous RVG (paper Section 5.3): RVG
//! samples every camera and draws the newest finished visible set with it
//! at once; OR and STC work on the newest camera whenever they are free.

use std::sync::{Condvar, Mutex};

use crossbeam_channel::{unbounded, TryRecvError};

use super::*;
use crate::stages::{OrStage, StcStage, Target};
use crate::ResolvedOptions;
use crate::{CameraSource, Presenter};

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
    t: Target,
    opts: &ResolvedOptions,
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
    let (feedback_tx, feedback_rx) = unbounded::<(u64, VisibleSet)>();
    let (report_tx, report_rx) = bounded::<FrameReport>(1);
    let b = t.rvg_device(opts);
    let latest = &latest;
    // Owned by RVG's body, so the slot closes when RVG ends for any reason,
    // or when its body is dropped without running.
    let close = CloseOnDrop(latest);
    std::thread::scope(|s| {
        let (stages, loader) = stage_bodies(
            t,
            opts,
            b,
            move |or| async_or_thread(or, opts, latest, or_tx, feedback_rx),
            move |stc| async_stc_thread(stc, or_rx, sets_tx, feedback_tx),
            move |rvg| {
                let _close = close;
                async_rvg_thread(rvg, t, opts, source, latest, sets_rx, report_tx, presenter)
            },
        );
        run_threads(s, stages, loader, report_rx, on_frame)
    })
}

fn async_or_thread(
    mut or: OrStage,
    opts: &ResolvedOptions,
    latest: &LatestSlot,
    out: Sender<OrToStc>,
    feedback: Receiver<(u64, VisibleSet)>,
) -> Result<(), RuntimeError> {
    let mut done: Option<u64> = None;
    let mut occluders = Occluders::new(opts);
    while let Some(sample) = latest.take_newer(done) {
        done = Some(sample.frame);
        loop {
            match feedback.try_recv() {
                Ok((f, v)) => occluders.push(f, v),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => return Ok(()),
            }
        }
        let o = or.run(
            sample.frame,
            &sample.view,
            sample.pixel_error,
            occluders.for_frame(sample.frame),
        )?;
        let msg = OrToStc {
            sample,
            depth: o.depth,
            or: o.figures,
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
    feedback: Sender<(u64, VisibleSet)>,
) -> Result<(), RuntimeError> {
    for m in input.iter() {
        let s = stc.run(
            m.sample.frame,
            &m.sample.view,
            m.sample.pixel_error,
            m.depth.as_ref(),
            &mut |_| {},
        )?;
        let _ = feedback.send((m.sample.frame, s.visible.clone()));
        let end = FrameEnd {
            sample: m.sample,
            or: m.or,
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
    t: Target,
    opts: &ResolvedOptions,
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
        let retile = reused.then_some((&sample.view, opts));
        draw_set(&mut rvg, t.skeleton, &set.stc, opts.chunk, retile)?;
        let end = FrameEnd {
            sample,
            or: set.or,
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
