//! Per-run statistics of a replay: frame rates, percentiles, speed-ups over
//! `vfc`, pooled accuracy; the shape of summary.json
//! (docs/report-format.md).

use serde::{Deserialize, Serialize};

use gigawalk_runtime::{Column, CullMethod, Pool, Setting};

use crate::accuracy::Accuracy;
use crate::mode::Mode;
use crate::replay::{FrameRecord, Replay, RunRecord};

/// summary.json.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Summary {
    pub scene: String,
    pub path: String,
    /// Poses replayed per run.
    pub frames: usize,
    pub width: u32,
    pub height: u32,
    pub warmup_frames: usize,
    pub accuracy_every: usize,
    /// False when the replay was stopped early: some runs have fewer frames
    /// or are missing.
    pub complete: bool,
    pub devices: Vec<String>,
    /// Ran on the null adapter (wgpu's noop backend): every GPU operation
    /// free, nothing drawn, depth read back as zeros, so frame times are
    /// what the CPU can feed, with nothing occluded, and no accuracy.
    #[serde(default)]
    pub null_adapter: bool,
    /// Objects hidden in the reference and every run (`--hide`,
    /// `--isolate`, `--view`); 0: every object shown.
    #[serde(default)]
    pub hidden_objects: usize,
    /// The section's planes and box, in the reference and every run
    /// (`--section`, `--section-box`); null: nothing cut.
    #[serde(default)]
    pub section: Option<String>,
    /// What each run's shown image added, run every frame (`--aa`,
    /// `--edges`, `--ao`, `--sky`); null: nothing.
    #[serde(default)]
    pub look: Option<String>,
    /// The hidden objects were drawn as x-ray ghosts (`--xray`).
    #[serde(default)]
    pub xray: bool,
    pub schedule: String,
    pub occluder_lag: u32,
    pub occluder_scale: f64,
    /// Most occluder triangles OR draws a frame; null: no fixed budget
    /// (all of frame i - lag's visible set, or adaptive).
    pub occluder_budget: Option<u64>,
    /// "all", "budget" (at most `occluder_budget` triangles) or "adaptive"
    /// (chosen frame by frame; each frame's choice is in frames.csv).
    #[serde(default)]
    pub occluder_selection: String,
    pub hzb_reduction: String,
    /// Streaming: device bytes a device may hold; null when the whole
    /// scene is resident (no `--memory-budget`, or the scene fits it).
    #[serde(default)]
    pub memory_budget: Option<u64>,
    /// Streamed reference frames still drawing a stand-in when taken.
    #[serde(default)]
    pub unsettled_reference_frames: usize,
    pub seconds: f64,
    /// Every culler's settings (`grid_cell`, `oq_batch`, ...: each
    /// culler's file names its own), null for a culler no run used.
    #[serde(flatten)]
    pub culler_settings: CullerSettings,
    pub modes: Vec<ModeSummary>,
}

