//! Model import: glTF 2.0, Wavefront OBJ and IFC (through gigawalk-ifc:
//! one object per product, docs/ifc.md) into a flat [`Model`] of
//! [`Object`]s in f64 world coordinates.
//!
//! glTF files may be compressed as gltfpack writes them: integer positions
//! and normals (KHR_mesh_quantization) and meshopt-compressed buffer views
//! (EXT_meshopt_compression, KHR_meshopt_compression). Draco
//! (KHR_draco_mesh_compression) and any other required extension is an
//! error naming it.
//!
//! Main entry points: [`import`] (one file, by extension) and
//! [`import_all`] (several files and directories of them as one model). Byte-level entry points
//! ([`import_gltf_bytes`], [`import_glb_bytes`], [`import_obj_str`]) serve
//! the fuzz targets and in-memory callers. Every failure is an
//! [`ImportError`] naming the file, the mesh/primitive or group, and the
//! index; bad input never panics.

#![forbid(unsafe_code)]

mod error;
mod glb;
mod gltf_accessors;
mod gltf_buffers;
mod gltf_extensions;
mod gltf_import;
mod ifc_import;
mod meshopt_views;
mod model;
mod obj_import;
mod triangles;

use std::collections::HashSet;
use std::path::{Path, PathBuf};

pub use error::ImportError;
pub use gltf_import::{import_glb_bytes, import_gltf_bytes};
pub use model::{Identity, ImportStats, Model, Object, Unsupported};
pub use obj_import::import_obj_str;

/// Imports a `.gltf`, `.glb`, `.obj` or `.ifc` file, chosen by extension
/// (case-insensitive). External glTF buffers and OBJ material libraries are
/// resolved relative to the file's directory.
pub fn import(path: &Path) -> Result<Model, ImportError> {
    Model::collect(|sink| import_each(path, sink))
}

/// [`import`], handing each object to `sink` as it is read instead of
/// collecting them: a glTF file's bytes and one object are held at a
/// time (an OBJ file is parsed whole first). Returns the stats; a `sink`
/// error stops the import.
pub fn import_each(
    path: &Path,
    sink: &mut dyn FnMut(Object) -> Result<(), ImportError>,
) -> Result<ImportStats, ImportError> {
    let file = path.display().to_string();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let base_dir = path.parent().unwrap_or(Path::new("."));
    match ext.as_deref() {
        Some("gltf") | Some("glb") => {
            // A binary container is read in place; JSON is read whole.
            let io = |source| ImportError::Io {
                file: file.clone(),
                source,
            };
            let f = std::fs::File::open(path).map_err(io)?;
            let mut magic = [0u8; 4];
            let binary = {
                use std::os::unix::fs::FileExt as _;
                f.read_at(&mut magic, 0).map_err(io)? == 4 && &magic == b"glTF"
            };
            if binary && !f.metadata().map_err(io)?.is_dir() {
                gltf_import::import_glb_file_each(f, &file, Some(base_dir), sink)
            } else {
                let bytes = read(path)?;
                gltf_import::import_gltf_each(&bytes, &file, Some(base_dir), sink)
            }
        }
        Some("obj") => {
            let bytes = read(path)?;
            let text = String::from_utf8_lossy(&bytes);
            obj_import::import_obj_each(&text, &file, Some(base_dir), sink)
        }
        Some("ifc") => ifc_import::import_ifc_each(path, &file, sink),
        _ => Err(ImportError::UnsupportedFormat { file }),
    }
}

/// Whether `path` names a file [`import`] reads (by extension).
pub fn is_model_file(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| ["gltf", "glb", "obj", "ifc"].contains(&e.to_ascii_lowercase().as_str()))
}

/// The model files `inputs` name, in order: each file as given (whatever
/// its extension: [`import`] says what is wrong with it), and for each
/// directory the `.gltf`, `.glb`, `.obj` and `.ifc` files below it, recursively,
/// sorted by path so the order never depends on the file system. Hidden
/// entries (names starting with '.') are skipped, and a file reached
/// twice (named and inside a named directory, or through a link) is
/// listed once. A directory with no model file is an error naming it.
pub fn model_files(inputs: &[PathBuf]) -> Result<Vec<PathBuf>, ImportError> {
    let mut out = Vec::new();
    let mut seen = HashSet::new();
    let mut push = |p: PathBuf, out: &mut Vec<PathBuf>| {
        let key = std::fs::canonicalize(&p).unwrap_or_else(|_| p.clone());
        if seen.insert(key) {
            out.push(p);
        }
    };
    for input in inputs {
        if input.is_dir() {
            let mut found = Vec::new();
            let mut dirs = HashSet::new();
            walk(input, &mut found, &mut dirs)?;
            if found.is_empty() {
                return Err(ImportError::NoModelFiles {
                    dir: input.display().to_string(),
                });
            }
            found.sort();
            for f in found {
                push(f, &mut out);
            }
        } else {
            push(input.clone(), &mut out);
        }
    }
    Ok(out)
}

/// Model files under `dir` (unsorted); `dirs` holds the directories
/// visited, canonical, so a link cycle ends.
fn walk(
    dir: &Path,
    found: &mut Vec<PathBuf>,
    dirs: &mut HashSet<PathBuf>,
) -> Result<(), ImportError> {
    let io = |source| ImportError::Io {
        file: dir.display().to_string(),
        source,
    };
    if !dirs.insert(std::fs::canonicalize(dir).map_err(io)?) {
        return Ok(());
    }
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let path = entry.map_err(io)?.path();
        if path
            .file_name()
            .and_then(|n| n.to_str())
            .is_some_and(|n| n.starts_with('.'))
        {
            continue;
        }
        if path.is_dir() {
            walk(&path, found, dirs)?;
        } else if is_model_file(&path) {
            found.push(path);
        }
    }
    Ok(())
}

/// Imports several files as one model ([`model_files`] says which, and in
/// what order). With more than one file every object's name starts with
/// its file's path (`plant/unit2.glb/Pipe.003#prim0`). The first file
/// that fails stops the import with its error, which names it.
/// `each(i, n, path)` hears of each file before it is read.
pub fn import_all(
    inputs: &[PathBuf],
    each: &mut dyn FnMut(usize, usize, &Path),
) -> Result<Model, ImportError> {
    Model::collect(|sink| import_all_each(inputs, each, sink))
}

/// [`import_all`], handing each object to `sink` as it is read (as
/// [`import_each`] does), named as [`import_all`] names them.
pub fn import_all_each(
    inputs: &[PathBuf],
    each: &mut dyn FnMut(usize, usize, &Path),
    sink: &mut dyn FnMut(Object) -> Result<(), ImportError>,
) -> Result<ImportStats, ImportError> {
    let files = model_files(inputs)?;
    if files.is_empty() {
        return Err(ImportError::NoGeometry {
            file: "(no input files)".into(),
        });
    }
    if let [only] = files.as_slice() {
        each(0, 1, only);
        return import_each(only, sink);
    }
    let mut stats = ImportStats::default();
    for (i, f) in files.iter().enumerate() {
        each(i, files.len(), f);
        let label = f.display().to_string();
        let s = import_each(f, &mut |mut o| {
            o.name = format!("{label}/{}", o.name);
            sink(o)
        })?;
        stats.add(s);
    }
    Ok(stats)
}

fn read(path: &Path) -> Result<Vec<u8>, ImportError> {
    std::fs::read(path).map_err(|source| ImportError::Io {
        file: path.display().to_string(),
        source,
    })
}
