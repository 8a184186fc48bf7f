//! One tile's content: one LOD of the scene as a binary glTF 2.0 (.glb)
//! with one mesh of one primitive under one node.
//!
//! The node carries where the LOD lies relative to the tileset's root
//! (its origin minus the scene origin, in f64), so vertices stay small
//! numbers near the LOD's own centre and a model far from its origin keeps
//! precision. With [`Encoding::Meshopt`] or [`Encoding::Quantized`] an
//! encoded LOD's positions go out exactly as the scene stores them: its
//! 16-bit grid coordinates (KHR_mesh_quantization), with the grid's origin
//! and step as the node's translation and scale, so a client draws the
//! geometry the stored errors were measured on. Object identity goes out
//! as EXT_mesh_features (a feature ID per vertex) over an
//! EXT_structural_metadata property table of the content's objects.

use std::collections::HashMap;

use bytemuck::Pod;
use gigawalk_scene::objects::{ObjectRecord, ObjectRun};
use gigawalk_scene::{Aabb, Colours, StoredLod};
use glam::DVec3;
use serde_json::{json, Map, Value};

/// How a content's vertex and index data are stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// Integer positions and normals (KHR_mesh_quantization) in buffer
    /// views compressed by meshoptimizer's codecs (EXT_meshopt_compression),
    /// as gltfpack writes them. Both extensions are required.
    Meshopt,
    /// Integer positions and normals (KHR_mesh_quantization), uncompressed.
    Quantized,
    /// Core glTF only: f32 positions and normals.
    Plain,
}

impl Encoding {
    pub fn name(self) -> &'static str {
        match self {
            Encoding::Meshopt => "meshopt",
            Encoding::Quantized => "quantized",
            Encoding::Plain => "plain",
        }
    }
}

/// Which objects a content's triangles belong to.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Identity<'a> {
    /// Not known per triangle (a level that merges several objects).
    None,
    /// Every triangle belongs to this object (a node of one object).
    One(u32),
    /// A leaf's full detail: consecutive runs of triangles per object.
    Runs(&'a [ObjectRun]),
}

/// A written content and what the tileset says of it.
pub(crate) struct Content {
    pub bytes: Vec<u8>,
    /// The box of its vertices, world coordinates.
    pub bounds: Aabb,
    pub triangles: u64,
    /// How many objects its feature IDs tell apart (0: none).
    pub features: usize,
}

/// A LOD's positions as the content stores them.
enum Positions {
    /// Grid coordinates (the 4th always 0, padding to 8 bytes), to be
    /// scaled by `scale` and moved by the node's translation.
    Grid {
        q: Vec<[u16; 4]>,
        /// The grid's origin relative to the scene origin.
        translation: DVec3,
        scale: [f32; 3],
    },
    /// f32 offsets from `translation` (the LOD's origin relative to the
    /// scene origin).
    Float {
        p: Vec<[f32; 3]>,
        translation: DVec3,
    },
}

/// A LOD's streams after the split by object.
struct Streams {
    positions: Positions,
    normals: Vec<[f32; 3]>,
    colours: Option<Vec<[u8; 4]>>,
    uniform: [u8; 4],
    indices: Vec<u32>,
    /// The stored normals' bits (8 or 16).
    normal_bits: u8,
}

/// One stored level of a content and what is known of its objects.
pub(crate) struct Level<'a> {
    pub stored: StoredLod,
    pub identity: Identity<'a>,
}

/// A level's vertices as they join its group's streams.
struct Placed {
    /// Its group (see [`Key`]).
    key: Key,
    /// The node that places it: translation from the scene origin, and
    /// the grid's step (1 for f32 positions).
    translation: DVec3,
    scale: [f32; 3],
    /// Indices, rebased to the group's vertices.
    indices: Vec<u32>,
    /// The distinct features its vertices carry (0: none).
    features: usize,
    material: usize,
}

/// Levels whose vertices can share streams: positions on a 16-bit grid or
/// f32, wide normals, per-vertex colours, feature IDs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Key {
    grid: bool,
    wide_normals: bool,
    colours: bool,
    features: bool,
}

/// One group's streams: every vertex of its levels, level after level.
#[derive(Default)]
struct Group {
    q: Vec<[u16; 4]>,
    p: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    colours: Vec<[u8; 4]>,
    features: Vec<u32>,
}

impl Group {
    fn len(&self) -> usize {
        self.normals.len()
    }
}