/// One run's figures. Frame statistics leave out the warm-up frames;
/// accuracy pools every compared frame.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModeSummary {
    pub name: String,
    pub pixel_error: f64,
    /// The occlusion culler ("hzb", "grid"); null for modes without
    /// occlusion.
    #[serde(default)]
    pub culler: Option<String>,
    /// Frames recorded (warm-up included).
    pub frames: usize,
    /// Frame intervals the statistics use.
    pub measured_frames: usize,
    /// Frames / time over the measured intervals (1000 / mean frame ms).
    pub mean_fps: f64,
    pub median_frame_ms: f64,
    pub p95_frame_ms: f64,
    pub mean_triangles: f64,
    /// `mean_triangles` / (`width` x `height`): triangles drawn a frame per
    /// viewport pixel. Above about 1 most drawn triangles cover less than
    /// a pixel, detail the image cannot show; null without measured frames.
    #[serde(default)]
    pub triangles_per_pixel: Option<f64>,
    pub mean_drawn_nodes: f64,
    pub mean_visited: f64,
    pub mean_occlusion_culled: f64,
    /// Nodes a frame dropped as wholly on the section's removed side.
    #[serde(default)]
    pub mean_section_culled: f64,
    /// mean_fps / vfc's mean_fps (null without a vfc run).
    pub speedup_vs_vfc: Option<f64>,
    /// vfc's median frame ms / this run's median frame ms.
    pub median_speedup_vs_vfc: Option<f64>,
    pub mean_latency_ms: f64,
    pub median_or_ms: f64,
    /// Median occluder triangles OR drew a frame.
    #[serde(default)]
    pub median_occluder_triangles: f64,
    pub median_hzb_ms: f64,
    pub median_stc_ms: f64,
    pub median_rvg_ms: f64,
    /// Where the stages' CPU time went (medians a frame) and what was read
    /// back (mean bytes a frame).
    #[serde(default)]
    pub cpu: CpuSummary,
    /// Every culler's figures of the run (`median_grid_raster_ms`,
    /// `mean_oq_queries`, ...: each culler's file names and pools its
    /// own), null for the cullers the run did not use.
    #[serde(flatten)]
    pub culler_figures: CullerFigures,
    /// A tiled display (`--tiles`): the grid ("4x4") and how items were
    /// sent to tiles; the median milliseconds of the adaptive and the
    /// naive method on the same frames (both run every frame); triangles
    /// of the busiest tile and of the mean tile, means over frames. Null
    /// without tiles.
    #[serde(default)]
    pub tiles: Option<String>,
    /// A target frame rate (`--target-fps`; runs with a pixel error only):
    /// the fps aimed for, the tolerance the controller chose (mean and
    /// median over measured frames) and its own cost a frame (mean
    /// microseconds). Null for runs without one.
    #[serde(default)]
    pub target_fps: Option<f64>,
    /// Popping: the mean share of pixels that change from a compared
    /// frame to the next where the full-detail reference's do not (LOD
    /// switches and culling changes, not camera motion); null without
    /// compared pairs.
    #[serde(default)]
    pub popping: Option<f64>,
    /// Speculative RVG: extra frames drawn while STC was late (all frames,
    /// warm-up included), and RVG's median wait for STC a frame (ms;
    /// pipelined schedule, 0 elsewhere).
    #[serde(default)]
    pub speculative_frames: u64,
    #[serde(default)]
    pub median_rvg_wait_ms: f64,
    #[serde(default)]
    pub mean_pixel_error_used: Option<f64>,
    #[serde(default)]
    pub median_pixel_error_used: Option<f64>,
    #[serde(default)]
    pub mean_controller_us: Option<f64>,
    #[serde(default)]
    pub tile_culling: Option<String>,
    #[serde(default)]
    pub cull_ms_adaptive: Option<f64>,
    #[serde(default)]
    pub cull_ms_naive: Option<f64>,
    #[serde(default)]
    pub max_tile_triangles: Option<f64>,
    #[serde(default)]
    pub mean_tile_triangles: Option<f64>,
    /// Frames compared with the reference.
    pub accuracy_frames: usize,
    /// Summed over the compared frames (null without accuracy frames).
    pub wrongly_culled_pixels: Option<u64>,
    pub wrongly_culled_fraction: Option<f64>,
    pub differing_pixels_fraction: Option<f64>,
    /// Pixels breaking the pixel-error bound (`bound_violations` at this
    /// run's tolerance), summed over the compared frames.
    pub bound_violating_pixels: Option<u64>,
    /// bound_violating_pixels over all compared pixels.
    pub bound_violating_fraction: Option<f64>,
    /// Pixels breaking the bound with the depth match scaled to the
    /// tolerance (`bound_exceedances`), summed over the compared frames.
    #[serde(default)]
    pub bound_exceeding_pixels: Option<u64>,
    /// bound_exceeding_pixels over all compared pixels.
    #[serde(default)]
    pub bound_exceeding_fraction: Option<f64>,
    /// From the pooled mean squared error; null when every compared frame
    /// is identical to the reference (infinite PSNR) or nothing was compared.
    pub psnr_db: Option<f64>,
    /// Streaming, over every frame of the run (warm-up included; zeros
    /// when the scene is resident): the most device bytes resident LODs
    /// took, bytes loaded, loader requests, stand-ins drawn, chosen LODs
    /// with no stand-in, and frames that drew a stand-in.
    #[serde(default)]
    pub peak_resident_bytes: u64,
    #[serde(default)]
    pub loaded_bytes: u64,
    #[serde(default)]
    pub requests: u64,
    #[serde(default)]
    pub substituted_draws: u64,
    #[serde(default)]
    pub missing_draws: u64,
    #[serde(default)]
    pub substituted_frames: usize,
}

impl ModeSummary {
    /// "och 1px" style label.
    pub fn label(&self) -> String {
        match self.name.parse::<Mode>() {
            Ok(m) => crate::replay::run_label(
                m,
                self.pixel_error,
                self.culler.as_deref().and_then(|c| c.parse().ok()),
                self.target_fps.is_some(),
            ),
            Err(_) => self.name.clone(),
        }
    }
}

/// Median (mean of the middle two for an even count); NaN when empty.
pub fn median(v: &[f64]) -> f64 {
    percentile(v, 50.0)
}

