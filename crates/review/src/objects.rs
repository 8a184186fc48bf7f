//! A reviewer's side of object identity: the selection, the search, the
//! hidden set and saved views, over the scene's object table
//! (`gigawalk_scene::objects`), and the framing of an object's box.
//!
//! Pure state and text: the frame loop (the native viewer's or the
//! page's) casts the pick ray (it reads the scene), flies the camera and
//! shows the messages these return, so all of this is unit-tested
//! without a window.

use std::sync::Arc;

use crate::select::HiddenSet;
use gigawalk_cull::Visibility;
use gigawalk_scene::objects::{ObjectRecord, ObjectTable, Pattern};
use gigawalk_scene::path::Pose;
use gigawalk_scene::views::{self, ObjectRef, SavedView, Views};
use gigawalk_scene::{Aabb, Skeleton};
use glam::DVec3;

/// What pick, find and hide say on a scene written before scenes kept
/// object identity.
pub const NO_IDENTITY: &str = "this scene records no object identity: preprocess the model again";

/// HUD lines are cut to this many characters (metadata can be long).
const HUD_LINE_CHARS: usize = 110;

/// The selected object, and where a click hit it (`None` when search or
/// a saved view selected it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Selection {
    pub object: u32,
    pub point: Option<DVec3>,
}

/// The last search: its text, the objects it matched (table order) and
/// the one shown last.
#[derive(Clone, Debug, PartialEq)]
pub struct Search {
    pub text: String,
    pub matches: Vec<u32>,
    pub current: usize,
}

/// The selection, search and hidden set of one viewer.
///
/// `H` and `I` act on the last search's matches while that search is
/// current (from its Enter until a click, a hide or a restored view),
/// else on the selection.
#[derive(Debug)]
pub struct Objects {
    /// The scene's object table, or why there is none (shown when asked).
    table: Result<ObjectTable, String>,
    selection: Option<Selection>,
    /// Objects hidden one by one (`H`) and the isolation (`I`).
    hidden: HiddenSet,
    search: Option<Search>,
    /// Objects `hidden` hides, of the table's.
    hidden_count: usize,
    /// The hidden set or the selection changed since `take_changed`.
    changed: bool,
}

impl Objects {
    /// `table`: the scene's object table, or the message to show when
    /// identity is asked for (`NO_IDENTITY`, or why the table could not
    /// be read).
    pub fn new(table: Result<ObjectTable, String>) -> Objects {
        Objects {
            table,
            selection: None,
            hidden: HiddenSet::default(),
            search: None,
            hidden_count: 0,
            changed: false,
        }
    }

    pub fn table(&self) -> Result<&ObjectTable, String> {
        self.table.as_ref().map_err(Clone::clone)
    }

    pub fn selection(&self) -> Option<Selection> {
        self.selection
    }

    pub fn search(&self) -> Option<&Search> {
        self.search.as_ref()
    }

    /// Objects hidden, of how many.
    pub fn hidden_count(&self) -> (usize, usize) {
        let n = self.table.as_ref().map_or(0, |t| t.objects().len());
        (self.hidden_count, n)
    }

    pub fn is_hidden(&self, object: u32) -> bool {
        self.hidden.is_hidden(object)
    }

    /// Whether the hidden set or the selection changed since the last
    /// call (the frame loop then builds a new [`Visibility`]).
    pub fn take_changed(&mut self) -> bool {
        std::mem::take(&mut self.changed)
    }

    /// What the passes need this frame: `None` when every object shows
    /// whole (nothing hidden, nothing selected).
    pub fn visibility(&self, skeleton: &Skeleton) -> Option<Arc<Visibility>> {
        let table = self.table.as_ref().ok()?;
        let selected = self.selection.map(|s| s.object);
        if self.hidden_count == 0 && selected.is_none() {
            return None;
        }
        let v = self.hidden.visibility(skeleton, table, selected);
        (!v.is_all()).then(|| Arc::new(v))
    }

    /// X-ray's ghosts: the hidden objects, to be drawn faint (`None`:
    /// nothing hidden, or no object table).
    pub fn ghosts(&self, skeleton: &Skeleton) -> Option<Arc<Visibility>> {
        let table = self.table.as_ref().ok()?;
        self.hidden.ghosts(skeleton, table).map(Arc::new)
    }

