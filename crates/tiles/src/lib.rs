//! gigawalk's 3D Tiles 1.1 export: a scene file as a tileset a CesiumJS,
//! three.js (3d-tiles-renderer), Unreal or Unity client streams.
//!
//! Main items: [`export`] (scene file in, directory of `tileset.json`,
//! external tilesets and `.glb` contents out), [`ExportOptions`],
//! [`ExportSummary`], [`ExportError`]; [`plan::plan`] the tile tree and its
//! geometric errors (the mapping from the scene's measured LOD errors is
//! stated there and in docs/tiles.md); [`Encoding`] how contents are
//! stored; [`Georef`] where the tileset sits on the Earth.
//!
//! The export streams: it holds the scene's skeleton and object table,
//! and one tile's levels per worker thread, never the geometry of the
//! whole scene. `tileset.json` is written last, after every content and
//! external tileset, so a failed export (a full disk) never leaves a
//! tileset that looks complete.

#![forbid(unsafe_code)]

mod georef;
mod glb;
pub mod plan;
mod tileset;

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use gigawalk_scene::objects::ObjectTable;
use gigawalk_scene::{ReadError, SceneReader};
use glam::DMat4;
use rayon::prelude::*;

pub use georef::{enu_to_ecef, Georef};
pub use glb::Encoding;

/// How to export.
#[derive(Clone, Debug)]
pub struct ExportOptions {
    pub encoding: Encoding,
    pub georef: Georef,
    /// Write into an output directory that exists and is not empty: its
    /// `tileset.json` is removed first, then its `content/` and
    /// `tilesets/`; nothing else in it is touched.
    pub force: bool,
    /// At most this many tiles in one tileset file (external tilesets
    /// take the rest): about 300 bytes of JSON a tile.
    pub tiles_per_file: usize,
    /// At most this many tiles from a file's root to its deepest tile.
    pub depth_per_file: usize,
    /// The triangles a content is cut to, about: a tile unites the levels
    /// of as many hierarchy nodes as fit (docs/tiles.md).
    pub content_triangles: u64,
    /// For tests: fail as a full disk would once this many contents are
    /// written. `None` in every real export.
    pub fail_after_contents: Option<usize>,
}

impl Default for ExportOptions {
    fn default() -> Self {
        ExportOptions {
            encoding: Encoding::Meshopt,
            georef: Georef::Local,
            force: false,
            tiles_per_file: DEFAULT_TILES_PER_FILE,
            depth_per_file: DEFAULT_DEPTH_PER_FILE,
            content_triangles: plan::DEFAULT_CONTENT_TRIANGLES,
            fail_after_contents: None,
        }
    }
}

/// About 1.2 MB of JSON: a client reads a file this size in one go.
pub const DEFAULT_TILES_PER_FILE: usize = 4000;
/// A tile nests two JSON levels deeper than its parent; parsers such as
/// serde_json stop at 128.
pub const DEFAULT_DEPTH_PER_FILE: usize = 40;

/// What an export wrote.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExportSummary {
    pub tiles: usize,
    pub contents: usize,
    /// Tileset files, the main one included.
    pub tileset_files: usize,
    pub content_bytes: u64,
    pub json_bytes: u64,
    /// The largest tileset file.
    pub largest_json_bytes: u64,
    /// Triangles over every content.
    pub triangles: u64,
    /// The median content's triangles.
    pub median_content_triangles: u64,
    /// Stored levels over every content (a level may be in several).
    pub parts: usize,
    /// Contents with feature IDs (object identity).
    pub contents_with_features: usize,
    /// Whether the scene holds object identity at all.
    pub identity: bool,
    /// Stored levels no content draws (bands pass over them).
    pub levels_left_out: usize,
    /// The deepest tile, counting the root as 1.
    pub depth: usize,
    pub seconds: f64,
}

/// Why an export failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExportError {
    #[error(transparent)]
    Read(#[from] ReadError),
    #[error("{0}: the output directory exists and is not empty")]
    OutputExists(PathBuf),
    #[error("{0}: exists and is not a directory")]
    NotADirectory(PathBuf),
    #[error("{path}: cannot write: {source}")]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("tile {tile} (first level LOD {first_lod}): cannot make its content: {detail}")]
    Content {
        tile: u32,
        first_lod: u32,
        detail: String,
    },
}

/// What an export reports as it goes.
pub trait Progress: Sync {
    /// A phase with `total` steps begins.
    fn start(&self, _phase: &str, _total: u64) {}
    fn advance(&self, _n: u64) {}
    fn finish(&self, _phase: &str, _seconds: f64) {}
}