/// `levels` as one .glb: one node and mesh per level (each level keeps
/// its own grid, so the node's scale and translation place it exactly),
/// the levels' vertices in one set of streams per [`Key`], their indices
/// in one stream per index width, and one property table of every object
/// the content's feature IDs name. `origin` is the scene origin the
/// tileset's root sits at; `objects` the scene's object table when
/// identity is known.
pub(crate) fn content(
    levels: Vec<Level>,
    objects: Option<&[ObjectRecord]>,
    origin: DVec3,
    encoding: Encoding,
) -> Result<Content, String> {
    // Per level: its streams and its triangles' objects.
    let mut prepared = Vec::with_capacity(levels.len());
    let mut triangles = 0u64;
    for level in levels {
        let s = streams(level.stored, origin, encoding);
        let n = s.indices.len() / 3;
        if n == 0 {
            continue;
        }
        triangles += n as u64;
        let per_triangle: Option<Vec<u32>> = match (level.identity, objects) {
            (Identity::None, _) | (_, None) => None,
            (Identity::One(o), Some(_)) => Some(vec![o; n]),
            (Identity::Runs(runs), Some(_)) => {
                let mut t = Vec::with_capacity(n);
                for r in runs {
                    t.extend(std::iter::repeat_n(r.object, r.triangles as usize));
                }
                (t.len() == n).then_some(t)
            }
        };
        prepared.push((s, per_triangle));
    }
    if triangles == 0 {
        return Err("the levels have no triangles".into());
    }
    // The content's objects in id order: row i of its property table is
    // feature ID i.
    let mut ids: Vec<u32> = prepared
        .iter()
        .filter_map(|(_, t)| t.as_ref())
        .flatten()
        .copied()
        .collect();
    ids.sort_unstable();
    ids.dedup();

    let mut groups: std::collections::BTreeMap<Key, Group> = Default::default();
    let mut placed = Vec::with_capacity(prepared.len());
    let mut materials: Vec<[f32; 4]> = Vec::new();
    let mut bounds = Aabb::EMPTY;
    for (mut s, per_triangle) in prepared {
        let feature_of_vertex = per_triangle.map(|t| {
            let local: Vec<u32> = t
                .iter()
                .map(|o| ids.binary_search(o).unwrap_or(0) as u32)
                .collect();
            split_by_feature(&mut s, &local)
        });
        bounds = bounds.union(&bounds_of(&s.positions, origin));
        let (translation, scale) = match &s.positions {
            Positions::Grid {
                translation, scale, ..
            } => (*translation, *scale),
            Positions::Float { translation, .. } => (*translation, [1.0; 3]),
        };
        let anisotropy = {
            let (lo, hi) = scale
                .iter()
                .fold((f32::MAX, 0f32), |(lo, hi), &x| (lo.min(x), hi.max(x)));
            hi / lo.max(f32::MIN_POSITIVE)
        };
        // 8 bits where the scene stores 8 and the scale's anisotropy (which
        // multiplies a stored normal's angular error by at most itself) is
        // at most 4: within 1.6 degrees, about what the scene's 8 bits give
        // (0.4); else 16.
        let key = Key {
            grid: matches!(s.positions, Positions::Grid { .. }),
            wide_normals: encoding != Encoding::Plain && (s.normal_bits > 8 || anisotropy > 4.0),
            colours: s.colours.is_some(),
            features: feature_of_vertex.is_some(),
        };
        let g = groups.entry(key).or_default();
        let base = g.len();
        match s.positions {
            Positions::Grid { q, .. } => g.q.extend(q),
            Positions::Float { p, .. } => g.p.extend(p),
        }
        // Under a non-uniform node scale a client transforms normals by
        // the inverse transpose, diag(1 / scale), so each is stored
        // multiplied by the scale and renormalized, which that undoes.
        g.normals.extend(s.normals.iter().map(|n| {
            let v = glam::Vec3::from(*n) * glam::Vec3::from(scale);
            v.try_normalize().unwrap_or(glam::Vec3::Y).to_array()
        }));
        let mut colour = [1.0f32; 4];
        match &s.colours {
            Some(c) => g.colours.extend_from_slice(c),
            None => {
                for (b, c) in colour.iter_mut().zip(s.uniform).take(3) {
                    *b = srgb_to_linear(c);
                }
            }
        }
        let mut features = 0;
        if let Some(fv) = feature_of_vertex {
            let mut used = fv.clone();
            used.sort_unstable();
            used.dedup();
            features = used.len();
            g.features.extend(fv);
        }
        let material = match materials.iter().position(|m| *m == colour) {
            Some(m) => m,
            None => {
                materials.push(colour);
                materials.len() - 1
            }
        };
        placed.push(Placed {
            key,
            translation,
            scale,
            indices: s.indices.iter().map(|&i| i + base as u32).collect(),
            features,
            material,
        });
    }

    let mut b = Builder::new(encoding == Encoding::Meshopt);
    // Vertex streams, group by group.
    let wide_ids = ids.len() > u16::MAX as usize;
    let mut group_attributes: std::collections::BTreeMap<Key, (Map<String, Value>, usize)> =
        Default::default();
    for (key, g) in &groups {
        let nv = g.len();
        let mut attributes = Map::new();
        if key.grid {
            let (lo, hi) = extent_u16(&g.q);
            let v = b.vertex_view(&g.q, None)?;
            attributes.insert(
                "POSITION".into(),
                json!(b.accessor(v, U16, false, nv, "VEC3", Some((json!(lo), json!(hi))))),
            );
        } else {
            let (lo, hi) = extent_f32(&g.p);
            let v = b.vertex_view(&g.p, None)?;
            attributes.insert(
                "POSITION".into(),
                json!(b.accessor(v, F32, false, nv, "VEC3", Some((json!(lo), json!(hi))))),
            );
        }
        let normals = &g.normals;
        let normal_accessor = match encoding {
            Encoding::Plain => {
                let v = b.vertex_view(normals, None)?;
                b.accessor(v, F32, false, nv, "VEC3", None)
            }
            Encoding::Quantized => {
                if key.wide_normals {
                    let q: Vec<[i16; 4]> = normals.iter().map(|n| snorm16(*n)).collect();
                    let v = b.vertex_view(&q, None)?;
                    b.accessor(v, I16, true, nv, "VEC3", None)
                } else {
                    let q: Vec<[i8; 4]> = normals.iter().map(|n| snorm8(*n)).collect();
                    let v = b.vertex_view(&q, None)?;
                    b.accessor(v, I8, true, nv, "VEC3", None)
                }
            }
            Encoding::Meshopt => {
                let n4: Vec<[f32; 4]> = normals.iter().map(|n| [n[0], n[1], n[2], 0.0]).collect();
                if key.wide_normals {
                    let q = meshopt::encode_filter_oct::<i16>(&n4, 16);
                    let v = b.vertex_view(&q, Some("OCTAHEDRAL"))?;
                    b.accessor(v, I16, true, nv, "VEC3", None)
                } else {
                    let q = meshopt::encode_filter_oct::<i8>(&n4, 8);
                    let v = b.vertex_view(&q, Some("OCTAHEDRAL"))?;
                    b.accessor(v, I8, true, nv, "VEC3", None)
                }
            }
        };
        attributes.insert("NORMAL".into(), json!(normal_accessor));
        if key.colours {
            // sRGB bytes in the scene, linear in glTF; 16 bits keep the
            // dark shades 8 linear bits would band.
            let lin: Vec<[u16; 4]> = g
                .colours
                .iter()
                .map(|c| {
                    [
                        linear16(c[0]),
                        linear16(c[1]),
                        linear16(c[2]),
                        u16::MAX, // opaque: the scene draws every level opaque
                    ]
                })
                .collect();
            let v = b.vertex_view(&lin, None)?;
            attributes.insert(
                "COLOR_0".into(),
                json!(b.accessor(v, U16, true, nv, "VEC4", None)),
            );
        }
        if key.features {
            // A u16 padded to 4 bytes, as vertex data must be.
            let acc = if !wide_ids {
                let d: Vec<[u16; 2]> = g.features.iter().map(|&f| [f as u16, 0]).collect();
                let v = b.vertex_view(&d, None)?;
                b.accessor(v, U16, false, nv, "SCALAR", None)
            } else {
                let d: Vec<f32> = g.features.iter().map(|&f| f as f32).collect();
                let v = b.vertex_view(&d, None)?;
                b.accessor(v, F32, false, nv, "SCALAR", None)
            };
            attributes.insert("_FEATURE_ID_0".into(), json!(acc));
        }
        group_attributes.insert(*key, (attributes, nv));
    }

    // Indices: one stream of 16-bit ones (levels whose group has at most
    // 65,536 vertices) and one of 32-bit, an accessor per level into it.
    let narrow_of = |p: &Placed| group_attributes[&p.key].1 <= u16::MAX as usize + 1;
    let mut index_accessors = vec![0usize; placed.len()];
    for narrow in [true, false] {
        let levels: Vec<usize> = (0..placed.len())
            .filter(|&i| narrow_of(&placed[i]) == narrow)
            .collect();
        if levels.is_empty() {
            continue;
        }
        let stream: Vec<u32> = levels
            .iter()
            .flat_map(|&i| placed[i].indices.iter().copied())
            .collect();
        let vertices = levels
            .iter()
            .map(|&i| group_attributes[&placed[i].key].1)
            .max()
            .unwrap_or(0);
        let (size, ty) = if narrow { (2, U16) } else { (4, U32) };
        let v = b.index_view(&stream, vertices, narrow)?;
        let mut at = 0usize;
        for &i in &levels {
            let n = placed[i].indices.len();
            index_accessors[i] = b.accessor(v, ty, false, n, "SCALAR", None);
            if at > 0 {
                b.accessors[index_accessors[i]]["byteOffset"] = json!(at * size);
            }
            at += n;
        }
    }

    let mut nodes = Vec::with_capacity(placed.len());
    let mut meshes = Vec::with_capacity(placed.len());
    for (i, p) in placed.iter().enumerate() {
        let mut primitive = json!({
            "attributes": group_attributes[&p.key].0,
            "indices": index_accessors[i],
            "material": p.material,
        });
        if p.features > 0 {
            primitive["extensions"] = json!({"EXT_mesh_features": {"featureIds": [{
                "featureCount": p.features,
                "attribute": 0,
                "propertyTable": 0,
                "label": "object",
            }]}});
        }
        meshes.push(json!({"primitives": [primitive]}));
        let mut node = json!({"mesh": i, "translation": p.translation.to_array()});
        if p.scale != [1.0; 3] {
            node["scale"] = json!(p.scale);
        }
        nodes.push(node);
    }
    let feature_count = if placed.iter().any(|p| p.features > 0) {
        ids.len()
    } else {
        0
    };
    let mut root_ext = Map::new();
    if let (true, Some(records)) = (feature_count > 0, objects) {
        root_ext.insert(
            "EXT_structural_metadata".into(),
            property_table(&mut b, &ids, records),
        );
    }
    let mut used = Vec::new();
    let mut required = Vec::new();
    if encoding != Encoding::Plain {
        used.push("KHR_mesh_quantization");
        required.push("KHR_mesh_quantization");
    }
    if encoding == Encoding::Meshopt {
        used.push("EXT_meshopt_compression");
        required.push("EXT_meshopt_compression");
    }
    if !root_ext.is_empty() {
        used.push("EXT_mesh_features");
        used.push("EXT_structural_metadata");
    }
    let materials: Vec<Value> = materials
        .iter()
        .map(|&c| {
            json!({
                "pbrMetallicRoughness": material_factors(c),
                // Models' windings are not consistent enough to cull back
                // faces (gigawalk draws both sides too).
                "doubleSided": true,
            })
        })
        .collect();
    let mut doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "accessors": b.accessors,
        "bufferViews": b.views,
    });
    let mut buffers = vec![json!({"byteLength": b.bin.len()})];
    if b.fallback > 0 {
        buffers.push(json!({
            "byteLength": b.fallback,
            "extensions": {"EXT_meshopt_compression": {"fallback": true}},
        }));
    }
    doc["buffers"] = Value::Array(buffers);
    if !used.is_empty() {
        doc["extensionsUsed"] = json!(used);
    }
    if !required.is_empty() {
        doc["extensionsRequired"] = json!(required);
    }
    if !root_ext.is_empty() {
        doc["extensions"] = Value::Object(root_ext);
    }
    let json = serde_json::to_vec(&doc).map_err(|e| format!("cannot write the glTF JSON: {e}"))?;
    Ok(Content {
        bytes: glb(json, b.bin),
        bounds,
        triangles,
        features: feature_count,
    })
}

