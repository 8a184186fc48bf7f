//! The stepped schedule: one thread that never blocks, for a browser page
//! (wasm32 has no threads, and a page's thread may not wait on the
//! device). The caller calls [`Stepped::step`] once an animation frame
//! with that frame's camera; each step
//! - takes the oldest OR submission's depth if the device has made it,
//!   and culls (STC) and draws (RVG) that submission's camera with it;
//! - submits OR for this step's camera, the last drawn visible set its
//!   occluders (frame i - lag's set, as in the pipeline), while fewer than
//!   [`OR_IN_FLIGHT`] wait.
//!
//! So a frame is drawn with the camera OR took, one or two animation
//! frames old, as the pipelined schedule draws frame i after OR and STC
//! took their turns. Before any submission (the first step, or after a
//! frame with no occluders) the camera is drawn unculled: the startup
//! bypass. The stages are the pipeline's own (`stages`), and so are
//! streaming's pool, stand-ins and request order: the caller only reads
//! what [`Stepped::wanted`] names (a page fetches it) and hands it to
//! [`Stepped::load`], where native's loader thread reads files.

use super::*;
use crate::stages::OrSubmitted;
use crate::streaming::Queue;
use crate::{check_viewport, CameraRequest, Runtime};

/// OR submissions a step may leave waiting for their depth. One frame
/// submitting while the last one's read-back is on its way keeps the
/// device busy without a frame of latency more.
pub const OR_IN_FLIGHT: usize = 2;

/// Options resolved for [`Runtime::stepped`], kept by the caller while
/// the schedule runs (its stages borrow them).
pub struct SteppedOptions(ResolvedOptions);

/// The stepped schedule on a runtime ([`Runtime::stepped`]).
pub struct Stepped<'s> {
    skeleton: &'s gigawalk_scene::Skeleton,
    source: &'s dyn LodSource,
    opts: &'s ResolvedOptions,
    or: OrStage<'s>,
    stc: StcStage<'s>,
    rvg: RvgStage<'s>,
    /// OR submissions waiting for their depth, oldest first, each with
    /// its camera.
    awaited: VecDeque<(Sample, OrSubmitted)>,
    /// The last drawn frame's visible set: the next submission's occluders.
    occluders: Option<VisibleSet>,
    frozen: Frozen,
    /// The next camera's frame number.
    frame: u64,
    /// Streaming: the loader's ends of the queues, and their order.
    loads: Option<(LoaderQueues<'s>, Queue)>,
}

impl<'s> Runtime<'s> {
    /// `opts` resolved for [`Runtime::stepped`] on this runtime. An
    /// adaptive occluder budget draws every occluder: it learns from
    /// frame times the stepped schedule does not see whole.
    pub fn stepped_options(&self, opts: &RuntimeOptions) -> Result<SteppedOptions, RuntimeError> {
        let mut opts = opts.resolve(self.rasterizes_on_cpu())?;
        if opts.occluders == OccluderSelection::Adaptive {
            opts.occluders = OccluderSelection::All;
        }
        check_viewport(&self.devices, opts.width, opts.height)?;
        Ok(SteppedOptions(opts))
    }

    /// The stepped schedule on device 0 (OR and RVG share it), for a
    /// thread that must never block.
    pub fn stepped<'r>(&'r self, opts: &'r SteppedOptions) -> Result<Stepped<'r>, RuntimeError> {
        let opts = &opts.0;
        let t = Target::gpu(self).with_occluders(match opts.occluders {
            OccluderSelection::Triangles(n) => crate::stages::OrBudget::Triangles(n),
            _ => crate::stages::OrBudget::All,
        });
        let links = stream_links(t, opts, 0, 0);
        Ok(Stepped {
            skeleton: t.skeleton,
            source: t.source,
            opts,
            or: t.or_stage(opts, links.or),
            stc: t.stc_stage(opts, 0, links.stc)?,
            rvg: t.rvg_stage(opts, 0, links.rvg),
            awaited: VecDeque::new(),
            occluders: None,
            frozen: Frozen::default(),
            frame: 0,
            loads: links.loader.map(|l| (l, Queue::default())),
        })
    }
}

