//! Runtime options: every speed/accuracy knob of the pipeline.

use gigawalk_cull::tiles::{TileGrid, TileMethod};
pub use gigawalk_cull::{auto_hzb_level, HZB_READ_TEXELS};
use gigawalk_cull::{Reduction, TraversalOptions};

pub use crate::cullers::{CullMethod, CullerOptions, CullerOptionsError};

/// How the three stages run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Schedule {
    /// OR, STC and RVG on their own threads (and devices), joined by
    /// queues: the paper's pipeline (Section 5.1).
    Pipelined,
    /// One thread, one device, the same algorithms one after another: the
    /// baseline the pipeline is measured against.
    Sequential,
}

/// A stage of the pipeline, for statistics, tracing and errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Occluder render (GPU device A).
    Or,
    /// Scene traversal, culling and LOD selection (CPU).
    Stc,
    /// Render visible geometry (GPU device B).
    Rvg,
    /// Read streamed LODs from the scene file (out of core).
    Loader,
}

impl std::fmt::Display for Stage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Stage::Or => "OR",
            Stage::Stc => "STC",
            Stage::Rvg => "RVG",
            Stage::Loader => "loader",
        })
    }
}

/// How many triangles of occluders OR draws a frame. Conservative at any
/// budget: fewer occluders make the HZB farther, so STC culls less, never
/// wrongly.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum OccluderBudget {
    /// All of frame i - lag's visible set (the paper). The default: with
    /// HLODs whose errors are measured bounds (preprocess revision 3) the
    /// visible set is small, and all occluders made `och` and `occ` faster
    /// than a 30k or 100k budget on the 4M, 20M and 50M plants even on
    /// lavapipe (docs/results.md, "Occluder budget").
    #[default]
    All,
    /// At most this many triangles, those hiding most per triangle first
    /// (`gigawalk_cull::select_occluders`).
    Triangles(u64),
    /// [`CPU_OCCLUDER_BUDGET`] triangles when a device is a CPU rasterizer
    /// (lavapipe, llvmpipe, WARP), where OR's triangles come out of RVG's
    /// time on the same cores; `All` on GPUs, where OR has its own device.
    /// The default until the visible sets shrank (it made `och` 1.29x
    /// faster on the 4M plant when och drew 335k triangles a frame).
    Auto,
    /// Chosen frame by frame from what OR costs against what its occluders
    /// save RVG (the runtime's `occluders` module): starts with all, probes
    /// smaller and larger budgets along the walk and keeps the cheaper.
    Adaptive,
}

/// The budget `OccluderBudget::Auto` uses on CPU rasterizers: on the 4M
/// demo plant with lavapipe and the estimated LOD errors of preprocess
/// revision 1, 10k-30k triangles made `och` 1.29x faster than all
/// occluders (docs/results.md, "Occluder budget").
pub const CPU_OCCLUDER_BUDGET: u64 = 30_000;

/// An [`OccluderBudget`] as a run on given devices uses it (`Auto`
/// resolved).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum OccluderSelection {
    /// All of frame i - lag's visible set.
    #[default]
    All,
    /// At most this many triangles, those hiding most per triangle first.
    Triangles(u64),
    /// Chosen frame by frame ([`OccluderBudget::Adaptive`]).
    Adaptive,
}

impl std::fmt::Display for OccluderSelection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            OccluderSelection::All => f.write_str("all"),
            OccluderSelection::Triangles(t) => write!(f, "at most {t} triangles"),
            OccluderSelection::Adaptive => f.write_str("adaptive"),
        }
    }
}

impl OccluderBudget {
    /// What the budget means given whether any device rasterizes on the
    /// CPU.
    pub fn resolve(self, cpu_device: bool) -> OccluderSelection {
        match self {
            OccluderBudget::All => OccluderSelection::All,
            OccluderBudget::Triangles(t) => OccluderSelection::Triangles(t),
            OccluderBudget::Auto if cpu_device => OccluderSelection::Triangles(CPU_OCCLUDER_BUDGET),
            OccluderBudget::Auto => OccluderSelection::All,
            OccluderBudget::Adaptive => OccluderSelection::Adaptive,
        }
    }
}

impl std::fmt::Display for OccluderBudget {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            OccluderBudget::All => f.write_str("all"),
            OccluderBudget::Triangles(t) => write!(f, "{t}"),
            OccluderBudget::Auto => f.write_str("auto"),
            OccluderBudget::Adaptive => f.write_str("adaptive"),
        }
    }
}