/// The LOD's streams in the form `encoding` stores: grid coordinates where
/// the scene stores at most 16 bits an axis (and the encoding allows
/// integers), else f32 offsets from the LOD's origin.
fn streams(stored: StoredLod, origin: DVec3, encoding: Encoding) -> Streams {
    match stored {
        StoredLod::Grid(g) => {
            let n = g.streams.positions.len();
            let normals: Vec<[f32; 3]> = (0..n).map(|i| g.streams.normal(i)).collect();
            let uniform = g.uniform_colour.unwrap_or([255; 4]);
            let normal_bits = g.streams.normal_bits;
            let grid = match (&g.streams.positions, encoding) {
                (gigawalk_scene::codec::GridPositions::U16(q), Encoding::Meshopt)
                | (gigawalk_scene::codec::GridPositions::U16(q), Encoding::Quantized) => {
                    // A flat axis has step 0: any scale works there when
                    // every coordinate is 0, and 1 keeps the node's matrix
                    // invertible (its normals' inverse transpose).
                    let mut scale = g.streams.step;
                    let mut ok = true;
                    for (a, s) in scale.iter_mut().enumerate() {
                        if *s == 0.0 {
                            ok &= q.iter().all(|v| v[a] == 0);
                            *s = 1.0;
                        }
                    }
                    ok.then(|| Positions::Grid {
                        q: q.clone(),
                        translation: g.origin + DVec3::from(g.streams.origin.map(f64::from))
                            - origin,
                        scale,
                    })
                }
                _ => None,
            };
            let positions = grid.unwrap_or_else(|| Positions::Float {
                p: (0..n).map(|i| g.streams.position(i)).collect(),
                translation: g.origin - origin,
            });
            Streams {
                positions,
                normals,
                colours: g.streams.colours,
                uniform,
                indices: g.streams.indices,
                normal_bits,
            }
        }
        StoredLod::Mesh(m) => {
            let (colours, uniform) = match m.colours {
                Colours::Uniform(c) => (None, c),
                Colours::PerVertex(c) => (Some(c), [255; 4]),
            };
            Streams {
                positions: Positions::Float {
                    p: m.positions,
                    translation: m.origin - origin,
                },
                normals: m.normals,
                colours,
                uniform,
                indices: m.indices,
                normal_bits: 16,
            }
        }
    }
}

