//! Object selection, the one home of what the viewer, `gigawalk pick`,
//! `find` and `replay --hide/--isolate/--view` ask of a scene's object
//! table (docs/scene-format.md, "OBJT"):
//! - the hidden set ([`HiddenSet`]): objects hidden one by one, plus,
//!   with an isolation, every object outside it; a saved view's hidden
//!   and isolated objects add to it;
//! - find: the objects a pattern names;
//! - pick: the object under a pixel ([`pick_pixel`], and [`pick`] for a
//!   camera path's pose), skipping hidden objects and what a section cuts
//!   away.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use gigawalk_cull::{default_near, Camera, PickHit, PickStats, Section, Viewport, Visibility};
use gigawalk_scene::objects::{ObjectRecord, ObjectTable, Pattern};
use gigawalk_scene::path::CameraPath;
use gigawalk_scene::views::{self, SavedView};
use gigawalk_scene::{SceneReader, Skeleton};
use glam::DVec3;
use web_time::Instant;

/// Why a pick, find or hide could not answer.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SelectError {
    #[error(transparent)]
    Scene(#[from] gigawalk_scene::ReadError),
    #[error(transparent)]
    Path(#[from] gigawalk_scene::path::PathReadError),
    #[error(
        "{0}: the scene records no object identity (it was written before scenes kept it); \
         preprocess the model again to pick, find or hide objects"
    )]
    NoIdentity(PathBuf),
    #[error("{path}: pose {frame} asked for, the path has {poses} (poses count from 0)")]
    NoPose {
        path: PathBuf,
        frame: usize,
        poses: usize,
    },
    #[error("pixel {x},{y} is outside the {width}x{height} viewport (0,0 is the top-left pixel)")]
    Pixel {
        x: u32,
        y: u32,
        width: u32,
        height: u32,
    },
    #[error("viewport {width}x{height}: both sides must be at least 1")]
    Viewport { width: u32, height: u32 },
    #[error("pattern {pattern:?}: {reason}")]
    Pattern { pattern: String, reason: String },
}

/// The scene's object table, or the error that says to preprocess again.
pub fn object_table(scene: &SceneReader, path: &Path) -> Result<ObjectTable, SelectError> {
    scene
        .objects()?
        .ok_or_else(|| SelectError::NoIdentity(path.to_path_buf()))
}

/// A pattern (docs: [`Pattern`]), or an error naming it.
pub fn pattern(p: &str) -> Result<Pattern, SelectError> {
    Pattern::new(p).map_err(|reason| SelectError::Pattern {
        pattern: p.to_string(),
        reason,
    })
}

/// Every object `pattern` matches, with its index in the table.
pub fn find(scene: &Path, pattern_text: &str) -> Result<Vec<(u32, ObjectRecord)>, SelectError> {
    let p = pattern(pattern_text)?;
    let reader = SceneReader::open(scene)?;
    let table = object_table(&reader, scene)?;
    Ok(table
        .find(&p)
        .into_iter()
        .map(|i| (i, table.objects()[i as usize].clone()))
        .collect())
}

/// A pick's question: pixels `(x, y)` of pose `frame` of a camera path,
/// rendered at `width` x `height`, with what `section` keeps.
#[derive(Clone, Debug)]
pub struct PickRequest {
    pub scene: PathBuf,
    pub path: PathBuf,
    pub frame: usize,
    pub pixels: Vec<(u32, u32)>,
    /// Section planes and box: a pick finds the nearest surface they keep.
    pub section: Option<Arc<Section>>,
    pub width: u32,
    pub height: u32,
    /// The near plane; `None`: [`default_near`] of the scene, as replay.
    pub near: Option<f64>,
}

/// A pick's answer.
#[derive(Clone, Debug)]
pub struct Picked {
    /// The object hit and its index in the table; `None`: nothing there.
    pub object: Option<(u32, ObjectRecord)>,
    /// The hit point, world coordinates.
    pub point: Option<DVec3>,
    pub distance: Option<f64>,
    /// The leaf hit, its finest LOD and the triangle within it.
    pub node: Option<u32>,
    pub lod: Option<u32>,
    pub triangle: Option<u32>,
    pub stats: PickStats,
    /// The ray cast and the leaves it read, in milliseconds (opening the
    /// scene and reading its object table excluded).
    pub ms: f64,
}

/// Answers `req`: for each pixel, the object the full-detail image (cut
/// by the section) shows at the pixel's centre.
pub fn pick(req: &PickRequest) -> Result<Vec<Picked>, SelectError> {
    let (w, h) = (req.width, req.height);
    if w == 0 || h == 0 {
        return Err(SelectError::Viewport {
            width: w,
            height: h,
        });
    }
    for &(x, y) in &req.pixels {
        if x >= w || y >= h {
            return Err(SelectError::Pixel {
                x,
                y,
                width: w,
                height: h,
            });
        }
    }
    let path = CameraPath::read(&req.path)?;
    let pose = path.poses.get(req.frame).ok_or(SelectError::NoPose {
        path: req.path.clone(),
        frame: req.frame,
        poses: path.poses.len(),
    })?;
    let reader = SceneReader::open(&req.scene)?;
    let table = object_table(&reader, &req.scene)?;
    let viewport = Viewport::new(w, h);
    let near = req
        .near
        .unwrap_or_else(|| default_near(&reader.skeleton().bounds()));
    let camera = Camera::of_pose(pose, viewport, near);
    let section = req.section.as_deref();
    req.pixels
        .iter()
        .map(|&p| pick_with(&reader, &table, &camera, viewport, p, &|_| false, section))
        .collect()
}