/// Linear-interpolated percentile `p` (0..=100) of `v`; NaN when empty.
pub fn percentile(v: &[f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let x = p / 100.0 * (s.len() - 1) as f64;
    let (i, f) = (x.floor() as usize, x.fract());
    if i + 1 < s.len() {
        s[i] + (s[i + 1] - s[i]) * f
    } else {
        s[i]
    }
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for x in v {
        s += x;
        n += 1;
    }
    if n == 0 {
        f64::NAN
    } else {
        s / n as f64
    }
}

/// The frames the statistics use: past the warm-up, with an interval. A
/// run shorter than the warm-up uses every frame with an interval.
pub fn measured(frames: &[FrameRecord]) -> Vec<&FrameRecord> {
    let m: Vec<&FrameRecord> = frames
        .iter()
        .filter(|f| !f.warmup && f.frame_ms.is_some())
        .collect();
    if m.is_empty() {
        frames.iter().filter(|f| f.frame_ms.is_some()).collect()
    } else {
        m
    }
}

/// One run's figures; `viewport_pixels` is width x height.
fn summarise(
    run: &RunRecord,
    tile_opts: Option<(gigawalk_runtime::TileGrid, gigawalk_runtime::TileMethod)>,
    target_ms: Option<f64>,
    viewport_pixels: u64,
) -> ModeSummary {
    let m = measured(&run.frames);
    let ms: Vec<f64> = m.iter().filter_map(|f| f.frame_ms).collect();
    let mean_ms = mean(ms.iter().copied());
    let mean_triangles = mean(m.iter().map(|f| f.drawn_triangles as f64));
    let mut acc = Accuracy::default();
    let mut accuracy_frames = 0;
    for a in run.frames.iter().filter_map(|f| f.accuracy.as_ref()) {
        acc.add(a);
        accuracy_frames += 1;
    }
    let has_acc = accuracy_frames > 0;
    let med = |f: fn(&FrameRecord) -> f64| median(&m.iter().map(|x| f(x)).collect::<Vec<_>>());
    let tl: Vec<crate::replay::TileFigures> = m.iter().filter_map(|f| f.tiles).collect();
    let us: Vec<f64> = m.iter().filter_map(|f| f.controller_us).collect();
    let tile_fig = |f: fn(&crate::replay::TileFigures) -> f64, med: bool| {
        let v: Vec<f64> = tl.iter().map(f).collect();
        (!v.is_empty()).then(|| if med { median(&v) } else { mean(v.into_iter()) })
    };
    ModeSummary {
        name: run.mode.name().into(),
        pixel_error: run.pixel_error,
        culler: run.culler.map(|c| c.to_string()),
        culler_figures: CullerFigures::of(&m),
        tiles: tile_opts.map(|(g, _)| g.to_string()),
        target_fps: target_ms.filter(|_| run.target).map(|ms| 1e3 / ms),
        speculative_frames: run.frames.iter().map(|f| f.speculative_before as u64).sum(),
        median_rvg_wait_ms: med(|f| f.rvg_wait_ms),
        popping: {
            let p: Vec<f64> = run.frames.iter().filter_map(|f| f.popping).collect();
            (!p.is_empty()).then(|| mean(p.into_iter()))
        },
        mean_pixel_error_used: run
            .target
            .then(|| mean(m.iter().map(|f| f.pixel_error_used))),
        median_pixel_error_used: run
            .target
            .then(|| median(&m.iter().map(|f| f.pixel_error_used).collect::<Vec<_>>())),
        mean_controller_us: (run.target && !us.is_empty()).then(|| mean(us.iter().copied())),
        tile_culling: tile_opts.map(|(_, m)| m.name().to_string()),
        cull_ms_adaptive: tile_fig(|t| t.ms_adaptive, true),
        cull_ms_naive: tile_fig(|t| t.ms_naive, true),
        max_tile_triangles: tile_fig(|t| t.max_triangles as f64, false),
        mean_tile_triangles: tile_fig(|t| t.mean_triangles, false),
        frames: run.frames.len(),
        measured_frames: ms.len(),
        mean_fps: 1e3 / mean_ms,
        median_frame_ms: median(&ms),
        p95_frame_ms: percentile(&ms, 95.0),
        mean_triangles,
        triangles_per_pixel: finite(mean_triangles / viewport_pixels as f64),
        mean_drawn_nodes: mean(m.iter().map(|f| f.drawn_nodes as f64)),
        mean_visited: mean(m.iter().map(|f| f.visited as f64)),
        mean_occlusion_culled: mean(m.iter().map(|f| f.occlusion_culled as f64)),
        mean_section_culled: mean(m.iter().map(|f| f.section_culled as f64)),
        speedup_vs_vfc: None,
        median_speedup_vs_vfc: None,
        mean_latency_ms: mean(m.iter().map(|f| f.latency_ms)),
        median_or_ms: med(|f| f.or_ms),
        median_occluder_triangles: med(|f| f.occluder_triangles as f64),
        median_hzb_ms: med(|f| f.hzb_ms),
        median_stc_ms: med(|f| f.stc_ms),
        median_rvg_ms: med(|f| f.rvg_ms),
        cpu: CpuSummary {
            median_hzb_level: med(|f| f.cpu.hzb_level as f64),
            median_or_encode_ms: med(|f| f.cpu.or_encode_ms),
            median_or_submit_ms: med(|f| f.cpu.or_submit_ms),
            median_or_wait_ms: med(|f| f.cpu.or_wait_ms),
            median_or_copy_ms: med(|f| f.cpu.or_copy_ms),
            median_traversal_ms: med(|f| f.cpu.traversal_ms),
            median_cull_test_ms: med(|f| f.cpu.cull_test_ms),
            median_rvg_encode_ms: med(|f| f.cpu.rvg_encode_ms),
            median_rvg_submit_ms: med(|f| f.cpu.rvg_submit_ms),
            median_rvg_device_wait_ms: med(|f| f.cpu.rvg_wait_ms),
            median_rvg_copy_ms: med(|f| f.cpu.rvg_copy_ms),
            mean_or_read_bytes: mean(m.iter().map(|f| f.cpu.or_read_bytes as f64)),
            mean_device_waits: mean(m.iter().map(|f| f.cpu.device_waits as f64)),
        },
        accuracy_frames,
        wrongly_culled_pixels: has_acc.then_some(acc.wrongly_culled_pixels),
        wrongly_culled_fraction: has_acc.then(|| acc.wrongly_culled_fraction()),
        differing_pixels_fraction: has_acc.then(|| acc.differing_fraction()),
        bound_violating_pixels: has_acc.then_some(acc.bound_violating_pixels),
        bound_violating_fraction: has_acc.then(|| acc.bound_violating_fraction()),
        bound_exceeding_pixels: has_acc.then_some(acc.bound_exceeding_pixels),
        bound_exceeding_fraction: has_acc.then(|| acc.bound_exceeding_fraction()),
        psnr_db: if has_acc { acc.psnr_db() } else { None },
        peak_resident_bytes: run
            .frames
            .iter()
            .map(|f| f.resident_bytes)
            .max()
            .unwrap_or(0),
        loaded_bytes: run.frames.iter().map(|f| f.loaded_bytes).sum(),
        requests: run.frames.iter().map(|f| f.requests).sum(),
        substituted_draws: run.frames.iter().map(|f| f.substituted_draws).sum(),
        missing_draws: run.frames.iter().map(|f| f.missing_draws).sum(),
        substituted_frames: run
            .frames
            .iter()
            .filter(|f| f.substituted_draws > 0)
            .count(),
    }
}

/// Where a run's CPU time went a frame (medians over measured frames, ms)
/// and what crossed from the devices (means): OR's depth pass, STC's HZB
/// build, traversal and culler tests, RVG's drawing (docs/report-format.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CpuSummary {
    /// The level of OR's depth pyramid read back (0: the whole image).
    pub median_hzb_level: f64,
    pub median_or_encode_ms: f64,
    pub median_or_submit_ms: f64,
    pub median_or_wait_ms: f64,
    pub median_or_copy_ms: f64,
    pub median_traversal_ms: f64,
    pub median_cull_test_ms: f64,
    pub median_rvg_encode_ms: f64,
    pub median_rvg_submit_ms: f64,
    pub median_rvg_device_wait_ms: f64,
    pub median_rvg_copy_ms: f64,
    /// Bytes OR read back a frame.
    pub mean_or_read_bytes: f64,
    pub mean_device_waits: f64,
}

