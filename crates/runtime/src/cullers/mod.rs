//! The occlusion cullers STC can ask (docs/culling.md), one file each.
//! A culler's file owns its options, their checks and command-line flags,
//! whether it can run on a given runtime ([`Unavailable`]), its state from
//! frame to frame, a frame's culling, and what it reports: its counts a
//! frame, its figures of a run and its table ([`figures`]). This file is
//! the registry: [`CullMethod::ALL`] lists the cullers, and the types here
//! ([`CullerOptions`], [`CullerArgs`], [`CullerWork`], [`State`]) are the
//! one place that dispatches on which runs. Adding a culler is its
//! algorithm (in gigawalk-cull), its file here, its lines in this file,
//! and its docs and tests; nothing outside this module names a culler.

pub mod ct;
pub mod figures;
pub mod grid;
pub mod hzb;
pub mod oq;

use gigawalk_cull::{
    CtStats, CullReason, CullView, Culler, DrawItem, GridStats, RelBox, TraversalOptions,
    TraversalStats, Traverser, Verdict,
};
use gigawalk_gpu::DepthLevel;
use gigawalk_scene::Skeleton;

use crate::streaming::LodSource;
use crate::ResolvedOptions;
use crate::{Runtime, RuntimeError};

pub use ct::{CtArgs, CtOptions};
pub use figures::{Column, Counter, Figure, Pool, Setting, Table};
pub use grid::{GridArgs, GridOptions};
pub use oq::{OqArgs, OqOptions, OqStats};

/// Which occlusion culler STC asks (docs/culling.md has each one's needs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum CullMethod {
    /// GigaWalk's hierarchical Z-buffer over OR's depth of the visible
    /// set of frame i - lag.
    #[default]
    Hzb,
    /// Hey et al.'s lazy occlusion grid over a software depth image STC
    /// draws of the frame it traverses (no OR, no lag).
    Grid,
    /// Bartz et al.'s hardware occlusion queries: node boxes drawn against
    /// the depth of what the frame drew so far, on RVG's device.
    Oq,
    /// Coorg and Teller's object-space culling by the scene's large convex
    /// occluders (no rendering at all).
    Ct,
}

impl CullMethod {
    pub const ALL: [CullMethod; 4] = [
        CullMethod::Hzb,
        CullMethod::Grid,
        CullMethod::Oq,
        CullMethod::Ct,
    ];

    /// Whether the culler reads OR's occluder depth (OR renders nothing
    /// for the others).
    pub fn needs_occluder_depth(self) -> bool {
        self == CullMethod::Hzb
    }

    /// Whether the culler reads the scene's stored occluders (OCCL).
    pub fn reads_occluders(self) -> bool {
        self == CullMethod::Ct
    }

    /// The counts the culler keeps each frame ([`CullerWork::counts`]).
    pub fn counters(self) -> &'static [Counter] {
        match self {
            CullMethod::Hzb => &[],
            CullMethod::Grid => grid::COUNTERS,
            CullMethod::Oq => oq::COUNTERS,
            CullMethod::Ct => ct::COUNTERS,
        }
    }

    /// The figures a run's summary pools from those counts.
    pub fn figures(self) -> &'static [Figure] {
        match self {
            CullMethod::Hzb => &[],
            CullMethod::Grid => grid::FIGURES,
            CullMethod::Oq => oq::FIGURES,
            CullMethod::Ct => ct::FIGURES,
        }
    }

    /// The culler's table in a replay's summary.md, if it has one.
    pub fn table(self) -> Option<&'static Table> {
        match self {
            CullMethod::Grid => Some(&grid::TABLE),
            CullMethod::Oq => Some(&oq::TABLE),
            CullMethod::Hzb | CullMethod::Ct => None,
        }
    }

    /// The culler's settings in `opts`, named as a replay's summary
    /// records them.
    pub fn settings(self, opts: &CullerOptions) -> Vec<(&'static str, Setting)> {
        match self {
            CullMethod::Hzb => Vec::new(),
            CullMethod::Grid => opts.grid.settings(),
            CullMethod::Oq => opts.oq.settings(),
            CullMethod::Ct => opts.ct.settings(),
        }
    }
}

/// Every culler's options (the HZB's are the runtime's own:
/// `RuntimeOptions::hzb_reduction`, the occluder budget and lag).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CullerOptions {
    pub grid: GridOptions,
    pub oq: OqOptions,
    pub ct: CtOptions,
}

impl CullerOptions {
    /// Checks every culler's options (not only the running one's: a bad
    /// value is an error whichever culler runs).
    pub fn validate(&self) -> Result<(), CullerOptionsError> {
        self.grid.validate()?;
        self.oq.validate()?;
        self.ct.validate()
    }
}

