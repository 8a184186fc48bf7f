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

use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use gigawalk_cull::Camera;
use gigawalk_gpu::{
    open_devices_for_window, GpuContext, GpuError, OverlayFrame, OverlayText, VisiblePass,
    WindowError, WindowSurface,
};
use gigawalk_runtime::target::{FrameRateController, MIN_TOLERANCE};
use gigawalk_runtime::{
    CameraError, CameraRequest, CameraSource, CullMethod, CullReason, DrawStyle, FrameReport,
    OccluderBudget, OccluderSelection, Presenter, Runtime, RuntimeError, RuntimeOptions,
};
use gigawalk_scene::path::{CameraPath, PathReadError, PathWriteError, Pose};
use gigawalk_scene::{SceneReader, Skeleton};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::PhysicalKey;
use winit::platform::pump_events::{EventLoopExtPumpEvents, PumpStatus};
use winit::window::{Window, WindowId};

use crate::boxes::{overlay_boxes, CullSets};
use crate::controller::FlyController;
use crate::controls::{self, Action, Does, Movement};
use crate::hud::{hud_lines, FrameClock, FrameNumbers, ViewerState};
use crate::image::{write_png, ScreenshotError};
use crate::recorder::{next_free_name, PathRecorder};
use crate::settings::Settings;

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
    /// Metres per model unit (1 for glTF's metres, 0.001 for a model in
    /// millimetres): walk mode's eye height follows.
    pub metres_per_unit: f64,
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
    Display(String),
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
}

/// How long a resize must be still before the pipeline restarts at the
/// new size (each restart costs a thread start and 2 bypass frames; the
/// blit scales the old size meanwhile).
const RESIZE_SETTLE: Duration = Duration::from_millis(200);
/// Shown when wireframe is asked for on a device without line mode.
const WIREFRAME_UNSUPPORTED: &str =
    "wireframe: this GPU has no line mode (POLYGON_MODE_LINE); drawing shaded";
/// How long HUD messages (screenshot written, path saved) stay up.
const MESSAGE_TIME: Duration = Duration::from_secs(4);
/// While minimised, the camera source waits this long per frame so a
/// hidden window does not spin the pipeline at full speed.
const MINIMISED_WAIT: Duration = Duration::from_millis(50);
/// HUD text is drawn 2x on windows at least this tall (8-pixel glyphs are
/// hard to read on large screens), else 1x.
const HUD_2X_MIN_HEIGHT: u32 = 600;

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
    let fovy = path
        .as_ref()
        .map_or(60f64.to_radians(), |p| p.poses[0].fovy);
    let controller = match &path {
        Some(p) => {
            let q = p.poses[0];
            FlyController::from_pose(q.position, q.orientation, q.fovy, &skeleton.bounds)
        }
        None => FlyController::overview(&skeleton.bounds, fovy),
    }
    .with_units(args.metres_per_unit);
    let near = args
        .near
        .unwrap_or_else(|| gigawalk_cull::default_near(&skeleton.bounds));

    let mut event_loop = EventLoop::new().map_err(|e| ViewError::Display(e.to_string()))?;
    let mut app = App {
        title: format!("gigawalk view {}", args.scene.display()),
        size: PhysicalSize::new(args.width.max(1), args.height.max(1)),
        window: None,
        error: None,
        held: HashSet::new(),
        drag: None,
        cursor: None,
        actions: Vec::new(),
        scroll: 0.0,
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
            return Err(ViewError::Display(format!("event loop exited ({code})")));
        }
    }
    if let Some(e) = app.error.take() {
        return Err(ViewError::Display(e));
    }
    let window = app
        .window
        .clone()
        .ok_or_else(|| ViewError::Display("the window was not created within 10 s".into()))?;
    let (devices, surface) =
        open_devices_for_window(args.devices, args.adapter.as_deref(), window.clone())?;
    let device_names = device_summary(&devices);
    let wireframe_supported = devices.iter().all(GpuContext::supports_wireframe);
    let mut start_message = None;
    let mut settings = args.settings.clone();
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
        target_tolerance: None,
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
    let (settings_target, target_fps, start_tolerance) =
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
            FrameRateController::new(1e3 / target_fps, start_tolerance.max(MIN_TOLERANCE), 16.0)
        }),
        last_finish: None,
    };
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
                let go_on = state.after_frame(&mut app, &shared, render, scripted.is_some());
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
    target_tolerance: Option<f64>,
}

