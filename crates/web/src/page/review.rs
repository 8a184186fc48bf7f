//! The page's review tools, the native viewer's keys and state
//! (`gigawalk_review`): click to pick an object (name, file, path,
//! metadata), `/` to find objects by name or path, `H` hide, `I`
//! isolate, `U` show all, `F` frame the selection, section planes at the
//! cursor (`X`, moved with `]` and `[`, flipped with `\`), a section box
//! (`J`), sections on and off (`0`) and cleared (`Delete`), and `V`: the
//! view (camera, selection, hidden objects, section) as a link in the
//! address bar ([`gigawalk_review::link`]); `M` and two clicks measure
//! a distance on full detail, `P` offers a screenshot and `R` records
//! the camera as a path, both as downloads.
//!
//! What a pick or the object table needs from the scene is fetched on
//! demand: the reader tries, a read of bytes not fetched yet names its
//! range ([`Sparse`]), the page fetches exactly that range and tries
//! again. A pick reads the full detail of the few leaves along its ray,
//! as native pick does, whatever LODs are resident; those bytes are
//! dropped after.

use std::sync::Arc;

use gigawalk_cull::{NodeShow, PickHit, Visibility};
use gigawalk_review::actions::act;
use gigawalk_review::objects::{frame_box, Objects, NO_IDENTITY};
use gigawalk_review::sections::box_in_view;
use gigawalk_scene::views::SavedView;

use super::*;

/// At most this many range requests for one read (a pick reads the
/// leaves along its ray, one request each): a bound on a scene whose
/// reads never complete.
const MAX_ROUNDS: usize = 4096;

/// How long a message stays in the HUD (milliseconds).
const MESSAGE_MS: f64 = 6000.0;

/// The page's review state: the selection, search and hidden objects
/// (the viewer's `Objects`), the sections, what they make of traversal's
/// view, and what the HUD says.
pub(super) struct Review {
    pub objects: Objects,
    pub sections: Sections,
    /// Hidden objects and the highlighted selection, as traversal and the
    /// passes see them; rebuilt when `objects` changes.
    pub visibility: Option<Arc<Visibility>>,
    /// X-ray's ghosts of the hidden objects, rebuilt with `visibility`.
    pub ghosts: Option<Arc<Visibility>>,
    /// Whether the object table has been asked for.
    pub table_asked: bool,
    /// A link's view whose objects wait for the table.
    pub pending: Option<SavedView>,
    /// The last thing said, and when (ms).
    pub message: Option<(String, f64)>,
    /// The pointer's last place on the canvas, in canvas pixels.
    pub cursor: (f64, f64),
}

impl Review {
    pub fn new() -> Review {
        Review {
            objects: Objects::new(Err("the object table is still loading".into())),
            sections: Sections::default(),
            visibility: None,
            ghosts: None,
            table_asked: false,
            pending: None,
            message: None,
            cursor: (0.0, 0.0),
        }
    }

    pub fn say(&mut self, text: String) {
        web_sys::console::log_1(&text.clone().into());
        set_stats(|s| s.message = Some(text.clone()));
        self.message = Some((text, now_ms()));
    }

    /// Says what an action came to, done or refused.
    pub fn say_either(&mut self, r: Result<String, String>) {
        let (Ok(m) | Err(m)) = r;
        self.say(m);
    }

    /// The message while it is fresh.
    pub fn message(&self) -> Option<&str> {
        self.message
            .as_ref()
            .filter(|(_, at)| now_ms() - at < MESSAGE_MS)
            .map(|(m, _)| m.as_str())
    }
}

