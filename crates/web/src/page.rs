//! The page (wasm32): [`start`] opens the page's one WebGPU device on a
//! canvas, opens the scene through range requests and runs the frame
//! loop on `requestAnimationFrame`; [`stats`] is what the page and its
//! tests read back.
//!
//! The frame is the runtime's: gigawalk-runtime's stepped schedule (OR,
//! STC and RVG on the page's one thread and device, OR's read-back
//! polled, nothing blocking) with the runtime's streaming (its pool,
//! stand-ins and order of requests). What is the page's own: the camera
//! from input, the canvas, the fetches that bring what the schedule asks
//! for ([`Stepped::wanted`], loaded with [`Stepped::load`] once the bytes
//! are in the [`Sparse`] view), and the HUD, drawn by the schedule's
//! presenter. An animation frame whose occluder depth has not come back
//! presents nothing new (`hzb_waits` counts them); the HZB is always the
//! depth of the camera it culls for, so culling stays conservative.
//!
//! The review tools (pick, find, hide, sections, view links) are
//! `review`'s.

use std::cell::RefCell;
use std::collections::{HashMap, HashSet};
use std::ops::Range;
use std::rc::Rc;

use gigawalk_cull::{default_near, step_pixel_error, Camera, Mode, Viewport};
use gigawalk_gpu::{
    Antialias, GpuContext, Look, OverlayFrame, OverlayText, VisiblePass, WindowSurface,
};
use gigawalk_review::fly::{FlyController, Movement};
use gigawalk_review::gestures::{Gesture, Pointers};
use gigawalk_review::keys::{self, Action, Does};
use gigawalk_review::measure::Measure;
use gigawalk_review::objects::hud_text;
use gigawalk_review::recorder::PathRecorder;
use gigawalk_review::sections::Sections;
use gigawalk_runtime::{
    CameraRequest, FrameReport, OccluderBudget, Presenter, Runtime, RuntimeOptions, Stepped,
    SteppedOptions,
};
use gigawalk_scene::sparse::{open_step, OpenStep, Sparse, OPEN_CHUNK};
use gigawalk_scene::units::Units;
use gigawalk_scene::SceneReader;
use wasm_bindgen::prelude::*;
use wasm_bindgen::JsCast;
use wasm_bindgen_futures::{spawn_local, JsFuture};
use web_sys::{
    Blob, HtmlAnchorElement, HtmlCanvasElement, KeyboardEvent, PointerEvent, Request, RequestInit,
    Response, WheelEvent,
};

use crate::stream::{batches, Batch};

mod review;

/// Vertical field of view of the page's camera.
const FOVY_DEGREES: f64 = 60.0;
/// LODs in flight at once. Nearby blobs share a range request
/// ([`batches`]); browsers run about six requests to one host at a time
/// and queue the rest.
const MAX_IN_FLIGHT: usize = 192;
/// Device bytes for geometry when the page's URL does not say
/// (`?budget=MB`).
const DEFAULT_BUDGET_MB: u64 = 256;
/// The most the pinned set (the coarsest LODs of the nodes nearest the
/// root, never evicted, a stand-in for everything below them) may take.
/// None: it would be fetched before the first frame, which then waits
/// for most of a small scene, and one corrupt LOD in it would stop the
/// page; fetched as the walk asks, a LOD that fails is said and left out.
const PINNED_BYTES: u64 = 0;

/// What the page reports (as JSON, through [`stats`]).
#[derive(Default, serde::Serialize)]
struct Stats {
    state: String,
    error: Option<String>,
    backend: String,
    /// Whether the adapter rasterizes on the CPU (the default look then
    /// leaves AO and FXAA off), and the look in words.
    cpu_rasterizer: bool,
    look: String,
    frames: u64,
    fps: f64,
    triangles: u64,
    draws: usize,
    stand_ins: usize,
    missing: usize,
    visited: u64,
    file_bytes: u64,
    fetched_bytes: u64,
    requests: u64,
    resident_bytes: u64,
    first_frame_ms: Option<f64>,
    /// Bytes fetched when the first frame was drawn.
    first_frame_fetched: u64,
    failed_lods: u64,
    /// Blob bytes of the LODs loaded, and the page's time taking them in
    /// (into the sparse view, read into the device layout, uploaded), in
    /// all: its cost per fetched byte.
    loaded_bytes: u64,
    load_ms: f64,
    /// Blob bytes of the LODs asked for in range requests (what they
    /// fetched beyond it is the gaps between blobs batched together).
    asked_bytes: u64,
    /// The last LOD that failed to fetch or decode, and why.
    lod_error: Option<String>,
    in_flight: usize,
    /// Whether the last frame drew every LOD it wanted, with nothing in
    /// flight: what tests wait for before they read an image.
    settled: bool,
    /// The last frame's time on the page's thread, all of it and its
    /// traversal's (milliseconds).
    cpu_ms: f64,
    traversal_ms: f64,
    mode: String,
    pixel_error: f64,
    /// Nodes the last frame culled by occlusion, whether it had an HZB
    /// (not in the startup frame or with no occluder resident), and the
    /// occluders drawn for it.
    occlusion_culled: u64,
    occlusion_used: bool,
    occluders: usize,
    occluder_triangles: u64,
    /// Animation frames that presented nothing new because OR's read-back
    /// had not arrived, in all; and the level read back.
    hzb_waits: u64,
    hzb_level: u32,
    /// Animation frames run, and the last drawn frame's time from OR
    /// taking its camera to the frame drawn (ms).
    animation_frames: u64,
    hzb_latency_ms: f64,
    /// The object table's size once read (`None` before, or without
    /// one), objects hidden, the selection's `file/path`, the section in
    /// effect and the last message the page showed.
    objects: Option<usize>,
    hidden: usize,
    selected: Option<String>,
    section: Option<String>,
    message: Option<String>,
    /// The measured distance once both points are picked (model units),
    /// the poses of a path being recorded (as of the last frame drawn),
    /// and the files offered for download (screenshots and recorded
    /// paths).
    measured: Option<f64>,
    recording: Option<usize>,
    downloads: Vec<String>,
}