/// No progress.
pub struct Quiet;
impl Progress for Quiet {}

/// Exports the scene file `scene` as a tileset in directory `out`.
pub fn export(
    scene: &Path,
    out: &Path,
    options: &ExportOptions,
    progress: &dyn Progress,
) -> Result<ExportSummary, ExportError> {
    let start = Instant::now();
    let reader = SceneReader::open(scene)?;
    let objects = reader.objects()?;
    let created = prepare_dir(out, options.force)?;
    let result = write_all(&reader, objects.as_ref(), out, options, progress);
    match result {
        Ok(mut s) => {
            s.seconds = start.elapsed().as_secs_f64();
            Ok(s)
        }
        Err(e) => {
            // Nothing half-written stays: what this export wrote goes
            // (tileset.json was never written), and the directory too when
            // the export made it.
            let _ = std::fs::remove_dir_all(out.join("content"));
            let _ = std::fs::remove_dir_all(out.join("tilesets"));
            if created {
                let _ = std::fs::remove_dir(out);
            }
            Err(e)
        }
    }
}

fn write_err(path: &Path) -> impl FnOnce(std::io::Error) -> ExportError + '_ {
    move |source| ExportError::Write {
        path: path.to_path_buf(),
        source,
    }
}

/// Makes `out` ready: created when missing (returns true), refused when it
/// holds anything and `force` is off, else cleared of an earlier export's
/// files, `tileset.json` first.
fn prepare_dir(out: &Path, force: bool) -> Result<bool, ExportError> {
    match std::fs::metadata(out) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            std::fs::create_dir_all(out).map_err(write_err(out))?;
            Ok(true)
        }
        Err(e) => Err(write_err(out)(e)),
        Ok(m) if !m.is_dir() => Err(ExportError::NotADirectory(out.to_path_buf())),
        Ok(_) => {
            let empty = std::fs::read_dir(out)
                .map_err(write_err(out))?
                .next()
                .is_none();
            if !empty {
                if !force {
                    return Err(ExportError::OutputExists(out.to_path_buf()));
                }
                let main = out.join("tileset.json");
                if main.exists() {
                    std::fs::remove_file(&main).map_err(write_err(&main))?;
                }
                for d in ["content", "tilesets"] {
                    let d = out.join(d);
                    if d.exists() {
                        std::fs::remove_dir_all(&d).map_err(write_err(&d))?;
                    }
                }
            }
            Ok(false)
        }
    }
}

/// Writes `bytes` to `path` through a temporary file renamed into place
/// (no sync: contents are many, and `tileset.json`, written last with a
/// sync, is what makes the tileset complete).
fn write_file(path: &Path, bytes: &[u8]) -> Result<(), ExportError> {
    let mut tmp = gigawalk_scene::temp_file_for(path).map_err(write_err(path))?;
    tmp.write_all(bytes).map_err(write_err(path))?;
    tmp.persist(path).map_err(write_err(path))
}

