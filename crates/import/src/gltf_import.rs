//! glTF 2.0 (.gltf with external or data: buffers, .glb) import: flatten
//! the node hierarchy in f64, one object per mesh-primitive instance.
//!
//! The `gltf` crate parses and validates the document, but it stores node
//! transforms as f32, which loses centimetres 10^7 units from the origin; so
//! node transforms are read again as f64 from the raw JSON. Accessors are
//! read by hand (`gltf_accessors`), with every offset bounds-checked, rather
//! than with the crate's reader, so that a lying file gives an error instead
//! of a panic; buffers are loaded and meshopt views decoded in
//! `gltf_buffers`.
//!
//! Compressed files from gltfpack and friends: integer positions and normals
//! (KHR_mesh_quantization) go through the same accessor reader, which
//! dequantizes every integer type; meshopt-compressed buffer views are
//! decoded first (`meshopt_views`) and then read like any other view.
//! Required extensions are checked here (`gltf_extensions`), since the
//! `gltf` crate knows none of these.

use std::borrow::Cow;
use std::path::Path;

use glam::{DMat3, DMat4, DQuat, DVec3};
use gltf::mesh::Mode;
use gltf::Semantic;
use serde::Deserialize;

use crate::error::ImportError;
use crate::gltf_accessors::{bad_accessor, read_floats, read_indices};
use crate::gltf_buffers::{load_data, Buffer, BufferData};
use crate::gltf_extensions;
use crate::model::{ImportStats, Model, Object};
use crate::triangles::{finish, RawObject};
use crate::Identity;

/// Imports glTF from memory, JSON or binary (.glb, recognised by its magic).
/// `name` appears in error messages. External buffers (file URIs) are
/// resolved against `base_dir`; with `None` they are an error.
pub fn import_gltf_bytes(
    bytes: &[u8],
    name: &str,
    base_dir: Option<&Path>,
) -> Result<Model, ImportError> {
    import_gltf(bytes, name, base_dir)
}

/// Imports a binary glTF (.glb) held in memory; external buffers are an error.
pub fn import_glb_bytes(bytes: &[u8], name: &str) -> Result<Model, ImportError> {
    import_gltf(bytes, name, None)
}

/// Node transform fields, as f64. Unknown fields are ignored.
#[derive(Deserialize)]
struct RawNode {
    extras: Option<serde_json::Value>,
    matrix: Option<[f64; 16]>,
    translation: Option<[f64; 3]>,
    rotation: Option<[f64; 4]>,
    scale: Option<[f64; 3]>,
}

/// What the `gltf` crate drops: f64 node transforms and the extension
/// objects this importer reads itself.
#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
pub(crate) struct RawRoot {
    #[serde(default)]
    nodes: Vec<RawNode>,
    #[serde(default)]
    extensions_required: Vec<String>,
    #[serde(default)]
    pub(crate) buffers: Vec<RawExtensible>,
    #[serde(default)]
    pub(crate) buffer_views: Vec<RawExtensible>,
    #[serde(default)]
    meshes: Vec<RawMesh>,
}

/// Any object, for its `extensions`.
#[derive(Deserialize)]
pub(crate) struct RawExtensible {
    #[serde(default)]
    pub(crate) extensions: serde_json::Map<String, serde_json::Value>,
}

#[derive(Deserialize)]
struct RawMesh {
    #[serde(default)]
    primitives: Vec<RawExtensible>,
}

/// At most this many validation messages go into an error: a fuzzed file can
/// produce thousands, and the first few say what is wrong.
const MAX_VALIDATION_MESSAGES: usize = 5;

pub(crate) fn import_gltf(
    bytes: &[u8],
    file: &str,
    base_dir: Option<&Path>,
) -> Result<Model, ImportError> {
    Model::collect(|sink| import_gltf_each(bytes, file, base_dir, sink))
}

/// [`import_gltf`], handing each object to `sink` as it is read (only
/// the file's bytes and one object are held), in file order; returns the
/// stats. A `sink` error stops the import.
pub(crate) fn import_gltf_each(
    bytes: &[u8],
    file: &str,
    base_dir: Option<&Path>,
    sink: &mut dyn FnMut(Object) -> Result<(), ImportError>,
) -> Result<ImportStats, ImportError> {
    let malformed = |message: String| ImportError::MalformedGltf {
        file: file.to_owned(),
        message,
    };
    let glb;
    let (json_bytes, blob): (&[u8], Option<&[u8]>) = if bytes.starts_with(b"glTF") {
        // gltf's GLB splitter trusts the header's length field (see glb.rs).
        let container = crate::glb::check(bytes).map_err(malformed)?;
        glb = gltf::Glb::from_slice(container).map_err(|e| malformed(format!("{e}")))?;
        (&glb.json[..], glb.bin.as_deref())
    } else {
        (bytes, None)
    };
    let blob = blob.map(|b| Buffer::Bytes(Cow::Borrowed(b)));
    import_document(json_bytes, blob, file, base_dir, sink)
}

