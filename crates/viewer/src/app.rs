//! The viewer app: a winit window, live input turned into cameras for the
//! pipelined runtime, and a presenter that shows RVG's frames with the HUD
//! and node boxes on top.
//!
//! Threads: the runtime's stages run on their own threads; this thread
//! runs the window's event loop by pumping it once per finished frame
//! (winit's `pump_app_events`), so the viewer starts no thread of its own.
//! The camera source (OR thread) and the presenter (RVG thread) read what
//! input produced through one mutex. Toggles that change the runtime's
//! options end the run and start a new one (a thread start and the 2-frame
//! startup bypass, invisible in a viewer).
//!
//! Here: the arguments, the errors, and [`run`], which opens the scene
//! (its object table and saved views too), the devices and the window
//! and restarts the runtime when a toggle or a resize needs it. Input is collected in `window` and applied between
//! frames in `frame_loop`; the runtime's camera source and presenter are
//! `camera_source` and `presenter`.

mod camera_source;
mod frame_loop;
mod presenter;
mod window;

use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use gigawalk_cull::Camera;
use gigawalk_cull::Section;
use gigawalk_gpu::{open_devices_for_window, GpuContext, WindowError};
use gigawalk_runtime::target::{FrameRateController, MIN_PIXEL_ERROR};
use gigawalk_runtime::{CullMethod, OccluderBudget, Runtime, RuntimeError, RuntimeOptions};
use gigawalk_scene::path::{CameraPath, PathReadError, PathWriteError, Pose};
use gigawalk_scene::units::Units;
use gigawalk_scene::views::{SavedView, Views};
use gigawalk_scene::SceneReader;
use winit::dpi::PhysicalSize;
use winit::event_loop::EventLoop;
use winit::platform::pump_events::{EventLoopExtPumpEvents, PumpStatus};

use crate::boxes::CullSets;
use crate::hud::{FrameClock, ViewerState};
use crate::image::ScreenshotError;
use crate::objects::{view_names, Objects, NO_IDENTITY};
use crate::sections::Sections;
use crate::settings::Settings;
use camera_source::LiveSource;
use frame_loop::LoopState;
use gigawalk_review::fly::FlyController;
use gigawalk_review::measure::Measure;
use gigawalk_review::recorder::{next_free_name, PathRecorder};
use presenter::ViewerPresenter;
use window::App;

/// Everything `gigawalk view` takes.
#[derive(Clone, Debug)]
pub struct ViewArgs {
    pub scene: PathBuf,
    /// Start at this path's first pose; in a scripted run, follow it.
    pub path: Option<PathBuf>,
    /// Scripted run: render this many frames, then exit.
    pub frames: Option<u64>,
    /// Scripted run: write the last frame (with overlays) here.
    pub screenshot: Option<PathBuf>,
    pub width: u32,
    pub height: u32,
    /// wgpu devices for the pipeline (1 or 2).
    pub devices: usize,
    /// Only adapters whose name contains this (case-insensitive).
    pub adapter: Option<String>,
    /// Near plane, model units; `None`: `gigawalk_cull::default_near` of
    /// the scene's bounds.
    pub near: Option<f64>,
    /// The model's unit (metres for glTF, millimetres for many CAD
    /// exports): walk mode's eye height and measurements follow.
    pub units: Units,
    /// Occluder triangles OR draws a frame (`auto`: 30k on CPU rasterizers).
    pub occluder_budget: OccluderBudget,
    /// Geometry memory a device may hold (`all`: the whole scene).
    pub memory_budget: gigawalk_runtime::MemoryBudget,
    /// The starting toggles.
    pub settings: Settings,
    /// Where recorded paths and key screenshots go.
    pub out_dir: PathBuf,
    /// A tiled display: the window split into this grid (left out while
    /// the window is smaller than one pixel a tile).
    pub tiles: Option<gigawalk_runtime::TileGrid>,
    /// How items are sent to the tiles.
    pub tile_culling: gigawalk_runtime::TileMethod,
    /// Start from this saved view (`SCENE.views.json`): its camera
    /// (unless `path` gives one), selection, hidden objects and section.
    pub view: Option<String>,
    /// Start with this section (over the saved view's).
    pub section: Option<Arc<Section>>,
    /// The look asked for; what it leaves open is `Look::auto` for the
    /// devices opened.
    pub look: gigawalk_gpu::LookChoice,
}