impl Stepped<'_> {
    /// One step with this animation frame's camera: the frame drawn (and
    /// shown through `presenter`), or `None` while the oldest
    /// submission's depth is on its way. Never blocks.
    pub fn step(
        &mut self,
        request: CameraRequest,
        presenter: &mut dyn Presenter,
    ) -> Result<Option<FrameReport>, RuntimeError> {
        let sample = sample_of(request, self.frame, self.opts)?;
        self.frame += 1;
        if let Some(held) = self.frozen.held(sample.hold) {
            return self
                .draw(sample, OrFigures::default(), held, true, presenter)
                .map(Some);
        }
        if !self.opts.wants_occluder_depth() {
            self.awaited.clear();
            return self.cull_and_draw(sample, None, presenter).map(Some);
        }
        let drawn = match self.awaited.pop_front() {
            None => Some(self.cull_and_draw(sample.clone(), None, presenter)?),
            Some((taken, submitted)) => match self.or.try_take(submitted)? {
                Err(submitted) => {
                    self.awaited.push_front((taken, submitted));
                    None
                }
                Ok(or) => Some(self.cull_and_draw(taken, Some(or), presenter)?),
            },
        };
        if self.awaited.len() < OR_IN_FLIGHT {
            if let Some(set) = self.occluders.clone() {
                let s = &sample;
                let submitted = self
                    .or
                    .submit(s.frame, &s.view, s.pixel_error, Some(&set))?;
                self.awaited.push_back((sample, submitted));
            }
        }
        Ok(drawn)
    }

    /// Starts reading back the last frame drawn, as drawn (before what a
    /// presenter adds): taken by [`Stepped::try_take_frame`]. Never
    /// blocks.
    pub fn submit_read_back(&mut self) -> Option<gigawalk_gpu::PendingFrame> {
        self.rvg.submit_read_back()
    }

    /// The frame `pending` reads, once the device has copied it; `Err`
    /// gives it back while it has not.
    pub fn try_take_frame(
        &mut self,
        pending: gigawalk_gpu::PendingFrame,
    ) -> Result<Result<gigawalk_gpu::FrameImage, RuntimeError>, gigawalk_gpu::PendingFrame> {
        self.rvg.try_take_frame(pending)
    }

    /// STC with OR's output (none: unculled) for `sample`, then RVG.
    fn cull_and_draw(
        &mut self,
        sample: Sample,
        or: Option<crate::stages::OrOutput>,
        presenter: &mut dyn Presenter,
    ) -> Result<FrameReport, RuntimeError> {
        let (depth, figures) = match or {
            Some(o) => (o.depth, o.figures),
            None => (None, OrFigures::default()),
        };
        let s = &sample;
        let culled = self
            .stc
            .run(s.frame, &s.view, s.pixel_error, depth.as_ref(), &mut |_| {})?;
        self.draw(sample, figures, culled, false, presenter)
    }

    fn draw(
        &mut self,
        sample: Sample,
        or: OrFigures,
        stc: StcOutput,
        reused: bool,
        presenter: &mut dyn Presenter,
    ) -> Result<FrameReport, RuntimeError> {
        self.rvg.begin(sample.frame, &sample.view, sample.style)?;
        let retile = reused.then_some((&sample.view, self.opts));
        draw_set(&mut self.rvg, self.skeleton, &stc, self.opts.chunk, retile)?;
        if !reused {
            self.occluders = Some(stc.visible.clone());
            self.frozen.record(&stc);
        }
        let end = FrameEnd {
            sample,
            or,
            stc,
            reused,
        };
        finish_frame(&mut self.rvg, presenter, end)
    }

    /// LODs the frames asked for and no device holds yet, at most `n`,
    /// in the loader's order (demands before prefetches, the newest
    /// frame's first, stale requests dropped). The caller makes each
    /// readable from the runtime's source (a page fetches its bytes) and
    /// calls [`Stepped::load`]; one it cannot get it drops: a frame that
    /// still needs it asks again. Empty when nothing streams.
    pub fn wanted(&mut self, n: usize) -> Vec<u32> {
        let Some((queues, queue)) = self.loads.as_mut() else {
            return Vec::new();
        };
        for r in queues
            .requests
            .try_iter()
            .chain(queues.prefetches.try_iter())
        {
            queue.add(r);
        }
        std::iter::from_fn(|| queue.next(queues.plan, queues.mask))
            .take(n)
            .collect()
    }

    /// Reads `lod` from the runtime's source and hands it to the device,
    /// which takes it in at its next draw (as from native's loader).
    pub fn load(&mut self, lod: u32) -> Result<(), RuntimeError> {
        let Some((queues, _)) = self.loads.as_ref() else {
            return Ok(());
        };
        let stored = self
            .source
            .read_lod_stored(lod)
            .map_err(|source| RuntimeError::Load {
                source: Box::new(source),
            })?;
        let loaded: streaming::Loaded =
            Arc::new((lod, gigawalk_gpu::DecodedLod::from_stored(stored)));
        for d in &queues.devices {
            // A full inbox drops it: the frame that needs it asks again.
            let _ = d.try_send(loaded.clone());
        }
        Ok(())
    }
}