/// [`import_gltf_each`] for a binary glTF file read in place: only its
/// JSON is read whole, and each accessor's bytes when its primitive's turn
/// comes (all of the BIN chunk when a view is meshopt-compressed, since a
/// compressed view decodes whole).
pub(crate) fn import_glb_file_each(
    f: std::fs::File,
    file: &str,
    base_dir: Option<&Path>,
    sink: &mut dyn FnMut(Object) -> Result<(), ImportError>,
) -> Result<ImportStats, ImportError> {
    let (json, bin) = crate::glb::check_file(&f).map_err(|message| ImportError::MalformedGltf {
        file: file.to_owned(),
        message,
    })?;
    let blob = bin.map(|(at, len)| Buffer::File { file: f, at, len });
    import_document(&json, blob, file, base_dir, sink)
}

/// The glTF JSON and the GLB BIN chunk, if any, into objects for `sink`.
fn import_document(
    json_bytes: &[u8],
    blob: Option<Buffer<'_>>,
    file: &str,
    base_dir: Option<&Path>,
    sink: &mut dyn FnMut(Object) -> Result<(), ImportError>,
) -> Result<ImportStats, ImportError> {
    let malformed = |message: String| ImportError::MalformedGltf {
        file: file.to_owned(),
        message,
    };
    let mut root = gltf::json::deserialize::from_slice::<gltf::json::Root>(json_bytes)
        .map_err(|e| malformed(format!("{e}")))?;
    let raw: RawRoot = serde_json::from_slice(json_bytes)
        .map_err(|e| malformed(format!("node transforms and extensions: {e}")))?;
    gltf_extensions::check_required(&raw.extensions_required, file)?;
    // Checked above; the gltf crate would reject every one it does not know.
    root.extensions_required.clear();
    // gltf-json's primitive validation indexes the accessor list with the
    // POSITION index before checking it (gltf-json 1.4.1, mesh.rs), so a
    // bad index would panic there: check every attribute index first.
    for (mi, mesh) in root.meshes.iter().enumerate() {
        for (pi, prim) in mesh.primitives.iter().enumerate() {
            for index in prim.attributes.values() {
                if index.value() >= root.accessors.len() {
                    return Err(malformed(format!(
                        "meshes[{mi}].primitives[{pi}].attributes: accessor {} out of range ({} accessors)",
                        index.value(),
                        root.accessors.len()
                    )));
                }
            }
        }
    }
    check_draco_primitives(&root, &raw, file)?;
    let doc = gltf::Document::from_json(root).map_err(|e| match e {
        gltf::Error::Validation(errors) => {
            let mut m = String::new();
            for (path, err) in errors.iter().take(MAX_VALIDATION_MESSAGES) {
                m += &format!("{path}: {err}; ");
            }
            if errors.len() > MAX_VALIDATION_MESSAGES {
                m += &format!("and {} more", errors.len() - MAX_VALIDATION_MESSAGES);
            }
            malformed(m.trim_end_matches("; ").to_owned())
        }
        other => malformed(format!("{other}")),
    })?;
    if raw.nodes.len() != doc.nodes().len()
        || raw.buffers.len() != doc.buffers().len()
        || raw.buffer_views.len() != doc.views().len()
        || raw.meshes.len() != doc.meshes().len()
    {
        return Err(malformed(
            "node, buffer, bufferView or mesh list could not be re-read".into(),
        ));
    }

    let data = load_data(&doc, &raw, blob, file, base_dir)?;
    let mut stats = ImportStats::default();
    let mut objects = 0usize;

    // Roots: the default scene, else the first, else every parentless node.
    let roots: Vec<usize> = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(scene) => scene.nodes().map(|n| n.index()).collect(),
        None => {
            let mut has_parent = vec![false; doc.nodes().len()];
            for n in doc.nodes() {
                for c in n.children() {
                    has_parent[c.index()] = true;
                }
            }
            (0..has_parent.len()).filter(|&i| !has_parent[i]).collect()
        }
    };

    let nodes: Vec<gltf::Node> = doc.nodes().collect();
    let mut visited = vec![false; nodes.len()];
    // Depth-first in file order; a node reached twice (a cycle, or two
    // parents, both invalid glTF) is an error rather than endless recursion.
    let mut stack: Vec<(usize, DMat4, String)> = roots
        .iter()
        .rev()
        .map(|&i| (i, DMat4::IDENTITY, String::new()))
        .collect();
    while let Some((ni, parent, parent_path)) = stack.pop() {
        if visited[ni] {
            return Err(ImportError::BadNode {
                file: file.to_owned(),
                node: ni,
                reason: "reached twice: the node hierarchy has a cycle or a node with two parents"
                    .into(),
            });
        }
        visited[ni] = true;
        let world = parent * local_transform(&raw.nodes[ni], ni, file)?;
        let node = &nodes[ni];
        let step = match node.name() {
            Some(n) => n.to_owned(),
            None => format!("#{ni}"),
        };
        let path = if parent_path.is_empty() {
            step
        } else {
            format!("{parent_path}/{step}")
        };
        for c in node.children().collect::<Vec<_>>().iter().rev() {
            stack.push((c.index(), world, path.clone()));
        }
        let Some(mesh) = node.mesh() else { continue };
        let identity = Identity {
            name: node
                .name()
                .or(mesh.name())
                .map(str::to_owned)
                .unwrap_or_else(|| format!("node {ni}")),
            path,
            file: file.to_owned(),
            extras: raw.nodes[ni]
                .extras
                .as_ref()
                .filter(|e| !e.is_null())
                .map(|e| e.to_string()),
            node: Some(ni),
        };
        for prim in mesh.primitives() {
            if let Some(raw_obj) = read_primitive(
                node, &mesh, &prim, &world, &data, file, &mut stats, &identity,
            )? {
                if let Some(o) = finish(raw_obj, &mut stats) {
                    objects += 1;
                    sink(o)?;
                }
            }
        }
    }
    if objects == 0 {
        return Err(ImportError::NoGeometry {
            file: file.to_owned(),
        });
    }
    Ok(stats)
}

