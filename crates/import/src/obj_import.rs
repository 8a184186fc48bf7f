//! Wavefront OBJ import with `tobj`: each group/object becomes an object,
//! its material's `Kd` the colour. A missing .mtl is a warning.
//!
//! `tobj` reports a bad face index or a NaN vertex without saying where, so
//! a cheap pre-scan of the text finds the line, group and index first. The
//! pre-scan is also what keeps tobj 4.0.5 from panicking: it resolves a
//! relative index that points before the first element to a huge `usize`
//! (and index 0 to "missing") and then computes `vt * 2 + 1` and
//! `vn * 3 + 2` on it unchecked (lib.rs, `add_vertex`), which overflows in
//! debug builds; only the position index is bounds-checked with saturating
//! arithmetic. So every position, texcoord and normal index of `f` and `l`
//! lines is checked here against the counts defined before it.
//!
//! tobj's .mtl parser unwraps a colour line with fewer than three values
//! (`Kd 1 1`, lib.rs `parse_float3`), a panic in every build, so material
//! libraries are read and checked here (`load_mtl`) before tobj parses them.

use std::cell::RefCell;
use std::io::BufRead as _;
use std::path::Path;

use glam::DVec3;

use crate::error::ImportError;
use crate::model::{ImportStats, Model, Object};
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
    Model::collect(|sink| import_obj_each(text, file, base_dir, sink))
}

/// [`import_obj`], handing each object to `sink` as it is converted, in
/// file order (tobj reads the whole text first); returns the stats.
pub(crate) fn import_obj_each(
    text: &str,
    file: &str,
    base_dir: Option<&Path>,
    sink: &mut dyn FnMut(Object) -> Result<(), ImportError>,
) -> Result<ImportStats, ImportError> {
    prescan(text, file)?;
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let mut reader = std::io::BufReader::new(text.as_bytes());
    // Material libraries that fail our check, with the reason.
    let mtl_problems = RefCell::new(Vec::new());
    let (models, materials) = tobj::load_obj_buf(&mut reader, &options, |mtl| match base_dir {
        Some(dir) => load_mtl(&dir.join(mtl), &mtl_problems),
        None => Err(tobj::LoadError::OpenFileFailed),
    })
    .map_err(|e| ImportError::MalformedObj {
        file: file.to_owned(),
        message: e.to_string(),
    })?;
    let mut stats = ImportStats::default();
    let mtl_problems = mtl_problems.into_inner();
    for problem in &mtl_problems {
        stats.warnings.push(format!(
            "{file}: material library not loaded ({problem}); objects using it get the default colour"
        ));
    }
    let materials = match materials {
        Ok(m) => m,
        Err(e) => {
            if mtl_problems.is_empty() && text.lines().any(|l| l.trim_start().starts_with("mtllib"))
            {
                stats.warnings.push(format!(
                    "{file}: material library not loaded ({e}); objects get the default colour"
                ));
            }
            Vec::new()
        }
    };

    let mut objects = 0usize;
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
            identity: crate::Identity {
                name: m.name.clone(),
                path: m.name.clone(),
                file: file.to_owned(),
                extras: None,
                node: None,
            },
            name: m.name,
            positions,
            normals,
            indices: mesh.indices,
            colour,
            vertex_colours,
        };
        if let Some(o) = finish(raw, &mut stats) {
            objects += 1;
            sink(o)?;
        }
    }
    if objects == 0 {
        return Err(ImportError::NoGeometry {
            file: file.to_owned(),
        });
    }
    Ok(stats)
}

/// Reads a material library for tobj, first checking what tobj's parser
/// would panic on; a problem is recorded in `problems` (becoming a warning)
/// and the library is not loaded.
fn load_mtl(path: &Path, problems: &RefCell<Vec<String>>) -> tobj::MTLLoadResult {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::InvalidData => {
            return Err(tobj::LoadError::ReadError)
        }
        Err(_) => return Err(tobj::LoadError::OpenFileFailed),
    };
    if let Err(reason) = check_mtl(&text) {
        problems
            .borrow_mut()
            .push(format!("{}: {reason}", path.display()));
        return Err(tobj::LoadError::MaterialParseError);
    }
    tobj::load_mtl_buf(&mut text.as_bytes())
}