thread_local! {
    static STATS: RefCell<Stats> = RefCell::new(Stats {
        state: "starting".into(),
        ..Stats::default()
    });
}

fn set_stats(f: impl FnOnce(&mut Stats)) {
    STATS.with(|s| f(&mut s.borrow_mut()));
}

/// The page's state as JSON: `state` (starting, opening, running,
/// error), `error`, frame and fetch counts. Tests poll it.
#[wasm_bindgen]
pub fn stats() -> String {
    STATS.with(|s| serde_json::to_string(&*s.borrow()).expect("the stats serialize"))
}

fn now_ms() -> f64 {
    web_sys::window()
        .and_then(|w| w.performance())
        .map_or(0.0, |p| p.now())
}

fn js_err(e: JsValue) -> String {
    e.as_string()
        .or_else(|| {
            e.dyn_ref::<js_sys::Error>()
                .map(|e| String::from(e.message()))
        })
        .unwrap_or_else(|| format!("{e:?}"))
}

/// One range request: the bytes and the file's length from
/// `Content-Range`. A server that answers with the whole file (200) or
/// anything but 206 is an error: the page never downloads a scene whole.
async fn fetch_range(url: &str, range: Range<u64>) -> Result<(Vec<u8>, Option<u64>), String> {
    let window = web_sys::window().ok_or("no window")?;
    let init = RequestInit::new();
    init.set_method("GET");
    let headers = web_sys::Headers::new().map_err(js_err)?;
    headers
        .set("Range", &format!("bytes={}-{}", range.start, range.end - 1))
        .map_err(js_err)?;
    init.set_headers(&headers);
    let request = Request::new_with_str_and_init(url, &init).map_err(js_err)?;
    let response: Response = JsFuture::from(window.fetch_with_request(&request))
        .await
        .map_err(|e| format!("cannot fetch {url}: {}", js_err(e)))?
        .dyn_into()
        .map_err(js_err)?;
    match response.status() {
        206 => {}
        200 => {
            return Err(format!(
                "the server does not answer range requests for {url} (it sent the whole \
                 file, HTTP 200): serve the page from one that does, e.g. `gigawalk serve`"
            ))
        }
        s => {
            return Err(format!(
                "cannot fetch {url}: HTTP {s} {}",
                response.status_text()
            ))
        }
    }
    let total = response
        .headers()
        .get("Content-Range")
        .ok()
        .flatten()
        .and_then(|v| {
            v.rsplit('/')
                .next()
                .and_then(|n| n.trim().parse::<u64>().ok())
        });
    let buffer = JsFuture::from(response.array_buffer().map_err(js_err)?)
        .await
        .map_err(|e| format!("cannot read {url}: {}", js_err(e)))?;
    let bytes = js_sys::Uint8Array::new(&buffer).to_vec();
    let want = range.end - range.start;
    if let Some(t) = total {
        let expect = want.min(t.saturating_sub(range.start));
        if bytes.len() as u64 != expect {
            return Err(format!(
                "{url} answered bytes {}..{} with {} bytes",
                range.start,
                range.end,
                bytes.len()
            ));
        }
    }
    Ok((bytes, total))
}

/// Opens the scene at `url`: the first range gives the file's length,
/// then as many rounds as the reader asks for.
async fn open_scene(url: &str) -> Result<(Box<SceneReader<Sparse>>, Sparse, u64, u64), String> {
    let (first, total) = fetch_range(url, 0..OPEN_CHUNK).await?;
    let len = total.ok_or_else(|| {
        format!("{url}: the server's range answer has no Content-Range with the file's length")
    })?;
    let sparse = Sparse::new(len);
    let mut fetched = first.len() as u64;
    let mut requests = 1;
    sparse.insert(0, first)?;
    let name = url.rsplit('/').next().unwrap_or(url).to_string();
    loop {
        match open_step(&sparse, &name) {
            OpenStep::Open(r) => return Ok((r, sparse, fetched, requests)),
            OpenStep::Fetch(range) => {
                let (bytes, _) = fetch_range(url, range.clone()).await?;
                fetched += bytes.len() as u64;
                requests += 1;
                sparse.insert(range.start, bytes)?;
            }
            OpenStep::Failed(e) => return Err(format!("{name} cannot be opened as a scene: {e}")),
        }
    }
}

/// A query parameter of the page's URL.
fn query(name: &str) -> Option<String> {
    let search = web_sys::window()?.location().search().ok()?;
    search
        .trim_start_matches('?')
        .split('&')
        .filter_map(|kv| kv.split_once('='))
        .find(|(k, _)| *k == name)
        .map(|(_, v)| v.to_string())
}

/// A LOD fetch's outcome, handed from its promise to the next frame.
type Arrivals = Rc<RefCell<Vec<(u32, Result<Vec<u8>, String>)>>>;

