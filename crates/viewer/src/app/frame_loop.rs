//! The frame loop's side of input: between frames it applies what the
//! window collected (actions, movement, mouse look), steers the target
//! frame rate, records the camera path, and publishes the next camera and
//! what the HUD shows.

use std::path::PathBuf;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use gigawalk_runtime::target::{FrameRateController, MIN_TOLERANCE};
use gigawalk_runtime::{CullMethod, OccluderSelection};
use winit::dpi::PhysicalSize;

use super::window::App;
use super::{aspect, Shared};
use crate::controller::FlyController;
use crate::controls::Action;
use crate::hud::ViewerState;
use crate::recorder::{next_free_name, PathRecorder};
use crate::settings::Settings;

/// Shown when wireframe is asked for on a device without line mode.
const WIREFRAME_UNSUPPORTED: &str =
    "wireframe: this GPU has no line mode (POLYGON_MODE_LINE); drawing shaded";
/// How long HUD messages (screenshot written, path saved) stay up.
const MESSAGE_TIME: Duration = Duration::from_secs(4);

/// The frame loop's own state (this thread).
pub(super) struct LoopState {
    pub(super) controller: FlyController,
    pub(super) settings: Settings,
    /// Every device has line mode (wireframe).
    pub(super) wireframe_supported: bool,
    /// The cullers that cannot run here, and what to show when one is
    /// asked for.
    pub(super) unavailable: Vec<(CullMethod, String)>,
    pub(super) recorder: PathRecorder,
    pub(super) record_start: Instant,
    pub(super) last_update: Instant,
    pub(super) message: Option<(String, Instant)>,
    pub(super) devices: String,
    pub(super) occluder_budget: OccluderSelection,
    pub(super) out_dir: PathBuf,
    pub(super) near: f64,
    pub(super) rendered: u64,
    /// The target-frame-rate controller while K holds a frame rate, and
    /// when the last frame finished.
    pub(super) target: Option<FrameRateController>,
    pub(super) last_finish: Option<Instant>,
}

impl LoopState {
    /// Feeds a finished frame to the target-frame-rate controller and
    /// publishes the tolerance for the next camera.
    pub(super) fn target_update(
        &mut self,
        report: &gigawalk_runtime::FrameReport,
        shared: &Mutex<Shared>,
    ) {
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
    pub(super) fn after_frame(
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