fn local_transform(n: &RawNode, index: usize, file: &str) -> Result<DMat4, ImportError> {
    let bad = |reason: &str| ImportError::BadNode {
        file: file.to_owned(),
        node: index,
        reason: reason.to_owned(),
    };
    let m = if let Some(m) = n.matrix {
        DMat4::from_cols_array(&m)
    } else {
        let t = DVec3::from_array(n.translation.unwrap_or([0.0; 3]));
        let r = n.rotation.unwrap_or([0.0, 0.0, 0.0, 1.0]);
        let q = DQuat::from_array(r);
        let len = q.length();
        if !(len.is_finite() && len > 0.0) {
            return Err(bad("rotation quaternion cannot be normalised"));
        }
        let s = DVec3::from_array(n.scale.unwrap_or([1.0; 3]));
        DMat4::from_scale_rotation_translation(s, q / len, t)
    };
    if !m.is_finite() {
        return Err(bad("transform is not finite"));
    }
    Ok(m)
}

/// A Draco primitive whose accessors have no uncompressed fallback (a
/// file that lists the extension only as used, not required) would
/// otherwise fail validation as "missing data"; name the extension
/// instead. Runs before validation, on attribute indices already checked.
fn check_draco_primitives(
    root: &gltf::json::Root,
    raw: &RawRoot,
    file: &str,
) -> Result<(), ImportError> {
    for (mesh, raw_mesh) in root.meshes.iter().zip(&raw.meshes) {
        for (prim, raw_prim) in mesh.primitives.iter().zip(&raw_mesh.primitives) {
            if raw_prim.extensions.contains_key(gltf_extensions::DRACO)
                && prim
                    .attributes
                    .values()
                    .any(|a| root.accessors[a.value()].buffer_view.is_none())
            {
                return Err(gltf_extensions::unsupported(gltf_extensions::DRACO, file));
            }
        }
    }
    Ok(())
}

fn object_label(node: &gltf::Node, mesh: &gltf::Mesh, prim: usize) -> String {
    let node_name = node
        .name()
        .map(|n| format!("node \"{n}\" ({})", node.index()));
    let mesh_name = match mesh.name() {
        Some(n) => format!("mesh \"{n}\" ({})", mesh.index()),
        None => format!("mesh {}", mesh.index()),
    };
    match node_name {
        Some(n) => format!("{n} {mesh_name} primitive {prim}"),
        None => format!("node {} {mesh_name} primitive {prim}", node.index()),
    }
}