/// tobj 4.0.5 `parse_float3` collects at most three words of a colour line
/// and unwraps them into an array, so a line with fewer panics. Lines are
/// split as tobj splits them (`BufRead::lines`, then whitespace).
fn check_mtl(text: &str) -> Result<(), String> {
    for (i, line) in text.as_bytes().lines().enumerate() {
        let Ok(line) = line else { break };
        let mut words = line.split_whitespace();
        if let Some(key @ ("Ka" | "Kd" | "Ks" | "Ke")) = words.next() {
            let values = words.count();
            if values < 3 {
                return Err(format!(
                    "line {}: {key} needs 3 values, found {values}",
                    i + 1
                ));
            }
        }
    }
    Ok(())
}

/// What a face element's slots index, with the count defined so far.
#[derive(Clone, Copy)]
enum Slot {
    Position,
    Texcoord,
    Normal,
}

/// Finds the first non-finite vertex or out-of-range face index, naming the
/// line, group and index, before tobj reports either without a location
/// (or, for texcoord and normal indices, overflows on them; see the module
/// comment). Counts elements as tobj does: every `v`, `vt` and `vn` line
/// adds one (one that tobj cannot parse stops the import there anyway).
/// Indices resolve as in the OBJ format: 1-based, negative ones counting
/// back from the latest element, and only elements defined earlier in the
/// file count.
fn prescan(text: &str, file: &str) -> Result<(), ImportError> {
    let mut vertices = 0usize;
    let mut texcoords = 0usize;
    let mut normals = 0usize;
    let mut group = String::from("default");
    for (i, line) in std::io::BufReader::new(text.as_bytes()).lines().enumerate() {
        let Ok(line) = line else { break };
        let line_no = i + 1;
        let mut words = line.split_whitespace();
        let what = match words.next() {
            Some("o") | Some("g") => {
                group = words.collect::<Vec<_>>().join(" ");
                continue;
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
                continue;
            }
            Some("vt") => {
                texcoords += 1;
                continue;
            }
            Some("vn") => {
                normals += 1;
                continue;
            }
            // tobj reads `l` lines as faces too (a degenerate triangle).
            Some("f") => "face",
            Some("l") => "line element",
            _ => continue,
        };
        for (position, w) in words.enumerate() {
            // tobj reads at most three slots (more is its parse error).
            let slots = [Slot::Position, Slot::Texcoord, Slot::Normal];
            for (slot, part) in slots.into_iter().zip(w.split('/')) {
                if part.is_empty() {
                    continue; // absent, as the texcoord in `1//2`
                }
                let Ok(index) = part.parse::<i64>() else {
                    continue; // malformed: let tobj word the error
                };
                let count = match slot {
                    Slot::Position => vertices,
                    Slot::Texcoord => texcoords,
                    Slot::Normal => normals,
                };
                let resolved = if index < 0 {
                    count as i64 + index
                } else {
                    index - 1
                };
                if resolved >= 0 && resolved < count as i64 {
                    continue;
                }
                let file = file.to_owned();
                let object = format!("group \"{group}\" {what} at line {line_no}");
                return Err(match slot {
                    Slot::Position => ImportError::IndexOutOfRange {
                        file,
                        object,
                        position,
                        value: index,
                        vertices,
                    },
                    Slot::Texcoord | Slot::Normal => ImportError::ObjIndexOutOfRange {
                        file,
                        object,
                        kind: if matches!(slot, Slot::Texcoord) {
                            "texcoord"
                        } else {
                            "normal"
                        },
                        position,
                        value: index,
                        count,
                    },
                });
            }
        }
    }
    Ok(())
}
