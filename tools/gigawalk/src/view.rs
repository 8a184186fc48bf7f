//! `gigawalk view`: the interactive walkthrough. Argument parsing only;
//! the viewer (window, input, HUD, runtime wiring) is gigawalk-viewer.

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::Context as _;
use gigawalk_scene::units::Units;
use gigawalk_viewer::{controls, Settings, ViewArgs};

/// The controls, for `--help` (the same table as the on-screen help).
fn controls_help() -> String {
    let mut s = String::from("Controls (F1 in the window shows them too):\n");
    for line in controls::help_lines() {
        s.push_str("  ");
        s.push_str(&line);
        s.push('\n');
    }
    s.push_str(
        "\nSaved views (V) go to SCENE.views.json beside the scene, with the section; --view NAME starts from one.\
         \nScripted run (tests, docs): --frames N --screenshot out.png [--path p.path] renders N frames and exits.",
    );
    s
}

#[derive(clap::Args)]
#[command(after_help = controls_help())]
pub struct Args {
    /// Scene file (.gwk) from `gigawalk preprocess`
    scene: PathBuf,
    /// Camera path (docs/path-format.md): start at its first pose; with --frames, follow it one pose a frame
    #[arg(long)]
    path: Option<PathBuf>,
    /// Start from this saved view (V saves them to SCENE.views.json beside the scene): its camera (unless --path is given), selection, hidden objects and section (unless --section or --section-box is given)
    #[arg(long, value_name = "NAME")]
    view: Option<String>,
    /// Scripted run: render this many frames, then exit
    #[arg(long)]
    frames: Option<u64>,
    /// Scripted run: write the last frame, as shown, to this PNG
    #[arg(long, requires = "frames")]
    screenshot: Option<PathBuf>,
    /// Window width in pixels
    #[arg(long, default_value_t = 1280)]
    width: u32,
    /// Window height in pixels
    #[arg(long, default_value_t = 720)]
    height: u32,
    /// wgpu devices for the pipeline: 2 = OR and RVG on their own devices (paper), 1 = shared
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u64).range(1..=2))]
    devices: u64,
    /// Use the GPU adapter whose name contains this (case-insensitive; the name as `gigawalk info --adapters` lists it, backend included: `--adapter gl` picks GL); WGPU_BACKEND=vulkan|gl|metal|dx12 picks the backend [default: the best adapter that qualifies and can present to the window]
    #[arg(long, value_name = "NAME")]
    adapter: Option<String>,
    /// Start without occlusion culling
    #[arg(long)]
    no_occlusion: bool,
    /// Starting occlusion culler (C cycles them): hzb = GigaWalk's hierarchical Z-buffer, grid = the lazy occlusion grid (Hey et al.), oq = hardware occlusion queries (Bartz et al.; not with --memory-budget), ct = large occluders (Coorg and Teller)
    #[arg(long, default_value = "hzb")]
    culler: gigawalk_runtime::CullMethod,
    /// Start without HLODs
    #[arg(long)]
    no_hlod: bool,
    /// Starting pixel-error tolerance (0 = full detail)
    #[arg(long, default_value_t = 1.0)]
    pixel_error: f64,
    /// Start with asynchronous rendering
    #[arg(long)]
    async_rvg: bool,
    /// Hold this frame rate from the start (K toggles it; without this flag K holds 30 fps): the pixel error is chosen each frame, from --pixel-error up to 16
    #[arg(long)]
    target_fps: Option<f64>,
    /// Tiled display (Nirnimesh et al.): split the window into COLSxROWS tiles (1-64 each), each drawn from its own list under its own scissor; the HUD shows the busiest tile and what sending items to tiles cost
    #[arg(long, value_name = "COLSxROWS")]
    tiles: Option<gigawalk_runtime::TileGrid>,
    /// Tiled display: adaptive, naive, object-hierarchy, frustum-hierarchy or binning
    #[arg(long, value_name = "METHOD", default_value = "adaptive")]
    tile_culling: gigawalk_runtime::TileMethod,
    /// Start in wireframe (triangle edges in each object's colour)
    #[arg(long)]
    wireframe: bool,
    /// Start in x-ray (F4): hidden objects, and those an isolation leaves out, drawn as faint ghosts
    #[arg(long)]
    xray: bool,
    #[command(flatten)]
    look: crate::look::LookArgs,
    /// Start with node bounding boxes shown
    #[arg(long)]
    boxes: bool,
    /// Start with the HUD hidden (Tab shows it)
    #[arg(long)]
    no_hud: bool,
    /// Occluder triangles OR draws a frame, those hiding most per triangle first: adaptive (chosen frame by frame from what OR costs against what it saves, starting from all), all (the paper), a count (30k), or auto (30k on CPU rasterizers such as lavapipe, all on GPUs)
    #[arg(
        long,
        value_name = "adaptive|all|TRIANGLES|auto",
        default_value = "adaptive"
    )]
    occluder_budget: gigawalk_runtime::OccluderBudget,
    /// Geometry memory a device may hold: all (load the whole scene first), a size (256M, 1G) or auto (a quarter of RAM); bigger scenes stream while you walk (the HUD shows resident MB and stand-ins)
    #[arg(long, value_name = "all|BYTES|auto", default_value = "all")]
    memory_budget: gigawalk_runtime::MemoryBudget,
    /// Near plane distance in model units [default: 1e-5 of the scene's bounding-box diagonal]
    #[arg(long)]
    near: Option<f64>,
    /// The model's unit, for walk mode's 1.7 m eye height and measurements (M) shown in metres too: m (glTF's), mm, cm, km, um, in, ft, yd, or a number of metres per unit
    #[arg(long, default_value = "m", value_parser = parse_units)]
    units: Units,
    #[command(flatten)]
    section: crate::section::SectionArgs,
    /// Directory for recorded paths and screenshots taken with keys
    #[arg(long, default_value = ".")]
    out_dir: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if !(a.pixel_error >= 0.0 && a.pixel_error.is_finite()) {
        anyhow::bail!(
            "--pixel-error {} must be a finite number >= 0",
            a.pixel_error
        );
    }
    if let Some(near) = a.near {
        if !(near > 0.0 && near.is_finite()) {
            anyhow::bail!("--near {near} must be a finite number > 0");
        }
    }
    if let Some(f) = a.target_fps.filter(|f| !(f.is_finite() && *f > 0.0)) {
        anyhow::bail!("--target-fps {f}: must be a finite number above 0");
    }
    if a.width == 0 || a.height == 0 {
        anyhow::bail!("--width and --height must be at least 1");
    }
    // Checked here, before a window opens; over a --view's own section.
    let section = a.section.given()?.map(Arc::new);
    let look = a.look.choice(a.units.metres)?;
    if let Some(null) = a
        .adapter
        .as_deref()
        .filter(|n| gigawalk_gpu::is_null_adapter(n))
    {
        anyhow::bail!(
            "--adapter {null}: the null adapter draws nothing and cannot show a window; it measures what the CPU can feed a GPU in `gigawalk replay` and `gigawalk demo`"
        );
    }
    let scene = a.scene.clone();
    gigawalk_viewer::run(ViewArgs {
        scene: a.scene,
        path: a.path,
        frames: a.frames,
        screenshot: a.screenshot,
        width: a.width,
        height: a.height,
        devices: a.devices as usize,
        adapter: a.adapter,
        near: a.near,
        units: a.units,
        occluder_budget: a.occluder_budget,
        memory_budget: a.memory_budget,
        settings: Settings {
            occlusion: !a.no_occlusion,
            culler: a.culler,
            hlod: !a.no_hlod,
            pixel_error: a.pixel_error,
            async_rvg: a.async_rvg,
            wireframe: a.wireframe,
            xray: a.xray,
            boxes: a.boxes,
            hud: !a.no_hud,
            target: a.target_fps.is_some(),
            target_fps: a.target_fps.unwrap_or(30.0),
            ..Settings::default()
        },
        out_dir: a.out_dir,
        tiles: a.tiles,
        tile_culling: a.tile_culling,
        view: a.view,
        section,
        look,
    })
    .with_context(|| format!("viewing {}", scene.display()))
}

/// `--units`: a unit's name, or a number of metres per model unit
/// (measurements then read "12 units (0.3 m)").
fn parse_units(s: &str) -> Result<Units, String> {
    if let Ok(u) = s.parse::<Units>() {
        return Ok(u);
    }
    let m: f64 = s.trim().parse().map_err(|_| {
        format!("{s:?} is not m, mm, cm, km, um, in, ft, yd or a number of metres per unit")
    })?;
    if m > 0.0 && m.is_finite() {
        Ok(Units {
            name: "units",
            metres: m,
        })
    } else {
        Err(format!(
            "{s:?}: metres per unit must be a finite number > 0"
        ))
    }
}
