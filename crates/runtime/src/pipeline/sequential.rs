//! The sequential schedule: one thread, one device, OR, STC and RVG one
//! after another (the baseline of the pipeline).

use super::*;
use crate::stages::Target;
use crate::streaming::Link;
use crate::ResolvedOptions;
use crate::{CameraSource, Presenter};

pub(crate) fn run_sequential(
    t: Target,
    opts: &ResolvedOptions,
    source: &mut dyn CameraSource,
    on_frame: &mut dyn FnMut(FrameReport) -> bool,
    presenter: &mut dyn Presenter,
) -> Result<u64, RuntimeError> {
    let StreamLinks {
        loader,
        or: or_link,
        rvg: rvg_link,
        stc: prefetch,
    } = stream_links(t, opts, 0, 0);
    let Some(loader) = loader else {
        return sequential_frames(t, opts, source, on_frame, presenter, None, None, None);
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
            t, opts, source, on_frame, presenter, or_link, rvg_link, prefetch,
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
    t: Target<'a>,
    opts: &'a ResolvedOptions,
    source: &mut dyn CameraSource,
    on_frame: &mut dyn FnMut(FrameReport) -> bool,
    presenter: &mut dyn Presenter,
    or_link: Option<Link>,
    rvg_link: Option<Link>,
    prefetch: Option<Prefetch<'a>>,
) -> Result<u64, RuntimeError> {
    let mut or = t.or_stage(opts, or_link);
    let mut stc = t.stc_stage(opts, 0, prefetch)?;
    let mut rvg = t.rvg_stage(opts, 0, rvg_link);
    let mut occluders = Occluders::new(opts);
    let mut frozen = Frozen::default();
    let mut frame = 0u64;
    while let Some(sample) = next_sample(source, frame, opts)? {
        let view = sample.view.clone();
        let (stc_out, o, reused) = match frozen.held(sample.hold) {
            Some(s) => (s, None, true),
            None => {
                let tol = sample.pixel_error;
                let o = or.run(frame, &view, tol, occluders.for_frame(frame))?;
                let s = stc.run(frame, &view, tol, o.depth.as_ref(), &mut |_| {})?;
                (s, Some(o), false)
            }
        };
        rvg.begin(frame, &view, sample.style)?;
        // The same chunks as the pipeline, drawn after traversal.
        let retile = reused.then_some((&view, opts));
        draw_set(&mut rvg, t.skeleton, &stc_out, opts.chunk, retile)?;
        occluders.push(frame, stc_out.visible.clone());
        frozen.record(&stc_out);
        let end = FrameEnd {
            sample,
            or: o.map(|o| o.figures).unwrap_or_default(),
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