/// NaN and infinities become JSON null through `Option`; keep figures
/// finite or absent.
fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

/// Every culler's figures of a run, in the registry's order, written as
/// fields of the run's object in summary.json (null where the run did not
/// use the culler, or measured no frame of it).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CullerFigures(pub Vec<(String, Option<f64>)>);

impl CullerFigures {
    /// Pooled over the measured frames `m`.
    fn of(m: &[&FrameRecord]) -> Self {
        let mut out = Vec::new();
        for c in CullMethod::ALL {
            let works: Vec<Vec<f64>> = m
                .iter()
                .filter_map(|f| f.culler_work)
                .filter(|w| w.culler() == c)
                .map(|w| w.counts())
                .collect();
            let counts = |name: &str| {
                let i = c
                    .counters()
                    .iter()
                    .position(|k| k.name == name)
                    .expect("a figure pools its own culler's counts");
                works.iter().map(move |w| w[i])
            };
            for f in c.figures() {
                let v = (!works.is_empty()).then(|| match f.pool {
                    Pool::Mean(n) => mean(counts(n)),
                    Pool::Median(n) => median(&counts(n).collect::<Vec<_>>()),
                    Pool::Share { part, whole } => {
                        counts(part).sum::<f64>() / counts(whole).sum::<f64>().max(1.0)
                    }
                });
                out.push((f.key.to_string(), v));
            }
        }
        CullerFigures(out)
    }

    /// The figure named `key` (None: unknown, or null).
    pub fn get(&self, key: &str) -> Option<f64> {
        self.0.iter().find(|(k, _)| k == key).and_then(|(_, v)| *v)
    }
}

/// Every culler's settings, in the registry's order, written as fields
/// of summary.json's top object.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CullerSettings(pub Vec<(String, Setting)>);

impl CullerSettings {
    /// The setting named `name` ([`Setting::Unset`] when unknown).
    pub fn get(&self, name: &str) -> Setting {
        self.0
            .iter()
            .find(|(k, _)| k == name)
            .map_or(Setting::Unset, |(_, v)| *v)
    }
}

impl Serialize for CullerFigures {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_map(self.0.iter().map(|(k, v)| (k, v)))
    }
}

impl Serialize for CullerSettings {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap as _;
        let mut m = s.serialize_map(Some(self.0.len()))?;
        for (k, v) in &self.0 {
            match *v {
                Setting::Whole(n) => m.serialize_entry(k, &n)?,
                Setting::Number(x) => m.serialize_entry(k, &x)?,
                Setting::Flag(b) => m.serialize_entry(k, &b)?,
                _ => m.serialize_entry(k, &())?,
            }
        }
        m.end()
    }
}

/// The fields of a flattened object that `names` lists, in that order
/// (other fields belong to the enclosing struct, or to nobody).
fn named_fields<'de, D: serde::Deserializer<'de>>(
    d: D,
    names: impl Iterator<Item = &'static str>,
) -> Result<Vec<(String, serde_json::Value)>, D::Error> {
    let mut all = std::collections::BTreeMap::<String, serde_json::Value>::deserialize(d)?;
    Ok(names
        .map(|n| (n.to_string(), all.remove(n).unwrap_or_default()))
        .collect())
}