struct App {
    url: String,
    canvas: HtmlCanvasElement,
    /// The scene and its geometry on the page's device: both live as long
    /// as the page.
    reader: &'static SceneReader<Sparse>,
    runtime: &'static Runtime<'static>,
    sparse: Sparse,
    /// The schedule for the canvas's size and the mode, rebuilt when
    /// either changes (streamed geometry stays with the runtime).
    schedule: Option<(ScheduleKey, Stepped<'static>)>,
    /// Options resolved per size and mode, kept for the page's life (the
    /// schedule's stages borrow them).
    options: HashMap<ScheduleKey, &'static SteppedOptions>,
    presenter: PagePresenter,
    /// LODs being fetched, and those whose fetch or read failed (never
    /// asked for again).
    fetching: HashSet<u32>,
    failed: HashSet<u32>,
    arrivals: Arrivals,
    fly: FlyController,
    held: HashSet<Movement>,
    /// Pointers down on the canvas: one looks around, two pinch to fly.
    pointers: Pointers,
    review: review::Review,
    mode: Mode,
    pixel_error: f64,
    /// How many occluder triangles OR draws (`?occluders=`).
    occluders: OccluderBudget,
    hud: bool,
    /// What the shown image adds (the viewer's E, F2 and F3), and x-ray:
    /// hidden objects drawn as faint ghosts (F4).
    look: Look,
    xray: bool,
    near: f64,
    /// The measurement (M), in `?units=` (metres by default), and the
    /// camera path being recorded (R) since `record_start` (ms).
    measure: Measure,
    units: Units,
    recorder: PathRecorder,
    record_start: f64,
    /// P: the next frame drawn is offered as a PNG.
    screenshot: bool,
    /// A camera path's poses (`load_path`), and the pose shown exactly
    /// (one of them, `show_pose`, or a link's) until the mouse or a key
    /// moves the camera.
    path: Vec<gigawalk_scene::path::Pose>,
    shown: Option<gigawalk_scene::path::Pose>,
    /// Frames drawn.
    frame: u64,
    last_ms: f64,
    /// When the last frame was drawn (the HUD's frame rate).
    last_drawn_ms: f64,
    started_ms: f64,
}

/// What a schedule is built for: the canvas's size and the mode.
type ScheduleKey = (u32, u32, Mode);

/// Shows the schedule's frames on the canvas with the HUD's lines.
struct PagePresenter {
    surface: WindowSurface,
    text: Vec<OverlayText>,
    /// The measurement, projected with each frame's own camera, and the
    /// units its label is in.
    measure: Measure,
    units: Units,
}

impl Presenter for PagePresenter {
    fn present(
        &mut self,
        ctx: &GpuContext,
        pass: &VisiblePass,
        report: &FrameReport,
    ) -> Result<(), gigawalk_gpu::GpuError> {
        let mut overlay = OverlayFrame {
            view_proj: report.camera.view_projection_rel(),
            text: std::mem::take(&mut self.text),
            ..OverlayFrame::default()
        };
        let marks = self.measure.on_screen(&report.camera, pass.size());
        let label = self.measure.label(&self.units).map(|l| hud_text(&l));
        overlay.push_measurement(&marks.markers, marks.segment, label, pass.size(), 1);
        self.surface
            .present(ctx, pass, &overlay, pass.size(), false)
            .map(|_| ())
    }
}

impl App {
    fn size(&self) -> (u32, u32) {
        (self.canvas.width().max(1), self.canvas.height().max(1))
    }

    /// A point on the canvas in CSS pixels, in the canvas's own pixels
    /// (what the image and a pick count in).
    fn canvas_point(&self, (x, y): (f64, f64)) -> (f64, f64) {
        let (w, h) = self.size();
        let cw = self.canvas.client_width().max(1) as f64;
        let ch = self.canvas.client_height().max(1) as f64;
        (x * w as f64 / cw, y * h as f64 / ch)
    }

    /// The camera shown now: a path's pose, or the fly controller's.
    fn camera(&self) -> Camera {
        let (w, h) = self.size();
        match &self.shown {
            Some(p) => Camera::of_pose(p, Viewport::new(w, h), self.near),
            None => self.fly.camera(w as f64 / h as f64, self.near),
        }
    }

    /// The schedule for the canvas's size and the mode, built if either
    /// changed.
    fn schedule(&mut self) -> Result<&mut Stepped<'static>, String> {
        let (w, h) = self.size();
        let key = (w, h, self.mode);
        if self.schedule.as_ref().is_none_or(|(k, _)| *k != key) {
            let opts = match self.options.get(&key) {
                Some(o) => *o,
                None => {
                    let o = RuntimeOptions {
                        width: w,
                        height: h,
                        occluder_budget: self.occluders,
                        traversal: self.mode.traversal(self.pixel_error),
                        ..RuntimeOptions::default()
                    };
                    let o = self
                        .runtime
                        .stepped_options(&o)
                        .map_err(|e| e.to_string())?;
                    let o: &'static SteppedOptions = Box::leak(Box::new(o));
                    self.options.insert(key, o);
                    o
                }
            };
            self.schedule = None;
            let stepped = self.runtime.stepped(opts).map_err(|e| e.to_string())?;
            self.schedule = Some((key, stepped));
        }
        Ok(&mut self.schedule.as_mut().expect("built above").1)
    }

    /// Takes what fetches brought: each LOD's blob put in the sparse view
    /// while the schedule reads it (checksum checked) for the device.
    fn take_arrivals(&mut self) -> Result<(), String> {
        let arrived: Vec<_> = self.arrivals.borrow_mut().drain(..).collect();
        let t0 = now_ms();
        let mut bytes = 0;
        for (lod, result) in arrived {
            self.fetching.remove(&lod);
            let info = self.reader.skeleton().lods()[lod as usize];
            let range = info.offset..info.offset + info.len;
            let sparse = self.sparse.clone();
            let loaded = match result {
                Err(e) => Err(e),
                Ok(blob) => match sparse.insert(range.start, blob) {
                    Err(e) => Err(e),
                    Ok(()) => {
                        bytes += info.len;
                        let r = self.schedule()?.load(lod).map_err(|e| e.to_string());
                        sparse.forget(range);
                        r
                    }
                },
            };
            if let Err(e) = loaded {
                web_sys::console::warn_1(&format!("LOD {lod}: {e}").into());
                self.failed.insert(lod);
                set_stats(|s| {
                    s.failed_lods += 1;
                    s.lod_error = Some(format!("LOD {lod}: {e}"));
                });
            }
        }
        let ms = now_ms() - t0;
        set_stats(|s| {
            s.loaded_bytes += bytes;
            s.load_ms += ms;
        });
        Ok(())
    }