/// Gives every vertex one feature: a vertex whose triangles belong to more
/// than one object is copied, once per further object. Returns each
/// vertex's feature (an index into the content's objects).
fn split_by_feature(s: &mut Streams, feature_of_triangle: &[u32]) -> Vec<u32> {
    let nv = s.normals.len();
    const NONE: u32 = u32::MAX;
    let mut feature = vec![NONE; nv];
    // (old vertex, feature) -> new vertex, for the copies only.
    let mut copies: HashMap<(u32, u32), u32> = HashMap::new();
    let mut source: Vec<u32> = (0..nv as u32).collect();
    for (t, tri) in s.indices.chunks_exact_mut(3).enumerate() {
        let f = feature_of_triangle[t];
        for v in tri {
            let old = *v as usize;
            if feature[old] == NONE {
                feature[old] = f;
            } else if feature[old] != f {
                let next = source.len() as u32;
                let new = *copies.entry((old as u32, f)).or_insert_with(|| {
                    source.push(old as u32);
                    feature.push(f);
                    next
                });
                *v = new;
            }
        }
    }
    if source.len() > nv {
        for &o in &source[nv..] {
            let o = o as usize;
            s.normals.push(s.normals[o]);
            if let Some(c) = &mut s.colours {
                c.push(c[o]);
            }
            match &mut s.positions {
                Positions::Grid { q, .. } => q.push(q[o]),
                Positions::Float { p, .. } => p.push(p[o]),
            }
        }
    }
    // A vertex no triangle uses keeps feature 0 (it is never drawn).
    feature
        .into_iter()
        .map(|f| if f == NONE { 0 } else { f })
        .collect()
}