impl<'de> Deserialize<'de> for CullerFigures {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let keys = CullMethod::ALL
            .into_iter()
            .flat_map(|c| c.figures().iter().map(|f| f.key));
        let fields = named_fields(d, keys)?;
        Ok(CullerFigures(
            fields.into_iter().map(|(k, v)| (k, v.as_f64())).collect(),
        ))
    }
}

impl<'de> Deserialize<'de> for CullerSettings {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let defaults = gigawalk_runtime::CullerOptions::default();
        let names: Vec<&'static str> = CullMethod::ALL
            .into_iter()
            .flat_map(|c| c.settings(&defaults).into_iter().map(|(k, _)| k))
            .collect();
        let fields = named_fields(d, names.into_iter())?;
        Ok(CullerSettings(
            fields
                .into_iter()
                .map(|(k, v)| {
                    let s = match v {
                        serde_json::Value::Bool(b) => Setting::Flag(b),
                        serde_json::Value::Number(n) => match n.as_u64() {
                            Some(w) => Setting::Whole(w),
                            None => n.as_f64().map_or(Setting::Unset, Setting::Number),
                        },
                        _ => Setting::Unset,
                    };
                    (k, s)
                })
                .collect(),
        ))
    }
}

impl Replay {
    /// The report's figures.
    pub fn summary(&self) -> Summary {
        let rt = &self.options.runtime;
        let tile_opts = rt.tiles.map(|g| (g, rt.tile_culling));
        let pixels = u64::from(rt.width) * u64::from(rt.height);
        let mut modes: Vec<ModeSummary> = self
            .runs
            .iter()
            .map(|r| summarise(r, tile_opts, self.options.target.map(|t| t.ms), pixels))
            .collect();
        let vfc = modes
            .iter()
            .find(|m| m.name == Mode::Vfc.name())
            .map(|m| (m.mean_fps, m.median_frame_ms));
        if let Some((fps, ms)) = vfc {
            for m in &mut modes {
                m.speedup_vs_vfc = finite(m.mean_fps / fps);
                m.median_speedup_vs_vfc = finite(ms / m.median_frame_ms);
            }
        }
        let r = &self.options.runtime;
        Summary {
            scene: self.scene.clone(),
            path: self.path.clone(),
            frames: self.frames,
            width: r.width,
            height: r.height,
            warmup_frames: self.options.warmup,
            accuracy_every: self.options.accuracy_every,
            complete: self.complete,
            devices: self.devices.clone(),
            null_adapter: self.null_adapter,
            hidden_objects: self.options.visibility.as_ref().map_or(0, |v| v.counts().0),
            section: self.options.section.as_ref().map(|s| s.describe()),
            look: (!self.options.look.is_plain()).then(|| self.options.look.describe()),
            xray: self.options.ghosts.is_some(),
            schedule: format!("{:?}", r.schedule).to_lowercase(),
            occluder_lag: r.occluder_lag,
            occluder_scale: r.occluder_scale,
            occluder_budget: match self.occluder_selection {
                gigawalk_runtime::OccluderSelection::Triangles(t) => Some(t),
                _ => None,
            },
            occluder_selection: match self.occluder_selection {
                gigawalk_runtime::OccluderSelection::All => "all",
                gigawalk_runtime::OccluderSelection::Triangles(_) => "budget",
                gigawalk_runtime::OccluderSelection::Adaptive => "adaptive",
            }
            .into(),
            hzb_reduction: match r.hzb_reduction {
                gigawalk_cull::Reduction::Farthest => "farthest".into(),
                gigawalk_cull::Reduction::NthFarthest(n) => format!("{n}-th farthest"),
            },
            memory_budget: self.memory_budget,
            unsettled_reference_frames: self.unsettled_reference_frames,
            seconds: self.seconds,
            culler_settings: CullerSettings(
                CullMethod::ALL
                    .into_iter()
                    .flat_map(|c| {
                        let ran = self.runs.iter().any(|run| run.culler == Some(c));
                        c.settings(&r.cullers).into_iter().map(move |(k, v)| {
                            (k.to_string(), if ran { v } else { Setting::Unset })
                        })
                    })
                    .collect(),
            ),
            modes,
        }
    }
}

/// The header of [`Summary::table`]: its column names and alignment rows.
pub const RUN_TABLE_HEADER: &str = "| mode | pixel error | mean fps | median frame ms | p95 frame ms | mean triangles | triangles / px | speed-up vs vfc (mean fps) | mean latency ms | wrongly culled px | differing px | bound-violating px | beyond the bound px | PSNR dB |\n\
     |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";