/// Runs `read` on the page's scene, fetching each range it misses first
/// and trying again; the fetched bytes are dropped after.
async fn with_fetched<T>(
    app: &Rc<RefCell<App>>,
    what: &str,
    read: impl Fn(&App) -> Result<T, String>,
) -> Result<T, String> {
    let mut held: Vec<Range<u64>> = Vec::new();
    let result = loop {
        let (r, missing, url) = {
            let a = app.borrow();
            a.sparse.take_missing();
            let r = read(&a);
            (r, a.sparse.take_missing(), a.url.clone())
        };
        let range = match (r, missing) {
            (Ok(v), _) => break Ok(v),
            (Err(e), None) => break Err(format!("{what}: {e}")),
            (Err(_), Some(_)) if held.len() >= MAX_ROUNDS => {
                break Err(format!("{what}: still reading after {MAX_ROUNDS} requests"))
            }
            (Err(_), Some(range)) => range,
        };
        match fetch_range(&url, range.clone()).await {
            Ok((bytes, _)) => {
                let n = bytes.len() as u64;
                set_stats(|s| {
                    s.fetched_bytes += n;
                    s.requests += 1;
                });
                if let Err(e) = app.borrow().sparse.insert(range.start, bytes) {
                    break Err(format!("{what}: {e}"));
                }
                held.push(range);
            }
            Err(e) => break Err(format!("{what}: {e}")),
        }
    };
    let a = app.borrow();
    for r in held {
        a.sparse.forget(r);
    }
    result
}

/// Fetches and reads the object table (once); then restores a link's
/// objects if one waits.
pub(super) fn ask_for_table(app: &Rc<RefCell<App>>) {
    {
        let mut a = app.borrow_mut();
        if a.review.table_asked {
            return;
        }
        a.review.table_asked = true;
    }
    let app = app.clone();
    spawn_local(async move {
        let table = with_fetched(&app, "the object table", |a| {
            a.reader.objects().map_err(|e| e.to_string())
        })
        .await;
        let mut a = app.borrow_mut();
        let table = match table {
            Ok(Some(t)) => Ok(t),
            Ok(None) => Err(NO_IDENTITY.to_string()),
            Err(e) => Err(format!(
                "object identity unreadable ({e}): pick, find and hide are off"
            )),
        };
        let objects = table.as_ref().ok().map(|t| t.objects().len());
        if let Err(why) = &table {
            web_sys::console::warn_1(&why.into());
        }
        a.review.objects = Objects::new(table);
        set_stats(|s| s.objects = objects);
        if let Some(view) = a.review.pending.take() {
            let m = a.review.objects.restore(&view);
            a.review.say(m);
        }
    });
}

impl App {
    /// Builds the visibility again if the hidden set or the selection
    /// changed (each frame does, and a pick before it casts).
    pub(super) fn refresh_visibility(&mut self) {
        if self.review.objects.take_changed() {
            self.review.visibility = self.review.objects.visibility(self.reader.skeleton());
            self.review.ghosts = self.review.objects.ghosts(self.reader.skeleton());
            let (hidden, _) = self.review.objects.hidden_count();
            set_stats(|s| s.hidden = hidden);
        }
    }

    /// The view as a saved view (what `V` puts in the link).
    pub(super) fn saved_view(&self) -> SavedView {
        let camera = self.camera();
        let pose = gigawalk_scene::path::Pose {
            time: 0.0,
            position: camera.position,
            orientation: camera.orientation,
            fovy: camera.fovy,
        };
        let mut v = self.review.objects.saved_view("link", &pose);
        v.section = self.review.sections.saved();
        v.xray = self.xray;
        v
    }

    /// Shows `view`: its camera now, its section, and its objects now or
    /// once the object table is in.
    pub(super) fn restore_view(&mut self, view: SavedView) -> Result<(), String> {
        // Shown exactly (roll included) until the mouse or a key moves it.
        self.shown = Some(view.pose()?);
        self.xray = view.xray;
        let m = self.review.sections.restore(view.section.as_ref());
        if !m.is_empty() {
            web_sys::console::log_1(&m.into());
        }
        if self.review.objects.table().is_ok() {
            let m = self.review.objects.restore(&view);
            self.review.say(m);
        } else {
            self.review.pending = Some(view);
        }
        Ok(())
    }

    /// `F`: the eye moved back along the view until the selection fits.
    fn frame_selection(&mut self) {
        let bounds = match self.review.objects.selected_bounds() {
            Ok(b) => b,
            Err(why) => return self.review.say(why),
        };
        let camera = self.camera();
        if let Some(to) = frame_box(
            &bounds,
            camera.forward(),
            camera.fovy,
            camera.aspect,
            self.near,
        ) {
            self.leave_pose();
            self.fly.set_pose(to, camera.orientation, camera.fovy);
        }
    }

