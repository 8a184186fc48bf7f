//! The occlusion cullers STC can ask (docs/culling.md), one file each.
//! A culler's file owns its options and their checks, whether it can run
//! on a given runtime ([`Unavailable`]), its state from frame to frame and
//! a frame's culling; [`CullMethod::ALL`] lists them, and [`State`] is the
//! one place that dispatches on which runs. Adding a culler is its
//! algorithm (in gigawalk-cull), its file here, its line in
//! [`CullMethod`] and [`State`], and its docs and tests.

pub mod ct;
pub mod grid;
pub mod hzb;
pub mod oq;

use gigawalk_cull::{
    CtStats, CullReason, CullView, Culler, DrawItem, GridStats, TraversalOptions, TraversalStats,
    Traverser,
};
use gigawalk_gpu::DepthImage;
use gigawalk_scene::Skeleton;

use crate::streaming::LodSource;
use crate::{Runtime, RuntimeError, RuntimeOptions};

pub use ct::CtOptions;
pub use grid::GridOptions;
pub use oq::{OqOptions, OqStats};

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
}

impl Traversal<'_, '_> {
    pub fn run<K: Culler + ?Sized>(&mut self, culler: &mut K) -> TraversalStats {
        let mut sink = &mut *self.sink;
        self.traverser.traverse_culled(
            self.skeleton,
            self.view,
            culler,
            self.options,
            &mut sink,
            &mut *self.on_cull,
        )
    }
}

/// What a culler did in a frame, beyond traversal's own counts.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Work {
    pub grid: Option<GridStats>,
    pub oq: Option<OqStats>,
    pub ct: Option<CtStats>,
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
    pub fn new(setup: &Setup<'a>, opts: &'a RuntimeOptions) -> Result<Self, RuntimeError> {
        Ok(match opts.culler {
            CullMethod::Hzb => State::Hzb(hzb::State::new(setup)),
            CullMethod::Grid => State::Grid(grid::State::new(setup, &opts.grid)),
            CullMethod::Oq => State::Oq(Box::new(oq::State::new(setup, opts)?)),
            CullMethod::Ct => State::Ct(ct::State::load(setup, &opts.ct)?),
        })
    }

    /// Gets the frame ready (the HZB from OR's `depth`); whether the
    /// culler culls this frame (the HZB needs OR's depth, none in the
    /// startup bypass; the others cull from frame 0), and the HZB's ms.
    pub fn prepare(
        &mut self,
        frame: u64,
        depth: Option<&DepthImage>,
        opts: &RuntimeOptions,
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
        opts: &RuntimeOptions,
    ) -> Result<(TraversalStats, Work), RuntimeError> {
        let mut work = Work::default();
        let stats = match self {
            State::Hzb(s) => s.cull(t),
            State::Grid(s) => {
                let (stats, g) = s.cull(t, &opts.grid);
                work.grid = Some(g);
                stats
            }
            State::Oq(s) => {
                let (stats, q) = s.cull(t, opts.oq)?;
                work.oq = Some(q);
                stats
            }
            State::Ct(s) => {
                let (stats, c) = s.cull(t, &opts.ct);
                work.ct = Some(c);
                stats
            }
        };
        Ok((stats, work))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