impl Summary {
    /// The per-run table of summary.md, also what `gigawalk replay` and
    /// `gigawalk demo` print.
    pub fn table(&self) -> String {
        let mut s = String::from(RUN_TABLE_HEADER);
        for m in &self.modes {
            s += &format!(
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
                self.mode_cell(m),
                m.pixel_error,
                num(m.mean_fps, 2),
                num(m.median_frame_ms, 1),
                num(m.p95_frame_ms, 1),
                thousands(m.mean_triangles),
                m.triangles_per_pixel.map_or("-".into(), |x| num(x, 3)),
                m.speedup_vs_vfc.map_or("-".into(), |x| format!("{x:.2}x")),
                num(m.mean_latency_ms, 1),
                m.wrongly_culled_pixels
                    .map_or("-".into(), |x| x.to_string()),
                m.differing_pixels_fraction
                    .map_or("-".into(), |x| format!("{:.2}%", 100.0 * x)),
                // Three decimals: a few pixels per frame are worth seeing.
                m.bound_violating_fraction
                    .map_or("-".into(), |x| format!("{:.3}%", 100.0 * x)),
                m.bound_exceeding_fraction
                    .map_or("-".into(), |x| format!("{:.3}%", 100.0 * x)),
                match (m.accuracy_frames, m.psnr_db) {
                    (0, _) => "-".into(),
                    (_, None) => "identical".into(),
                    (_, Some(p)) => format!("{p:.1}"),
                },
            );
        }
        s
    }

    /// Stage times and node counts per run.
    pub fn stage_table(&self) -> String {
        let mut s = String::from(
            "| mode | pixel error | OR ms | OR triangles | HZB ms | STC ms (HZB incl.) | RVG ms | nodes visited | occlusion-culled | drawn nodes | median speed-up vs vfc |\n\
             |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
        );
        for m in &self.modes {
            s += &format!(
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
                self.mode_cell(m),
                m.pixel_error,
                num(m.median_or_ms, 2),
                thousands(m.median_occluder_triangles),
                num(m.median_hzb_ms, 2),
                num(m.median_stc_ms, 2),
                num(m.median_rvg_ms, 2),
                thousands(m.mean_visited),
                thousands(m.mean_occlusion_culled),
                thousands(m.mean_drawn_nodes),
                m.median_speedup_vs_vfc
                    .map_or("-".into(), |x| format!("{x:.2}x")),
            );
        }
        s
    }

    /// summary.md's table of where each run's CPU time went a frame.
    pub fn cpu_table(&self) -> String {
        let mut s = String::from(
            "| mode | pixel error | OR encode | OR submit | OR wait | OR copy | HZB level | HZB build | traversal | culler tests | RVG encode | RVG submit | RVG wait | OR read-back KB | device waits |\n\
             |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
        );
        for m in &self.modes {
            let c = &m.cpu;
            s += &format!(
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
                self.mode_cell(m),
                m.pixel_error,
                num(c.median_or_encode_ms, 3),
                num(c.median_or_submit_ms, 3),
                num(c.median_or_wait_ms, 3),
                num(c.median_or_copy_ms, 3),
                num(c.median_hzb_level, 0),
                num(m.median_hzb_ms, 3),
                num(c.median_traversal_ms, 3),
                num(c.median_cull_test_ms, 3),
                num(c.median_rvg_encode_ms, 3),
                num(c.median_rvg_submit_ms, 3),
                num(c.median_rvg_device_wait_ms, 3),
                num(c.mean_or_read_bytes / 1024.0, 1),
                num(c.mean_device_waits, 1),
            );
        }
        s
    }

    /// A run's mode as the tables show it: with its culler when some run
    /// used a culler other than the HZB ("och grid", "och hzb").
    pub fn mode_cell(&self, m: &ModeSummary) -> String {
        let other = self
            .modes
            .iter()
            .any(|m| m.culler.as_deref().is_some_and(|c| c != "hzb"));
        let name = if m.target_fps.is_some() {
            format!("{} target", m.name)
        } else {
            m.name.clone()
        };
        match &m.culler {
            Some(c) if other => format!("{name} {c}"),
            _ => name,
        }
    }

    /// `culler`'s table of summary.md (its title and text; empty without
    /// a run of the culler, or for a culler without a table).
    pub fn culler_table(&self, culler: CullMethod) -> Option<(&'static str, String)> {
        let t = culler.table()?;
        let runs: Vec<&ModeSummary> = self
            .modes
            .iter()
            .filter(|m| {
                culler
                    .figures()
                    .iter()
                    .any(|f| m.culler_figures.get(f.key).is_some())
            })
            .collect();
        if runs.is_empty() {
            return None;
        }
        let setting = |name: &str| self.culler_settings.get(name);
        let mut s = format!(
            "{}\n\n| mode | pixel error | {} |\n|---|---:|{}\n",
            (t.preamble)(&setting),
            t.columns
                .iter()
                .map(|c| c.header())
                .collect::<Vec<_>>()
                .join(" | "),
            "---:|".repeat(t.columns.len()),
        );
        for m in runs {
            let cells: Vec<String> = t
                .columns
                .iter()
                .map(|c| match *c {
                    Column::StcMs => num(m.median_stc_ms, 2),
                    Column::Figure { key, decimals, .. } => {
                        m.culler_figures
                            .get(key)
                            .map_or("-".into(), |x| match decimals {
                                Some(d) => num(x, d),
                                None => thousands(x),
                            })
                    }
                    Column::OcclusionCulled => thousands(m.mean_occlusion_culled),
                    Column::Triangles => thousands(m.mean_triangles),
                    _ => "-".into(),
                })
                .collect();
            s += &format!(
                "| {} | {} | {} |\n",
                self.mode_cell(m),
                m.pixel_error,
                cells.join(" | ")
            );
        }
        Some((t.title, s))
    }