/// The nearest surface the full-detail image shows at image point `(x,
/// y)` of `camera` on `viewport` (pixels from the top-left corner; a
/// pixel's centre is at `+0.5`): nodes `hidden_node` says hold nothing
/// shown and objects `hidden` says are hidden are skipped, and only what
/// `section` keeps is hit. `None`: nothing there, or outside the image.
#[allow(clippy::too_many_arguments)]
pub fn pick_pixel(
    reader: &SceneReader,
    table: Option<&ObjectTable>,
    camera: &Camera,
    viewport: Viewport,
    (x, y): (f64, f64),
    hidden_node: &dyn Fn(u32) -> bool,
    hidden: &dyn Fn(u32) -> bool,
    section: Option<&Section>,
) -> Result<(Option<PickHit>, PickStats), gigawalk_scene::ReadError> {
    // What the section cuts away shows nothing to pick.
    let Some(ray) = camera
        .pixel_ray(viewport, x, y)
        .and_then(|r| r.clipped(section))
    else {
        return Ok((None, PickStats::default()));
    };
    gigawalk_cull::pick(
        reader.skeleton(),
        table,
        &ray,
        hidden_node,
        hidden,
        &mut |lod| reader.read_lod(lod),
    )
}

/// Pixel `(x, y)` (its centre) of `camera` on `viewport`, objects
/// `hidden` says skipped, only what `section` keeps.
pub fn pick_with(
    reader: &SceneReader,
    table: &ObjectTable,
    camera: &Camera,
    viewport: Viewport,
    (x, y): (u32, u32),
    hidden: &dyn Fn(u32) -> bool,
    section: Option<&Section>,
) -> Result<Picked, SelectError> {
    let t = Instant::now();
    if x >= viewport.width || y >= viewport.height {
        return Err(SelectError::Pixel {
            x,
            y,
            width: viewport.width,
            height: viewport.height,
        });
    }
    let (hit, stats) = pick_pixel(
        reader,
        Some(table),
        camera,
        viewport,
        (x as f64 + 0.5, y as f64 + 0.5),
        &|_| false,
        hidden,
        section,
    )?;
    let ms = t.elapsed().as_secs_f64() * 1e3;
    Ok(Picked {
        object: hit
            .and_then(|h| h.object)
            .and_then(|o| table.object(o).map(|r| (o, r.clone()))),
        point: hit.map(|h| h.point),
        distance: hit.map(|h| h.distance),
        node: hit.map(|h| h.node),
        lod: hit.map(|h| h.lod),
        triangle: hit.map(|h| h.triangle),
        stats,
        ms,
    })
}

/// Which objects are hidden: those hidden one by one, and, with an
/// isolation, every object outside it.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct HiddenSet {
    hidden: BTreeSet<u32>,
    isolated: Option<BTreeSet<u32>>,
}

impl HiddenSet {
    pub fn is_hidden(&self, object: u32) -> bool {
        self.hidden.contains(&object)
            || self.isolated.as_ref().is_some_and(|s| !s.contains(&object))
    }

    /// Hides `objects` too.
    pub fn hide(&mut self, objects: impl IntoIterator<Item = u32>) {
        self.hidden.extend(objects);
    }

    /// Adds `objects` to the isolation (starting one if there is none):
    /// with several patterns or a view, each isolates what it names.
    pub fn isolate_also(&mut self, objects: impl IntoIterator<Item = u32>) {
        self.isolated
            .get_or_insert_with(BTreeSet::new)
            .extend(objects);
    }

    /// Isolates `objects` alone, replacing an earlier isolation; they show
    /// even if hidden one by one before.
    pub fn isolate(&mut self, objects: impl IntoIterator<Item = u32>) {
        let objects: BTreeSet<u32> = objects.into_iter().collect();
        self.hidden.retain(|o| !objects.contains(o));
        self.isolated = Some(objects);
    }

    /// Every object shows.
    pub fn clear(&mut self) {
        *self = HiddenSet::default();
    }

    /// Objects hidden one by one.
    pub fn hidden(&self) -> &BTreeSet<u32> {
        &self.hidden
    }

    /// The isolation, if any.
    pub fn isolated(&self) -> Option<&BTreeSet<u32>> {
        self.isolated.as_ref()
    }