    /// Fetches `lods` in as few range requests as [`batches`] makes.
    fn fetch(&mut self, lods: &[u32]) {
        let all = self.reader.skeleton().lods();
        let wanted: Vec<(u32, Range<u64>)> = lods
            .iter()
            .filter(|l| !self.failed.contains(l) && self.fetching.insert(**l))
            .map(|&l| {
                let i = all[l as usize];
                (l, i.offset..i.offset + i.len)
            })
            .collect();
        for Batch { range, lods } in batches(&wanted) {
            let url = self.url.clone();
            let arrivals = self.arrivals.clone();
            let blobs: Vec<(u32, Range<u64>)> = lods
                .iter()
                .map(|&l| {
                    let i = all[l as usize];
                    (l, i.offset - range.start..i.offset - range.start + i.len)
                })
                .collect();
            let asked: u64 = blobs.iter().map(|(_, r)| r.end - r.start).sum();
            set_stats(|s| {
                s.requests += 1;
                s.asked_bytes += asked;
            });
            spawn_local(async move {
                let r = fetch_range(&url, range).await.map(|(b, _)| b);
                let mut arrived = arrivals.borrow_mut();
                match r {
                    Ok(bytes) => {
                        let n = bytes.len() as u64;
                        set_stats(|s| s.fetched_bytes += n);
                        for (lod, at) in blobs {
                            let blob = bytes.get(at.start as usize..at.end as usize);
                            arrived.push((
                                lod,
                                blob.map(<[u8]>::to_vec)
                                    .ok_or_else(|| "the range came back short".to_string()),
                            ));
                        }
                    }
                    Err(e) => {
                        for (lod, _) in blobs {
                            arrived.push((lod, Err(e.clone())));
                        }
                    }
                }
            });
        }
    }

    /// One animation frame: arrivals in, the camera moved, one step of
    /// the schedule, fetches out, the stats.
    fn frame(&mut self, now: f64) -> Result<(), String> {
        let t0 = now_ms();
        set_stats(|s| s.animation_frames += 1);
        self.take_arrivals()?;
        let dt = ((now - self.last_ms) / 1e3).clamp(0.0, 0.25);
        self.last_ms = now;
        self.fly.update(dt, &self.held);
        self.refresh_visibility();
        let camera = self.camera();
        self.recorder.push((now - self.record_start) / 1e3, &camera);
        let request = CameraRequest {
            look: self.look,
            ghosts: self.review.ghosts.clone().filter(|_| self.xray),
            pixel_error: Some(self.pixel_error),
            visibility: self.review.visibility.clone(),
            section: self.review.sections.current(),
            ..CameraRequest::new(camera, false)
        };
        self.presenter.measure = self.measure;
        let (w, _) = self.size();
        self.presenter.text = if self.hud {
            self.hud_text(w)
        } else {
            Vec::new()
        };
        self.schedule()?;
        let (_, stepped) = self.schedule.as_mut().expect("built above");
        let report = stepped
            .step(request, &mut self.presenter)
            .map_err(|e| e.to_string())?;
        let room = MAX_IN_FLIGHT.saturating_sub(self.fetching.len());
        let wanted = match room {
            0 => Vec::new(),
            n => self.schedule()?.wanted(n),
        };
        self.fetch(&wanted);
        match report {
            None => set_stats(|s| s.hzb_waits += 1),
            Some(r) => {
                self.drawn(&r, now);
                if std::mem::take(&mut self.screenshot) {
                    self.offer_screenshot();
                }
            }
        }
        let cpu_ms = now_ms() - t0;
        set_stats(|s| s.cpu_ms = cpu_ms);
        Ok(())
    }

    /// A frame drawn: its figures in the stats.
    fn drawn(&mut self, r: &FrameReport, now: f64) {
        self.frame += 1;
        let first = self.frame == 1;
        let selected = self.review.objects.selection().and_then(|sel| {
            let t = self.review.objects.table().ok()?;
            t.object(sel.object).map(|o| o.full_path())
        });
        let section = self.review.sections.hud_line();
        let since_start = now - self.started_ms;
        let drawn_dt = (now - self.last_drawn_ms) / 1e3;
        self.last_drawn_ms = now;
        let in_flight = self.fetching.len();
        let mode = self.mode;
        let pixel_error = self.pixel_error;
        let look = self.look.describe();
        let measured = self.measure.distance();
        let recording = self
            .recorder
            .is_recording()
            .then(|| self.recorder.pose_count());
        set_stats(|s| {
            s.state = "running".into();
            s.frames = self.frame;
            // Frames drawn, not animation frames: one that waits for
            // OR's read-back presents nothing.
            let fps = if drawn_dt > 0.0 { 1.0 / drawn_dt } else { 0.0 };
            s.fps = if s.fps == 0.0 {
                fps
            } else {
                0.9 * s.fps + 0.1 * fps
            };
            let st = &r.streaming;
            s.triangles = r.stats.drawn_triangles;
            s.draws = r.stats.drawn_nodes as usize;
            s.stand_ins = st.substituted as usize;
            s.missing = st.missing as usize;
            s.visited = r.stats.visited;
            s.occlusion_culled = r.stats.occlusion_culled;
            s.occlusion_used = r.occlusion_used;
            s.occluders = r.occluder_items;
            s.occluder_triangles = r.occluder_triangles;
            s.hzb_level = r.hzb_level;
            s.hzb_latency_ms = r.latency_ms();
            s.resident_bytes = st.resident_bytes;
            s.in_flight = in_flight;
            s.traversal_ms = r.traversal_ms;
            // An occlusion mode has settled only on a culled frame.
            s.settled = st.missing == 0
                && st.substituted == 0
                && in_flight == 0
                && (r.occlusion_used || !mode.occlusion());
            s.mode = mode.name().into();
            s.look = look;
            s.measured = measured;
            s.recording = recording;
            s.pixel_error = pixel_error;
            s.selected = selected;
            s.section = section;
            if first {
                s.first_frame_ms = Some(since_start);
                s.first_frame_fetched = s.fetched_bytes;
            }
        });
    }