/// The window's side of the event loop: collects input for the frame loop.
struct App {
    title: String,
    size: PhysicalSize<u32>,
    window: Option<Arc<Window>>,
    error: Option<String>,
    held: HashSet<Movement>,
    /// Drag-to-look is on while any mouse button is held.
    drag: Option<u32>,
    cursor: Option<(f64, f64)>,
    actions: Vec<Action>,
    scroll: f64,
    look: (f64, f64),
    /// When the window last changed size.
    resized: Option<Instant>,
    close: bool,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        let attrs = Window::default_attributes()
            .with_title(self.title.clone())
            .with_inner_size(self.size);
        match event_loop.create_window(attrs) {
            Ok(w) => {
                let s = w.inner_size();
                if s.width > 0 && s.height > 0 {
                    self.size = s;
                }
                self.window = Some(Arc::new(w));
            }
            Err(e) => self.error = Some(e.to_string()),
        }
    }

    fn window_event(&mut self, _: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested | WindowEvent::Destroyed => self.close = true,
            WindowEvent::Resized(s) if s != self.size => {
                self.size = s;
                self.resized = Some(Instant::now());
            }
            WindowEvent::Focused(false) => {
                self.held.clear();
                self.drag = None;
            }
            WindowEvent::KeyboardInput { event, .. } => {
                let PhysicalKey::Code(code) = event.physical_key else {
                    return;
                };
                match controls::lookup(code) {
                    Some(Does::Move(m)) => {
                        if event.state == ElementState::Pressed {
                            self.held.insert(*m);
                        } else {
                            self.held.remove(m);
                        }
                    }
                    Some(Does::Act(a)) if event.state == ElementState::Pressed && !event.repeat => {
                        self.actions.push(*a)
                    }
                    _ => {}
                }
            }
            WindowEvent::MouseInput { state, .. } => {
                let held = self.drag.unwrap_or(0);
                self.drag = match state {
                    ElementState::Pressed => Some(held + 1),
                    ElementState::Released => held.checked_sub(1).filter(|&n| n > 0),
                };
            }
            WindowEvent::CursorMoved { position, .. } => {
                let p = (position.x, position.y);
                if let (Some(_), Some(c)) = (self.drag, self.cursor) {
                    self.look.0 += p.0 - c.0;
                    self.look.1 += p.1 - c.1;
                }
                self.cursor = Some(p);
            }
            WindowEvent::CursorLeft { .. } => self.cursor = None,
            WindowEvent::MouseWheel { delta, .. } => {
                self.scroll += match delta {
                    MouseScrollDelta::LineDelta(_, y) => y as f64,
                    // Touchpads: ~50 pixels a notch, as browsers count.
                    MouseScrollDelta::PixelDelta(p) => p.y / 50.0,
                };
            }
            _ => {}
        }
    }
}

/// The frame loop's own state (this thread).
struct LoopState {
    controller: FlyController,
    settings: Settings,
    /// Every device has line mode (wireframe).
    wireframe_supported: bool,
    /// The cullers that cannot run here, and what to show when one is
    /// asked for.
    unavailable: Vec<(CullMethod, String)>,
    recorder: PathRecorder,
    record_start: Instant,
    last_update: Instant,
    message: Option<(String, Instant)>,
    devices: String,
    occluder_budget: OccluderSelection,
    out_dir: PathBuf,
    near: f64,
    rendered: u64,
    /// The target-frame-rate controller while K holds a frame rate, and
    /// when the last frame finished.
    target: Option<FrameRateController>,
    last_finish: Option<Instant>,
}

impl LoopState {
    /// Feeds a finished frame to the target-frame-rate controller and
    /// publishes the tolerance for the next camera.
    fn target_update(&mut self, report: &gigawalk_runtime::FrameReport, shared: &Mutex<Shared>) {
        let ms = self
            .last_finish
            .map(|t| (report.finished_at - t).as_secs_f64() * 1e3);
        self.last_finish = Some(report.finished_at);
        let tolerance = match (&mut self.target, ms) {
            (Some(c), Some(ms)) if !report.speculative => {
                Some(c.update(ms, report.stats.drawn_triangles, report.pixel_error))
            }
            (Some(c), _) => Some(c.tolerance()),
            (None, _) => None,
        };
        if let Ok(mut s) = shared.lock() {
            s.target_tolerance = tolerance;
        }
    }