fn write_all(
    reader: &SceneReader,
    objects: Option<&ObjectTable>,
    out: &Path,
    options: &ExportOptions,
    progress: &dyn Progress,
) -> Result<ExportSummary, ExportError> {
    let skeleton = reader.skeleton();
    let plan = plan::plan(skeleton, options.content_triangles);
    let node_objects = objects.map(|t| t.node_objects(skeleton));

    // Contents, on rayon's pool, one tile's levels in memory per worker.
    let with_content: Vec<u32> = (0..plan.tiles.len() as u32)
        .filter(|&t| {
            plan.tiles[t as usize]
                .parts
                .iter()
                .any(|q| skeleton.lods()[q.lod as usize].triangles > 0)
        })
        .collect();
    let mut dirs: Vec<u32> = with_content.iter().map(|&t| t / 1000).collect();
    dirs.dedup();
    for d in dirs {
        let d = out.join(format!("content/{d}"));
        std::fs::create_dir_all(&d).map_err(write_err(&d))?;
    }
    let phase = Instant::now();
    progress.start("contents", with_content.len() as u64);
    let written = AtomicUsize::new(0);
    let records = objects.map(|t| t.objects());
    let results: Vec<(u32, tileset::ContentInfo, u64, u64, bool)> = with_content
        .par_iter()
        .map(|&t| {
            let tile = &plan.tiles[t as usize];
            let mut levels = Vec::with_capacity(tile.parts.len());
            for q in &tile.parts {
                let node = skeleton.node(q.node);
                // Known per triangle: a leaf's full detail (its runs), or
                // any level of a node that holds one object.
                let identity = match (objects, &node_objects) {
                    (Some(table), Some(per_node)) => {
                        match table
                            .runs(q.lod)
                            .filter(|_| node.is_leaf() && q.lod == node.first_lod)
                        {
                            Some(runs) => glb::Identity::Runs(runs),
                            None => match per_node[q.node as usize].as_slice() {
                                [one] => glb::Identity::One(*one),
                                _ => glb::Identity::None,
                            },
                        }
                    }
                    _ => glb::Identity::None,
                };
                levels.push(glb::Level {
                    stored: reader.read_lod_stored(q.lod)?,
                    identity,
                });
            }
            let c = glb::content(levels, records, skeleton.origin(), options.encoding).map_err(
                |detail| ExportError::Content {
                    tile: t,
                    first_lod: tile.parts[0].lod,
                    detail,
                },
            )?;
            if let Some(n) = options.fail_after_contents {
                if written.load(Ordering::Relaxed) >= n {
                    return Err(write_err(out)(std::io::Error::new(
                        std::io::ErrorKind::StorageFull,
                        "no space left on device (a test's failure)",
                    )));
                }
            }
            write_file(&out.join(tileset::content_path(t)), &c.bytes)?;
            written.fetch_add(1, Ordering::Relaxed);
            progress.advance(1);
            Ok((
                t,
                tileset::ContentInfo { bounds: c.bounds },
                c.bytes.len() as u64,
                c.triangles,
                c.features > 0,
            ))
        })
        .collect::<Result<_, ExportError>>()?;
    progress.finish("contents", phase.elapsed().as_secs_f64());

    let mut contents = vec![None; plan.tiles.len()];
    let mut summary = ExportSummary {
        tiles: plan.tiles.len(),
        contents: results.len(),
        identity: objects.is_some(),
        levels_left_out: plan.levels_left_out,
        ..ExportSummary::default()
    };
    let mut sizes = Vec::with_capacity(results.len());
    for (t, info, bytes, triangles, features) in results {
        sizes.push(triangles);
        contents[t as usize] = Some(info);
        summary.content_bytes += bytes;
        summary.triangles += triangles;
        summary.contents_with_features += features as usize;
    }
    sizes.sort_unstable();
    summary.median_content_triangles = sizes.get(sizes.len() / 2).copied().unwrap_or(0);
    summary.parts = plan.tiles.iter().map(|t| t.parts.len()).sum();
    summary.depth = depth(&plan);

    // Tileset files: the external ones, then the main one, last.
    let files = plan::files(&plan, options.tiles_per_file, options.depth_per_file);
    let origin = skeleton.origin();
    let root_transform = options.georef.frame() * DMat4::from_translation(georef::z_up(origin));
    let b = skeleton.bounds();
    let diagonal = (b.max - b.min).length();
    let writer = tileset::Writer {
        skeleton,
        plan: &plan,
        files: &files,
        contents: &contents,
        root_transform,
        top_error: diagonal.max(plan.tiles[0].error),
        quantum: tileset::Quantum::for_extent(diagonal),
    };
    if files.roots.len() > 1 {
        let d = out.join("tilesets");
        std::fs::create_dir_all(&d).map_err(write_err(&d))?;
    }
    let phase = Instant::now();
    progress.start("tilesets", files.roots.len() as u64);
    for &root in files.roots.iter().skip(1).chain(std::iter::once(&0)) {
        let json = serde_json::to_vec(&writer.file(root)).expect("JSON values serialize");
        let path = if root == 0 {
            out.join("tileset.json")
        } else {
            out.join(tileset::external_path(root))
        };
        if root == 0 {
            gigawalk_scene::write_atomic(&path, &json).map_err(write_err(&path))?;
        } else {
            write_file(&path, &json)?;
        }
        summary.json_bytes += json.len() as u64;
        summary.largest_json_bytes = summary.largest_json_bytes.max(json.len() as u64);
        progress.advance(1);
    }
    progress.finish("tilesets", phase.elapsed().as_secs_f64());
    summary.tileset_files = files.roots.len();
    Ok(summary)
}

/// The tree's depth in tiles.
fn depth(plan: &plan::Plan) -> usize {
    let mut d = vec![0usize; plan.tiles.len()];
    d[0] = 1;
    let mut deepest = 1;
    for t in 0..plan.tiles.len() {
        for &c in &plan.tiles[t].children {
            d[c as usize] = d[t] + 1;
            deepest = deepest.max(d[t] + 1);
        }
    }
    deepest
}
