//! Model import: glTF 2.0 and Wavefront OBJ into a flat [`Model`] of
//! [`Object`]s in f64 world coordinates.
//!
//! glTF files may be compressed as gltfpack writes them: integer positions
//! and normals (KHR_mesh_quantization) and meshopt-compressed buffer views
//! (EXT_meshopt_compression, KHR_meshopt_compression). Draco
//! (KHR_draco_mesh_compression) and any other required extension is an
//! error naming it.
//!
//! Main entry point: [`import`] (by file extension). Byte-level entry points
//! ([`import_gltf_bytes`], [`import_glb_bytes`], [`import_obj_str`]) serve
//! the fuzz targets and in-memory callers. Every failure is an
//! [`ImportError`] naming the file, the mesh/primitive or group, and the
//! index; bad input never panics.

mod error;
mod glb;
mod gltf_extensions;
mod gltf_import;
mod meshopt_views;
mod model;
mod obj_import;
mod triangles;

use std::path::Path;

pub use error::ImportError;
pub use gltf_import::{import_glb_bytes, import_gltf_bytes};
pub use model::{ImportStats, Model, Object};
pub use obj_import::import_obj_str;

/// Imports a `.gltf`, `.glb` or `.obj` file, chosen by extension
/// (case-insensitive). External glTF buffers and OBJ material libraries are
/// resolved relative to the file's directory.
pub fn import(path: &Path) -> Result<Model, ImportError> {
    let file = path.display().to_string();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let base_dir = path.parent().unwrap_or(Path::new("."));
    match ext.as_deref() {
        Some("gltf") | Some("glb") => {
            let bytes = read(path)?;
            gltf_import::import_gltf(&bytes, &file, Some(base_dir))
        }
        Some("obj") => {
            let bytes = read(path)?;
            let text = String::from_utf8_lossy(&bytes);
            obj_import::import_obj(&text, &file, Some(base_dir))
        }
        _ => Err(ImportError::UnsupportedFormat { file }),
    }
}

fn read(path: &Path) -> Result<Vec<u8>, ImportError> {
    std::fs::read(path).map_err(|source| ImportError::Io {
        file: path.display().to_string(),
        source,
    })
}