    /// The review keys' actions; whether `action` was one.
    pub(super) fn review_key(&mut self, action: Action, app: &Rc<RefCell<App>>) -> bool {
        let eye = self.camera().position;
        let diagonal = self.reader.skeleton().bounds().diagonal();
        let review = &mut self.review;
        if let Some(said) = act(
            action,
            &mut review.objects,
            &mut review.sections,
            eye,
            diagonal,
        ) {
            if let Some(m) = said {
                review.say(m);
            }
            return true;
        }
        match action {
            Action::FrameSelection => self.frame_selection(),
            Action::NextMatch => {
                let found = self.review.objects.next_match();
                self.after_find(found);
            }
            Action::Search => {
                let text = web_sys::window()
                    .and_then(|w| {
                        w.prompt_with_message("find objects by name or path (* ? wildcards)")
                            .ok()
                    })
                    .flatten();
                if let Some(t) = text.filter(|t| !t.trim().is_empty()) {
                    let found = self.review.objects.find(t.trim());
                    self.after_find(found);
                }
            }
            Action::SectionPlane => spawn_local(section_plane_at(app.clone(), self.review.cursor)),
            Action::SectionBox => spawn_local(section_box(app.clone())),
            Action::SaveView => {
                let r = self.share_link();
                self.review.say_either(r);
            }
            // Esc clears a measurement, as in the viewer (a page does not
            // quit).
            Action::Measure => self.toggle_measure(),
            Action::Quit if self.measure.is_active() => self.toggle_measure(),
            Action::Screenshot => self.screenshot = true,
            Action::ToggleRecord => {
                let r = self.toggle_record();
                self.review.say_either(r);
            }
            _ => return false,
        }
        true
    }

    pub(super) fn after_find(&mut self, found: Result<u32, String>) {
        match found {
            Ok(_) => {
                if let Some(d) = self.review.objects.describe_selection() {
                    self.review.say(d);
                }
                self.frame_selection();
            }
            Err(why) => self.review.say(why),
        }
    }

    /// `M`: starts a measurement, or clears the one there is.
    fn toggle_measure(&mut self) {
        let m = self.measure.toggle();
        self.review.say(m);
    }

    /// `R`: starts recording the camera, or stops and offers the path
    /// (docs/path-format.md, what `gigawalk replay --path` reads) as a
    /// download.
    fn toggle_record(&mut self) -> Result<String, String> {
        let Some(path) = self.recorder.stop() else {
            self.recorder.start();
            self.record_start = now_ms();
            return Ok("recording the camera: R stops and saves the path".into());
        };
        if path.poses.is_empty() {
            return Err("recording stopped before a frame: no path".into());
        }
        let parts = js_sys::Array::of1(&path.to_text().into());
        let options = web_sys::BlobPropertyBag::new();
        options.set_type("text/plain");
        let blob = Blob::new_with_str_sequence_and_options(&parts, &options).map_err(js_err)?;
        download(&blob, "gigawalk-view.path")?;
        Ok(format!(
            "path of {} poses saved (a download)",
            path.poses.len()
        ))
    }

    /// `V`: the view into the address bar (`#view=`), to copy and share.
    fn share_link(&mut self) -> Result<String, String> {
        let link = self.view_link()?;
        let window = web_sys::window().ok_or("no window")?;
        window
            .history()
            .and_then(|h| h.replace_state_with_url(&JsValue::NULL, "", Some(&link)))
            .map_err(js_err)?;
        Ok("the address bar now links to this view: copy it to share".into())
    }

    /// The page's address with this view in its fragment.
    pub(super) fn view_link(&self) -> Result<String, String> {
        let window = web_sys::window().ok_or("no window")?;
        let href = window.location().href().map_err(js_err)?;
        let base = href.split('#').next().unwrap_or(&href);
        Ok(format!(
            "{base}#{}={}",
            gigawalk_review::link::KEY,
            gigawalk_review::link::encode(&self.saved_view())
        ))
    }
}