/// The world box of the content's vertices as a client places them.
fn bounds_of(p: &Positions, origin: DVec3) -> Aabb {
    match p {
        Positions::Grid {
            q,
            translation,
            scale,
        } => {
            let (lo, hi) = extent_u16(q);
            let s = DVec3::from(scale.map(f64::from));
            let at = |c: [u16; 3]| origin + *translation + DVec3::from(c.map(f64::from)) * s;
            Aabb::from_points([at(lo), at(hi)])
        }
        Positions::Float { p, translation } => {
            let (lo, hi) = extent_f32(p);
            let at = |c: [f32; 3]| origin + *translation + DVec3::from(c.map(f64::from));
            Aabb::from_points([at(lo), at(hi)])
        }
    }
}

fn extent_u16(q: &[[u16; 4]]) -> ([u16; 3], [u16; 3]) {
    let mut lo = [u16::MAX; 3];
    let mut hi = [0u16; 3];
    for v in q {
        for a in 0..3 {
            lo[a] = lo[a].min(v[a]);
            hi[a] = hi[a].max(v[a]);
        }
    }
    (lo, hi)
}

fn extent_f32(p: &[[f32; 3]]) -> ([f32; 3], [f32; 3]) {
    let mut lo = [f32::MAX; 3];
    let mut hi = [f32::MIN; 3];
    for v in p {
        for a in 0..3 {
            lo[a] = lo[a].min(v[a]);
            hi[a] = hi[a].max(v[a]);
        }
    }
    (lo, hi)
}

fn snorm16(n: [f32; 3]) -> [i16; 4] {
    let q = |x: f32| (x.clamp(-1.0, 1.0) * 32767.0).round() as i16;
    [q(n[0]), q(n[1]), q(n[2]), 0]
}