impl std::str::FromStr for OccluderBudget {
    type Err = String;
    /// `all`, `auto`, `adaptive`, or a triangle count (`30000`, `30k`, `2M`).
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "all" => return Ok(OccluderBudget::All),
            "auto" => return Ok(OccluderBudget::Auto),
            "adaptive" => return Ok(OccluderBudget::Adaptive),
            _ => {}
        }
        let (v, mul) = scaled(s, &[(b'k', 1e3), (b'm', 1e6)]).ok_or_else(|| {
            format!("occluder budget {s:?} is not all, auto, adaptive or a triangle count (e.g. 30000, 30k)")
        })?;
        // Below 2^63: every count that fits prints and parses back.
        if !(v.is_finite() && v >= 0.0) || v * mul >= 9.2e18 {
            return Err(format!(
                "occluder budget {s:?} is out of range (0 to 9.2e18 triangles)"
            ));
        }
        Ok(OccluderBudget::Triangles((v * mul).round() as u64))
    }
}

/// What STC asks the loader for ahead of need when streaming
/// (docs/results.md, "Prefetch", has what each costs and buys).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Prefetching {
    /// Nothing: the loader reads what frames had to stand in for.
    #[default]
    Off,
    /// The distance band: what a drawn LOD near its switching distance
    /// will switch to as the camera approaches.
    Band,
    /// The ring a quarter wider than the frustum, at the view's pixel
    /// scale: what a turn or a sideways step brings into view.
    Ring,
    /// Both.
    Both,
}

impl Prefetching {
    pub fn band(self) -> bool {
        matches!(self, Prefetching::Band | Prefetching::Both)
    }
    pub fn ring(self) -> bool {
        matches!(self, Prefetching::Ring | Prefetching::Both)
    }
    pub fn any(self) -> bool {
        self != Prefetching::Off
    }
}

impl std::fmt::Display for Prefetching {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Prefetching::Off => "off",
            Prefetching::Band => "band",
            Prefetching::Ring => "ring",
            Prefetching::Both => "both",
        })
    }
}

impl std::str::FromStr for Prefetching {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s {
            "off" => Prefetching::Off,
            "band" => Prefetching::Band,
            "ring" => Prefetching::Ring,
            "both" => Prefetching::Both,
            _ => return Err(format!("prefetch {s:?} is not off, band, ring or both")),
        })
    }
}

/// Where STC's HZB pyramid is built (`--hzb`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HzbBuild {
    /// On OR's device, from its depth, up to a level that is read back;
    /// STC reduces the coarser levels and tests no finer than that one.
    Gpu(HzbLevel),
    /// The whole depth image read back and the pyramid built on the CPU
    /// (the paper's Section 5.1.2, and the reference the GPU's is measured
    /// against).
    Cpu,
}

impl Default for HzbBuild {
    fn default() -> Self {
        HzbBuild::Gpu(HzbLevel::Auto)
    }
}

/// Which level of OR's pyramid is read back (`--hzb-level`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum HzbLevel {
    /// [`auto_hzb_level`] of the occluder size.
    #[default]
    Auto,
    /// This level (0: the whole image; clamped to the 1x1 top).
    Fixed(u32),
}

impl std::str::FromStr for HzbBuild {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "gpu" => Ok(HzbBuild::default()),
            "cpu" => Ok(HzbBuild::Cpu),
            _ => Err(format!("--hzb {s:?} is not gpu or cpu")),
        }
    }
}

impl std::str::FromStr for HzbLevel {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(HzbLevel::Auto),
            _ => s
                .parse::<u32>()
                .ok()
                .filter(|&k| k <= MAX_HZB_LEVEL)
                .map(HzbLevel::Fixed)
                .ok_or_else(|| {
                    format!("--hzb-level {s:?} is not auto or a level 0 to {MAX_HZB_LEVEL}")
                }),
        }
    }
}

/// The coarsest level a run may ask for: a 16384-pixel side's pyramid
/// reaches 1x1 at level 14.
pub const MAX_HZB_LEVEL: u32 = 14;