/// What is under canvas point `(x, y)` of the camera shown now: the
/// nearest full-detail surface of an object shown, within the section
/// (`None`: nothing there).
pub(super) async fn pick_at(
    app: &Rc<RefCell<App>>,
    (x, y): (f64, f64),
) -> Result<Option<PickHit>, String> {
    let (camera, viewport) = {
        let mut a = app.borrow_mut();
        a.refresh_visibility();
        let (w, h) = a.size();
        (a.camera(), Viewport::new(w, h))
    };
    // The pointer names a pixel; cast through its centre, as `gigawalk
    // pick` does.
    let (x, y) = (x.floor() + 0.5, y.floor() + 0.5);
    with_fetched(app, "pick", move |a| {
        let section = a.review.sections.current();
        let Some(ray) = camera
            .pixel_ray(viewport, x, y)
            .and_then(|r| r.clipped(section.as_deref()))
        else {
            return Ok(None);
        };
        let vis = a.review.visibility.as_deref();
        let objects = &a.review.objects;
        gigawalk_cull::pick(
            a.reader.skeleton(),
            objects.table().ok(),
            &ray,
            &|node| vis.is_some_and(|v| v.node(node) == NodeShow::Hidden),
            &|o| objects.is_hidden(o),
            &mut |lod| a.reader.read_lod(lod),
        )
        .map(|(hit, _)| hit)
        .map_err(|e| e.to_string())
    })
    .await
}

/// A click at `at`: selects the object there (nothing there: clears the
/// selection) and says what it is.
pub(super) async fn click(app: Rc<RefCell<App>>, at: (f64, f64)) {
    ask_for_table(&app);
    // A measuring click needs a surface, not the object table. (The
    // borrow ends with the `let`: saying why borrows the page mutably.)
    let measuring = app.borrow().measure.wants_click();
    let refused = app.borrow().review.objects.table().err();
    if let (false, Some(why)) = (measuring, refused) {
        app.borrow_mut().review.say(why);
        return;
    }
    let hit = pick_at(&app, at).await;
    let mut a = app.borrow_mut();
    match hit {
        Err(e) => a.review.say(e),
        Ok(hit) if measuring => {
            let units = a.units;
            let m = a.measure.click(hit.map(|h| h.point), &units);
            a.review.say(m);
        }
        Ok(hit) => {
            let had = a.review.objects.selection();
            a.review
                .objects
                .click(hit.and_then(|h| h.object.map(|o| (o, h.point))));
            if a.review.objects.selection() != had {
                let m = a
                    .review
                    .objects
                    .describe_selection()
                    .unwrap_or_else(|| "nothing selected".into());
                a.review.say(m);
            }
        }
    }
}

/// `X`: a section plane through the surface under `at`, facing the eye.
async fn section_plane_at(app: Rc<RefCell<App>>, at: (f64, f64)) {
    let hit = pick_at(&app, at).await;
    let mut a = app.borrow_mut();
    let forward = a.camera().forward();
    let r = match hit {
        Ok(Some(h)) => a.review.sections.place_plane(h.point, forward),
        Ok(None) => Err("section plane: no surface under the cursor to cut at".into()),
        Err(e) => Err(e),
    };
    a.review.say_either(r);
}

/// `J`: a section box around the selection, or around what is in view.
async fn section_box(app: Rc<RefCell<App>>) {
    let (selected, centre, camera, bounds) = {
        let a = app.borrow();
        let (w, h) = a.size();
        (
            a.review.objects.selection().is_some(),
            (w as f64 * 0.5, h as f64 * 0.5),
            a.camera(),
            a.reader.skeleton().bounds(),
        )
    };
    let diagonal = bounds.diagonal();
    let around = if selected {
        app.borrow().review.objects.selected_bounds()
    } else {
        match pick_at(&app, centre).await {
            Err(e) => Err(e),
            Ok(hit) => box_in_view(&camera, hit.map(|h| h.distance), &bounds),
        }
    };
    let mut a = app.borrow_mut();
    let r = around.and_then(|b| a.review.sections.box_around(&b, diagonal));
    a.review.say_either(r);
}
