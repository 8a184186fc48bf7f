//! The frame loop's side of input: between frames it applies what the
//! window collected (actions, clicks, searches, movement, mouse look),
//! steers the target frame rate, records the camera path, and publishes
//! the next camera, the hidden and highlighted objects, the section, and
//! what the HUD and the measurement overlay show.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use gigawalk_cull::{NodeShow, PickHit, Viewport, Visibility};
use gigawalk_review::select;
use gigawalk_runtime::target::{FrameRateController, MIN_PIXEL_ERROR};
use gigawalk_runtime::{CullMethod, OccluderSelection};
use gigawalk_scene::path::Pose;
use gigawalk_scene::units::Units;
use gigawalk_scene::views::{SavedView, Views};
use gigawalk_scene::Aabb;
use gigawalk_scene::SceneReader;
use glam::DVec3;
use winit::dpi::PhysicalSize;

use super::window::{App, Input};
use super::{aspect, Shared};
use crate::controls::Action;
use crate::hud::ViewerState;
use crate::objects::{frame_box, save_view, view_names, Objects};
use crate::sections::{box_in_view, Sections};
use crate::settings::Settings;
use gigawalk_review::fly::FlyController;
use gigawalk_review::measure::Measure;
use gigawalk_review::recorder::{next_free_name, PathRecorder};

/// Shown when wireframe is asked for on a device without line mode.
const WIREFRAME_UNSUPPORTED: &str =
    "wireframe: this GPU has no line mode (POLYGON_MODE_LINE); drawing shaded";
/// How long HUD messages (screenshot written, path saved) stay up.
const MESSAGE_TIME: Duration = Duration::from_secs(4);
/// Said when a plane key finds no plane.
use gigawalk_review::actions::{act, NO_PLANE};
/// How long framing an object takes to fly there: long enough to see
/// where the camera went, short enough not to wait for it.
const FLIGHT_TIME: Duration = Duration::from_millis(400);

/// The camera on its way to frame an object; a movement key ends it.
#[derive(Clone, Copy, Debug)]
pub(super) struct Flight {
    from: DVec3,
    to: DVec3,
    start: Instant,
}