    fn hud_text(&self, width: u32) -> Vec<OverlayText> {
        let lines = STATS.with(|s| {
            let s = s.borrow();
            vec![
                format!("gigawalk  {}  {}", s.backend, s.mode),
                format!(
                    "{:.0} fps  {} triangles  {} draws",
                    s.fps, s.triangles, s.draws
                ),
                format!(
                    "fetched {:.1} of {:.1} MB in {} requests",
                    s.fetched_bytes as f64 / 1e6,
                    s.file_bytes as f64 / 1e6,
                    s.requests
                ),
                format!(
                    "resident {:.1} MB  waiting {}  stand-ins {}",
                    s.resident_bytes as f64 / 1e6,
                    s.missing,
                    s.stand_ins
                ),
                format!(
                    "culled by occlusion {}  occluders {} ({} triangles)",
                    s.occlusion_culled, s.occluders, s.occluder_triangles
                ),
                format!(
                    "pixel error {}  (O: occlusion, L: HLOD, -/+: error, Tab: HUD)",
                    s.pixel_error
                ),
                format!(
                    "look: {}  x-ray {}  (E edges, F2 AO, F3 FXAA, F4 x-ray)",
                    self.look.describe(),
                    if self.xray { "on" } else { "off" }
                ),
            ]
            .into_iter()
            .chain(
                s.lod_error
                    .iter()
                    .map(|e| format!("{} LODs failed; last {e}", s.failed_lods)),
            )
            .collect::<Vec<_>>()
        });
        let review = &self.review;
        let lines = lines
            .into_iter()
            .chain(review.objects.hud_lines())
            .chain(review.sections.hud_line())
            .chain(self.measure.hud_line(&self.units))
            .chain(
                self.recorder
                    .is_recording()
                    .then(|| format!("recording: {} poses (R stops)", self.recorder.pose_count())),
            )
            .chain(review.message().map(gigawalk_review::objects::hud_text))
            .collect();
        vec![OverlayText {
            x: 8.0,
            y: 8.0,
            scale: if width >= 1600 { 2 } else { 1 },
            lines,
            colour: [1.0, 1.0, 1.0, 1.0],
            background: [0.0, 0.0, 0.0, 0.55],
        }]
    }

    /// P: the canvas as just drawn (the HUD and measurement included, as
    /// the viewer's screenshot), as a PNG download. Taken in the task that
    /// drew it, while the canvas still holds the frame.
    fn offer_screenshot(&self) {
        let f = Closure::once_into_js(|blob: Option<Blob>| {
            let r = blob
                .ok_or_else(|| "the canvas gave no image".to_string())
                .and_then(|b| download(&b, "gigawalk-view.png"));
            if let Err(e) = r {
                web_sys::console::warn_1(&format!("screenshot: {e}").into());
            }
        });
        if let Err(e) = self.canvas.to_blob(f.unchecked_ref()) {
            web_sys::console::warn_1(&format!("screenshot: {}", js_err(e)).into());
        }
    }

    /// Leaves a shown pose for the fly controller, at that pose.
    fn leave_pose(&mut self) {
        if let Some(p) = self.shown.take() {
            self.fly.set_pose(p.position, p.orientation, p.fovy);
        }
    }

    /// A key (`KeyboardEvent.code`) went down or up, looked up in the
    /// viewer's table; whether the page used it.
    fn key(&mut self, code: &str, down: bool, app: &Rc<RefCell<App>>) -> bool {
        let action = match keys::lookup(code) {
            Some(Does::Move(m)) => {
                self.leave_pose();
                if down {
                    self.held.insert(*m);
                } else {
                    self.held.remove(m);
                }
                return true;
            }
            Some(Does::Act(a)) if down => *a,
            _ => return false,
        };
        match action {
            Action::ToggleOcclusion => {
                self.mode = Mode::of(!self.mode.occlusion(), self.mode.hlod())
            }
            Action::ToggleHlod => self.mode = Mode::of(self.mode.occlusion(), !self.mode.hlod()),
            Action::PixelErrorDown => self.pixel_error = step_pixel_error(self.pixel_error, false),
            Action::PixelErrorUp => self.pixel_error = step_pixel_error(self.pixel_error, true),
            Action::ToggleHud => self.hud = !self.hud,
            Action::ToggleWalk => self.fly.toggle_walk(),
            Action::ToggleEdges => self.look.edges = !self.look.edges,
            Action::ToggleAmbientOcclusion => self.look.ao = !self.look.ao,
            Action::ToggleAntialiasing => {
                self.look.aa = match self.look.aa {
                    Antialias::Off => Antialias::Fxaa,
                    Antialias::Fxaa => Antialias::Off,
                }
            }
            Action::ToggleXray => self.xray = !self.xray,
            _ => return self.review_key(action, app),
        }
        true
    }
}

thread_local! {
    /// The running page, for the calls below.
    static APP: RefCell<Option<Rc<RefCell<App>>>> = const { RefCell::new(None) };
}

/// The running page, for calls that outlive one borrow of it (they await).
fn running_app() -> Result<Rc<RefCell<App>>, JsValue> {
    APP.with(|a| a.borrow().clone())
        .ok_or_else(|| JsValue::from_str("the page has not started"))
}

fn with_app<T>(f: impl FnOnce(&mut App) -> Result<T, String>) -> Result<T, JsValue> {
    f(&mut running_app()?.borrow_mut()).map_err(|e| JsValue::from_str(&e))
}

