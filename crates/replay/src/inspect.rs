//! `gigawalk pick` and `gigawalk find`: what is under a pixel of a camera
//! path's pose, and which objects a pattern names, from a scene's object
//! table (docs/scene-format.md, "OBJT").

use std::path::{Path, PathBuf};
use std::time::Instant;

use gigawalk_cull::{default_near, Camera, PickStats, Viewport};
use gigawalk_scene::objects::{ObjectRecord, ObjectTable, Pattern};
use gigawalk_scene::path::CameraPath;
use gigawalk_scene::SceneReader;
use glam::DVec3;

/// Why a pick or find could not answer.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum InspectError {
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
pub fn object_table(scene: &SceneReader, path: &Path) -> Result<ObjectTable, InspectError> {
    scene
        .objects()?
        .ok_or_else(|| InspectError::NoIdentity(path.to_path_buf()))
}

/// A pattern (docs: [`Pattern`]), or an error naming it.
pub fn pattern(p: &str) -> Result<Pattern, InspectError> {
    Pattern::new(p).map_err(|reason| InspectError::Pattern {
        pattern: p.to_string(),
        reason,
    })
}

/// Every object `pattern` matches, with its index in the table.
pub fn find(scene: &Path, pattern_text: &str) -> Result<Vec<(u32, ObjectRecord)>, InspectError> {
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
    pub section: Option<std::sync::Arc<gigawalk_cull::Section>>,
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
pub fn pick(req: &PickRequest) -> Result<Vec<Picked>, InspectError> {
    let (w, h) = (req.width, req.height);
    if w == 0 || h == 0 {
        return Err(InspectError::Viewport {
            width: w,
            height: h,
        });
    }
    for &(x, y) in &req.pixels {
        if x >= w || y >= h {
            return Err(InspectError::Pixel {
                x,
                y,
                width: w,
                height: h,
            });
        }
    }
    let path = CameraPath::read(&req.path)?;
    let pose = path.poses.get(req.frame).ok_or(InspectError::NoPose {
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

/// Pixel `(x, y)` (its centre) of `camera` on `viewport`, objects
/// `hidden` says skipped, only what `section` keeps.
pub fn pick_with(
    reader: &SceneReader,
    table: &ObjectTable,
    camera: &Camera,
    viewport: Viewport,
    (x, y): (u32, u32),
    hidden: &dyn Fn(u32) -> bool,
    section: Option<&gigawalk_cull::Section>,
) -> Result<Picked, InspectError> {
    let t = Instant::now();
    let ray = camera
        .pixel_ray(viewport, x as f64 + 0.5, y as f64 + 0.5)
        .ok_or(InspectError::Pixel {
            x,
            y,
            width: viewport.width,
            height: viewport.height,
        })?;
    let Some(ray) = ray.clipped(section) else {
        // The section keeps nothing along this ray.
        return Ok(Picked {
            object: None,
            point: None,
            distance: None,
            node: None,
            lod: None,
            triangle: None,
            stats: PickStats::default(),
            ms: t.elapsed().as_secs_f64() * 1e3,
        });
    };
    let (hit, stats) = gigawalk_cull::pick(
        reader.skeleton(),
        Some(table),
        &ray,
        &|_| false,
        hidden,
        &mut |lod| reader.read_lod(lod),
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

/// One object as `--json` prints it.
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

/// What `--hide`, `--isolate` and `--view` ask to hide.
#[derive(Clone, Debug, Default)]
pub struct HideRequest {
    /// Objects matching any of these are hidden.
    pub hide: Vec<String>,
    /// When any, every object matching none of these is hidden.
    pub isolate: Vec<String>,
    /// A saved view's hidden and isolated objects.
    pub view: Option<gigawalk_scene::views::SavedView>,
}

/// The hidden set [`HideRequest`] names.
#[derive(Clone, Debug)]
pub struct Hidden {
    pub visibility: std::sync::Arc<gigawalk_cull::Visibility>,
    /// Objects hidden, of how many.
    pub hidden: usize,
    pub objects: usize,
    /// Objects a saved view names that the scene no longer has.
    pub missing: Vec<String>,
}

/// Resolves `req` against the scene's object table: each pattern must
/// match an object (else an error naming it).
pub fn hidden(
    scene: &SceneReader,
    scene_path: &Path,
    req: &HideRequest,
) -> Result<Hidden, InspectError> {
    let table = object_table(scene, scene_path)?;
    let n = table.objects().len();
    let mut hide = vec![false; n];
    let matches = |p: &str| -> Result<Vec<u32>, InspectError> {
        let found = table.find(&pattern(p)?);
        if found.is_empty() {
            return Err(InspectError::Pattern {
                pattern: p.to_string(),
                reason: format!("matches none of the scene's {n} objects"),
            });
        }
        Ok(found)
    };
    for p in &req.hide {
        for i in matches(p)? {
            hide[i as usize] = true;
        }
    }
    let mut keep: Option<Vec<bool>> = None;
    for p in &req.isolate {
        let k = keep.get_or_insert_with(|| vec![false; n]);
        for i in matches(p)? {
            k[i as usize] = true;
        }
    }
    let mut missing = Vec::new();
    if let Some(v) = &req.view {
        let (ids, m) = gigawalk_scene::views::resolve(&v.hidden, &table);
        missing.extend(m);
        for i in ids {
            hide[i as usize] = true;
        }
        if let Some(iso) = &v.isolated {
            let (ids, m) = gigawalk_scene::views::resolve(iso, &table);
            missing.extend(m);
            let k = keep.get_or_insert_with(|| vec![false; n]);
            for i in ids {
                k[i as usize] = true;
            }
        }
    }
    if let Some(k) = keep {
        for (h, k) in hide.iter_mut().zip(k) {
            *h |= !k;
        }
    }
    let visibility =
        gigawalk_cull::Visibility::new(scene.skeleton(), &table, &|o| hide[o as usize], &|_| false);
    Ok(Hidden {
        visibility: std::sync::Arc::new(visibility),
        hidden: hide.iter().filter(|&&h| h).count(),
        objects: n,
        missing,
    })
}