/// A culler's option out of its range, named with its value.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CullerOptionsError {
    #[error("grid cell {0} must be 1..=1024 pixels")]
    GridCell(u32),
    #[error("object-space occluders a frame {0} must be 1..=64")]
    CtOccluders(usize),
    #[error("occlusion-query batch {0} must be 1..=4096 (a query set's size)")]
    OqBatch(u32),
    #[error("occlusion-query budget {0} must be a fraction in [0, 10]")]
    OqBudget(f64),
}

/// Every culler's command-line flags, for a CLI to flatten.
#[derive(Clone, Debug, clap::Args)]
pub struct CullerArgs {
    #[command(flatten)]
    grid: GridArgs,
    #[command(flatten)]
    oq: OqArgs,
    #[command(flatten)]
    ct: CtArgs,
}

impl CullerArgs {
    pub fn options(&self) -> CullerOptions {
        CullerOptions {
            grid: self.grid.options(),
            oq: self.oq.options(),
            ct: self.ct.options(),
        }
    }
}

/// What the running culler did in a frame, beyond traversal's own counts
/// (none for the HZB): typed, and as named counts.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum CullerWork {
    Grid(GridStats),
    Oq(OqStats),
    Ct(CtStats),
}

impl CullerWork {
    pub fn culler(&self) -> CullMethod {
        match self {
            CullerWork::Grid(_) => CullMethod::Grid,
            CullerWork::Oq(_) => CullMethod::Oq,
            CullerWork::Ct(_) => CullMethod::Ct,
        }
    }

    /// The frame's counts, in the order of the culler's
    /// [`CullMethod::counters`].
    pub fn counts(&self) -> Vec<f64> {
        match self {
            CullerWork::Grid(s) => grid::counts(s),
            CullerWork::Oq(s) => oq::counts(s),
            CullerWork::Ct(s) => ct::counts(s),
        }
    }

    /// The count named `name`, if this culler keeps it.
    pub fn count(&self, name: &str) -> Option<f64> {
        let i = self
            .culler()
            .counters()
            .iter()
            .position(|c| c.name == name)?;
        Some(self.counts()[i])
    }
}

impl std::fmt::Display for CullMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            CullMethod::Hzb => "hzb",
            CullMethod::Grid => "grid",
            CullMethod::Oq => "oq",
            CullMethod::Ct => "ct",
        })
    }
}

impl std::str::FromStr for CullMethod {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        CullMethod::ALL
            .into_iter()
            .find(|c| c.to_string() == s)
            .ok_or_else(|| {
                let names: Vec<String> = CullMethod::ALL.iter().map(|c| c.to_string()).collect();
                let (last, rest) = names.split_last().expect("at least one culler");
                format!("culler {s:?} is not {} or {last}", rest.join(", "))
            })
    }
}

/// What a runtime offers its cullers ([`CullMethod::check`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Host {
    /// A GPU device (not the CPU rasterizer tests use).
    pub device: bool,
    /// RVG's device holds the whole scene (no streaming).
    pub resident: bool,
    /// The scene file stores occluders (OCCL).
    pub occluders: bool,
}

/// Why a culler cannot run on a runtime.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum Unavailable {
    #[error("it needs a device (none on the CPU)")]
    NoDevice,
    #[error("it draws on RVG's device, which must hold the whole scene (drop --memory-budget)")]
    NotResident,
    #[error("adaptive culling needs sample counts, and this device's occlusion queries only say zero or not")]
    NoSampleCounts,
    #[error(
        "the scene file stores no occluders (written before they were stored): preprocess it again"
    )]
    NoOccluders,
}

impl CullMethod {
    /// Whether the culler can run on `host` (one with adaptive occlusion
    /// queries also needs sample counts, known once its device is asked).
    pub fn check(self, host: &Host) -> Result<(), Unavailable> {
        match self {
            CullMethod::Hzb | CullMethod::Grid => Ok(()),
            CullMethod::Oq => oq::check(host),
            CullMethod::Ct => ct::check(host),
        }
    }
}

/// What STC's culler may use: the scene's LODs and occluders, and the
/// devices when there are any.
pub(crate) struct Setup<'a> {
    pub source: &'a dyn LodSource,
    pub gpu: Option<&'a Runtime<'a>>,
    /// The device RVG draws on.
    pub rvg_device: usize,
}

/// One frame's traversal, run by a culler with its own test.
pub(crate) struct Traversal<'t, 'a> {
    pub traverser: &'t mut Traverser,
    pub skeleton: &'a Skeleton,
    pub view: &'t CullView,
    pub options: &'t TraversalOptions,
    pub sink: &'t mut dyn FnMut(DrawItem),
    pub on_cull: &'t mut dyn FnMut(u32, CullReason),
    /// Time the culler's tests took (summed over the frame's nodes).
    pub test_time: std::time::Duration,
}