impl Flight {
    /// Where the eye is at `now` (smoothstep from `from` to `to`), and
    /// whether it has arrived.
    fn at(&self, now: Instant) -> (DVec3, bool) {
        let t = (now.saturating_duration_since(self.start).as_secs_f64()
            / FLIGHT_TIME.as_secs_f64())
        .clamp(0.0, 1.0);
        let s = t * t * (3.0 - 2.0 * t);
        (self.from.lerp(self.to, s), t >= 1.0)
    }
}

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
    /// Selection, search and hidden set.
    pub(super) objects: Objects,
    /// What the passes draw of the objects (`None`: all, none tinted).
    pub(super) visibility: Option<Arc<Visibility>>,
    /// X-ray's ghosts of the hidden objects (`None`: x-ray off, or
    /// nothing hidden).
    pub(super) ghosts: Option<Arc<Visibility>>,
    pub(super) flight: Option<Flight>,
    /// `SCENE.views.json`, and the names of its views (help lists them).
    pub(super) views_file: PathBuf,
    pub(super) view_names: Vec<String>,
    /// The view `N` restores next, counting from 0.
    pub(super) next_view: usize,
    /// Section planes and box, published with every camera.
    pub(super) sections: Sections,
    pub(super) measure: Measure,
    /// The model's unit, for measurements.
    pub(super) units: Units,
    /// The scene's box: section boxes stay within it, plane steps scale
    /// with it.
    pub(super) scene_bounds: Aabb,
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
        let pixel_error = match (&mut self.target, ms) {
            (Some(c), Some(ms)) if !report.speculative => {
                Some(c.update(ms, report.stats.drawn_triangles, report.pixel_error))
            }
            (Some(c), _) => Some(c.pixel_error()),
            (None, _) => None,
        };
        if let Ok(mut s) = shared.lock() {
            s.target_pixel_error = pixel_error;
        }
    }

    /// Applies the input since the last frame and publishes the next
    /// camera and what the HUD shows; false to end the run (quit).
    pub(super) fn after_frame(
        &mut self,
        app: &mut App,
        shared: &Mutex<Shared>,
        scene: &SceneReader,
        render: PhysicalSize<u32>,
        scripted: bool,
    ) -> bool {
        let now = Instant::now();
        let mut capture = None;
        for input in std::mem::take(&mut app.inputs) {
            let a = match input {
                Input::Act(a) => a,
                Input::Click { x, y, double } => {
                    self.click(scene, (x, y), app.size, render, double, now);
                    continue;
                }
                Input::Find(text) => {
                    let found = self.objects.find(&text);
                    self.fly_to_match(found, render, now);
                    continue;
                }
                Input::RestoreView(n) => {
                    self.restore_view(Some(n), now);
                    continue;
                }
                Input::SectionPlane { at } => {
                    self.place_section_plane(scene, at, app.size, render, now);
                    continue;
                }
                Input::MoveSection(notches) => {
                    self.move_section(notches, now);
                    continue;
                }
            };
            // Clearing the sections is also printed (below).
            if a != Action::ClearSections {
                let (eye, diagonal) = (self.controller.position, self.scene_bounds.diagonal());
                if let Some(said) = act(a, &mut self.objects, &mut self.sections, eye, diagonal) {
                    if let Some(m) = said {
                        self.say(m, now);
                    }
                    continue;
                }
            }
            match a {
                // Esc first clears a measurement, as in other viewers.
                Action::Quit if self.measure.is_active() => {
                    let m = self.measure.toggle();
                    self.announce(m, now);
                }
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
                            self.settings.pixel_error.max(MIN_PIXEL_ERROR),
                            16.0,
                        )
                    });
                }
                Action::ToggleWireframe if self.wireframe_supported => {
                    self.settings.wireframe ^= true
                }
                Action::ToggleWireframe => self.message = Some((WIREFRAME_UNSUPPORTED.into(), now)),
                Action::ToggleEdges => self.settings.look.edges ^= true,
                Action::ToggleAmbientOcclusion => self.settings.look.ao ^= true,
                Action::ToggleAntialiasing => self.settings.toggle_aa(),
                Action::ToggleXray => {
                    self.settings.xray ^= true;
                    self.objects.mark_changed();
                    if self.settings.xray && self.objects.hidden_count().0 == 0 {
                        self.say("x-ray on: hidden objects will show as ghosts".into(), now);
                    }
                }
                Action::ToggleBoxes => self.settings.boxes ^= true,
                Action::ToggleFreeze => self.settings.frozen ^= true,
                Action::ToggleHud => self.settings.hud ^= true,
                Action::ToggleHelp => self.settings.help ^= true,
                Action::Screenshot => {
                    capture = Some(next_free_name(&self.out_dir, "gigawalk-view", "png"))
                }
                Action::ToggleRecord => self.toggle_record(now),
                Action::FrameSelection => self.frame_selection(render, now),
                // The window opens the prompt; nothing to do here.
                Action::Search => {}
                Action::NextMatch => {
                    let found = self.objects.next_match();
                    self.fly_to_match(found, render, now);
                }
                Action::SaveView => self.save_view(now),
                Action::NextView => self.restore_view(None, now),
                // The window sends `Input::SectionPlane` with the cursor.
                Action::SectionPlane => {}
                Action::SectionBox => self.section_box(scene, render, now),
                // The rest of the object and section keys are `act`'s.
                Action::Hide
                | Action::Isolate
                | Action::ShowAll
                | Action::SectionForward
                | Action::SectionBack
                | Action::FlipSection
                | Action::ToggleSections => {}
                Action::ClearSections => {
                    let m = self.sections.clear();
                    self.announce(m, now);
                }
                Action::Measure => {
                    let m = self.measure.toggle();
                    self.announce(m, now);
                }
            }
        }
        if self.objects.take_changed() {
            self.refresh_visibility(scene.skeleton());
        }
        if !scripted {
            let (dx, dy) = std::mem::take(&mut app.look);
            self.controller.look(dx, dy);
            self.controller.scroll(std::mem::take(&mut app.scroll));
            if let Some(f) = self.flight {
                if app.held.is_empty() {
                    let (at, arrived) = f.at(now);
                    self.controller.position = at;
                    if arrived {
                        self.flight = None;
                    }
                } else {
                    self.flight = None;
                }
            }
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
        let mut objects = self.objects.hud_lines();
        objects.extend(self.sections.hud_line());
        objects.extend(self.measure.hud_line(&self.units));
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
            objects,
            prompt: app.prompt.clone(),
            views: self.view_names.clone(),
            measure: self.measure,
            units: self.units,
        };
        s.visibility = self.visibility.clone();
        s.ghosts = self.ghosts.clone();
        s.section = self.sections.current();
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

    /// A HUD message.
    fn say(&mut self, text: String, now: Instant) {
        self.message = Some((text, now));
    }

    /// A HUD message that is also printed (what a terminal user, or a
    /// script, wants to keep: selections, saved and restored views).
    fn announce(&mut self, text: String, now: Instant) {
        eprintln!("{text}");
        self.say(text, now);
    }

    /// A click at window pixel `at`: selects the object the full-detail
    /// image shows there (hidden ones skipped), or nothing; a double click
    /// also frames it.
    fn click(
        &mut self,
        scene: &SceneReader,
        at: (f64, f64),
        window: PhysicalSize<u32>,
        render: PhysicalSize<u32>,
        double: bool,
        now: Instant,
    ) {
        if self.measure.wants_click() {
            // Measuring picks points on any surface, identity or not.
            let hit = match self.pick_at(scene, at, window, render) {
                Ok(h) => h,
                Err(e) => return self.announce(e, now),
            };
            let m = self.measure.click(hit.map(|h| h.point), &self.units);
            return self.announce(m, now);
        }
        if let Err(why) = self.objects.table() {
            return self.say(why, now);
        }
        let hit = match self.pick_at(scene, at, window, render) {
            Ok(hit) => hit.and_then(|h| h.object.map(|o| (o, h.point))),
            Err(e) => return self.announce(e, now),
        };
        let had = self.objects.selection();
        self.objects.click(hit);
        // Said once per new selection (a double click's second click hits
        // the same point).
        if self.objects.selection() != had {
            match self.objects.describe_selection() {
                Some(text) => self.announce(text, now),
                None => self.announce("selection cleared".into(), now),
            }
        }
        if double && hit.is_some() {
            self.frame_selection(render, now);
        }
    }

    /// What the passes draw of the objects, after the hidden set, the
    /// selection or x-ray changed.
    pub(super) fn refresh_visibility(&mut self, skeleton: &gigawalk_scene::Skeleton) {
        self.visibility = self.objects.visibility(skeleton);
        self.ghosts = if self.settings.xray {
            self.objects.ghosts(skeleton)
        } else {
            None
        };
    }

    /// What the full-detail image shows at window pixel `at`: the nearest
    /// surface the section keeps, hidden objects skipped. `Ok(None)`:
    /// nothing there (or outside the image).
    fn pick_at(
        &mut self,
        scene: &SceneReader,
        at: (f64, f64),
        window: PhysicalSize<u32>,
        render: PhysicalSize<u32>,
    ) -> Result<Option<PickHit>, String> {
        if self.objects.take_changed() {
            // Input earlier in this batch changed what is hidden.
            self.refresh_visibility(scene.skeleton());
        }
        // The window shows the render target scaled to fit, so the click's
        // place in the window is its place in the image.
        let camera = self.controller.camera(aspect(render), self.near);
        let viewport = Viewport::new(window.width.max(1), window.height.max(1));
        // The pointer names a pixel; cast through its centre, as
        // `gigawalk pick` does.
        let (x, y) = (at.0.floor() + 0.5, at.1.floor() + 0.5);
        let section = self.sections.current();
        let vis = self.visibility.as_deref();
        let objects = &self.objects;
        select::pick_pixel(
            scene,
            objects.table().ok(),
            &camera,
            viewport,
            (x, y),
            &|node| vis.is_some_and(|v| v.node(node) == NodeShow::Hidden),
            &|o| objects.is_hidden(o),
            section.as_deref(),
        )
        .map(|(hit, _)| hit)
        .map_err(|e| format!("pick failed: {e}"))
    }

    /// `X`: a section plane through the surface under the cursor (the
    /// window's centre when the cursor is outside), facing the camera.
    fn place_section_plane(
        &mut self,
        scene: &SceneReader,
        at: Option<(f64, f64)>,
        window: PhysicalSize<u32>,
        render: PhysicalSize<u32>,
        now: Instant,
    ) {
        let at = at.unwrap_or((window.width as f64 * 0.5, window.height as f64 * 0.5));
        let hit = match self.pick_at(scene, at, window, render) {
            Ok(Some(h)) => h,
            Ok(None) => {
                return self.say(
                    "section plane: no surface under the cursor to cut at".into(),
                    now,
                )
            }
            Err(e) => return self.announce(e, now),
        };
        let forward = self.controller.camera(aspect(render), self.near).forward();
        let r = self.sections.place_plane(hit.point, forward);
        match r {
            Ok(m) => self.announce(m, now),
            Err(m) => self.say(m, now),
        }
    }

    /// `]`, `[`, Shift+wheel: the active plane along its normal.
    fn move_section(&mut self, steps: f64, now: Instant) {
        let eye = self.controller.position;
        if !self
            .sections
            .move_active(steps, eye, self.scene_bounds.diagonal())
        {
            self.say(NO_PLANE.into(), now);
        }
    }

    /// `J`: a section box around the selection, or with none, around what
    /// is in view: up to a few times the distance of the surface under
    /// the window's centre (the scene's far side when there is none).
    fn section_box(&mut self, scene: &SceneReader, render: PhysicalSize<u32>, now: Instant) {
        let diagonal = self.scene_bounds.diagonal();
        let around = if self.objects.selection().is_some() {
            match self.objects.selected_bounds() {
                Ok(b) => b,
                Err(why) => return self.say(why, now),
            }
        } else {
            let centre = (render.width as f64 * 0.5, render.height as f64 * 0.5);
            let camera = self.controller.camera(aspect(render), self.near);
            let hit = match self.pick_at(scene, centre, render, render) {
                Ok(h) => h.map(|h| h.distance),
                Err(e) => return self.announce(e, now),
            };
            match box_in_view(&camera, hit, &self.scene_bounds) {
                Ok(b) => b,
                Err(m) => return self.say(m, now),
            }
        };
        match self.sections.box_around(&around, diagonal) {
            Ok(m) => self.announce(m, now),
            Err(m) => self.say(m, now),
        }
    }

    /// `F`: fly back along the view until the selected object fits.
    fn frame_selection(&mut self, render: PhysicalSize<u32>, now: Instant) {
        let bounds = match self.objects.selected_bounds() {
            Ok(b) => b,
            Err(why) => return self.say(why, now),
        };
        let camera = self.controller.camera(aspect(render), self.near);
        let Some(to) = frame_box(
            &bounds,
            camera.forward(),
            camera.fovy,
            camera.aspect,
            self.near,
        ) else {
            return;
        };
        // Framing leaves the floor: walk mode would pull the eye back down.
        if self.controller.walking() {
            self.controller.toggle_walk();
        }
        self.flight = Some(Flight {
            from: self.controller.position,
            to,
            start: now,
        });
    }

    /// After a search's Enter: frame the match it selected, or say why not.
    fn fly_to_match(
        &mut self,
        found: Result<u32, String>,
        render: PhysicalSize<u32>,
        now: Instant,
    ) {
        match found {
            Ok(_) => {
                if let Some(text) = self.objects.describe_selection() {
                    eprintln!("{text}");
                }
                self.frame_selection(render, now);
            }
            Err(why) => self.say(why, now),
        }
    }

    /// `V`: the camera, selection, hidden objects and section as `view N` in the
    /// scene's views file (a file that does not read is left alone).
    fn save_view(&mut self, now: Instant) {
        let c = &self.controller;
        let pose = Pose {
            time: 0.0,
            position: c.position,
            orientation: c.orientation(),
            fovy: c.fovy,
        };
        let (objects, section) = (&self.objects, self.sections.saved());
        let xray = self.settings.xray;
        let make = |name: &str| {
            let mut v = objects.saved_view(name, &pose);
            v.section = section;
            v.xray = xray;
            v
        };
        match save_view(&self.views_file, make) {
            Ok((name, names)) => {
                let n = names.len();
                self.view_names = names;
                let key = if n <= 9 {
                    format!("{n} restores it")
                } else {
                    "N cycles views".to_string()
                };
                self.announce(
                    format!(
                        "saved view {name:?} to {} ({key})",
                        self.views_file.display()
                    ),
                    now,
                );
            }
            Err(e) => self.announce(format!("view NOT saved: {e}"), now),
        }
    }

    /// `1`-`9` (`Some(n)`, counting from 1) or `N` (`None`: the next one):
    /// restores a saved view, read afresh from the file.
    fn restore_view(&mut self, number: Option<usize>, now: Instant) {
        let views = match Views::read(&self.views_file) {
            Ok(v) => v,
            Err(e) => return self.announce(format!("no view restored: {e}"), now),
        };
        self.view_names = view_names(&views);
        let count = views.views.len();
        if count == 0 {
            return self.say(
                format!(
                    "no saved views in {} yet: V saves one",
                    self.views_file.display()
                ),
                now,
            );
        }
        let index = match number {
            Some(n) if n >= 1 && n <= count => n - 1,
            Some(n) => {
                return self.say(
                    format!(
                        "no saved view {n}: {} has {count}",
                        self.views_file.display()
                    ),
                    now,
                )
            }
            None => self.next_view % count,
        };
        self.next_view = index + 1;
        self.apply_view(&views.views[index], true, now);
    }

    /// A saved view's selection, hidden objects and section, and its
    /// camera when `camera`.
    pub(super) fn apply_view(&mut self, view: &SavedView, camera: bool, now: Instant) {
        if camera {
            match view.pose() {
                Ok(p) => {
                    self.flight = None;
                    self.controller.set_pose(p.position, p.orientation, p.fovy);
                }
                Err(e) => return self.say(format!("view {:?} not restored: {e}", view.name), now),
            }
        }
        let mut text = self.objects.restore(view);
        text.push_str(&self.sections.restore(view.section.as_ref()));
        if self.settings.xray != view.xray {
            self.settings.xray = view.xray;
            self.objects.mark_changed();
        }
        self.announce(text, now);
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