#[derive(Clone, Debug, PartialEq)]
pub struct RuntimeOptions {
    pub schedule: Schedule,
    /// Viewport size of the visible render.
    pub width: u32,
    pub height: u32,
    /// Occlusion culling, HLOD and the pixel-error tolerance.
    pub traversal: TraversalOptions,
    /// Frame i's occluders are the visible set of frame i - lag (paper:
    /// 2, so OR never waits for the previous frame's STC; 1 is tighter but
    /// serialises OR behind STC). The first `lag` frames run without
    /// occlusion (startup bypass, Section 5.1.1).
    pub occluder_lag: u32,
    /// Occluder depth resolution as a fraction of the viewport (Section
    /// 5.3: lower is faster and approximate). 1 = conservative.
    pub occluder_scale: f64,
    /// How many occluder triangles OR draws a frame (see [`OccluderBudget`]).
    pub occluder_budget: OccluderBudget,
    /// How the HZB reduces depth: farthest (conservative) or n-th farthest
    /// (approximate, Section 5.3; built on the CPU whatever `hzb` says).
    pub hzb_reduction: Reduction,
    /// Where the HZB's pyramid is built: on OR's device, a small level of
    /// it read back (the default), or on the CPU from the whole image.
    pub hzb: HzbBuild,
    /// Number of wgpu devices in pipelined mode (1 or 2).
    pub devices: usize,
    /// Visible items per RVG submission: RVG starts drawing a frame while
    /// STC is still traversing it.
    pub chunk: usize,
    /// Asynchronous RVG (Section 5.3): RVG does not wait for STC's list of
    /// the current camera; it draws the newest finished list with the
    /// newest camera. Removes a frame of latency; may show brief occlusion
    /// errors when the camera moves fast. Pipelined schedule only.
    pub async_rvg: bool,
    /// Speculative RVG (the paper's Section 8 proposal): when nothing of
    /// STC's list for the next camera has come within the last frame's own
    /// drawing time, RVG draws the last finished list with that camera
    /// instead of waiting, once, then draws the real frame when it comes.
    /// Reported as extra frames (`FrameReport::speculative`). Pipelined,
    /// synchronous RVG only.
    pub speculative_rvg: bool,
    /// Measurement hook: STC sleeps this many ms a frame (a slow STC, to
    /// measure what speculative or asynchronous RVG save). 0: off.
    pub stc_delay_ms: f64,
    /// Streaming: what STC asks the loader for ahead of need. Off by
    /// default: on the 50M plant's walk the band cut frames with a
    /// stand-in (35-38 of 55 instead of 48) but drew more stand-ins and
    /// loaded 30% more; the ring loaded 85% more for no fewer stand-ins
    /// (docs/results.md, "Prefetch").
    pub prefetch: Prefetching,
    /// The occlusion culler (with `traversal.occlusion`).
    pub culler: CullMethod,
    /// Every culler's own options.
    pub cullers: CullerOptions,
    /// A tiled display (Nirnimesh, Harish and Narayanan): the viewport
    /// split into `cols x rows` tiles, each drawn from its own list under
    /// its own scissor rectangle; `None`: one view.
    pub tiles: Option<TileGrid>,
    /// How STC sends drawn items to the tiles (both naive and adaptive are
    /// timed every frame; this one is drawn).
    pub tile_culling: TileMethod,
    /// Fill `FrameReport::culled` with every culled node (for the viewer's
    /// box overlay); off by default since big scenes cull many nodes.
    pub record_culled: bool,
    /// Test hook: make a stage fail at a frame, to check that any
    /// stage's error stops every stage. Only the `testing` feature can
    /// set one ([`FailureHook::at`]); the field exists either way, so the
    /// feature never changes this struct for other crates.
    #[doc(hidden)]
    pub inject_failure: FailureHook,
}

/// A stage made to fail from a frame on (see
/// [`RuntimeOptions::inject_failure`]); none by default.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FailureHook(Option<(Stage, u64)>);

impl FailureHook {
    /// `stage` fails at `frame` (or the first frame after it that it
    /// runs: with asynchronous RVG, OR and STC may skip the exact frame).
    #[cfg(feature = "testing")]
    pub fn at(stage: Stage, frame: u64) -> Self {
        FailureHook(Some((stage, frame)))
    }

    /// The injected error, when `stage` is the one to fail and its frame
    /// has come.
    pub(crate) fn check(self, stage: Stage, frame: u64) -> Result<(), crate::RuntimeError> {
        match self.0 {
            Some((s, f)) if s == stage && frame >= f => {
                Err(crate::RuntimeError::Injected { stage, frame: f })
            }
            _ => Ok(()),
        }
    }
}