    /// Applies the input since the last frame and publishes the next
    /// camera and what the HUD shows; false to end the run (quit).
    fn after_frame(
        &mut self,
        app: &mut App,
        shared: &Mutex<Shared>,
        render: PhysicalSize<u32>,
        scripted: bool,
    ) -> bool {
        let now = Instant::now();
        let mut capture = None;
        for a in std::mem::take(&mut app.actions) {
            match a {
                Action::Quit => app.close = true,
                Action::ToggleWalk => self.controller.toggle_walk(),
                Action::ToggleOcclusion => self.settings.occlusion ^= true,
                Action::CycleCuller => {
                    // The next culler that can run here (hzb always can).
                    for _ in 0..CullMethod::ALL.len() {
                        self.settings.cycle_culler();
                        let culler = self.settings.culler;
                        match self.unavailable.iter().find(|u| u.0 == culler) {
                            Some((_, why)) => self.message = Some((why.clone(), now)),
                            None => break,
                        }
                    }
                }
                Action::ToggleHlod => self.settings.hlod ^= true,
                Action::PixelErrorUp => self.settings.step_pixel_error(true),
                Action::PixelErrorDown => self.settings.step_pixel_error(false),
                Action::ToggleAsync => self.settings.async_rvg ^= true,
                Action::ToggleTarget => {
                    self.settings.target ^= true;
                    self.target = self.settings.target.then(|| {
                        FrameRateController::new(
                            1e3 / self.settings.target_fps,
                            self.settings.pixel_error.max(MIN_TOLERANCE),
                            16.0,
                        )
                    });
                }
                Action::ToggleWireframe if self.wireframe_supported => {
                    self.settings.wireframe ^= true
                }
                Action::ToggleWireframe => self.message = Some((WIREFRAME_UNSUPPORTED.into(), now)),
                Action::ToggleBoxes => self.settings.boxes ^= true,
                Action::ToggleFreeze => self.settings.frozen ^= true,
                Action::ToggleHud => self.settings.hud ^= true,
                Action::ToggleHelp => self.settings.help ^= true,
                Action::Screenshot => {
                    capture = Some(next_free_name(&self.out_dir, "gigawalk-view", "png"))
                }
                Action::ToggleRecord => self.toggle_record(now),
            }
        }
        if !scripted {
            let (dx, dy) = std::mem::take(&mut app.look);
            self.controller.look(dx, dy);
            self.controller.scroll(std::mem::take(&mut app.scroll));
            self.controller
                .update((now - self.last_update).as_secs_f64(), &app.held);
        }
        self.last_update = now;
        let camera = self.controller.camera(aspect(render), self.near);
        self.recorder
            .push((now - self.record_start).as_secs_f64(), &camera);
        let mut s = shared.lock().expect("viewer state");
        if let Some(m) = s.message.take() {
            self.message = Some((m, now));
        }
        if self
            .message
            .as_ref()
            .is_some_and(|(_, t)| now - *t > MESSAGE_TIME)
        {
            self.message = None;
        }
        s.viewer = ViewerState {
            walking: self.controller.walking(),
            speed: self.controller.speed,
            recording: self
                .recorder
                .is_recording()
                .then(|| self.recorder.pose_count()),
            devices: self.devices.clone(),
            message: self.message.as_ref().map(|(m, _)| m.clone()),
            occluder_budget: self.occluder_budget,
        };
        s.camera = camera;
        s.frozen = self.settings.frozen;
        s.settings = self.settings.clone();
        s.window_size = (app.size.width, app.size.height);
        if capture.is_some() {
            s.capture = capture;
        }
        s.quit = app.close;
        !app.close
    }

    fn toggle_record(&mut self, now: Instant) {
        if let Some(path) = self.recorder.stop() {
            let file = next_free_name(&self.out_dir, "gigawalk-view", "path");
            let text = match path.write(&file) {
                Ok(()) => format!(
                    "path written: {} ({} poses)",
                    file.display(),
                    path.poses.len()
                ),
                Err(e) => format!("path NOT written: {e}"),
            };
            eprintln!("{text}");
            self.message = Some((text, now));
        } else {
            self.recorder.start();
            self.record_start = now;
        }
    }
}

/// Cameras for the runtime (OR thread): the live controller's, or the
/// script's.
struct LiveSource {
    shared: Arc<Mutex<Shared>>,
    script: Option<Script>,
    sent: u64,
    near: f64,
}

impl CameraSource for LiveSource {
    fn next_camera(&mut self, frame: u64) -> Result<Option<CameraRequest>, CameraError> {
        let (camera, frozen, style, quit, minimised, pixel_error) = {
            let s = self.shared.lock().map_err(|_| CameraError::Source {
                frame,
                source: "the window's state is poisoned: its thread panicked".into(),
            })?;
            (
                s.camera,
                s.frozen,
                if s.settings.wireframe {
                    DrawStyle::Wireframe
                } else {
                    DrawStyle::Shaded
                },
                s.quit,
                s.window_size.0 == 0 || s.window_size.1 == 0,
                s.target_tolerance.filter(|_| s.settings.target),
            )
        };
        if quit {
            return Ok(None);
        }
        if let Some(script) = &self.script {
            if self.sent >= script.frames {
                return Ok(None);
            }
            let i = self.sent as usize;
            self.sent += 1;
            let camera = match script.poses.get(i).or(script.poses.last()) {
                Some(p) => Camera {
                    position: p.position,
                    orientation: p.orientation,
                    fovy: p.fovy,
                    near: self.near,
                    ..camera
                },
                None => camera,
            };
            return Ok(Some(CameraRequest {
                camera,
                read_back: false,
                hold_culling: false,
                style,
                pixel_error,
            }));
        }
        if minimised {
            std::thread::sleep(MINIMISED_WAIT);
        }
        Ok(Some(CameraRequest {
            camera,
            read_back: false,
            hold_culling: frozen,
            style,
            pixel_error,
        }))
    }
}