/// Loads a camera path (docs/path-format.md, as text); returns its
/// number of poses.
#[wasm_bindgen]
pub fn load_path(text: &str) -> Result<u32, JsValue> {
    let path = gigawalk_scene::path::CameraPath::parse(text)
        .map_err(|e| JsValue::from_str(&format!("the camera path: {e}")))?;
    with_app(|app| {
        app.path = path.poses;
        app.shown = None;
        Ok(app.path.len() as u32)
    })
}

/// Shows pose `i` of the loaded path, exactly (roll included).
#[wasm_bindgen]
pub fn show_pose(i: u32) -> Result<(), JsValue> {
    with_app(|app| {
        if i as usize >= app.path.len() {
            return Err(format!("pose {i} of a path of {}", app.path.len()));
        }
        app.shown = Some(app.path[i as usize]);
        Ok(())
    })
}

/// Sets what traversal culls and draws, as replay's modes: "vfc"
/// (frustum culling, full detail), "hlod" (and levels of detail at the
/// pixel error), "occ" (frustum and occlusion culling, full detail) or
/// "och" (all three).
#[wasm_bindgen]
pub fn set_mode(mode: &str) -> Result<(), JsValue> {
    with_app(|app| {
        app.mode = mode.parse()?;
        Ok(())
    })
}

/// Sets the pixel error hlod selects levels by (positive, finite).
#[wasm_bindgen]
pub fn set_pixel_error(pixel_error: f64) -> Result<(), JsValue> {
    with_app(|app| {
        if !(pixel_error.is_finite() && pixel_error > 0.0) {
            return Err(format!("pixel error {pixel_error}: a positive number"));
        }
        app.pixel_error = pixel_error;
        Ok(())
    })
}

/// Shows or hides the HUD (tests compare images without it).
#[wasm_bindgen]
pub fn set_hud(on: bool) -> Result<(), JsValue> {
    with_app(|app| {
        app.hud = on;
        Ok(())
    })
}

/// What is under canvas pixel `(x, y)` (its centre) of the camera shown
/// now, as `gigawalk pick --json` says it: `object` (null when nothing
/// is there; else its index `id`, `name`, `file`, `path` and
/// `metadata`), `point` and `distance`. Hidden objects and what the
/// section cuts away are skipped. Selects nothing.
#[wasm_bindgen]
pub async fn pick(x: f64, y: f64) -> Result<String, JsValue> {
    let app = running_app()?;
    review::ask_for_table(&app);
    let hit = review::pick_at(&app, (x, y))
        .await
        .map_err(|e| JsValue::from_str(&e))?;
    let a = app.borrow();
    let object = hit.and_then(|h| h.object).and_then(|o| {
        let r = a.review.objects.table().ok()?.object(o)?;
        Some(gigawalk_review::objects::object_json(o, r))
    });
    Ok(serde_json::json!({
        "object": object,
        "point": hit.map(|h| h.point.to_array()),
        "distance": hit.map(|h| h.distance),
    })
    .to_string())
}

/// The last frame drawn, as RVG made it (before the HUD): `{width,
/// height, colour, depth}`, colour as 8-bit sRGB RGBA rows from the top
/// and depth as reversed-Z floats (1 at the near plane, 0 where nothing
/// was drawn), what replay's accuracy measures compare. Read without
/// blocking the page.
#[wasm_bindgen]
pub async fn read_frame() -> Result<js_sys::Object, JsValue> {
    let app = running_app()?;
    let mut pending = {
        let a = &mut *app.borrow_mut();
        a.schedule()
            .map_err(|e| JsValue::from_str(&e))?
            .submit_read_back()
            .ok_or_else(|| JsValue::from_str("no frame to read back"))?
    };
    let frame = loop {
        next_task().await;
        let taken = {
            let a = &mut *app.borrow_mut();
            a.schedule()
                .map_err(|e| JsValue::from_str(&e))?
                .try_take_frame(pending)
        };
        match taken {
            Ok(frame) => break frame.map_err(|e| JsValue::from_str(&e.to_string()))?,
            Err(p) => pending = p,
        }
    };
    let out = js_sys::Object::new();
    let set = |k: &str, v: &JsValue| js_sys::Reflect::set(&out, &k.into(), v);
    set("width", &frame.depth.width.into())?;
    set("height", &frame.depth.height.into())?;
    set(
        "colour",
        &js_sys::Uint8Array::from(&frame.colour[..]).into(),
    )?;
    set(
        "depth",
        &js_sys::Float32Array::from(&frame.depth.depth[..]).into(),
    )?;
    Ok(out)
}

/// Resolves after the page's other tasks have had a turn (a few ms).
async fn next_task() {
    let p = js_sys::Promise::new(&mut |resolve, _| {
        if let Some(w) = web_sys::window() {
            let _ = w.set_timeout_with_callback_and_timeout_and_arguments_0(&resolve, 4);
        }
    });
    let _ = JsFuture::from(p).await;
}

/// A click at canvas pixel `(x, y)`, as with the mouse: selects the
/// object there (or clears the selection).
#[wasm_bindgen]
pub async fn click(x: f64, y: f64) -> Result<(), JsValue> {
    review::click(running_app()?, (x, y)).await;
    Ok(())
}

/// Finds objects by name or path (`*` and `?` wildcards), as `/` does:
/// selects and frames the first match; the same text again, the next.
#[wasm_bindgen]
pub fn find(text: &str) -> Result<(), JsValue> {
    with_app(|app| {
        let found = app.review.objects.find(text);
        app.after_find(found);
        Ok(())
    })
}

/// This view (camera, selection, hidden objects, section) as a link:
/// the page's address with `#view=`.
#[wasm_bindgen]
pub fn view_link() -> Result<String, JsValue> {
    with_app(|app| app.view_link())
}

/// This view as a saved view's JSON (docs/views-format.md).
#[wasm_bindgen]
pub fn view_json() -> Result<String, JsValue> {
    with_app(|app| serde_json::to_string(&app.saved_view()).map_err(|e| e.to_string()))
}