    /// How many of objects `0..objects` are hidden.
    pub fn count(&self, objects: usize) -> usize {
        let n = objects as u32;
        match &self.isolated {
            Some(iso) => {
                objects
                    - iso
                        .iter()
                        .filter(|&&o| o < n && !self.hidden.contains(&o))
                        .count()
            }
            None => self.hidden.iter().filter(|&&o| o < n).count(),
        }
    }

    /// Adds what saved view `view` hides and isolates, found in `table`
    /// by id and path ([`views::resolve`]); returns the paths of objects
    /// it names that `table` no longer has.
    pub fn add_view(&mut self, view: &SavedView, table: &ObjectTable) -> Vec<String> {
        let (ids, mut missing) = views::resolve(&view.hidden, table);
        self.hide(ids);
        if let Some(iso) = &view.isolated {
            let (ids, m) = views::resolve(iso, table);
            missing.extend(m);
            self.isolate_also(ids);
        }
        missing
    }

    /// What the passes need: objects of `table` shown or not, `selected`
    /// highlighted (unless hidden).
    pub fn visibility(
        &self,
        skeleton: &Skeleton,
        table: &ObjectTable,
        selected: Option<u32>,
    ) -> Visibility {
        Visibility::new(skeleton, table, &|o| self.is_hidden(o), &|o| {
            Some(o) == selected
        })
    }

    /// X-ray's ghosts: the hidden objects of `table` as a visibility of
    /// their own (`None`: nothing hidden).
    pub fn ghosts(&self, skeleton: &Skeleton, table: &ObjectTable) -> Option<Visibility> {
        Visibility::ghosts(skeleton, table, &|o| self.is_hidden(o))
    }
}

/// What `--hide`, `--isolate` and `--view` ask to hide.
#[derive(Clone, Debug, Default)]
pub struct HideRequest {
    /// Objects matching any of these are hidden.
    pub hide: Vec<String>,
    /// When any, every object matching none of these is hidden.
    pub isolate: Vec<String>,
    /// A saved view's hidden and isolated objects.
    pub view: Option<SavedView>,
}

/// The hidden set [`HideRequest`] names.
#[derive(Clone, Debug)]
pub struct Hidden {
    pub visibility: Arc<Visibility>,
    /// X-ray's ghosts of the hidden objects (`None`: none hidden).
    pub ghosts: Option<Arc<Visibility>>,
    /// Objects hidden, of how many.
    pub hidden: usize,
    pub objects: usize,
    /// Objects a saved view names that the scene no longer has.
    pub missing: Vec<String>,
}

/// The objects of `table` that `pattern` matches; an error when it is
/// not a pattern or matches none.
pub fn matching(table: &ObjectTable, pattern_text: &str) -> Result<Vec<u32>, SelectError> {
    let found = table.find(&pattern(pattern_text)?);
    if found.is_empty() {
        return Err(SelectError::Pattern {
            pattern: pattern_text.to_string(),
            reason: format!(
                "matches none of the scene's {} objects",
                table.objects().len()
            ),
        });
    }
    Ok(found)
}

/// Resolves `req` against the scene's object table: each pattern must
/// match an object (else an error naming it).
pub fn hidden(
    scene: &SceneReader,
    scene_path: &Path,
    req: &HideRequest,
) -> Result<Hidden, SelectError> {
    let table = object_table(scene, scene_path)?;
    let mut set = HiddenSet::default();
    for p in &req.hide {
        set.hide(matching(&table, p)?);
    }
    for p in &req.isolate {
        set.isolate_also(matching(&table, p)?);
    }
    let missing = match &req.view {
        Some(v) => set.add_view(v, &table),
        None => Vec::new(),
    };
    let n = table.objects().len();
    Ok(Hidden {
        visibility: Arc::new(set.visibility(scene.skeleton(), &table, None)),
        ghosts: set.ghosts(scene.skeleton(), &table).map(Arc::new),
        hidden: set.count(n),
        objects: n,
        missing,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hiding_isolating_and_counting_agree() {
        let mut s = HiddenSet::default();
        assert!(!s.is_hidden(3));
        assert_eq!(s.count(10), 0);
        s.hide([1, 2, 42]);
        assert!(s.is_hidden(1) && s.is_hidden(2) && !s.is_hidden(3));
        // Ids beyond the table are not counted.
        assert_eq!(s.count(10), 2);
        // Two isolating patterns keep what either names.
        s.isolate_also([2, 3]);
        s.isolate_also([4]);
        assert!(s.is_hidden(0) && s.is_hidden(2) && !s.is_hidden(3) && !s.is_hidden(4));
        assert_eq!(s.count(10), 8);
        assert_eq!((0..10).filter(|&o| s.is_hidden(o)).count(), s.count(10));
        // Isolating anew replaces the isolation and shows its objects.
        s.isolate([1, 5]);
        assert!(!s.is_hidden(1) && !s.is_hidden(5) && s.is_hidden(3));
        assert_eq!(s.count(10), 8);
        assert_eq!(s.isolated().map(|i| i.len()), Some(2));
        assert!(s.hidden().contains(&2) && !s.hidden().contains(&1));
        s.clear();
        assert_eq!(s, HiddenSet::default());
    }
}