/// A runtime option out of its range, named with its value.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum OptionsError {
    #[error("viewport {width}x{height} must be 1..=16384 on each side")]
    Viewport { width: u32, height: u32 },
    #[error("occluder lag {0} must be 1 or 2")]
    OccluderLag(u32),
    #[error("occluder scale {0} must be in (0, 1]")]
    OccluderScale(f64),
    #[error("devices {0} must be 1 or 2")]
    Devices(usize),
    #[error("tiles {tiles}: each tile needs at least one pixel of the {width}x{height} viewport")]
    Tiles {
        tiles: TileGrid,
        width: u32,
        height: u32,
    },
    #[error("pixel error {0} must be a finite number >= 0")]
    PixelError(f64),
    #[error("n-th farthest HZB needs n in 1..=4, got {0}")]
    NthFarthest(u8),
    #[error("HZB level {0} must be 0 to 14 (0 reads the whole depth image)")]
    HzbLevel(u32),
    #[error("asynchronous RVG needs the pipelined schedule")]
    AsyncNeedsPipelined,
    #[error("speculative RVG needs the pipelined schedule with synchronous RVG")]
    SpeculativeNeedsSynchronousPipeline,
    #[error("STC delay {0} ms must be 0 to 10000")]
    StcDelay(f64),
    #[error("chunk must be at least 1")]
    Chunk,
    #[error(transparent)]
    Culler(#[from] CullerOptionsError),
}

impl Default for RuntimeOptions {
    fn default() -> Self {
        RuntimeOptions {
            schedule: Schedule::Pipelined,
            width: 640,
            height: 360,
            traversal: TraversalOptions::default(),
            occluder_lag: 2,
            occluder_scale: 1.0,
            occluder_budget: OccluderBudget::All,
            hzb_reduction: Reduction::Farthest,
            hzb: HzbBuild::default(),
            devices: 2,
            chunk: 256,
            async_rvg: false,
            speculative_rvg: false,
            stc_delay_ms: 0.0,
            prefetch: Prefetching::Off,
            culler: CullMethod::Hzb,
            cullers: CullerOptions::default(),
            tiles: None,
            tile_culling: TileMethod::Adaptive,
            record_culled: false,
            inject_failure: FailureHook::default(),
        }
    }
}

/// Options a run has checked, with the occluder budget resolved for its
/// devices: all the schedules and stages receive. Only
/// [`RuntimeOptions::resolve`] makes one, so no stage sees an unchecked
/// option or an unresolved `auto` budget. Reads as the options it holds.
#[derive(Clone, Debug)]
pub(crate) struct ResolvedOptions {
    opts: RuntimeOptions,
    /// What the occluder budget means on the run's devices.
    pub occluders: OccluderSelection,
}

impl std::ops::Deref for ResolvedOptions {
    type Target = RuntimeOptions;

    fn deref(&self) -> &RuntimeOptions {
        &self.opts
    }
}

impl RuntimeOptions {
    /// The checked options for a run on devices of which some rasterize
    /// on the CPU (`cpu_device`: `auto` budgets resolve for them).
    pub(crate) fn resolve(&self, cpu_device: bool) -> Result<ResolvedOptions, OptionsError> {
        self.validate()?;
        let t = self.traversal;
        Ok(ResolvedOptions {
            opts: RuntimeOptions {
                // HLOD off is full detail, whatever the pixel error.
                traversal: TraversalOptions::mode(t.occlusion, t.hlod, t.pixel_error),
                ..self.clone()
            },
            occluders: self.occluder_budget.resolve(cpu_device),
        })
    }