fn snorm8(n: [f32; 3]) -> [i8; 4] {
    let q = |x: f32| (x.clamp(-1.0, 1.0) * 127.0).round() as i8;
    [q(n[0]), q(n[1]), q(n[2]), 0]
}

pub(crate) fn srgb_to_linear(c: u8) -> f32 {
    let c = c as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn linear16(c: u8) -> u16 {
    (srgb_to_linear(c) * 65535.0).round() as u16
}

/// The content's objects as an EXT_structural_metadata property table:
/// row i is feature ID i.
fn property_table(b: &mut Builder, ids: &[u32], records: &[ObjectRecord]) -> Value {
    let record = |i: u32| records.get(i as usize);
    let object_ids: Vec<u32> = ids.to_vec();
    let mut props = Map::new();
    let v = b.plain_view(bytemuck::cast_slice(&object_ids));
    props.insert("objectId".into(), json!({"values": v}));
    type Column<'a> = (&'a str, &'a dyn Fn(&ObjectRecord) -> String);
    let strings: [Column; 4] = [
        ("name", &|r| r.name.clone()),
        ("path", &|r| r.path.clone()),
        ("file", &|r| r.file.clone()),
        ("metadata", &|r| r.metadata.clone().unwrap_or_default()),
    ];
    let mut classes = Map::new();
    classes.insert(
        "objectId".into(),
        json!({"type": "SCALAR", "componentType": "UINT32"}),
    );
    for (name, get) in strings {
        let mut bytes = Vec::new();
        let mut offsets = vec![0u32];
        for &i in ids {
            if let Some(r) = record(i) {
                bytes.extend_from_slice(get(r).as_bytes());
            }
            offsets.push(bytes.len() as u32);
        }
        // A column empty in every row is left out (no property is
        // required): most models name no file and carry no extras.
        if bytes.is_empty() && name != "name" {
            continue;
        }
        let values = b.plain_view(&bytes);
        let offs = b.plain_view(bytemuck::cast_slice(&offsets));
        props.insert(
            name.into(),
            json!({"values": values, "stringOffsets": offs}),
        );
        classes.insert(name.into(), json!({"type": "STRING"}));
    }
    // The schema's meaning is in docs/tiles.md; each content carries only
    // its shape, to keep small contents small.
    json!({
        "schema": {"id": "gigawalk", "classes": {"object": {"properties": classes}}},
        "propertyTables": [{"class": "object", "count": ids.len(), "properties": props}],
    })
}

const I8: u32 = 5120;
const U16: u32 = 5123;
const I16: u32 = 5122;
const U32: u32 = 5125;
const F32: u32 = 5126;

/// The binary chunk, buffer views and accessors of one content.
struct Builder {
    meshopt: bool,
    /// Buffer 0: the GLB's binary chunk.
    bin: Vec<u8>,
    /// Bytes of buffer 1, the fallback buffer the compressed views
    /// decode into (no data of its own).
    fallback: usize,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    fn new(meshopt: bool) -> Self {
        Builder {
            meshopt,
            bin: Vec::new(),
            fallback: 0,
            views: Vec::new(),
            accessors: Vec::new(),
        }
    }

    /// Pads the binary chunk to 8 bytes (metadata views must start
    /// there; vertex data at 4).
    fn align(&mut self) {
        while !self.bin.len().is_multiple_of(8) {
            self.bin.push(0);
        }
    }

    /// Uncompressed bytes in buffer 0.
    fn plain_view(&mut self, bytes: &[u8]) -> usize {
        self.align();
        let off = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.views
            .push(json!({"buffer": 0, "byteLength": bytes.len()}));
        if off > 0 {
            self.views.last_mut().expect("just pushed")["byteOffset"] = json!(off);
        }
        self.views.len() - 1
    }

    /// A vertex attribute stream, one `T` a vertex (its size the stride).
    fn vertex_view<T: Pod>(&mut self, data: &[T], filter: Option<&str>) -> Result<usize, String> {
        let stride = std::mem::size_of::<T>();
        debug_assert!(stride.is_multiple_of(4));
        let raw: &[u8] = bytemuck::cast_slice(data);
        if !self.meshopt {
            let v = self.plain_view(raw);
            self.views[v]["byteStride"] = json!(stride);
            return Ok(v);
        }
        // Version 0 of the vertex codec: the one EXT_meshopt_compression
        // specifies.
        let enc = meshopt::encode_vertex_buffer_level(data, 2, Some(0))
            .map_err(|e| format!("meshopt cannot encode a vertex stream: {e:?}"))?;
        Ok(self.compressed_view(
            &enc,
            raw.len(),
            data.len(),
            stride,
            "ATTRIBUTES",
            filter,
            Some(stride),
        ))
    }

    #[allow(clippy::too_many_arguments)]
    fn compressed_view(
        &mut self,
        enc: &[u8],
        len: usize,
        count: usize,
        stride: usize,
        mode: &str,
        filter: Option<&str>,
        view_stride: Option<usize>,
    ) -> usize {
        self.align();
        let off = self.bin.len();
        self.bin.extend_from_slice(enc);
        self.fallback = self.fallback.next_multiple_of(8);
        let fb = self.fallback;
        self.fallback += len;
        let mut ext = json!({
            "buffer": 0, "byteLength": enc.len(),
            "byteStride": stride, "count": count, "mode": mode,
        });
        if off > 0 {
            ext["byteOffset"] = json!(off);
        }
        if let Some(f) = filter {
            ext["filter"] = json!(f);
        }
        let mut view = json!({
            "buffer": 1, "byteLength": len,
            "extensions": {"EXT_meshopt_compression": ext},
        });
        if fb > 0 {
            view["byteOffset"] = json!(fb);
        }
        if let Some(s) = view_stride {
            view["byteStride"] = json!(s);
        }
        self.views.push(view);
        self.views.len() - 1
    }

    /// A stream of triangle lists, stored as 16-bit indices when
    /// `narrow` (every index below 65,536), else 32-bit.
    fn index_view(
        &mut self,
        indices: &[u32],
        vertices: usize,
        narrow: bool,
    ) -> Result<usize, String> {
        let size = if narrow { 2 } else { 4 };
        if self.meshopt {
            let enc = meshopt::encode_index_buffer(indices, vertices)
                .map_err(|e| format!("meshopt cannot encode the indices: {e:?}"))?;
            return Ok(self.compressed_view(
                &enc,
                size * indices.len(),
                indices.len(),
                size,
                "TRIANGLES",
                None,
                None,
            ));
        }
        Ok(if narrow {
            let i: Vec<u16> = indices.iter().map(|&i| i as u16).collect();
            self.plain_view(bytemuck::cast_slice(&i))
        } else {
            self.plain_view(bytemuck::cast_slice(indices))
        })
    }

    fn accessor(
        &mut self,
        view: usize,
        component: u32,
        normalized: bool,
        count: usize,
        ty: &str,
        min_max: Option<(Value, Value)>,
    ) -> usize {
        let mut a =
            json!({"bufferView": view, "componentType": component, "count": count, "type": ty});
        if normalized {
            a["normalized"] = json!(true);
        }
        if let Some((lo, hi)) = min_max {
            a["min"] = lo;
            a["max"] = hi;
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }
}

/// A material's factors, defaults left out (the glTF JSON is most of a
/// small content): no metal, fully rough, the base colour only when not
/// white.
fn material_factors(base: [f32; 4]) -> Value {
    if base == [1.0; 4] {
        json!({"metallicFactor": 0})
    } else {
        json!({"baseColorFactor": base, "metallicFactor": 0})
    }
}

/// The GLB container: header, JSON chunk (padded with spaces), binary
/// chunk (padded with zeros).
fn glb(mut json: Vec<u8>, mut bin: Vec<u8>) -> Vec<u8> {
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    if !bin.is_empty() {
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use gigawalk_scene::LodMesh;

    fn quad() -> LodMesh {
        LodMesh {
            origin: DVec3::new(1000.0, 0.0, 0.0),
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
            normals: vec![[0.0, 0.0, 1.0]; 4],
            colours: Colours::Uniform([255, 0, 0, 255]),
            indices: vec![0, 1, 2, 0, 2, 3],
        }
    }

    fn records(n: usize) -> Vec<ObjectRecord> {
        (0..n)
            .map(|i| ObjectRecord {
                name: format!("o{i}"),
                path: format!("root/o{i}"),
                file: String::new(),
                metadata: None,
                bounds: Aabb::EMPTY,
                triangles: 1,
            })
            .collect()
    }

    #[test]
    fn a_shared_vertex_of_two_objects_is_copied() {
        let runs = [
            ObjectRun {
                object: 3,
                triangles: 1,
            },
            ObjectRun {
                object: 1,
                triangles: 1,
            },
        ];
        let r = records(4);
        for enc in [Encoding::Plain, Encoding::Quantized, Encoding::Meshopt] {
            let c = content(
                vec![Level {
                    stored: StoredLod::Mesh(quad()),
                    identity: Identity::Runs(&runs),
                }],
                Some(&r),
                DVec3::ZERO,
                enc,
            )
            .unwrap();
            assert_eq!(c.triangles, 2);
            assert_eq!(c.features, 2);
            assert_eq!(c.bounds.min, DVec3::new(1000.0, 0.0, 0.0));
            assert_eq!(c.bounds.max, DVec3::new(1001.0, 1.0, 0.0));
            // Without validation: the gltf crate knows no custom
            // attribute (_FEATURE_ID_0) unless built with its `extras`.
            let g = gltf::Gltf::from_slice_without_validation(&c.bytes).unwrap();
            let p = g.meshes().next().unwrap().primitives().next().unwrap();
            // Vertices 0 and 2 are shared by both objects: 4 + 2.
            assert_eq!(p.get(&gltf::Semantic::Positions).unwrap().count(), 6);
        }
    }

    #[test]
    fn no_triangles_is_an_error() {
        let mut m = quad();
        m.indices.clear();
        let e = content(
            vec![Level {
                stored: StoredLod::Mesh(m),
                identity: Identity::None,
            }],
            None,
            DVec3::ZERO,
            Encoding::Plain,
        );
        assert!(e.is_err());
    }

    /// The positions of node `n`'s primitive as a client places them.
    fn placed(c: &Content, n: usize) -> Vec<DVec3> {
        let g = gltf::Gltf::from_slice_without_validation(&c.bytes).unwrap();
        let bin = g.blob.as_deref().unwrap();
        let node = g.nodes().nth(n).unwrap();
        let (t, _, s) = node.transform().decomposed();
        let p = node.mesh().unwrap().primitives().next().unwrap();
        let read = |a: gltf::Accessor, i: usize| -> usize {
            let v = a.view().unwrap();
            let at = v.offset() + a.offset() + i * a.size();
            match a.data_type() {
                gltf::accessor::DataType::U16 => {
                    u16::from_le_bytes([bin[at], bin[at + 1]]) as usize
                }
                _ => u32::from_le_bytes(bin[at..at + 4].try_into().unwrap()) as usize,
            }
        };
        let pos = p.get(&gltf::Semantic::Positions).unwrap();
        let idx = p.indices().unwrap();
        (0..idx.count())
            .map(|i| {
                let v = read(idx.clone(), i);
                let view = pos.view().unwrap();
                let at = view.offset() + pos.offset() + v * view.stride().unwrap_or(12);
                let f = |k: usize| {
                    f32::from_le_bytes(bin[at + 4 * k..at + 4 * k + 4].try_into().unwrap())
                };
                DVec3::new(
                    t[0] as f64 + s[0] as f64 * f(0) as f64,
                    t[1] as f64 + s[1] as f64 * f(1) as f64,
                    t[2] as f64 + s[2] as f64 * f(2) as f64,
                )
            })
            .collect()
    }

    #[test]
    fn levels_share_streams_and_keep_their_places() {
        let mut far = quad();
        far.origin = DVec3::new(-5.0, 2.0, 0.0);
        far.colours = Colours::Uniform([0, 0, 255, 255]);
        let runs = [ObjectRun {
            object: 2,
            triangles: 2,
        }];
        let r = records(3);
        let c = content(
            vec![
                Level {
                    stored: StoredLod::Mesh(quad()),
                    identity: Identity::One(0),
                },
                Level {
                    stored: StoredLod::Mesh(far.clone()),
                    identity: Identity::Runs(&runs),
                },
            ],
            Some(&r),
            DVec3::new(1.0, 0.0, 0.0),
            Encoding::Plain,
        )
        .unwrap();
        assert_eq!(c.triangles, 4);
        assert_eq!(c.features, 2);
        assert_eq!(c.bounds.min, DVec3::new(-5.0, 0.0, 0.0));
        assert_eq!(c.bounds.max, DVec3::new(1001.0, 3.0, 0.0));
        let g = gltf::Gltf::from_slice_without_validation(&c.bytes).unwrap();
        // One stream set (both levels f32, no per-vertex colours, with
        // features: 3 views), one index stream, the property table's 5
        // views (ids, names and paths with their offsets); two materials.
        assert_eq!(g.nodes().count(), 2);
        assert_eq!(g.materials().count(), 2);
        assert_eq!(g.views().count(), 3 + 1 + 5);
        // Each level's triangles where its origin puts them, relative to
        // the tileset's origin.
        for (n, m) in [(0, quad()), (1, far)] {
            let want: Vec<DVec3> = m
                .indices
                .iter()
                .map(|&i| m.origin + DVec3::from(m.positions[i as usize].map(f64::from)) - DVec3::X)
                .collect();
            assert_eq!(placed(&c, n), want);
        }
    }
}