/// Shows frames in the window (RVG thread).
struct ViewerPresenter<'s> {
    surface: WindowSurface,
    shared: Arc<Mutex<Shared>>,
    skeleton: &'s Skeleton,
    /// The last culled frame's sets, shown while culling is frozen.
    culled_sets: CullSets,
    script: Option<Script>,
    clock: FrameClock,
}

impl Presenter for ViewerPresenter<'_> {
    fn present(
        &mut self,
        ctx: &GpuContext,
        pass: &VisiblePass,
        report: &FrameReport,
    ) -> Result<(), GpuError> {
        let (settings, viewer, size, mut capture) = {
            let mut s = self.shared.lock().expect("viewer state");
            (
                s.settings.clone(),
                s.viewer.clone(),
                s.window_size,
                s.capture.take(),
            )
        };
        // The HUD shows this frame's own numbers (the frame loop only
        // hears of it after it is presented).
        self.clock.tick(report.finished_at);
        let numbers = FrameNumbers {
            frame: report.frame,
            or_ms: report.or_ms,
            hzb_ms: report.hzb_ms,
            stc_ms: report.stc_ms,
            rvg_ms: report.rvg_ms,
            latency_ms: report.latency_ms(),
            occlusion_used: report.occlusion_used,
            occluder_triangles: report.occluder_triangles,
            stats: report.stats,
            streaming: report.streaming,
            tiles: report.tiles.as_ref().map(|t| {
                (
                    t.grid.to_string(),
                    t.max_triangles,
                    t.ms_adaptive,
                    t.ms_naive,
                )
            }),
            pixel_error: report.pixel_error,
            culler_work: report.culler_work,
        };
        let hud = hud_lines(self.clock.fps(), &numbers, &settings, &viewer);
        if let Some(script) = &self.script {
            if report.frame + 1 >= script.frames {
                capture = script.screenshot.clone();
            }
        }
        // A frame that reused an older visible set (frozen, or async RVG
        // ahead of STC) keeps the boxes of the frame that culled it.
        if !report.reused_visible_set || self.culled_sets.drawn.is_empty() {
            self.culled_sets = cull_sets(report);
        }
        let mut overlay = OverlayFrame {
            view_proj: report.camera.view_projection_rel(),
            ..Default::default()
        };
        if settings.boxes || settings.frozen {
            overlay.boxes = overlay_boxes(self.skeleton, &self.culled_sets, report.camera.position);
        }
        let (w, h) = pass.size();
        let scale = if h >= HUD_2X_MIN_HEIGHT { 2 } else { 1 };
        let glyph = (8 * scale) as f32;
        if settings.hud && !hud.is_empty() {
            overlay.text.push(OverlayText {
                x: glyph,
                y: glyph,
                scale,
                lines: hud,
                colour: [1.0, 1.0, 0.85, 1.0],
                background: [0.0, 0.0, 0.0, 0.55],
            });
        }
        if settings.help {
            let lines: Vec<String> = std::iter::once("gigawalk view: controls".to_string())
                .chain(std::iter::once(String::new()))
                .chain(controls::help_lines())
                .collect();
            let cols = lines.iter().map(|l| l.len()).max().unwrap_or(0) as f32;
            overlay.text.push(OverlayText {
                x: (w as f32 - cols * glyph - glyph).max(glyph),
                y: glyph,
                scale,
                lines,
                colour: [0.85, 0.95, 1.0, 1.0],
                background: [0.0, 0.02, 0.08, 0.75],
            });
        }
        let shown = self
            .surface
            .present(ctx, pass, &overlay, size, capture.is_some())?;
        if let (Some(file), Some((w, h, rgba))) = (capture, shown.capture) {
            let mut s = self.shared.lock().expect("viewer state");
            match write_png(&file, w, h, &rgba) {
                Ok(()) => {
                    eprintln!("screenshot: {}", file.display());
                    s.message = Some(format!("screenshot: {}", file.display()));
                }
                Err(e) if self.script.is_some() => s.error = Some(e.into()),
                Err(e) => s.message = Some(format!("screenshot failed: {e}")),
            }
        }
        Ok(())
    }
}

fn cull_sets(report: &FrameReport) -> CullSets {
    let mut sets = CullSets {
        drawn: report.visible.iter().map(|d| d.node).collect(),
        ..Default::default()
    };
    for &(node, why) in report.culled.iter() {
        match why {
            CullReason::Frustum => sets.frustum_culled.push(node),
            CullReason::Occlusion => sets.occlusion_culled.push(node),
        }
    }
    sets
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
