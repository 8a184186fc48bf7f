//! Wavefront OBJ import with `tobj`: each group/object becomes an object,
//! its material's `Kd` the colour. A missing .mtl is a warning.
//!
//! `tobj` reports a bad face index or a NaN vertex without saying where, so
//! a cheap pre-scan of the text finds the line, group and index first.

use std::io::BufRead as _;
use std::path::Path;

use glam::DVec3;

use crate::error::ImportError;
use crate::model::{ImportStats, Model};
use crate::triangles::{finish, RawObject};

/// Colour of objects without a material (tobj gives none, or the .mtl is
/// missing): a neutral light grey.
const DEFAULT_COLOUR: [f32; 4] = [0.8, 0.8, 0.8, 1.0];

/// Imports OBJ text held in memory; `mtllib` references cannot be resolved
/// and become warnings. `name` appears in error messages.
pub fn import_obj_str(text: &str, name: &str) -> Result<Model, ImportError> {
    import_obj(text, name, None)
}

pub(crate) fn import_obj(
    text: &str,
    file: &str,
    base_dir: Option<&Path>,
) -> Result<Model, ImportError> {
    prescan(text, file)?;
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let mut reader = std::io::BufReader::new(text.as_bytes());
    let (models, materials) = tobj::load_obj_buf(&mut reader, &options, |mtl| match base_dir {
        Some(dir) => tobj::load_mtl(dir.join(mtl)),
        None => Err(tobj::LoadError::OpenFileFailed),
    })
    .map_err(|e| ImportError::MalformedObj {
        file: file.to_owned(),
        message: e.to_string(),
    })?;
    let mut stats = ImportStats::default();
    let materials = match materials {
        Ok(m) => m,
        Err(e) => {
            if text.lines().any(|l| l.trim_start().starts_with("mtllib")) {
                stats.warnings.push(format!(
                    "{file}: material library not loaded ({e}); objects get the default colour"
                ));
            }
            Vec::new()
        }
    };

    let mut objects = Vec::new();
    for m in models {
        let object = format!("group \"{}\"", m.name);
        let mesh = m.mesh;
        let n = mesh.positions.len() / 3;
        if mesh.indices.is_empty() {
            // tobj emits a model for a group that only names a material or
            // holds lines/points; there is nothing to draw in it.
            stats.skipped_primitives += 1;
            continue;
        }
        let positions: Vec<DVec3> = mesh
            .positions
            .chunks_exact(3)
            .map(|c| DVec3::new(c[0], c[1], c[2]))
            .collect();
        for (vertex, p) in positions.iter().enumerate() {
            if !p.is_finite() {
                return Err(ImportError::NonFinitePosition {
                    file: file.to_owned(),
                    object,
                    vertex,
                    position: p.to_array(),
                });
            }
        }
        for (position, &value) in mesh.indices.iter().enumerate() {
            if value as usize >= n {
                return Err(ImportError::IndexOutOfRange {
                    file: file.to_owned(),
                    object,
                    position,
                    value: value as i64,
                    vertices: n,
                });
            }
        }
        let normals = (mesh.normals.len() == mesh.positions.len()).then(|| {
            mesh.normals
                .chunks_exact(3)
                .map(|c| DVec3::new(c[0], c[1], c[2]))
                .collect()
        });
        let vertex_colours = (mesh.vertex_color.len() == mesh.positions.len()).then(|| {
            mesh.vertex_color
                .chunks_exact(3)
                .map(|c| [c[0] as f32, c[1] as f32, c[2] as f32, 1.0])
                .collect()
        });
        let colour = mesh
            .material_id
            .and_then(|id| materials.get(id))
            .and_then(|mat| mat.diffuse)
            .map(|d| [d[0] as f32, d[1] as f32, d[2] as f32, 1.0])
            .unwrap_or(DEFAULT_COLOUR);
        let raw = RawObject {
            name: m.name,
            positions,
            normals,
            indices: mesh.indices,
            colour,
            vertex_colours,
        };
        if let Some(o) = finish(raw, &mut stats) {
            objects.push(o);
        }
    }
    if objects.is_empty() {
        return Err(ImportError::NoGeometry {
            file: file.to_owned(),
        });
    }
    Ok(Model { objects, stats })
}

/// Finds the first non-finite vertex or out-of-range face index, naming the
/// line, group and index, before tobj reports either without a location.
fn prescan(text: &str, file: &str) -> Result<(), ImportError> {
    let mut vertices = 0usize;
    let mut group = String::from("default");
    for (i, line) in std::io::BufReader::new(text.as_bytes()).lines().enumerate() {
        let Ok(line) = line else { break };
        let line_no = i + 1;
        let mut words = line.split_whitespace();
        match words.next() {
            Some("o") | Some("g") => {
                group = words.collect::<Vec<_>>().join(" ");
            }
            Some("v") => {
                let coords: Vec<f64> = words.take(3).filter_map(|w| w.parse().ok()).collect();
                if coords.iter().any(|c| !c.is_finite()) {
                    let mut p = [0.0; 3];
                    for (k, c) in coords.iter().enumerate() {
                        p[k] = *c;
                    }
                    return Err(ImportError::NonFinitePosition {
                        file: file.to_owned(),
                        object: format!("group \"{group}\" (line {line_no})"),
                        vertex: vertices,
                        position: p,
                    });
                }
                vertices += 1;
            }
            Some("f") => {
                for (position, w) in words.enumerate() {
                    let Some(Ok(index)) = w.split('/').next().map(|s| s.parse::<i64>()) else {
                        continue; // malformed: let tobj word the error
                    };
                    // OBJ indices are 1-based; negative ones count back from
                    // the latest vertex.
                    let resolved = if index < 0 {
                        vertices as i64 + index
                    } else {
                        index - 1
                    };
                    if resolved < 0 || resolved >= vertices as i64 {
                        return Err(ImportError::IndexOutOfRange {
                            file: file.to_owned(),
                            object: format!("group \"{group}\" face at line {line_no}"),
                            position,
                            value: index,
                            vertices,
                        });
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}