    /// Makes the next [`Objects::take_changed`] say so (what the passes
    /// need changed for another reason: x-ray turned on or off).
    pub fn mark_changed(&mut self) {
        self.changed = true;
    }

    /// A click: `hit` is the object under the cursor and where (`None`:
    /// nothing there, which clears the selection). Ends the current search.
    pub fn click(&mut self, hit: Option<(u32, DVec3)>) {
        let next = hit.map(|(object, point)| Selection {
            object,
            point: Some(point),
        });
        self.changed |= self.selection.map(|s| s.object) != next.map(|s| s.object);
        self.selection = next;
        self.search = None;
    }

    /// The selected object's box, for framing it.
    pub fn selected_bounds(&self) -> Result<Aabb, String> {
        let table = self.table()?;
        let s = self
            .selection
            .ok_or("F frames the selection: click an object (or / to find one) first")?;
        let o = table
            .object(s.object)
            .ok_or_else(|| format!("object {} is not in the table", s.object))?;
        if o.bounds.is_valid() && !o.bounds.is_empty() {
            Ok(o.bounds)
        } else {
            Err(format!("{}: the object has no box to frame", o.name))
        }
    }

    /// Enter in the search prompt: the first match of `text` not hidden,
    /// selected (the same text again: the next match). The error is what
    /// to show instead.
    pub fn find(&mut self, text: &str) -> Result<u32, String> {
        let table = self.table()?;
        if self.search.as_ref().is_some_and(|s| s.text == text) {
            return self.next_match();
        }
        let pattern = Pattern::new(text).map_err(|e| format!("find {text:?}: {e}"))?;
        let matches = table.find(&pattern);
        if matches.is_empty() {
            let n = table.objects().len();
            self.search = None;
            return Err(format!(
                "find {text:?}: no object matches (of {n}; * and ? are wildcards)"
            ));
        }
        let last = matches.len() - 1;
        self.search = Some(Search {
            text: text.to_string(),
            matches,
            // The step below starts after this one: at the first match.
            current: last,
        });
        self.next_match()
    }

    /// Enter after a search: the next match not hidden, selected, wrapping
    /// around (`k of n` in the HUD).
    pub fn next_match(&mut self) -> Result<u32, String> {
        let s = self
            .search
            .as_ref()
            .ok_or("Enter goes to the next match of a search: / starts one")?;
        let n = s.matches.len();
        let next = (1..=n)
            .map(|k| (s.current + k) % n)
            .find(|&i| !self.is_hidden(s.matches[i]));
        let Some(i) = next else {
            return Err(format!(
                "find {:?}: all {n} matches are hidden (U shows all)",
                s.text
            ));
        };
        let object = s.matches[i];
        if let Some(s) = &mut self.search {
            s.current = i;
        }
        self.changed |= self.selection.map(|s| s.object) != Some(object);
        self.selection = Some(Selection {
            object,
            point: None,
        });
        Ok(object)
    }

    /// What `H` and `I` act on: the current search's matches, else the
    /// selection.
    fn targets(&self, key: &str) -> Result<Vec<u32>, String> {
        self.table()?;
        if let Some(s) = &self.search {
            return Ok(s.matches.clone());
        }
        match self.selection {
            Some(s) => Ok(vec![s.object]),
            None => Err(format!(
                "{key} acts on the selection: click an object (or / to find some) first"
            )),
        }
    }

    /// `H`: hides the targets (the search ends with it).
    pub fn hide(&mut self) -> Result<String, String> {
        let targets = self.targets("H")?;
        let k = targets.len();
        self.hidden.hide(targets);
        self.search = None;
        self.after_hiding_changed();
        Ok(format!(
            "hid {}: {}",
            count(k, "object"),
            self.hidden_line()
        ))
    }

    /// `I`: hides every object but the targets (replacing an earlier
    /// isolation; the targets show even if hidden one by one before).
    pub fn isolate(&mut self) -> Result<String, String> {
        let targets = self.targets("I")?;
        let k = targets.len();
        self.hidden.isolate(targets);
        self.after_hiding_changed();
        Ok(format!(
            "isolated {}: {}",
            count(k, "object"),
            self.hidden_line()
        ))
    }