/// Why the viewer stopped with an error.
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    #[error("{file}: cannot open the scene: {source}")]
    Scene {
        file: PathBuf,
        source: gigawalk_scene::ReadError,
    },
    #[error(transparent)]
    Path(#[from] PathReadError),
    #[error("{0}: the camera path has no poses")]
    EmptyPath(PathBuf),
    #[error("cannot open a window (no display? set DISPLAY, or run under Xvfb): {0}")]
    Display(#[source] DisplayError),
    #[error(transparent)]
    Window(#[from] WindowError),
    #[error(transparent)]
    Runtime(#[from] RuntimeError),
    #[error(transparent)]
    Screenshot(#[from] ScreenshotError),
    #[error(transparent)]
    Record(#[from] PathWriteError),
    #[error(
        "--wireframe: {devices} cannot draw lines (no POLYGON_MODE_LINE, e.g. GLES); leave it out"
    )]
    NoWireframe { devices: String },
    #[error("the scripted run ended before frame {wanted} (rendered {rendered})")]
    TooFewFrames { wanted: u64, rendered: u64 },
    #[error(transparent)]
    Views(#[from] gigawalk_scene::views::ViewsError),
    #[error("--view {name:?}: {detail}")]
    BadView { name: String, detail: String },
}

/// Why no window could be opened ([`ViewError::Display`]).
#[derive(Debug, thiserror::Error)]
pub enum DisplayError {
    /// winit could not start its event loop (no display to connect to).
    #[error(transparent)]
    EventLoop(#[from] winit::error::EventLoopError),
    /// The window system refused the window.
    #[error(transparent)]
    Window(#[from] winit::error::OsError),
    /// The event loop ended, with this code, before the window was made.
    #[error("event loop exited ({0})")]
    Exited(i32),
    /// The first pumps of the event loop did not create the window.
    #[error("the window was not created within 10 s")]
    Timeout,
}

/// How long a resize must be still before the pipeline restarts at the
/// new size (each restart costs a thread start and 2 bypass frames; the
/// blit scales the old size meanwhile).
const RESIZE_SETTLE: Duration = Duration::from_millis(200);

/// Opens the scene and the window and runs until the window closes (or,
/// scripted, until the last frame).
pub fn run(args: ViewArgs) -> Result<(), ViewError> {
    let scene = SceneReader::open(&args.scene).map_err(|source| ViewError::Scene {
        file: args.scene.clone(),
        source,
    })?;
    let skeleton = scene.skeleton();
    let path = match &args.path {
        Some(p) => {
            let path = CameraPath::read(p)?;
            if path.poses.is_empty() {
                return Err(ViewError::EmptyPath(p.clone()));
            }
            Some(path)
        }
        None => None,
    };
    // Saved views: the one to start from must be there; otherwise a file
    // that does not read is only reported (V will not write over it).
    let views_file = Views::file_for(&args.scene);
    let mut views_note = None;
    let (start_view, view_list) = match &args.view {
        Some(name) => {
            let views = Views::read(&views_file)?;
            let view: SavedView = views.get(&views_file, name)?.clone();
            (Some(view), view_names(&views))
        }
        None => match Views::read(&views_file) {
            Ok(views) => (None, view_names(&views)),
            Err(e) => {
                views_note = Some(format!("saved views unreadable, V will not save: {e}"));
                (None, Vec::new())
            }
        },
    };
    let start_pose = match &start_view {
        Some(v) => Some(v.pose().map_err(|detail| ViewError::BadView {
            name: v.name.clone(),
            detail,
        })?),
        None => None,
    };
    if let Some(spec) = start_view.as_ref().and_then(|v| v.section.as_ref()) {
        if args.section.is_none() {
            if let Err(e) = Section::new(spec.clone()) {
                return Err(ViewError::BadView {
                    name: args.view.clone().unwrap_or_default(),
                    detail: format!("its section: {e}"),
                });
            }
        }
    }
    let start = path.as_ref().map(|p| p.poses[0]).or(start_pose);
    let fovy = start.map_or(60f64.to_radians(), |p| p.fovy);
    let controller = match start {
        Some(q) => FlyController::from_pose(q.position, q.orientation, q.fovy, &skeleton.bounds()),
        None => FlyController::overview(&skeleton.bounds(), fovy),
    }
    .with_units(args.units.metres);
    let near = args
        .near
        .unwrap_or_else(|| gigawalk_cull::default_near(&skeleton.bounds()));

    let mut event_loop = EventLoop::new().map_err(|e| ViewError::Display(e.into()))?;
    let mut app = App {
        title: format!("gigawalk view {}", args.scene.display()),
        size: PhysicalSize::new(args.width.max(1), args.height.max(1)),
        window: None,
        error: None,
        held: HashSet::new(),
        drag: None,
        cursor: None,
        press: None,
        last_click: None,
        prompt: None,
        inputs: Vec::new(),
        scroll: 0.0,
        shift: false,
        look: (0.0, 0.0),
        resized: None,
        close: false,
    };
    // The window is created in `resumed`, on the first pump.
    let deadline = Instant::now() + Duration::from_secs(10);
    while app.window.is_none() && app.error.is_none() && Instant::now() < deadline {
        if let PumpStatus::Exit(code) =
            event_loop.pump_app_events(Some(Duration::from_millis(10)), &mut app)
        {
            return Err(ViewError::Display(DisplayError::Exited(code)));
        }
    }
    if let Some(e) = app.error.take() {
        return Err(ViewError::Display(e.into()));
    }
    let window = app
        .window
        .clone()
        .ok_or(ViewError::Display(DisplayError::Timeout))?;
    let (devices, surface) =
        open_devices_for_window(args.devices, args.adapter.as_deref(), window.clone())?;
    let device_names = device_summary(&devices);
    let wireframe_supported = devices.iter().all(GpuContext::supports_wireframe);
    let mut start_message = None;
    let mut settings = args.settings.clone();
    settings.look = args.look.over(gigawalk_gpu::Look::auto(
        devices.iter().any(GpuContext::is_cpu),
    ));
    if settings.wireframe && !wireframe_supported {
        // Asked for on the command line: refuse rather than draw something
        // else (T in the window only shows that it draws shaded).
        return Err(ViewError::NoWireframe {
            devices: device_names,
        });
    }
    let runtime = Runtime::with_budget(&scene, devices, args.memory_budget, &mut load_lines())?;
    tracing::info!("viewing {} on {device_names}", args.scene.display());
    // Why each culler cannot run here (a stored but corrupt OCCL or OCVC
    // ends the viewer naming it).
    let mut unavailable = Vec::new();
    for c in CullMethod::ALL {
        match runtime.check_culler(c) {
            Ok(()) => {}
            Err(e @ gigawalk_runtime::RuntimeError::CullerUnavailable { .. }) => {
                unavailable.push((c, format!("{e}: culler left as it was")))
            }
            Err(e) => return Err(e.into()),
        }
    }
    if let Some((_, why)) = unavailable.iter().find(|u| u.0 == settings.culler) {
        settings.culler = CullMethod::Hzb;
        start_message = Some((why.clone(), Instant::now()));
        eprintln!("{why}");
    }
    if let Some(note) = views_note {
        eprintln!("{note}");
        start_message = start_message.or(Some((note, Instant::now())));
    }
    // Object identity: without it (an older scene, or an unreadable OBJT
    // section) everything else works and pick, find and hide say why not.
    let table = match scene.objects() {
        Ok(Some(t)) => Ok(t),
        Ok(None) => Err(NO_IDENTITY.to_string()),
        Err(e) => {
            let why = format!("object identity unreadable ({e}): pick, find and hide are off");
            eprintln!("{why}");
            Err(why)
        }
    };

    let scripted = args.frames.map(|n| Script {
        frames: n.max(1),
        poses: path.as_ref().map(|p| p.poses.clone()).unwrap_or_default(),
        screenshot: args.screenshot.clone(),
    });
    let shared = Arc::new(Mutex::new(Shared {
        camera: controller.camera(aspect(app.size), near),
        frozen: settings.frozen,
        window_size: (app.size.width, app.size.height),
        capture: None,
        settings: settings.clone(),
        viewer: ViewerState::default(),
        quit: false,
        message: None,
        error: None,
        target_pixel_error: None,
        visibility: None,
        ghosts: None,
        section: None,
    }));
    let mut source = LiveSource {
        shared: shared.clone(),
        script: scripted.clone(),
        sent: 0,
        near,
    };
    let mut presenter = ViewerPresenter {
        surface,
        shared: shared.clone(),
        skeleton,
        culled_sets: CullSets::default(),
        script: scripted.clone(),
        clock: FrameClock::default(),
    };
    let (settings_target, target_fps, start_pixel_error) =
        (settings.target, settings.target_fps, settings.pixel_error);
    let mut state = LoopState {
        controller,
        settings,
        wireframe_supported,
        unavailable,
        recorder: PathRecorder::default(),
        record_start: Instant::now(),
        last_update: Instant::now(),
        message: start_message,
        devices: device_names,
        occluder_budget: runtime.occluder_selection(args.occluder_budget),
        out_dir: args.out_dir.clone(),
        near,
        rendered: 0,
        target: settings_target.then(|| {
            FrameRateController::new(
                1e3 / target_fps,
                start_pixel_error.max(MIN_PIXEL_ERROR),
                16.0,
            )
        }),
        last_finish: None,
        objects: Objects::new(table),
        visibility: None,
        ghosts: None,
        flight: None,
        views_file,
        view_names: view_list,
        next_view: 0,
        sections: Sections::default(),
        measure: Measure::default(),
        units: args.units,
        scene_bounds: skeleton.bounds(),
    };
    if let Some(view) = &start_view {
        // The controller starts at the view's camera already, unless a
        // path gave it its first pose.
        state.apply_view(view, false, Instant::now());
        state.refresh_visibility(skeleton);
        state.objects.take_changed();
        let mut s = shared.lock().expect("viewer state");
        s.visibility = state.visibility.clone();
        s.ghosts = state.ghosts.clone();
    }
    if let Some(section) = &args.section {
        // The command line's section over the saved view's.
        state.sections.set_spec(section.spec());
    }
    if let Some(section) = state.sections.current() {
        if !section.keeps_any_of(&skeleton.bounds()) {
            let b = skeleton.bounds();
            let why = format!(
                "the section ({}) keeps nothing of the model, whose bounds are {:.6?} .. {:.6?}: \
                 0 turns it off, Delete clears it",
                section.describe(),
                b.min.to_array(),
                b.max.to_array()
            );
            eprintln!("warning: {why}");
            state.message = Some((why, Instant::now()));
        }
    }
    shared.lock().expect("viewer state").section = state.sections.current();
    loop {
        let render = PhysicalSize::new(app.size.width.max(1), app.size.height.max(1));
        let running = state.settings.clone();
        let opts = RuntimeOptions {
            width: render.width,
            height: render.height,
            devices: args.devices,
            occluder_budget: args.occluder_budget,
            traversal: running.traversal(),
            culler: running.culler,
            async_rvg: running.async_rvg,
            tiles: args
                .tiles
                .filter(|t| t.cols <= render.width && t.rows <= render.height),
            tile_culling: args.tile_culling,
            // Always: freezing must find the culled set of the frame it
            // freezes, and a list of node ids per frame is cheap.
            record_culled: true,
            ..RuntimeOptions::default()
        };
        let mut restart = false;
        let result = runtime.run_presenting(
            &opts,
            &mut source,
            &mut |report| {
                state.target_update(&report, &shared);
                if let PumpStatus::Exit(_) =
                    event_loop.pump_app_events(Some(Duration::ZERO), &mut app)
                {
                    app.close = true;
                }
                state.rendered += 1;
                let go_on =
                    state.after_frame(&mut app, &shared, &scene, render, scripted.is_some());
                if !go_on {
                    return false;
                }
                let resize_settled = app.resized.is_some_and(|t| t.elapsed() >= RESIZE_SETTLE)
                    && app.size.width > 0
                    && app.size.height > 0;
                if scripted.is_none() && (running.needs_restart(&state.settings) || resize_settled)
                {
                    app.resized = None;
                    restart = true;
                    return false;
                }
                true
            },
            &mut presenter,
        );
        // Input during the restart is kept: the next run picks it up.
        result?;
        if let Some(e) = shared.lock().expect("viewer state").error.take() {
            return Err(e);
        }
        if !restart {
            break;
        }
    }
    if let Some(path) = state.recorder.stop() {
        let file = next_free_name(&state.out_dir, "gigawalk-view", "path");
        path.write(&file)?;
        eprintln!("recorded camera path: {}", file.display());
    }
    if let Some(s) = &scripted {
        if state.rendered < s.frames {
            return Err(ViewError::TooFewFrames {
                wanted: s.frames,
                rendered: state.rendered,
            });
        }
    }
    Ok(())
}

/// "2 x llvmpipe (LLVM 15.0.6, 256 bits)": the adapters, short enough
/// for the HUD.
fn device_summary(devices: &[GpuContext]) -> String {
    let mut names: Vec<String> = devices
        .iter()
        .map(|d| d.adapter_name().to_string())
        .collect();
    names.dedup();
    match names.as_slice() {
        [one] => format!("{} x {one}", devices.len()),
        _ => names.join(" + "),
    }
}

fn aspect(size: PhysicalSize<u32>) -> f64 {
    if size.width == 0 || size.height == 0 {
        1.0
    } else {
        size.width as f64 / size.height as f64
    }
}

/// A scripted run: `frames` frames along `poses` (one pose a frame, the
/// last one held), the last frame written to `screenshot`.
#[derive(Clone, Debug)]
struct Script {
    frames: u64,
    poses: Vec<Pose>,
    screenshot: Option<PathBuf>,
}

/// What input produced, read by the OR thread (camera) and the RVG thread
/// (overlay, window size, screenshot requests).
struct Shared {
    camera: Camera,
    frozen: bool,
    window_size: (u32, u32),
    /// Write the next presented frame here.
    capture: Option<PathBuf>,
    settings: Settings,
    /// What the HUD shows besides the frame's own numbers; the presenter
    /// builds the HUD from it and the frame it presents.
    viewer: ViewerState,
    quit: bool,
    message: Option<String>,
    /// A failure on the RVG thread that is not the runtime's (screenshot).
    error: Option<ViewError>,
    /// The next frame's pixel error while a target frame rate is held.
    target_pixel_error: Option<f64>,
    /// Hidden and highlighted objects (`None`: all show, none tinted).
    visibility: Option<Arc<gigawalk_cull::Visibility>>,
    /// X-ray's ghosts of the hidden objects (`None`: none drawn).
    ghosts: Option<Arc<gigawalk_cull::Visibility>>,
    /// What the section keeps (`None`: everything).
    section: Option<Arc<Section>>,
}

/// Loading progress for the terminal: a line a second while the LODs the
/// first frame needs are read, and one when done (nothing for a load
/// under a second).
fn load_lines() -> impl FnMut(u64, u64) {
    let started = Instant::now();
    let mut printed = Instant::now();
    move |done, total| {
        if printed.elapsed().as_secs_f64() >= 1.0 {
            eprintln!("loading: {done}/{total} LODs");
            printed = Instant::now();
        }
        let secs = started.elapsed().as_secs_f64();
        if done == total && secs >= 1.0 {
            eprintln!("loaded {total} LODs in {secs:.1} s");
        }
    }
}