/// Shows the view a link's `#view=` text holds (the page does this for
/// its own address when it starts).
#[wasm_bindgen]
pub fn show_view(text: &str) -> Result<(), JsValue> {
    let view = gigawalk_review::link::decode(text).map_err(|e| JsValue::from_str(&e))?;
    with_app(|app| app.restore_view(view))
}

/// Shows `message` as the page's error (and in the stats).
fn fail(message: String) -> JsValue {
    web_sys::console::error_1(&message.clone().into());
    set_stats(|s| {
        s.state = "error".into();
        s.error = Some(message.clone());
    });
    JsValue::from_str(&message)
}

/// Starts the page on `canvas` with the scene at `scene_url`; resolves
/// once the first frame is scheduled, rejects with a message a person can
/// act on (no WebGPU, no scene, a server without range requests, a file
/// that is not a scene).
#[wasm_bindgen]
pub async fn start(canvas: HtmlCanvasElement, scene_url: String) -> Result<(), JsValue> {
    let started_ms = now_ms();
    set_stats(|s| s.state = "opening".into());
    let has_webgpu = web_sys::window().is_some_and(|w| {
        js_sys::Reflect::get(&w.navigator(), &"gpu".into()).is_ok_and(|g| !g.is_undefined())
    });
    let (ctx, surface) = gigawalk_gpu::open_device_for_canvas(canvas.clone(), has_webgpu)
        .await
        .map_err(|e| {
            fail(format!(
                "this browser can run neither WebGPU nor WebGL2 here: {e}. Use a current \
                 Chrome, Edge, Firefox or Safari, with hardware acceleration on"
            ))
        })?;
    let (reader, sparse, fetched, requests) = open_scene(&scene_url).await.map_err(fail)?;
    let bounds = reader.skeleton().bounds();
    let budget_mb = match query("budget") {
        None => DEFAULT_BUDGET_MB as f64,
        Some(v) => v
            .parse::<f64>()
            .ok()
            .filter(|b| b.is_finite() && *b > 0.0)
            .ok_or_else(|| fail(format!("?budget={v}: megabytes, a positive number")))?,
    };
    let budget = (budget_mb * (1u64 << 20) as f64) as u64;
    let pixel_error = match query("pixel_error") {
        None => 1.0,
        Some(v) => v
            .parse::<f64>()
            .ok()
            .filter(|p| p.is_finite() && *p > 0.0)
            .ok_or_else(|| fail(format!("?pixel_error={v}: pixels, a positive number")))?,
    };
    // The viewer's look for this device (`Look::auto`: on a CPU
    // rasterizer such as SwiftShader, edges and the sky without AO and
    // FXAA), or plain (`?look=plain`, what the tests compare).
    let look = match query("look").as_deref() {
        None | Some("auto") => Look::auto(ctx.is_cpu()),
        Some("plain") => Look::PLAIN,
        Some(v) => return Err(fail(format!("?look={v}: auto or plain"))),
    };
    let occluders = match query("occluders") {
        None => OccluderBudget::All,
        Some(v) => v
            .parse::<OccluderBudget>()
            .map_err(|e| fail(format!("?occluders={v}: {e}")))?,
    };
    let units = match query("units") {
        None => Units::default(),
        Some(v) => v
            .parse::<Units>()
            .map_err(|e| fail(format!("?units={v}: {e}")))?,
    };
    set_stats(|s| {
        let api = if ctx.is_gl() { "WebGL2" } else { "WebGPU" };
        s.backend = match ctx.adapter_name() {
            "" => api.to_string(),
            name => format!("{api} ({name})"),
        };
        s.cpu_rasterizer = ctx.is_cpu();
        s.file_bytes = sparse.len();
        s.fetched_bytes = fetched;
        s.requests = requests;
    });
    // The scene lives as long as the page; so does its runtime.
    let reader: &'static SceneReader<Sparse> = Box::leak(reader);
    let runtime = Runtime::streamed(reader, vec![ctx], budget, PINNED_BYTES)
        .map_err(|e| fail(format!("the scene's geometry: {e}")))?;
    let runtime: &'static Runtime<'static> = Box::leak(Box::new(runtime));
    let app = App {
        url: scene_url,
        canvas: canvas.clone(),
        reader,
        runtime,
        sparse,
        schedule: None,
        options: HashMap::new(),
        presenter: PagePresenter {
            surface,
            text: Vec::new(),
            measure: Measure::Off,
            units,
        },
        fetching: HashSet::new(),
        failed: HashSet::new(),
        arrivals: Rc::new(RefCell::new(Vec::new())),
        fly: FlyController::overview(&bounds, FOVY_DEGREES.to_radians()),
        held: HashSet::new(),
        pointers: Pointers::default(),
        review: review::Review::new(),
        mode: Mode::Och,
        occluders,
        look,
        xray: false,
        pixel_error,
        hud: true,
        near: default_near(&bounds),
        measure: Measure::Off,
        units,
        recorder: PathRecorder::default(),
        record_start: 0.0,
        screenshot: false,
        path: Vec::new(),
        shown: None,
        frame: 0,
        last_ms: now_ms(),
        last_drawn_ms: now_ms(),
        started_ms,
    };
    let app = Rc::new(RefCell::new(app));
    APP.with(|a| *a.borrow_mut() = Some(app.clone()));
    // A shared link's view: shown from the first frame; a bad one is
    // said and the page starts at the overview.
    let fragment = web_sys::window()
        .and_then(|w| w.location().hash().ok())
        .unwrap_or_default();
    if let Some(view) = gigawalk_review::link::from_fragment(&fragment) {
        let mut a = app.borrow_mut();
        if let Err(e) = view.and_then(|v| a.restore_view(v)) {
            a.review.say(format!("{e}; showing the overview"));
        }
    }
    listen(&canvas, app.clone())?;
    run_frames(app);
    Ok(())
}