    /// `U`: every object shows again.
    pub fn show_all(&mut self) -> Result<String, String> {
        self.table()?;
        if self.hidden_count == 0 {
            return Ok("nothing is hidden".into());
        }
        let k = self.hidden_count;
        self.hidden.clear();
        self.after_hiding_changed();
        Ok(format!("showing all objects again ({k} were hidden)"))
    }

    fn after_hiding_changed(&mut self) {
        let n = self.table.as_ref().map_or(0, |t| t.objects().len());
        self.hidden_count = self.hidden.count(n);
        if self.selection.is_some_and(|s| self.is_hidden(s.object)) {
            self.selection = None;
        }
        self.changed = true;
    }

    fn hidden_line(&self) -> String {
        let (h, n) = self.hidden_count();
        format!("hidden: {h} of {n} objects")
    }

    /// A saved view of `pose` with this selection and hidden set.
    pub fn saved_view(&self, name: &str, pose: &Pose) -> SavedView {
        let mut v = SavedView::new(name, pose);
        if let Ok(t) = &self.table {
            let refs = |ids: &mut dyn Iterator<Item = u32>| -> Vec<ObjectRef> {
                ids.filter_map(|i| ObjectRef::of(t, i)).collect()
            };
            v.selected = refs(&mut self.selection.map(|s| s.object).into_iter());
            v.hidden = refs(&mut self.hidden.hidden().iter().copied());
            v.isolated = self.hidden.isolated().map(|s| refs(&mut s.iter().copied()));
        }
        v
    }

    /// Sets the selection and hidden set to `view`'s (its camera is the
    /// caller's); what to show about it.
    pub fn restore(&mut self, view: &SavedView) -> String {
        let names_objects =
            !view.selected.is_empty() || !view.hidden.is_empty() || view.isolated.is_some();
        let head = format!("restored {:?}", view.name);
        let table = match &self.table {
            Ok(t) => t,
            Err(why) if names_objects => return format!("{head}, the camera only: {why}"),
            Err(_) => return head,
        };
        let (selected, mut missing) = views::resolve(&view.selected, table);
        let mut hidden = HiddenSet::default();
        missing.extend(hidden.add_view(view, table));
        self.hidden = hidden;
        self.search = None;
        self.selection = selected.first().map(|&object| Selection {
            object,
            point: None,
        });
        self.after_hiding_changed();
        let mut text = head;
        if self.hidden_count > 0 {
            text.push_str(&format!(", {}", self.hidden_line()));
        }
        if !missing.is_empty() {
            text.push_str(&format!(
                "; {} it names {} no longer in the scene (the rest restored)",
                count(missing.len(), "object"),
                if missing.len() == 1 { "is" } else { "are" }
            ));
        }
        text
    }

    /// The HUD's lines: the selection (name, file, path, metadata, hit
    /// point), the hidden count and the current search.
    pub fn hud_lines(&self) -> Vec<String> {
        let mut lines = Vec::new();
        let Ok(table) = &self.table else {
            return lines;
        };
        if let Some(s) = self.selection {
            if let Some(o) = table.object(s.object) {
                lines.push(format!(
                    "selected: {} ({} tris; F frames it)",
                    o.name,
                    crate::group(o.triangles)
                ));
                lines.push(format!("  file {}  path {}", o.file, o.path));
                if let Some(m) = &o.metadata {
                    lines.push(format!("  metadata {m}"));
                }
                if let Some(p) = s.point {
                    lines.push(format!("  hit at {}", point_text(p)));
                }
            }
        }
        if self.hidden_count > 0 {
            lines.push(format!(
                "{}{} (U shows all)",
                self.hidden_line(),
                if self.hidden.isolated().is_some() {
                    ", isolated"
                } else {
                    ""
                }
            ));
        }
        if let Some(s) = &self.search {
            let n = s.matches.len();
            lines.push(format!(
                "find {:?}: {} of {n} (Enter: next; H / I: hide / isolate all {n})",
                s.text,
                s.current + 1
            ));
        }
        lines.into_iter().map(|l| hud_text(&l)).collect()
    }

    /// The selection as one line for the terminal: name, `file/path` and
    /// the hit point.
    pub fn describe_selection(&self) -> Option<String> {
        let s = self.selection?;
        let o = self.table.as_ref().ok()?.object(s.object)?;
        Some(match s.point {
            Some(p) => format!(
                "selected: {} ({}) at {}",
                o.name,
                o.full_path(),
                point_text(p)
            ),
            None => format!("selected: {} ({})", o.name, o.full_path()),
        })
    }
}