    /// Checks the options; the error names the first bad one.
    pub fn validate(&self) -> Result<(), OptionsError> {
        if self.width == 0 || self.height == 0 || self.width > 16384 || self.height > 16384 {
            return Err(OptionsError::Viewport {
                width: self.width,
                height: self.height,
            });
        }
        if !(1..=2).contains(&self.occluder_lag) {
            return Err(OptionsError::OccluderLag(self.occluder_lag));
        }
        if !(self.occluder_scale > 0.0 && self.occluder_scale <= 1.0) {
            return Err(OptionsError::OccluderScale(self.occluder_scale));
        }
        if !(1..=2).contains(&self.devices) {
            return Err(OptionsError::Devices(self.devices));
        }
        if !(self.traversal.pixel_error >= 0.0 && self.traversal.pixel_error.is_finite()) {
            return Err(OptionsError::PixelError(self.traversal.pixel_error));
        }
        if let Reduction::NthFarthest(n) = self.hzb_reduction {
            if !(1..=4).contains(&n) {
                return Err(OptionsError::NthFarthest(n));
            }
        }
        if let HzbBuild::Gpu(HzbLevel::Fixed(k)) = self.hzb {
            if k > MAX_HZB_LEVEL {
                return Err(OptionsError::HzbLevel(k));
            }
        }
        if self.async_rvg && self.schedule == Schedule::Sequential {
            return Err(OptionsError::AsyncNeedsPipelined);
        }
        if self.speculative_rvg && (self.async_rvg || self.schedule == Schedule::Sequential) {
            return Err(OptionsError::SpeculativeNeedsSynchronousPipeline);
        }
        if !(self.stc_delay_ms.is_finite() && (0.0..=10_000.0).contains(&self.stc_delay_ms)) {
            return Err(OptionsError::StcDelay(self.stc_delay_ms));
        }
        if self.chunk == 0 {
            return Err(OptionsError::Chunk);
        }
        if let Some(t) = self.tiles {
            if t.cols == 0 || t.rows == 0 || t.cols > self.width || t.rows > self.height {
                return Err(OptionsError::Tiles {
                    tiles: t,
                    width: self.width,
                    height: self.height,
                });
            }
        }
        self.cullers.validate()?;
        Ok(())
    }

    /// Whether OR renders occluder depth at all (the culler reads it).
    /// The traversal of a frame whose request sets `pixel_error` (`None`:
    /// the options'): HLOD off stays full detail whatever the request
    /// (`TraversalOptions::mode`).
    pub fn traversal_at(&self, pixel_error: Option<f64>) -> TraversalOptions {
        let t = self.traversal;
        TraversalOptions::mode(t.occlusion, t.hlod, pixel_error.unwrap_or(t.pixel_error))
    }

    pub fn wants_occluder_depth(&self) -> bool {
        self.traversal.occlusion && self.culler.needs_occluder_depth()
    }

    /// The level of the occluder depth's pyramid OR reads back for the
    /// HZB: 0 (the whole image) when the CPU builds the pyramid, as it
    /// does for an n-th farthest reduction (OR's device reduces only to
    /// the farthest); with `auto`, [`auto_hzb_level`] of the occluder size.
    pub fn hzb_read_level(&self) -> u32 {
        match (self.hzb, self.hzb_reduction) {
            (HzbBuild::Cpu, _) | (_, Reduction::NthFarthest(2..)) => 0,
            (HzbBuild::Gpu(HzbLevel::Fixed(k)), _) => k,
            (HzbBuild::Gpu(HzbLevel::Auto), _) => {
                let (w, h) = self.occluder_size();
                auto_hzb_level(w, h)
            }
        }
    }