/// Offers `blob` as a download named `name`, as a link the user clicked
/// would (the browser numbers repeated names).
fn download(blob: &Blob, name: &str) -> Result<(), String> {
    let document = web_sys::window()
        .and_then(|w| w.document())
        .ok_or("no document")?;
    let url = web_sys::Url::create_object_url_with_blob(blob).map_err(js_err)?;
    let a: HtmlAnchorElement = document
        .create_element("a")
        .map_err(js_err)?
        .unchecked_into();
    a.set_href(&url);
    a.set_download(name);
    a.click();
    set_stats(|s| s.downloads.push(name.to_string()));
    // The browser has the blob once the click is handled; the URL goes
    // after that.
    let revoke = Closure::once_into_js(move || {
        let _ = web_sys::Url::revoke_object_url(&url);
    });
    if let Some(w) = web_sys::window() {
        let _ =
            w.set_timeout_with_callback_and_timeout_and_arguments_0(revoke.unchecked_ref(), 60_000);
    }
    Ok(())
}

/// Where a pointer event is on the canvas, in CSS pixels.
fn css_point(e: &PointerEvent) -> (f64, f64) {
    (e.offset_x() as f64, e.offset_y() as f64)
}

/// Keys on the window; pointers (mouse, pen, touch) and the wheel on the
/// canvas: drag looks around, a click picks, two fingers pinch to fly.
fn listen(canvas: &HtmlCanvasElement, app: Rc<RefCell<App>>) -> Result<(), JsValue> {
    let window = web_sys::window().ok_or("no window")?;
    for down in [true, false] {
        let a = app.clone();
        let f = Closure::<dyn FnMut(KeyboardEvent)>::new(move |e: KeyboardEvent| {
            // The browser's own shortcuts (Ctrl+L, Cmd+R, Alt+arrows)
            // stay the browser's; Ctrl alone is the viewer's "down".
            let code = e.code();
            let modified = e.meta_key() || e.alt_key() || (e.ctrl_key() && code != "ControlLeft");
            // F12 opens the browser's developer tools (P screenshots).
            if (down && modified) || code == "F12" {
                return;
            }
            let used = {
                let mut app = a.borrow_mut();
                app.key(&code, down, &a)
            };
            if used {
                e.prevent_default();
            }
        });
        let name = if down { "keydown" } else { "keyup" };
        window.add_event_listener_with_callback(name, f.as_ref().unchecked_ref())?;
        f.forget();
    }
    let a = app.clone();
    let c = canvas.clone();
    let f = Closure::<dyn FnMut(PointerEvent)>::new(move |e: PointerEvent| {
        let _ = c.set_pointer_capture(e.pointer_id());
        let _ = c.focus();
        let p = css_point(&e);
        let mut app = a.borrow_mut();
        app.review.cursor = app.canvas_point(p);
        app.pointers.press(e.pointer_id(), p);
    });
    canvas.add_event_listener_with_callback("pointerdown", f.as_ref().unchecked_ref())?;
    f.forget();
    let a = app.clone();
    let f = Closure::<dyn FnMut(PointerEvent)>::new(move |e: PointerEvent| {
        let p = css_point(&e);
        let mut app = a.borrow_mut();
        app.review.cursor = app.canvas_point(p);
        match app.pointers.moved(e.pointer_id(), p) {
            Gesture::Look(dx, dy) => {
                app.leave_pose();
                app.fly.look(dx, dy);
            }
            Gesture::Fly(seconds) => {
                app.leave_pose();
                let forward = app.fly.orientation() * glam::DVec3::NEG_Z;
                let step = app.fly.speed * seconds;
                app.fly.position += forward * step;
            }
            Gesture::None => {}
        }
    });
    canvas.add_event_listener_with_callback("pointermove", f.as_ref().unchecked_ref())?;
    f.forget();
    for name in ["pointerup", "pointercancel"] {
        let a = app.clone();
        let f = Closure::<dyn FnMut(PointerEvent)>::new(move |e: PointerEvent| {
            let id = e.pointer_id();
            let click = {
                let mut app = a.borrow_mut();
                let released = e.type_() == "pointerup" && e.button() == 0;
                app.pointers
                    .release(id, released)
                    .then(|| app.canvas_point(css_point(&e)))
            };
            if let Some(at) = click {
                spawn_local(review::click(a.clone(), at));
            }
        });
        canvas.add_event_listener_with_callback(name, f.as_ref().unchecked_ref())?;
        f.forget();
    }
    let a = app;
    let f = Closure::<dyn FnMut(WheelEvent)>::new(move |e: WheelEvent| {
        e.prevent_default();
        a.borrow_mut().fly.scroll(-e.delta_y().signum());
    });
    canvas.add_event_listener_with_callback("wheel", f.as_ref().unchecked_ref())?;
    f.forget();
    Ok(())
}

/// Runs [`App::frame`] on every animation frame until one fails.
fn run_frames(app: Rc<RefCell<App>>) {
    type Tick = Rc<RefCell<Option<Closure<dyn FnMut(f64)>>>>;
    let tick: Tick = Rc::new(RefCell::new(None));
    let next = tick.clone();
    *tick.borrow_mut() = Some(Closure::new(move |now: f64| {
        if let Err(e) = app.borrow_mut().frame(now) {
            fail(e);
            return;
        }
        // The object table (pick, find, hide, a link's objects) comes
        // after the first frame: it never delays it.
        if app.borrow().frame >= 1 {
            review::ask_for_table(&app);
        }
        request_frame(next.borrow().as_ref().expect("set below"));
    }));
    request_frame(tick.borrow().as_ref().expect("just set"));
}

fn request_frame(f: &Closure<dyn FnMut(f64)>) {
    if let Some(w) = web_sys::window() {
        let _ = w.request_animation_frame(f.as_ref().unchecked_ref());
    }
}
