//! gigawalk's replay reports: a camera path replayed in the paper's Table 2
//! modes, every frame timed and counted, every K-th frame compared with a
//! full-detail reference; and the `gigawalk demo` driver.
//!
//! Main items: [`replay()`] (run it) with [`ReplayOptions`] and a
//! [`Progress`] watcher, giving a [`Replay`] (every [`FrameRecord`] of
//! every [`RunRecord`]); [`Replay::summary`] ([`Summary`], summary.json)
//! and [`Replay::write_report`] (the report directory,
//! docs/report-format.md); [`Mode`]; [`Accuracy`]; [`demo::DemoScene`].
//!
//! The library prints nothing and draws no bars; the CLI does. It starts
//! no threads of its own ([`bound_violations`] uses rayon's pool inside
//! the call, after each run, like the cull crate's HZB build).

#![forbid(unsafe_code)]

mod accuracy;
pub mod demo;
pub mod gpu_run;
mod mode;
mod plot;
mod replay;
mod report;
mod summary;

pub use accuracy::{
    bound_violations, bound_window, Accuracy, BOUND_RELATIVE_DEPTH, WRONGLY_CULLED_RELATIVE_DEPTH,
};
pub use mode::{runs, Mode};
pub use plot::PlotError;
pub use replay::{
    probe_devices, replay, replay_on, BadOption, FrameRecord, NoProgress, Progress, Replay,
    ReplayError, ReplayOptions, RunRecord, TargetFps, TileFigures,
};
pub use report::{markdown, ReportError, Written};
pub use summary::{median, percentile, ModeSummary, Summary, RUN_TABLE_HEADER};