    /// The occluder depth image size.
    pub fn occluder_size(&self) -> (u32, u32) {
        let s = |v: u32| ((v as f64 * self.occluder_scale).round() as u32).max(1);
        (s(self.width), s(self.height))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_options_are_typed_errors_naming_the_option() {
        let check = |edit: &dyn Fn(&mut RuntimeOptions), expected: OptionsError, text: &str| {
            let mut o = RuntimeOptions::default();
            edit(&mut o);
            let e = o.validate().unwrap_err();
            assert_eq!(e, expected);
            assert!(e.to_string().contains(text), "{e}");
        };
        assert_eq!(RuntimeOptions::default().validate(), Ok(()));
        check(
            &|o| o.width = 0,
            OptionsError::Viewport {
                width: 0,
                height: 360,
            },
            "viewport 0x360",
        );
        check(
            &|o| o.occluder_lag = 3,
            OptionsError::OccluderLag(3),
            "occluder lag 3",
        );
        check(
            &|o| o.occluder_scale = 0.0,
            OptionsError::OccluderScale(0.0),
            "occluder scale 0",
        );
        check(&|o| o.devices = 3, OptionsError::Devices(3), "devices 3");
        check(&|o| o.chunk = 0, OptionsError::Chunk, "chunk");
        check(
            &|o| o.hzb_reduction = Reduction::NthFarthest(5),
            OptionsError::NthFarthest(5),
            "got 5",
        );
        check(
            &|o| {
                o.async_rvg = true;
                o.schedule = Schedule::Sequential;
            },
            OptionsError::AsyncNeedsPipelined,
            "asynchronous RVG",
        );
        check(
            &|o| {
                o.speculative_rvg = true;
                o.async_rvg = true;
            },
            OptionsError::SpeculativeNeedsSynchronousPipeline,
            "speculative RVG",
        );
        check(
            &|o| o.stc_delay_ms = -1.0,
            OptionsError::StcDelay(-1.0),
            "STC delay",
        );
        let o = RuntimeOptions {
            stc_delay_ms: f64::NAN,
            ..RuntimeOptions::default()
        };
        assert!(matches!(o.validate(), Err(OptionsError::StcDelay(_))));
    }

    #[test]
    fn occluder_budget_parses_and_resolves() {
        let p = |s: &str| s.parse::<OccluderBudget>();
        assert_eq!(p("all"), Ok(OccluderBudget::All));
        assert_eq!(p("auto"), Ok(OccluderBudget::Auto));
        assert_eq!(p("adaptive"), Ok(OccluderBudget::Adaptive));
        assert_eq!(p("30000"), Ok(OccluderBudget::Triangles(30_000)));
        assert_eq!(p("30k"), Ok(OccluderBudget::Triangles(30_000)));
        assert_eq!(p("1.5M"), Ok(OccluderBudget::Triangles(1_500_000)));
        assert_eq!(p("0"), Ok(OccluderBudget::Triangles(0)));
        for bad in ["", "k", "-5", "nan", "inf", "1e19", "lots", "ALL"] {
            let e = p(bad).unwrap_err();
            assert!(e.contains("occluder budget"), "{bad:?}: {e}");
        }
        for b in [
            OccluderBudget::All,
            OccluderBudget::Auto,
            OccluderBudget::Adaptive,
            OccluderBudget::Triangles(7),
            OccluderBudget::Triangles(1 << 62),
        ] {
            assert_eq!(p(&b.to_string()), Ok(b));
        }
        use OccluderSelection as S;
        assert_eq!(
            OccluderBudget::Auto.resolve(true),
            S::Triangles(CPU_OCCLUDER_BUDGET)
        );
        assert_eq!(OccluderBudget::Auto.resolve(false), S::All);
        assert_eq!(OccluderBudget::All.resolve(true), S::All);
        assert_eq!(OccluderBudget::Adaptive.resolve(true), S::Adaptive);
        assert_eq!(OccluderBudget::Adaptive.resolve(false), S::Adaptive);
        assert_eq!(OccluderBudget::Triangles(5).resolve(false), S::Triangles(5));
        assert_eq!(
            RuntimeOptions::default().occluder_budget,
            OccluderBudget::All
        );
    }
}

/// Device memory for geometry, per device (`--memory-budget`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MemoryBudget {
    /// The whole scene, loaded before the first frame.
    #[default]
    All,
    /// At most this many bytes a device; a scene that does not fit is
    /// streamed (out of core), one that fits is loaded whole.
    Bytes(u64),
    /// [`AUTO_MEMORY_SHARE`] of the machine's physical memory a device.
    Auto,
}

/// The share of physical memory `MemoryBudget::Auto` gives each device.
/// lavapipe's devices live in host memory, so two of them take half.
pub const AUTO_MEMORY_SHARE: f64 = 0.25;

/// `--memory-budget auto` on a machine whose memory size is unknown.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "memory budget auto: cannot read this machine's memory size (/proc/meminfo); give a size such as 4G"
)]
pub struct MemoryUnknown;

impl MemoryBudget {
    /// Bytes a device may hold, `None` for all of the scene.
    pub fn resolve(self) -> Result<Option<u64>, MemoryUnknown> {
        match self {
            MemoryBudget::All => Ok(None),
            MemoryBudget::Bytes(b) => Ok(Some(b)),
            MemoryBudget::Auto => physical_memory()
                .map(|m| Some((m as f64 * AUTO_MEMORY_SHARE) as u64))
                .ok_or(MemoryUnknown),
        }
    }
}