/// "3 objects", "1 object".
fn count(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}

/// A world point with enough digits to find it again: micro-units on a
/// model far from its origin.
pub fn point_text(p: DVec3) -> String {
    // + 0.0 turns -0 into 0: "-0.000000" reads as a sign that is not there.
    let p = p + DVec3::ZERO;
    format!("{:.6}, {:.6}, {:.6}", p.x, p.y, p.z)
}

/// An object as `gigawalk pick --json`, `find --json` and the page's
/// `pick` give it: its index, name, file, path, metadata (its JSON),
/// triangles and box.
pub fn object_json(id: u32, o: &ObjectRecord) -> serde_json::Value {
    serde_json::json!({
        "id": id,
        "name": o.name,
        "file": o.file,
        "path": o.path,
        "metadata": o.metadata.as_deref().and_then(|m| serde_json::from_str::<serde_json::Value>(m).ok()),
        "triangles": o.triangles,
        "bounds": {"min": o.bounds.min.to_array(), "max": o.bounds.max.to_array()},
    })
}

/// HUD text: the HUD's font is ASCII, so anything else shows as `?`,
/// and long lines are cut.
pub fn hud_text(s: &str) -> String {
    let mut out: String = s
        .chars()
        .map(|c| {
            if c.is_ascii() && !c.is_ascii_control() {
                c
            } else {
                '?'
            }
        })
        .take(HUD_LINE_CHARS)
        .collect();
    if s.chars().count() > HUD_LINE_CHARS {
        out.truncate(HUD_LINE_CHARS - 3);
        out.push_str("...");
    }
    out
}

/// Where the eye goes to frame `bounds` looking along `forward`: back
/// from the box's centre until its bounding sphere fits the narrower of
/// the two fields of view, and never closer than the near plane allows.
/// `None` for an empty or non-finite box.
pub fn frame_box(
    bounds: &Aabb,
    forward: DVec3,
    fovy: f64,
    aspect: f64,
    near: f64,
) -> Option<DVec3> {
    if bounds.is_empty() || !bounds.min.is_finite() || !bounds.max.is_finite() {
        return None;
    }
    let f = forward.try_normalize()?;
    let centre = (bounds.min + bounds.max) * 0.5;
    let radius = (bounds.max - bounds.min).length() * 0.5;
    let half_y = (fovy * 0.5).clamp(1e-3, 1.5);
    let half_x = (half_y.tan() * aspect.max(1e-3)).atan();
    let half = half_y.min(half_x);
    let distance = (radius / half.sin()).max(radius + 2.0 * near.max(0.0));
    Some(centre - f * distance)
}

/// Saves a view made by `make` (given its name, `view N`) into `file`,
/// atomically: an existing file that does not read is an error and is
/// left as it is. The view's name and every name in the file, in order.
/// (Not in the page: it has no files; its views are links.)
#[cfg(not(target_arch = "wasm32"))]
pub fn save_view(
    file: &std::path::Path,
    make: impl FnOnce(&str) -> SavedView,
) -> Result<(String, Vec<String>), views::ViewsError> {
    let mut views = Views::read(file)?;
    let name = views.next_name();
    views.put(make(&name));
    views.write(file)?;
    Ok((name, view_names(&views)))
}