impl Traversal<'_, '_> {
    pub fn run<K: Culler + ?Sized>(&mut self, culler: &mut K) -> TraversalStats {
        let mut sink = &mut *self.sink;
        let mut timed = Timed {
            culler,
            time: std::time::Duration::ZERO,
            tests: 0,
        };
        let stats = self.traverser.traverse_culled(
            self.skeleton,
            self.view,
            &mut timed,
            self.options,
            &mut sink,
            &mut *self.on_cull,
        );
        self.test_time += timed.time;
        stats
    }
}

/// A culler whose tests are timed, for the report's split of STC's time:
/// one test in [`TIMED_EVERY`], its time counted that many times (two
/// clock reads a test cost about a fifth of a cheap test's time).
struct Timed<'c, K: ?Sized> {
    culler: &'c mut K,
    time: std::time::Duration,
    tests: u32,
}

/// Tests of a frame's traversal per timed one.
const TIMED_EVERY: u32 = 16;

impl<K: Culler + ?Sized> Culler for Timed<'_, K> {
    type Ctx = K::Ctx;
    const HEARS_QUEUED: bool = K::HEARS_QUEUED;

    fn begin(&mut self, view: &CullView) {
        self.culler.begin(view)
    }

    fn queued(&mut self, view: &CullView, node: u32, b: &RelBox, ctx: &K::Ctx) {
        self.culler.queued(view, node, b, ctx)
    }

    fn test(&mut self, view: &CullView, node: u32, b: &RelBox, ctx: &K::Ctx) -> (Verdict, K::Ctx) {
        self.tests = self.tests.wrapping_add(1);
        if !self.tests.is_multiple_of(TIMED_EVERY) {
            return self.culler.test(view, node, b, ctx);
        }
        let t = web_time::Instant::now();
        let out = self.culler.test(view, node, b, ctx);
        self.time += t.elapsed() * TIMED_EVERY;
        out
    }

    fn drawn(&mut self, view: &CullView, item: DrawItem) {
        self.culler.drawn(view, item)
    }
}