#[allow(clippy::too_many_arguments)]
fn read_primitive(
    node: &gltf::Node,
    mesh: &gltf::Mesh,
    prim: &gltf::Primitive,
    world: &DMat4,
    data: &BufferData,
    file: &str,
    stats: &mut ImportStats,
    identity: &Identity,
) -> Result<Option<RawObject>, ImportError> {
    let object = object_label(node, mesh, prim.index());
    match prim.mode() {
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan => {}
        Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip => {
            stats.skipped_primitives += 1;
            return Ok(None);
        }
    }
    let empty = |reason: &str| ImportError::EmptyMesh {
        file: file.to_owned(),
        object: object.clone(),
        reason: reason.to_owned(),
    };
    let pos_acc = prim
        .get(&Semantic::Positions)
        .ok_or_else(|| empty("no POSITION attribute"))?;
    let local = read_floats(&pos_acc, 3, data, file, &object, "POSITION")?;
    let n = local.len() / 3;
    if n == 0 {
        return Err(empty("no vertices"));
    }
    let mut positions = Vec::with_capacity(n);
    for v in 0..n {
        let p = DVec3::new(
            local[3 * v] as f64,
            local[3 * v + 1] as f64,
            local[3 * v + 2] as f64,
        );
        let w = world.transform_point3(p);
        if !p.is_finite() || !w.is_finite() {
            return Err(ImportError::NonFinitePosition {
                file: file.to_owned(),
                object,
                vertex: v,
                position: if p.is_finite() {
                    w.to_array()
                } else {
                    p.to_array()
                },
            });
        }
        positions.push(w);
    }

    let normals = match prim.get(&Semantic::Normals) {
        Some(acc) => {
            let raw = read_floats(&acc, 3, data, file, &object, "NORMAL")?;
            if raw.len() / 3 != n {
                return Err(bad_accessor(
                    file,
                    &object,
                    &acc,
                    "NORMAL",
                    format!("{} normals for {n} positions", raw.len() / 3),
                ));
            }
            let nm = DMat3::from_mat4(*world).inverse().transpose();
            Some(
                raw.chunks_exact(3)
                    .map(|c| nm * DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64))
                    .collect(),
            )
        }
        None => None,
    };

    let vertex_colours = match prim.get(&Semantic::Colors(0)) {
        Some(acc) => {
            let dims = acc.dimensions().multiplicity();
            if dims != 3 && dims != 4 {
                return Err(bad_accessor(
                    file,
                    &object,
                    &acc,
                    "COLOR_0",
                    "must be VEC3 or VEC4".into(),
                ));
            }
            let raw = read_floats(&acc, dims, data, file, &object, "COLOR_0")?;
            if raw.len() / dims != n {
                return Err(bad_accessor(
                    file,
                    &object,
                    &acc,
                    "COLOR_0",
                    format!("{} colours for {n} positions", raw.len() / dims),
                ));
            }
            Some(
                raw.chunks_exact(dims)
                    .map(|c| [c[0], c[1], c[2], if dims == 4 { c[3] } else { 1.0 }])
                    .collect(),
            )
        }
        None => None,
    };

    let source: Vec<u32> = match prim.indices() {
        Some(acc) => read_indices(&acc, data, file, &object)?,
        None => (0..n as u32).collect(),
    };
    for (position, &value) in source.iter().enumerate() {
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
    let mut indices = to_triangle_list(prim.mode(), &source);
    if indices.is_empty() {
        return Err(empty("no triangles"));
    }
    // A mirroring transform turns counter-clockwise front faces clockwise.
    if world.determinant() < 0.0 {
        for t in indices.chunks_exact_mut(3) {
            t.swap(1, 2);
        }
    }
    let colour = prim.material().pbr_metallic_roughness().base_color_factor();
    Ok(Some(RawObject {
        name: object,
        identity: identity.clone(),
        positions,
        normals,
        indices,
        colour,
        vertex_colours,
    }))
}

/// Strips alternate winding so every triangle keeps the strip's
/// orientation (glTF 2.0 spec, section 3.7.2.1).
fn to_triangle_list(mode: Mode, s: &[u32]) -> Vec<u32> {
    match mode {
        Mode::Triangles => s[..s.len() / 3 * 3].to_vec(),
        Mode::TriangleStrip => {
            let mut out = Vec::with_capacity(s.len().saturating_sub(2) * 3);
            for i in 0..s.len().saturating_sub(2) {
                if i % 2 == 0 {
                    out.extend_from_slice(&[s[i], s[i + 1], s[i + 2]]);
                } else {
                    out.extend_from_slice(&[s[i + 1], s[i], s[i + 2]]);
                }
            }
            out
        }
        Mode::TriangleFan => {
            let mut out = Vec::with_capacity(s.len().saturating_sub(2) * 3);
            for i in 1..s.len().saturating_sub(1) {
                out.extend_from_slice(&[s[0], s[i], s[i + 1]]);
            }
            out
        }
        _ => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strip_keeps_orientation() {
        assert_eq!(
            to_triangle_list(Mode::TriangleStrip, &[0, 1, 2, 3]),
            vec![0, 1, 2, 2, 1, 3]
        );
    }

    #[test]
    fn fan_pivots_on_first_vertex() {
        assert_eq!(
            to_triangle_list(Mode::TriangleFan, &[0, 1, 2, 3]),
            vec![0, 1, 2, 0, 2, 3]
        );
    }

    #[test]
    fn too_short_strip_is_empty() {
        assert!(to_triangle_list(Mode::TriangleStrip, &[0, 1]).is_empty());
        assert!(to_triangle_list(Mode::TriangleFan, &[]).is_empty());
    }
}