pub fn view_names(views: &Views) -> Vec<String> {
    views.views.iter().map(|v| v.name.clone()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use gigawalk_scene::objects::{ObjectRecord, ObjectRun};
    use glam::DQuat;

    fn record(name: &str, x: f64) -> ObjectRecord {
        ObjectRecord {
            name: name.into(),
            path: format!("Plant/{name}"),
            file: "a.glb".into(),
            metadata: Some(r#"{"tag":"P-101"}"#.into()),
            bounds: Aabb::new(DVec3::new(x, 0.0, 0.0), DVec3::new(x + 1.0, 1.0, 1.0)),
            triangles: 1234,
        }
    }

    /// Five objects, two of them pipes.
    fn table() -> ObjectTable {
        ObjectTable::new(
            vec![
                record("Pipe.001", 0.0),
                record("Valve", 2.0),
                record("Pipe.002", 4.0),
                record("Pump", 6.0),
                record("Tank", 8.0),
            ],
            vec![(
                0,
                (0..5)
                    .map(|object| ObjectRun {
                        object,
                        triangles: 2,
                    })
                    .collect(),
            )],
        )
    }

    fn objects() -> Objects {
        Objects::new(Ok(table()))
    }

    fn pose() -> Pose {
        Pose {
            time: 0.0,
            position: DVec3::new(1.0, 2.0, 3.0),
            orientation: DQuat::IDENTITY,
            fovy: 1.0,
        }
    }

    #[test]
    fn framing_keeps_the_direction_and_fits_the_box() {
        let b = Aabb::new(DVec3::new(-1.0, -1.0, -1.0), DVec3::new(1.0, 1.0, 1.0));
        let fovy = 60f64.to_radians();
        let eye = frame_box(&b, DVec3::NEG_Z, fovy, 2.0, 0.01).unwrap();
        // Straight back along +Z from the centre, the sphere of radius
        // sqrt(3) just inside the 30-degree half angle.
        assert!(eye.x.abs() < 1e-12 && eye.y.abs() < 1e-12);
        assert!((eye.z - 3f64.sqrt() / 30f64.to_radians().sin()).abs() < 1e-9);
        // A narrow window: the horizontal field of view decides, farther.
        let narrow = frame_box(&b, DVec3::NEG_Z, fovy, 0.25, 0.01).unwrap();
        assert!(narrow.z > eye.z * 3.0);
        // Any direction: the centre lies straight ahead.
        let dir = DVec3::new(1.0, -2.0, 0.5);
        let e = frame_box(&b, dir, fovy, 1.0, 0.01).unwrap();
        assert!((-e).normalize().dot(dir.normalize()) > 1.0 - 1e-12);
    }

    #[test]
    fn framing_a_point_keeps_the_near_plane_off_it_and_empty_boxes_do_not_frame() {
        let p = DVec3::new(5.0, 0.0, 0.0);
        let eye = frame_box(&Aabb::new(p, p), DVec3::X, 1.0, 1.0, 0.1).unwrap();
        assert!(((p - eye).length() - 0.2).abs() < 1e-12);
        assert!(frame_box(&Aabb::EMPTY, DVec3::X, 1.0, 1.0, 0.1).is_none());
        let nan = Aabb::new(DVec3::NAN, DVec3::ONE);
        assert!(frame_box(&nan, DVec3::X, 1.0, 1.0, 0.1).is_none());
        let unit = Aabb::new(DVec3::ZERO, DVec3::ONE);
        assert!(frame_box(&unit, DVec3::ZERO, 1.0, 1.0, 0.1).is_none());
    }

    #[test]
    fn search_cycles_through_matches_and_says_k_of_n() {
        let mut o = objects();
        assert_eq!(o.find("pipe"), Ok(0));
        assert!(o.hud_lines().iter().any(|l| l.contains("1 of 2")));
        assert_eq!(o.find("pipe"), Ok(2), "Enter again: the next match");
        assert!(o.hud_lines().iter().any(|l| l.contains("2 of 2")));
        assert_eq!(o.next_match(), Ok(0), "wraps around");
        assert_eq!(o.selection().unwrap().object, 0);
        // A new pattern starts over; glob patterns match whole names (or
        // whole paths).
        assert_eq!(o.find("pu*"), Ok(3));
        assert_eq!(o.search().unwrap().matches, vec![3]);
        assert_eq!(o.find("Plant/*"), Ok(0));
        assert_eq!(o.search().unwrap().matches.len(), 5);
        assert_eq!(o.find("P?mp"), Ok(3));
    }

    #[test]
    fn search_with_no_match_or_no_pattern_says_so() {
        let mut o = objects();
        let e = o.find("boiler").unwrap_err();
        assert!(e.contains("no object matches"), "{e}");
        assert!(o.search().is_none() && o.selection().is_none());
        assert!(o.find("  ").unwrap_err().contains("empty pattern"));
        assert!(o.next_match().unwrap_err().contains("/ starts one"));
    }

    #[test]
    fn search_skips_hidden_matches() {
        let mut o = objects();
        o.click(Some((2, DVec3::ZERO)));
        o.hide().unwrap();
        assert_eq!(o.find("pipe"), Ok(0));
        assert_eq!(o.next_match(), Ok(0), "Pipe.002 is hidden");
        o.click(Some((0, DVec3::ZERO)));
        o.hide().unwrap();
        let e = o.find("pipe").unwrap_err();
        assert!(e.contains("all 2 matches are hidden"), "{e}");
    }

    #[test]
    fn hide_acts_on_the_selection_or_the_current_search() {
        let mut o = objects();
        assert!(o.hide().unwrap_err().contains("click an object"));
        o.click(Some((1, DVec3::new(2.5, 0.5, 0.5))));
        assert!(o.take_changed());
        let m = o.hide().unwrap();
        assert!(m.contains("hidden: 1 of 5 objects"), "{m}");
        assert!(o.is_hidden(1) && o.selection().is_none());
        o.find("pipe").unwrap();
        o.hide().unwrap();
        assert_eq!(o.hidden_count(), (3, 5));
        assert!(o.search().is_none(), "hiding ends the search");
        assert!(o
            .hud_lines()
            .iter()
            .any(|l| l == "hidden: 3 of 5 objects (U shows all)"));
        let m = o.show_all().unwrap();
        assert!(m.contains("3 were hidden"), "{m}");
        assert_eq!(o.hidden_count(), (0, 5));
        assert_eq!(o.show_all().unwrap(), "nothing is hidden");
    }

    #[test]
    fn isolate_hides_everything_else() {
        let mut o = objects();
        o.click(Some((4, DVec3::ZERO)));
        o.hide().unwrap();
        o.find("pipe").unwrap();
        o.isolate().unwrap();
        assert_eq!(o.hidden_count(), (3, 5));
        assert!(!o.is_hidden(0) && !o.is_hidden(2) && o.is_hidden(3) && o.is_hidden(4));
        // Enter still cycles the isolated matches.
        assert_eq!(o.next_match(), Ok(2));
        // Isolating an object hidden one by one shows it.
        o.click(Some((2, DVec3::ZERO)));
        o.hide().unwrap();
        o.click(None);
        assert!(o.isolate().unwrap_err().contains("click an object"));
        o.find("Pipe.002").unwrap_err();
        o.restore(&SavedView::new("x", &pose()));
        assert_eq!(o.hidden_count(), (0, 5));
    }

    #[test]
    fn visibility_highlights_the_selection_and_hides_the_hidden() {
        use gigawalk_scene::{IndexFormat, LodInfo, Node, Provenance, NO_NODE};
        let bounds = Aabb::new(DVec3::ZERO, DVec3::new(9.0, 1.0, 1.0));
        let nodes = vec![Node {
            bounds,
            parent: NO_NODE,
            first_child: 0,
            child_count: 0,
            first_lod: 0,
            lod_count: 1,
        }];
        let lods = vec![LodInfo {
            error: 0.0,
            triangles: 10,
            vertices: 30,
            origin: DVec3::ZERO,
            index_format: IndexFormat::U16,
            uniform_colour: None,
            encoded: false,
            grid: None,
            compressed: false,
            offset: 0,
            len: 0,
            checksum: 0,
        }];
        let skeleton = Skeleton::new(DVec3::ZERO, bounds, nodes, lods, Provenance::default())
            .expect("a one-leaf skeleton");
        let mut o = objects();
        assert!(o.visibility(&skeleton).is_none());
        o.click(Some((1, DVec3::ZERO)));
        let v = o.visibility(&skeleton).unwrap();
        assert_eq!(v.counts(), (0, 1));
        o.hide().unwrap();
        let v = o.visibility(&skeleton).unwrap();
        assert_eq!(v.counts(), (1, 0));
        let pieces = v.pieces(0).unwrap();
        assert_eq!(pieces.len(), 2, "{pieces:?}");
    }

    #[test]
    fn without_identity_everything_says_preprocess_again() {
        let mut o = Objects::new(Err(NO_IDENTITY.into()));
        for e in [
            o.find("pipe").unwrap_err(),
            o.hide().unwrap_err(),
            o.isolate().unwrap_err(),
            o.show_all().unwrap_err(),
            o.selected_bounds().unwrap_err(),
        ] {
            assert!(e.contains("preprocess the model again"), "{e}");
        }
        assert!(o.hud_lines().is_empty());
        let mut v = SavedView::new("v", &pose());
        assert_eq!(o.restore(&v), "restored \"v\"");
        v.hidden.push(ObjectRef {
            id: 0,
            path: "a.glb/Plant/Pipe.001".into(),
        });
        let m = o.restore(&v);
        assert!(
            m.contains("the camera only") && m.contains("preprocess"),
            "{m}"
        );
    }

    #[test]
    fn a_saved_view_round_trips_the_hidden_set_and_selection() {
        let mut o = objects();
        o.click(Some((3, DVec3::ZERO)));
        o.hide().unwrap();
        o.find("pipe").unwrap();
        o.isolate().unwrap();
        o.click(Some((2, DVec3::ZERO)));
        let v = o.saved_view("view 1", &pose());
        assert_eq!(v.selected[0].path, "a.glb/Plant/Pipe.002");
        assert_eq!(v.hidden.len(), 1, "the pump, hidden before the isolation");
        assert_eq!(v.isolated.as_ref().unwrap().len(), 2);
        let mut fresh = objects();
        let m = fresh.restore(&v);
        assert_eq!(m, "restored \"view 1\", hidden: 3 of 5 objects");
        assert_eq!(fresh.selection().unwrap().object, 2);
        assert_eq!(fresh.hidden_count(), (3, 5));
        for i in 0..5 {
            assert_eq!(fresh.is_hidden(i), o.is_hidden(i), "object {i}");
        }
        assert_eq!(fresh.saved_view("view 1", &pose()), v);
    }

    #[test]
    fn a_view_naming_objects_no_longer_there_restores_the_rest() {
        let mut o = objects();
        let mut v = SavedView::new("old", &pose());
        v.hidden = vec![
            ObjectRef {
                id: 1,
                path: "a.glb/Plant/Valve".into(),
            },
            ObjectRef {
                id: 7,
                path: "a.glb/Plant/Gone".into(),
            },
        ];
        // Index 9 is gone but the path is found at its new index.
        v.selected = vec![ObjectRef {
            id: 9,
            path: "a.glb/Plant/Tank".into(),
        }];
        let m = o.restore(&v);
        assert!(
            m.contains("1 object it names is no longer in the scene"),
            "{m}"
        );
        assert!(o.is_hidden(1) && !o.is_hidden(0));
        assert_eq!(o.selection().unwrap().object, 4);
    }

    #[test]
    fn hud_shows_name_file_path_metadata_and_hit_point() {
        let mut o = objects();
        o.click(Some((1, DVec3::new(1e7 + 0.25, -2.0, 1.0 / 3.0))));
        let text = o.hud_lines().join("\n");
        for want in [
            "selected: Valve (1,234 tris",
            "file a.glb  path Plant/Valve",
            r#"metadata {"tag":"P-101"}"#,
            "hit at 10000000.250000, -2.000000, 0.333333",
        ] {
            assert!(text.contains(want), "{want:?} missing from\n{text}");
        }
        assert_eq!(
            o.describe_selection().unwrap(),
            "selected: Valve (a.glb/Plant/Valve) at 10000000.250000, -2.000000, 0.333333"
        );
        assert_eq!(
            point_text(DVec3::new(-0.0, 0.0, -1e-9)),
            "0.000000, 0.000000, -0.000000"
        );
    }

    #[test]
    fn hud_text_is_ascii_and_short() {
        assert_eq!(hud_text("Ventil \u{00fc}ber"), "Ventil ?ber");
        let long = hud_text(&"x".repeat(500));
        assert_eq!(long.len(), HUD_LINE_CHARS);
        assert!(long.ends_with("..."));
    }

    #[test]
    fn saving_adds_view_n_and_never_overwrites_a_corrupt_file() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("s.gwk.views.json");
        let o = objects();
        let (a, names) = save_view(&file, |n| o.saved_view(n, &pose())).unwrap();
        assert_eq!((a.as_str(), names.len()), ("view 1", 1));
        let (b, names) = save_view(&file, |n| o.saved_view(n, &pose())).unwrap();
        assert_eq!(b, "view 2");
        assert_eq!(names, vec!["view 1", "view 2"]);
        std::fs::write(&file, "{ not json").unwrap();
        let e = save_view(&file, |n| o.saved_view(n, &pose())).unwrap_err();
        assert!(e.to_string().contains("not a saved-views file"), "{e}");
        assert_eq!(std::fs::read_to_string(&file).unwrap(), "{ not json");
    }
}