/// A number with an optional one-letter suffix from `suffixes` (either
/// case): the number and the suffix's multiplier (1 without one).
fn scaled(s: &str, suffixes: &[(u8, f64)]) -> Option<(f64, f64)> {
    let last = s.as_bytes().last()?.to_ascii_lowercase();
    let (num, mul) = match suffixes.iter().find(|(c, _)| *c == last) {
        Some(&(_, m)) => (&s[..s.len() - 1], m),
        None => (s, 1.0),
    };
    Some((num.parse().ok()?, mul))
}

/// Physical memory in bytes (Linux: MemTotal of /proc/meminfo).
fn physical_memory() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

impl std::fmt::Display for MemoryBudget {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MemoryBudget::All => f.write_str("all"),
            MemoryBudget::Bytes(b) => write!(f, "{b}"),
            MemoryBudget::Auto => f.write_str("auto"),
        }
    }
}

impl std::str::FromStr for MemoryBudget {
    type Err = String;
    /// `all`, `auto`, or bytes with an optional K, M or G suffix (powers
    /// of 1024: `256M`, `1.5G`, `1000000`).
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "all" => return Ok(MemoryBudget::All),
            "auto" => return Ok(MemoryBudget::Auto),
            _ => {}
        }
        let k = 1024.0;
        let (v, mul) =
            scaled(s, &[(b'k', k), (b'm', k * k), (b'g', k * k * k)]).ok_or_else(|| {
                format!("memory budget {s:?} is not all, auto or a size in bytes (e.g. 256M, 1G)")
            })?;
        let bytes = v * mul;
        if !(bytes.is_finite() && bytes >= 1.0) || bytes >= 9.2e18 {
            return Err(format!(
                "memory budget {s:?} is out of range (1 byte to 8 EiB)"
            ));
        }
        Ok(MemoryBudget::Bytes(bytes as u64))
    }
}

#[cfg(test)]
mod budget_tests {
    use super::*;

    #[test]
    fn memory_budgets_parse_with_suffixes_and_reject_nonsense() {
        let p = |s: &str| s.parse::<MemoryBudget>();
        assert_eq!(p("all"), Ok(MemoryBudget::All));
        assert_eq!(p("auto"), Ok(MemoryBudget::Auto));
        assert_eq!(p("1000"), Ok(MemoryBudget::Bytes(1000)));
        assert_eq!(p("64k"), Ok(MemoryBudget::Bytes(65536)));
        assert_eq!(p("256M"), Ok(MemoryBudget::Bytes(256 << 20)));
        assert_eq!(p("1G"), Ok(MemoryBudget::Bytes(1 << 30)));
        assert_eq!(p("1.5g"), Ok(MemoryBudget::Bytes(3 << 29)));
        for bad in [
            "", "G", "-1G", "0", "nan", "inf", "1e30", "lots", "ALL", "1T",
        ] {
            let e = p(bad).unwrap_err();
            assert!(e.contains("memory budget"), "{bad:?}: {e}");
        }
        for b in [
            MemoryBudget::All,
            MemoryBudget::Auto,
            MemoryBudget::Bytes(12345),
        ] {
            assert_eq!(p(&b.to_string()), Ok(b));
        }
        assert_eq!(MemoryBudget::All.resolve(), Ok(None));
        assert_eq!(MemoryBudget::Bytes(7).resolve(), Ok(Some(7)));
        if std::path::Path::new("/proc/meminfo").exists() {
            assert!(MemoryBudget::Auto.resolve().unwrap().unwrap() > 1 << 20);
        }
    }
}

#[cfg(test)]
mod prefetch_tests {
    use super::*;

    #[test]
    fn prefetch_modes_parse_print_and_say_what_they_ask_for() {
        for m in [
            Prefetching::Off,
            Prefetching::Band,
            Prefetching::Ring,
            Prefetching::Both,
        ] {
            assert_eq!(m.to_string().parse::<Prefetching>(), Ok(m));
            assert_eq!(m.any(), m.band() || m.ring());
        }
        assert!(Prefetching::Both.band() && Prefetching::Both.ring());
        assert!(!Prefetching::Band.ring() && !Prefetching::Ring.band());
        for bad in ["", "on", "BAND", "band,ring"] {
            let e = bad.parse::<Prefetching>().unwrap_err();
            assert!(e.contains("off, band, ring or both"), "{bad:?}: {e}");
        }
    }
}