/// The running culler's state from frame to frame (the query pass boxed:
/// it is twice the next largest).
pub(crate) enum State<'a> {
    Hzb(hzb::State),
    Grid(grid::State<'a>),
    Oq(Box<oq::State<'a>>),
    Ct(ct::State),
}

impl<'a> State<'a> {
    /// The state of `opts.culler`: an error naming why it cannot run here
    /// (each culler's own setup finds that out as it takes what it needs:
    /// oq its device's resident geometry, ct the scene's occluders).
    pub fn new(setup: &Setup<'a>, opts: &'a ResolvedOptions) -> Result<Self, RuntimeError> {
        Ok(match opts.culler {
            CullMethod::Hzb => State::Hzb(hzb::State::new(setup)),
            CullMethod::Grid => State::Grid(grid::State::new(setup, &opts.cullers.grid)),
            CullMethod::Oq => State::Oq(Box::new(oq::State::new(setup, opts)?)),
            CullMethod::Ct => State::Ct(ct::State::load(setup, &opts.cullers.ct)?),
        })
    }

    /// Gets the frame ready (the HZB from OR's `depth`); whether the
    /// culler culls this frame (the HZB needs OR's depth, none in the
    /// startup bypass; the others cull from frame 0), and the HZB's ms.
    pub fn prepare(
        &mut self,
        frame: u64,
        depth: Option<&DepthLevel>,
        opts: &ResolvedOptions,
    ) -> Result<(bool, f64), RuntimeError> {
        match self {
            State::Hzb(s) => s.prepare(frame, depth, opts),
            _ => Ok((true, 0.0)),
        }
    }

    /// Traverses the frame with the culler's test.
    pub fn cull(
        &mut self,
        t: &mut Traversal<'_, 'a>,
        opts: &ResolvedOptions,
    ) -> Result<(TraversalStats, Option<CullerWork>), RuntimeError> {
        let o = &opts.cullers;
        Ok(match self {
            State::Hzb(s) => (s.cull(t), None),
            State::Grid(s) => {
                let (stats, g) = s.cull(t, &o.grid);
                (stats, Some(CullerWork::Grid(g)))
            }
            State::Oq(s) => {
                let (stats, q) = s.cull(t, o.oq)?;
                (stats, Some(CullerWork::Oq(q)))
            }
            State::Ct(s) => {
                let (stats, c) = s.cull(t, &o.ct);
                (stats, Some(CullerWork::Ct(c)))
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::RuntimeOptions;

    #[test]
    fn cullers_parse_print_and_say_whether_or_renders() {
        for c in CullMethod::ALL {
            assert_eq!(c.to_string().parse::<CullMethod>(), Ok(c));
        }
        let e = "zbuf".parse::<CullMethod>().unwrap_err();
        assert!(e.contains("hzb, grid, oq or ct"), "{e}");
        let mut o = RuntimeOptions::default();
        assert!(o.wants_occluder_depth());
        o.culler = CullMethod::Grid;
        assert!(!o.wants_occluder_depth());
        o.culler = CullMethod::Hzb;
        o.traversal.occlusion = false;
        assert!(!o.wants_occluder_depth());
    }

    #[test]
    fn bad_culler_options_are_typed_errors_naming_the_option() {
        use crate::OptionsError;
        let check =
            |edit: &dyn Fn(&mut CullerOptions), expected: CullerOptionsError, text: &str| {
                let mut o = RuntimeOptions::default();
                edit(&mut o.cullers);
                let e = o.validate().unwrap_err();
                assert_eq!(e, OptionsError::Culler(expected));
                assert!(e.to_string().contains(text), "{e}");
            };
        check(
            &|o| o.oq.batch = 0,
            CullerOptionsError::OqBatch(0),
            "batch 0",
        );
        check(
            &|o| o.ct.occluders = 65,
            CullerOptionsError::CtOccluders(65),
            "a frame 65",
        );
        check(
            &|o| o.oq.budget = Some(-1.0),
            CullerOptionsError::OqBudget(-1.0),
            "budget -1",
        );
        check(
            &|o| o.grid.cell = 0,
            CullerOptionsError::GridCell(0),
            "grid cell 0",
        );
        check(
            &|o| o.grid.cell = 4096,
            CullerOptionsError::GridCell(4096),
            "grid cell 4096",
        );
    }

    #[test]
    fn every_culler_names_its_counts_figures_and_columns_once() {
        let mut names = std::collections::HashSet::new();
        for c in CullMethod::ALL {
            let counters = c.counters();
            for k in counters {
                assert!(names.insert(k.name), "{c}: count {} twice", k.name);
            }
            let known = |n: &str| counters.iter().any(|k| k.name == n);
            for f in c.figures() {
                assert!(names.insert(f.key), "{c}: figure {} twice", f.key);
                match f.pool {
                    Pool::Mean(n) | Pool::Median(n) => assert!(known(n), "{c}: {n}"),
                    Pool::Share { part, whole } => assert!(known(part) && known(whole), "{c}"),
                }
            }
            for (name, _) in c.settings(&CullerOptions::default()) {
                assert!(names.insert(name), "{c}: setting {name} twice");
            }
            if let Some(t) = c.table() {
                for col in t.columns {
                    if let Column::Figure { key, .. } = col {
                        assert!(c.figures().iter().any(|f| f.key == *key), "{c}: {key}");
                    }
                }
                assert!(!(t.preamble)(&|_| Setting::Unset).is_empty());
            }
        }
    }

    #[test]
    fn a_frames_work_gives_its_counts_by_name() {
        let w = CullerWork::Oq(OqStats {
            queries: 7,
            round_trips: 2,
            over_budget: 1,
            coherent: 3,
            ms: 0.5,
        });
        assert_eq!(w.culler(), CullMethod::Oq);
        assert_eq!(w.counts().len(), CullMethod::Oq.counters().len());
        assert_eq!(w.count("oq_queries"), Some(7.0));
        assert_eq!(w.count("oq_untested"), Some(4.0));
        assert_eq!(w.count("grid_raster_ms"), None);
        let g = CullerWork::Grid(GridStats::default());
        assert_eq!(g.counts().len(), CullMethod::Grid.counters().len());
        let c = CullerWork::Ct(CtStats {
            cache_hits: 3,
            cache_misses: 1,
            ..Default::default()
        });
        assert_eq!(c.counts().len(), CullMethod::Ct.counters().len());
        assert_eq!(c.count("ct_cache_lookups"), Some(4.0));
    }

    #[test]
    fn each_culler_says_what_it_needs() {
        let full = Host {
            device: true,
            resident: true,
            occluders: true,
        };
        for c in CullMethod::ALL {
            assert_eq!(c.check(&full), Ok(()), "{c}");
        }
        let cpu = Host {
            device: false,
            ..full
        };
        assert_eq!(CullMethod::Oq.check(&cpu), Err(Unavailable::NoDevice));
        let streamed = Host {
            resident: false,
            ..full
        };
        assert_eq!(
            CullMethod::Oq.check(&streamed),
            Err(Unavailable::NotResident)
        );
        let old = Host {
            occluders: false,
            ..full
        };
        assert_eq!(CullMethod::Ct.check(&old), Err(Unavailable::NoOccluders));
        for h in [cpu, streamed, old] {
            assert_eq!(CullMethod::Hzb.check(&h), Ok(()));
            assert_eq!(CullMethod::Grid.check(&h), Ok(()));
        }
    }
}