    /// The tiled-display table (empty without tiles).
    pub fn tile_table(&self) -> String {
        let runs: Vec<&ModeSummary> = self.modes.iter().filter(|m| m.tiles.is_some()).collect();
        if runs.is_empty() {
            return String::new();
        }
        let mut s = String::from(
            "Items are sent to tiles after culling; both methods run every frame on the same items (median ms); the lists drawn are the named method's.\n\n\
             | mode | pixel error | tiles | drawn by | adaptive ms | naive ms | busiest tile triangles | mean tile triangles | triangles |\n\
             |---|---:|---|---|---:|---:|---:|---:|---:|\n",
        );
        let o = |x: Option<f64>, d: usize| x.map_or("-".into(), |x| num(x, d));
        for m in runs {
            s += &format!(
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
                self.mode_cell(m),
                m.pixel_error,
                m.tiles.as_deref().unwrap_or("-"),
                m.tile_culling.as_deref().unwrap_or("-"),
                o(m.cull_ms_adaptive, 3),
                o(m.cull_ms_naive, 3),
                m.max_tile_triangles.map_or("-".into(), thousands),
                m.mean_tile_triangles.map_or("-".into(), thousands),
                thousands(m.mean_triangles),
            );
        }
        s
    }

    /// The streaming table of summary.md (empty when nothing streamed).
    pub fn streaming_table(&self) -> String {
        let Some(budget) = self.memory_budget else {
            return String::new();
        };
        let mib = |b: u64| format!("{:.1}", b as f64 / (1u64 << 20) as f64);
        let mut s = format!(
            "Memory budget {} MiB a device; {} reference frames still drew a stand-in when taken.\n\n\
             | mode | pixel error | peak resident MiB | loaded MiB | requests | substituted draws | frames with stand-ins | missing draws |\n\
             |---|---:|---:|---:|---:|---:|---:|---:|\n",
            mib(budget),
            self.unsettled_reference_frames
        );
        for m in &self.modes {
            s += &format!(
                "| {} | {} | {} | {} | {} | {} | {} | {} |\n",
                self.mode_cell(m),
                m.pixel_error,
                mib(m.peak_resident_bytes),
                mib(m.loaded_bytes),
                m.requests,
                m.substituted_draws,
                m.substituted_frames,
                m.missing_draws,
            );
        }
        s
    }
}

fn num(x: f64, digits: usize) -> String {
    if x.is_finite() {
        format!("{x:.digits$}")
    } else {
        "-".into()
    }
}

/// 1234567.8 -> "1,234,568".
fn thousands(x: f64) -> String {
    if !x.is_finite() {
        return "-".into();
    }
    let s = format!("{:.0}", x.round());
    let (sign, digits) = s.split_at(if s.starts_with('-') { 1 } else { 0 });
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    format!("{sign}{out}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles() {
        assert!(median(&[]).is_nan());
        assert_eq!(median(&[3.0]), 3.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert_eq!(percentile(&[0.0, 10.0], 95.0), 9.5);
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert!((percentile(&v, 95.0) - 95.05).abs() < 1e-9);
    }

    /// A frame of `triangles` drawn in 10 ms; nothing else measured.
    fn frame(frame: u64, triangles: u64, warmup: bool) -> FrameRecord {
        FrameRecord {
            frame,
            pose_time_s: frame as f64,
            frame_ms: (frame > 0).then_some(10.0),
            latency_ms: 20.0,
            or_ms: 1.0,
            occluder_triangles: 0,
            occluder_limit: None,
            hzb_ms: 0.1,
            stc_ms: 1.0,
            rvg_ms: 5.0,
            visited: 10,
            frustum_culled: 0,
            occlusion_culled: 0,
            section_culled: 0,
            drawn_nodes: 5,
            drawn_triangles: triangles,
            occlusion_used: false,
            pixel_error_used: 0.0,
            controller_us: None,
            speculative_before: 0,
            rvg_wait_ms: 0.0,
            culler_work: None,
            tiles: None,
            resident_bytes: 0,
            loaded_bytes: 0,
            requests: 0,
            substituted_draws: 0,
            missing_draws: 0,
            warmup,
            popping: None,
            accuracy: None,
            cpu: Default::default(),
        }
    }

    /// A replay at `width` x `height` of one vfc run with these frames.
    fn replay(width: u32, height: u32, frames: Vec<FrameRecord>) -> Replay {
        let mut options = crate::ReplayOptions {
            warmup: 1,
            ..Default::default()
        };
        options.runtime.width = width;
        options.runtime.height = height;
        Replay {
            scene: "s.gwk".into(),
            path: "p.path".into(),
            frames: frames.len(),
            near: 0.1,
            options,
            occluder_selection: gigawalk_runtime::OccluderSelection::All,
            devices: vec!["test".into()],
            null_adapter: false,
            runs: vec![RunRecord {
                mode: Mode::Vfc,
                pixel_error: 0.0,
                culler: None,
                target: false,
                frames,
            }],
            complete: true,
            reference_frames: 0,
            memory_budget: None,
            unsettled_reference_frames: 0,
            seconds: 1.0,
        }
    }

    /// The first row's cell under `column` of a markdown table.
    fn cell(table: &str, column: &str) -> String {
        let cells = |i: usize| -> Vec<String> {
            let line = table.lines().nth(i).unwrap();
            line.split('|').map(|c| c.trim().to_string()).collect()
        };
        let (header, row) = (cells(0), cells(2));
        assert_eq!(header.len(), row.len(), "{table}");
        let i = header.iter().position(|h| h == column).unwrap();
        row[i].clone()
    }

    #[test]
    fn triangles_per_pixel_is_the_mean_over_the_viewport() {
        // The warm-up frame's 999 999 triangles are left out: mean 2000
        // over 16 x 10 pixels.
        let r = replay(
            16,
            10,
            vec![
                frame(0, 999_999, true),
                frame(1, 1000, false),
                frame(2, 2000, false),
                frame(3, 3000, false),
            ],
        );
        let s = r.summary();
        assert_eq!(s.modes[0].mean_triangles, 2000.0);
        assert_eq!(s.modes[0].triangles_per_pixel, Some(12.5));
        assert_eq!(cell(&s.table(), "triangles / px"), "12.500");
        let json = serde_json::to_value(&s).unwrap();
        assert_eq!(json["modes"][0]["triangles_per_pixel"], 12.5);
        // An older summary.json without the field still reads.
        let mut old = json.clone();
        old["modes"][0]
            .as_object_mut()
            .unwrap()
            .remove("triangles_per_pixel");
        let back: Summary = serde_json::from_value(old).unwrap();
        assert_eq!(back.modes[0].triangles_per_pixel, None);

        // No measured frame: no figure, a dash in the table.
        let s = replay(16, 10, vec![frame(0, 5, true)]).summary();
        assert_eq!(s.modes[0].triangles_per_pixel, None);
        assert_eq!(cell(&s.table(), "triangles / px"), "-");
    }

    #[test]
    fn culler_figures_pool_by_name_print_in_the_tables_and_read_back() {
        use gigawalk_runtime::{CullerWork, OqStats};
        let oq = |f: u64, queries: u64, ms: f64| FrameRecord {
            culler_work: Some(CullerWork::Oq(OqStats {
                queries,
                round_trips: 2,
                ms,
                over_budget: 1,
                coherent: 1,
            })),
            ..frame(f, 100, f == 0)
        };
        let mut r = replay(
            16,
            10,
            vec![oq(0, 999, 9.0), oq(1, 10, 1.0), oq(2, 20, 3.0)],
        );
        r.runs[0].mode = Mode::Occ;
        r.runs[0].culler = Some(CullMethod::Oq);
        r.options.runtime.cullers.oq.budget = Some(0.25);
        let s = r.summary();
        let f = &s.modes[0].culler_figures;
        // The warm-up frame is left out of the means and medians.
        assert_eq!(f.get("mean_oq_queries"), Some(15.0));
        assert_eq!(f.get("median_oq_ms"), Some(2.0));
        assert_eq!(f.get("mean_oq_untested"), Some(2.0));
        assert_eq!(f.get("median_grid_raster_ms"), None);
        assert_eq!(s.culler_settings.get("oq_batch"), Setting::Whole(32));
        assert_eq!(s.culler_settings.get("grid_cell"), Setting::Unset);
        let (title, table) = s.culler_table(CullMethod::Oq).unwrap();
        assert_eq!(title, "Occlusion queries");
        assert!(table.starts_with("Batches of 32 boxes"), "{table}");
        assert!(
            table.contains("time budget 0.25 of the last frame"),
            "{table}"
        );
        let rows: String = table.lines().skip(2).collect::<Vec<_>>().join("\n");
        assert_eq!(cell(&rows, "queries"), "15");
        assert_eq!(cell(&rows, "ms in round trips"), "2.00");
        assert!(s.culler_table(CullMethod::Grid).is_none());
        // In summary.json every culler's figures and settings are fields,
        // null for the cullers no run used, and they read back.
        let json = serde_json::to_value(&s).unwrap();
        assert_eq!(json["modes"][0]["mean_oq_queries"], 15.0);
        assert!(json["modes"][0]["median_grid_raster_ms"].is_null());
        assert!(json["modes"][0]["mean_ct_candidates"].is_null());
        assert_eq!(json["oq_budget"], 0.25);
        assert_eq!(json["oq_coherent"], false);
        assert!(json["grid_lazy"].is_null());
        let back: Summary = serde_json::from_value(json).unwrap();
        assert_eq!(back.modes[0].culler_figures, *f);
        assert_eq!(back.culler_settings, s.culler_settings);
        // frames.csv: the oq columns filled, the grid's empty.
        let csv = r.csv();
        let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
        let row: Vec<&str> = csv.lines().nth(2).unwrap().split(',').collect();
        assert_eq!(header.len(), row.len());
        let at = |c: &str| row[header.iter().position(|h| *h == c).unwrap()];
        assert_eq!(at("oq_queries"), "10");
        assert_eq!(at("oq_ms"), "1.000");
        assert_eq!(at("grid_raster_ms"), "");
    }

    #[test]
    fn thousands_separators() {
        assert_eq!(thousands(0.0), "0");
        assert_eq!(thousands(999.4), "999");
        assert_eq!(thousands(1234567.8), "1,234,568");
        assert_eq!(thousands(f64::NAN), "-");
    }
}
