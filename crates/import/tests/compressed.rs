//! Compressed glTF, built in the test: quantized (KHR_mesh_quantization) and
//! meshopt-compressed (EXT/KHR_meshopt_compression) versions of one mesh
//! import to the same triangles as the uncompressed file; Draco and other
//! unknown required extensions are errors naming them; corrupt compressed
//! data is an error naming the buffer view, never a panic.

use gigawalk_import::{import_glb_bytes, Model};
use gigawalk_testkit::XorShift;
use glam::{DQuat, DVec3, Vec3};
use serde_json::{json, Value};

const BYTE: u32 = 5120;
const UNSIGNED_BYTE: u32 = 5121;
const SHORT: u32 = 5122;
const UNSIGNED_SHORT: u32 = 5123;
const UNSIGNED_INT: u32 = 5125;
const FLOAT: u32 = 5126;

/// A GLB file: JSON chunk and BIN chunk, both padded to 4 bytes.
fn glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut j = serde_json::to_vec(json).unwrap();
    j.resize(j.len().next_multiple_of(4), b' ');
    let mut b = bin.to_vec();
    b.resize(b.len().next_multiple_of(4), 0);
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(j);
    out.extend((b.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(b);
    out
}

/// Buffer views and accessors of one GLB: buffer 0 is the BIN chunk;
/// compressed views decode into buffer 1, a fallback buffer with no data.
#[derive(Default)]
struct Builder {
    bin: Vec<u8>,
    fallback_len: usize,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    fn push_bin(&mut self, bytes: &[u8]) -> usize {
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        offset
    }

    /// An uncompressed view of buffer 0.
    fn view(&mut self, bytes: &[u8], stride: Option<usize>) -> usize {
        let offset = self.push_bin(bytes);
        let mut v = json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()});
        if let Some(s) = stride {
            v["byteStride"] = json!(s);
        }
        self.views.push(v);
        self.views.len() - 1
    }

    /// A view of `count` elements of `stride` bytes stored meshopt-encoded
    /// in buffer 0 and decoded into the fallback buffer.
    #[allow(clippy::too_many_arguments)]
    fn compressed_view(
        &mut self,
        extension: &str,
        encoded: &[u8],
        count: usize,
        stride: usize,
        mode: &str,
        filter: &str,
        vertex_data: bool,
    ) -> usize {
        let offset = self.push_bin(encoded);
        let length = count * stride;
        let mut v = json!({
            "buffer": 1, "byteOffset": self.fallback_len, "byteLength": length,
            "extensions": {extension: {
                "buffer": 0, "byteOffset": offset, "byteLength": encoded.len(),
                "byteStride": stride, "count": count, "mode": mode, "filter": filter,
            }},
        });
        if vertex_data {
            v["byteStride"] = json!(stride);
        }
        self.fallback_len += length.next_multiple_of(4);
        self.views.push(v);
        self.views.len() - 1
    }

    fn accessor(
        &mut self,
        view: usize,
        component: u32,
        normalized: bool,
        count: usize,
        ty: &str,
    ) -> usize {
        let mut a =
            json!({"bufferView": view, "componentType": component, "count": count, "type": ty});
        if normalized {
            a["normalized"] = json!(true);
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    /// POSITION accessors must carry min and max; the importer does not
    /// read them, so any finite box will do.
    fn position_accessor(
        &mut self,
        view: usize,
        component: u32,
        normalized: bool,
        count: usize,
    ) -> usize {
        let a = self.accessor(view, component, normalized, count, "VEC3");
        self.accessors[a]["min"] = json!([-1e9, -1e9, -1e9]);
        self.accessors[a]["max"] = json!([1e9, 1e9, 1e9]);
        a
    }

    /// The GLB with one mesh of one primitive under `nodes` (node 0 is the
    /// scene root, each later node the child of the one before; the last
    /// holds the mesh).
    fn finish(
        self,
        attributes: Value,
        indices: usize,
        nodes: Vec<Value>,
        required: &[&str],
    ) -> Vec<u8> {
        let mut nodes = nodes;
        let last = nodes.len() - 1;
        for (i, node) in nodes.iter_mut().enumerate().take(last) {
            node["children"] = json!([i + 1]);
        }
        nodes[last]["mesh"] = json!(0);
        let mut buffers = vec![json!({"byteLength": self.bin.len()})];
        if self.fallback_len > 0 {
            buffers.push(json!({"byteLength": self.fallback_len,
                "extensions": {"EXT_meshopt_compression": {"fallback": true}}}));
        }
        let mut root = json!({
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": [0]}],
            "nodes": nodes,
            "meshes": [{"primitives": [{"attributes": attributes, "indices": indices}]}],
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": buffers,
        });
        if !required.is_empty() {
            root["extensionsUsed"] = json!(required);
            root["extensionsRequired"] = json!(required);
        }
        glb(&root, &self.bin)
    }
}

/// A 5 x 5 height field: 25 vertices, 32 triangles, unit normals.
struct Mesh {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    indices: Vec<u32>,
}

fn grid() -> Mesh {
    const N: u32 = 5;
    let h = |x: f32, z: f32| 0.3 * (x * 1.3).sin() + 0.2 * (z * 0.7).cos();
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for j in 0..N {
        for i in 0..N {
            let (x, z) = (i as f32 * 1.5 - 3.0, j as f32 * 0.7 + 2.0);
            positions.push([x, h(x, z) + 10.0, z]);
            let (dx, dz) = (0.39 * (x * 1.3).cos(), -0.14 * (z * 0.7).sin());
            normals.push(Vec3::new(-dx, 1.0, -dz).normalize().to_array());
        }
    }
    let mut indices = Vec::new();
    for j in 0..N - 1 {
        for i in 0..N - 1 {
            let a = j * N + i;
            indices.extend([a, a + N, a + 1, a + 1, a + N, a + N + 1]);
        }
    }
    Mesh {
        positions,
        normals,
        indices,
    }
}

fn bytes_of<T: Copy, const K: usize>(items: &[[T; K]], to_le: impl Fn(T) -> Vec<u8>) -> Vec<u8> {
    items.iter().flatten().flat_map(|&x| to_le(x)).collect()
}

/// Every file's mesh sits under this rotation, so transforms compose.
fn outer_node() -> Value {
    let q = DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 0.5).normalize(), 0.7);
    json!({"rotation": q.to_array(), "translation": [100.0, -5.0, 3.0]})
}

/// The plain file: float positions and normals, u16 indices.
fn float_glb(mesh: &Mesh) -> Vec<u8> {
    let mut b = Builder::default();
    let pv = b.view(
        &bytes_of(&mesh.positions, |x: f32| x.to_le_bytes().to_vec()),
        Some(12),
    );
    let nv = b.view(
        &bytes_of(&mesh.normals, |x: f32| x.to_le_bytes().to_vec()),
        Some(12),
    );
    let idx: Vec<u8> = mesh
        .indices
        .iter()
        .flat_map(|&i| (i as u16).to_le_bytes())
        .collect();
    let iv = b.view(&idx, None);
    let n = mesh.positions.len();
    let pa = b.position_accessor(pv, FLOAT, false, n);
    let na = b.accessor(nv, FLOAT, false, n, "VEC3");
    let ia = b.accessor(iv, UNSIGNED_SHORT, false, mesh.indices.len(), "SCALAR");
    b.finish(
        json!({"POSITION": pa, "NORMAL": na}),
        ia,
        vec![outer_node(), json!({})],
        &[],
    )
}

/// gltfpack's layout: SHORT positions padded to 8 bytes with the
/// dequantization as a node scale and translation, BYTE normalized normals
/// padded to 4 bytes.
struct Quantized {
    positions: Vec<[i16; 4]>,
    normals: Vec<[i8; 4]>,
    step: f64,
    node: Value,
}

fn quantize(mesh: &Mesh) -> Quantized {
    let (mut lo, mut hi) = (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN));
    for p in &mesh.positions {
        let p = Vec3::from_array(*p).as_dvec3();
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let centre = (lo + hi) / 2.0;
    let step = (hi - lo).max_element() / 60000.0;
    let positions = mesh
        .positions
        .iter()
        .map(|p| {
            let q = ((Vec3::from_array(*p).as_dvec3() - centre) / step).round();
            [q.x as i16, q.y as i16, q.z as i16, 0]
        })
        .collect();
    let normals = mesh
        .normals
        .iter()
        .map(|n| {
            let q = |c: f32| (c * 127.0).round() as i8;
            [q(n[0]), q(n[1]), q(n[2]), 0]
        })
        .collect();
    Quantized {
        positions,
        normals,
        step,
        node: json!({"translation": centre.to_array(), "scale": [step, step, step]}),
    }
}

fn quantized_glb(mesh: &Mesh) -> Vec<u8> {
    let q = quantize(mesh);
    let mut b = Builder::default();
    let pv = b.view(
        &bytes_of(&q.positions, |x: i16| x.to_le_bytes().to_vec()),
        Some(8),
    );
    let nv = b.view(&bytes_of(&q.normals, |x: i8| vec![x as u8]), Some(4));
    let idx: Vec<u8> = mesh
        .indices
        .iter()
        .flat_map(|&i| (i as u16).to_le_bytes())
        .collect();
    let iv = b.view(&idx, None);
    let n = mesh.positions.len();
    let pa = b.position_accessor(pv, SHORT, false, n);
    let na = b.accessor(nv, BYTE, true, n, "VEC3");
    let ia = b.accessor(iv, UNSIGNED_SHORT, false, mesh.indices.len(), "SCALAR");
    b.finish(
        json!({"POSITION": pa, "NORMAL": na}),
        ia,
        vec![outer_node(), q.node],
        &["KHR_mesh_quantization"],
    )
}

/// The quantized file with every view meshopt-encoded: ATTRIBUTES for the
/// vertex streams, TRIANGLES for the indices.
fn quantized_meshopt_glb(mesh: &Mesh) -> Vec<u8> {
    let q = quantize(mesh);
    let mut b = Builder::default();
    let ext = "EXT_meshopt_compression";
    let n = mesh.positions.len();
    let pe = meshopt::encode_vertex_buffer(&q.positions).unwrap();
    let pv = b.compressed_view(ext, &pe, n, 8, "ATTRIBUTES", "NONE", true);
    let ne = meshopt::encode_vertex_buffer(&q.normals).unwrap();
    let nv = b.compressed_view(ext, &ne, n, 4, "ATTRIBUTES", "NONE", true);
    let ie = meshopt::encode_index_buffer(&mesh.indices, n).unwrap();
    let iv = b.compressed_view(ext, &ie, mesh.indices.len(), 2, "TRIANGLES", "NONE", false);
    let pa = b.position_accessor(pv, SHORT, false, n);
    let na = b.accessor(nv, BYTE, true, n, "VEC3");
    let ia = b.accessor(iv, UNSIGNED_SHORT, false, mesh.indices.len(), "SCALAR");
    b.finish(
        json!({"POSITION": pa, "NORMAL": na}),
        ia,
        vec![outer_node(), q.node],
        &["EXT_meshopt_compression", "KHR_mesh_quantization"],
    )
}

fn import(bytes: &[u8], name: &str) -> Model {
    import_glb_bytes(bytes, name).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Triangle by triangle: corners (in winding order, from any first
/// corner, since the meshopt triangle codec may rotate a triangle) with
/// positions within `pos_tol` and normals within `normal_tol`.
fn assert_same_triangles(got: &Model, want: &Model, pos_tol: f64, normal_tol: f32) {
    assert_eq!(got.objects.len(), want.objects.len());
    for (g, w) in got.objects.iter().zip(&want.objects) {
        assert_eq!(g.triangle_count(), w.triangle_count());
        for (t, (gt, wt)) in g
            .indices
            .chunks_exact(3)
            .zip(w.indices.chunks_exact(3))
            .enumerate()
        {
            let same = |r: usize| {
                (0..3).all(|k| {
                    let (gi, wi) = (gt[(k + r) % 3] as usize, wt[k] as usize);
                    g.positions[gi].distance(w.positions[wi]) <= pos_tol
                        && g.normals[gi].distance(w.normals[wi]) <= normal_tol
                })
            };
            assert!(
                (0..3).any(same),
                "triangle {t}: {:?} vs {:?}",
                gt.iter()
                    .map(|&i| (g.positions[i as usize], g.normals[i as usize]))
                    .collect::<Vec<_>>(),
                wt.iter()
                    .map(|&i| (w.positions[i as usize], w.normals[i as usize]))
                    .collect::<Vec<_>>()
            );
        }
    }
}

#[test]
fn quantized_positions_and_normals_match_the_float_file() {
    let mesh = grid();
    let want = import(&float_glb(&mesh), "float.glb");
    let got = import(&quantized_glb(&mesh), "quantized.glb");
    assert_eq!(want.stats.triangles, 32);
    // Rounding moves each coordinate at most half a step.
    let step = quantize(&mesh).step;
    assert_same_triangles(&got, &want, step * 0.5 * 3f64.sqrt(), 0.01);
}

#[test]
fn meshopt_compressed_views_decode_to_the_quantized_file() {
    let mesh = grid();
    let want = import(&quantized_glb(&mesh), "quantized.glb");
    let got = import(&quantized_meshopt_glb(&mesh), "meshopt.glb");
    // The codecs are lossless: the very same vertices and triangles (the
    // triangle codec may start a triangle at another corner).
    assert_eq!(got.objects[0].positions, want.objects[0].positions);
    assert_eq!(got.objects[0].normals, want.objects[0].normals);
    assert_same_triangles(&got, &want, 0.0, 0.0);
}

#[test]
fn fallback_buffer_without_the_fallback_tag_is_not_loaded() {
    // Older gltfpack output: the placeholder buffer has no URI and no tag.
    let mesh = grid();
    let bytes = quantized_meshopt_glb(&mesh);
    let (mut json, bin) = split_glb(&bytes);
    json["buffers"][1] = json!({"byteLength": json["buffers"][1]["byteLength"]});
    let got = import(&glb(&json, &bin), "untagged.glb");
    assert_same_triangles(
        &got,
        &import(&quantized_glb(&mesh), "quantized.glb"),
        0.0,
        0.0,
    );
}

#[test]
fn meshopt_filters_exponential_positions_octahedral_normals_and_index_sequence() {
    // gltfpack -cc's float layout: EXPONENTIAL positions, OCTAHEDRAL
    // normals; u32 indices as an INDICES sequence; under the KHR name.
    let mesh = grid();
    let ext = "KHR_meshopt_compression";
    let n = mesh.positions.len();
    let mut b = Builder::default();
    let exp = meshopt::encode_filter_exp(&mesh.positions, 20, meshopt::EncodeExpMode::SharedVector);
    let pv = b.compressed_view(
        ext,
        &meshopt::encode_vertex_buffer(&exp).unwrap(),
        n,
        12,
        "ATTRIBUTES",
        "EXPONENTIAL",
        true,
    );
    let n4: Vec<[f32; 4]> = mesh
        .normals
        .iter()
        .map(|v| [v[0], v[1], v[2], 0.0])
        .collect();
    let oct = meshopt::encode_filter_oct::<i8>(&n4, 8);
    let nv = b.compressed_view(
        ext,
        &meshopt::encode_vertex_buffer(&oct).unwrap(),
        n,
        4,
        "ATTRIBUTES",
        "OCTAHEDRAL",
        true,
    );
    let ie = meshopt::encode_index_sequence(&mesh.indices, n).unwrap();
    let iv = b.compressed_view(ext, &ie, mesh.indices.len(), 4, "INDICES", "NONE", false);
    let pa = b.position_accessor(pv, FLOAT, false, n);
    let na = b.accessor(nv, BYTE, true, n, "VEC3");
    let ia = b.accessor(iv, UNSIGNED_INT, false, mesh.indices.len(), "SCALAR");
    let bytes = b.finish(
        json!({"POSITION": pa, "NORMAL": na}),
        ia,
        vec![outer_node(), json!({})],
        &[ext],
    );
    let got = import(&bytes, "filters.glb");
    let want = import(&float_glb(&mesh), "float.glb");
    // 20 mantissa bits on coordinates below 16: error below 2^-16.
    assert_same_triangles(&got, &want, 1e-4, 0.02);
}

/// The JSON and BIN chunk of a GLB this test wrote.
fn split_glb(bytes: &[u8]) -> (Value, Vec<u8>) {
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let bin = bytes[20 + json_len + 8..].to_vec();
    (json, bin)
}

#[test]
fn truncated_compressed_views_are_errors_naming_the_view() {
    let (json, bin) = split_glb(&quantized_meshopt_glb(&grid()));
    for view in 0..3 {
        let ext = &json["bufferViews"][view]["extensions"]["EXT_meshopt_compression"];
        let length = ext["byteLength"].as_u64().unwrap();
        for cut in [1, 2, 7, length / 2, length - 1] {
            let mut j = json.clone();
            j["bufferViews"][view]["extensions"]["EXT_meshopt_compression"]["byteLength"] =
                json!(length - cut);
            let e = import_glb_bytes(&glb(&j, &bin), "cut.glb").expect_err("truncated");
            let msg = e.to_string();
            assert!(
                msg.starts_with(&format!(
                    "cut.glb: bufferView {view} (EXT_meshopt_compression): cannot decode"
                )),
                "{msg}"
            );
        }
    }
}

#[test]
fn bad_header_byte_is_an_error() {
    let (json, mut bin) = split_glb(&quantized_meshopt_glb(&grid()));
    let at = json["bufferViews"][0]["extensions"]["EXT_meshopt_compression"]["byteOffset"]
        .as_u64()
        .unwrap() as usize;
    bin[at] = 0x55;
    let msg = import_glb_bytes(&glb(&json, &bin), "header.glb")
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("bufferView 0") && msg.contains("bad header"),
        "{msg}"
    );
}

#[test]
fn corrupt_compressed_bytes_never_panic() {
    let (json, bin) = split_glb(&quantized_meshopt_glb(&grid()));
    let mut rng = XorShift::new(0x9E37_79B9_7F4A_7C15);
    let mut next = move || rng.next_u64();
    for _ in 0..2000 {
        let mut bin = bin.clone();
        for _ in 0..1 + next() % 4 {
            let at = next() as usize % bin.len();
            bin[at] = next() as u8;
        }
        // A model (the damage hit nothing that matters, or produced other
        // valid numbers) or an error naming the file; never a panic.
        if let Err(e) = import_glb_bytes(&glb(&json, &bin), "corrupt.glb") {
            assert!(e.to_string().starts_with("corrupt.glb: "), "{e}");
        }
    }
}

#[test]
fn draco_required_names_the_extension_and_how_to_decompress() {
    let mut b = Builder::default();
    let pv = b.view(&[0; 36], Some(12));
    let pa = b.position_accessor(pv, FLOAT, false, 3);
    let iv = b.view(&[0, 0, 1, 0, 2, 0], None);
    let ia = b.accessor(iv, UNSIGNED_SHORT, false, 3, "SCALAR");
    let bytes = b.finish(
        json!({"POSITION": pa}),
        ia,
        vec![json!({})],
        &["KHR_mesh_quantization", "KHR_draco_mesh_compression"],
    );
    let msg = import_glb_bytes(&bytes, "draco.glb")
        .unwrap_err()
        .to_string();
    assert!(
        msg.starts_with("draco.glb: requires glTF extension KHR_draco_mesh_compression"),
        "{msg}"
    );
    assert!(msg.contains("gltf-transform"), "{msg}");
}

#[test]
fn draco_primitive_without_fallback_names_the_extension() {
    // Only "used": the primitive's accessors have no bufferView to fall back on.
    let (mut json, bin) = split_glb(&float_glb(&grid()));
    json["accessors"][0]
        .as_object_mut()
        .unwrap()
        .remove("bufferView");
    json["meshes"][0]["primitives"][0]["extensions"] =
        json!({"KHR_draco_mesh_compression": {"bufferView": 0, "attributes": {"POSITION": 0}}});
    json["extensionsUsed"] = json!(["KHR_draco_mesh_compression"]);
    let msg = import_glb_bytes(&glb(&json, &bin), "draco.glb")
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("KHR_draco_mesh_compression") && msg.contains("gltf-transform cp"),
        "{msg}"
    );
}

#[test]
fn other_required_extension_is_named() {
    let (mut json, bin) = split_glb(&float_glb(&grid()));
    json["extensionsRequired"] = json!(["EXT_mesh_gpu_instancing"]);
    let msg = import_glb_bytes(&glb(&json, &bin), "inst.glb")
        .unwrap_err()
        .to_string();
    assert!(
        msg.starts_with("inst.glb: requires glTF extension EXT_mesh_gpu_instancing"),
        "{msg}"
    );
}

#[test]
fn required_texture_extension_is_ignored() {
    // gltfpack -tc: the texture names its image only through KHR_texture_basisu.
    let (mut json, bin) = split_glb(&float_glb(&grid()));
    json["extensionsRequired"] = json!(["KHR_texture_basisu"]);
    json["images"] = json!([{"uri": "colour.ktx2"}]);
    json["textures"] = json!([{"extensions": {"KHR_texture_basisu": {"source": 0}}}]);
    json["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    json["meshes"][0]["primitives"][0]["material"] = json!(0);
    let got = import(&glb(&json, &bin), "basisu.glb");
    assert_eq!(
        got.objects[0].positions,
        import(&float_glb(&grid()), "float.glb").objects[0].positions
    );
}

/// One triangle with corners on the axes at the stored integers `q`, read
/// as `component` (normalized or not), must land at `want`.
fn check_dequantized(component: u32, normalized: bool, q: [i32; 3], want: [f64; 3]) {
    let size: usize = match component {
        BYTE | UNSIGNED_BYTE => 1,
        _ => 2,
    };
    let stride = (3 * size).next_multiple_of(4);
    let mut bytes = Vec::new();
    for (axis, &v) in q.iter().enumerate() {
        let mut element = vec![0u8; stride];
        let le = (v as u32).to_le_bytes();
        element[axis * size..(axis + 1) * size].copy_from_slice(&le[..size]);
        bytes.extend(element);
    }
    let mut b = Builder::default();
    let pv = b.view(&bytes, Some(stride));
    let pa = b.position_accessor(pv, component, normalized, 3);
    let iv = b.view(&[0, 1, 2, 0], None);
    let ia = b.accessor(iv, UNSIGNED_BYTE, false, 3, "SCALAR");
    let file = b.finish(
        json!({"POSITION": pa}),
        ia,
        vec![json!({})],
        &["KHR_mesh_quantization"],
    );
    let m = import(&file, "q.glb");
    let p = &m.objects[0].positions;
    let got = [p[0].x, p[1].y, p[2].z];
    for (g, w) in got.iter().zip(want) {
        assert!(
            (g - w).abs() < 1e-6,
            "{component} normalized {normalized}: {got:?} vs {want:?}"
        );
    }
}

#[test]
fn every_quantized_position_type_dequantizes_by_the_gltf_rules() {
    check_dequantized(BYTE, false, [-128, 127, 5], [-128.0, 127.0, 5.0]);
    check_dequantized(BYTE, true, [-128, 127, -64], [-1.0, 1.0, -64.0 / 127.0]);
    check_dequantized(UNSIGNED_BYTE, false, [255, 1, 200], [255.0, 1.0, 200.0]);
    check_dequantized(UNSIGNED_BYTE, true, [255, 1, 51], [1.0, 1.0 / 255.0, 0.2]);
    check_dequantized(SHORT, false, [-32768, 32767, -3], [-32768.0, 32767.0, -3.0]);
    check_dequantized(
        SHORT,
        true,
        [-32768, 32767, 16384],
        [-1.0, 1.0, 16384.0 / 32767.0],
    );
    check_dequantized(
        UNSIGNED_SHORT,
        false,
        [65535, 1, 40000],
        [65535.0, 1.0, 40000.0],
    );
    check_dequantized(
        UNSIGNED_SHORT,
        true,
        [65535, 1, 13107],
        [1.0, 1.0 / 65535.0, 0.2],
    );
}

/// Writes the quantized and meshopt-compressed files as seeds for the
/// import_gltf fuzz target (fuzz/seeds/import_gltf, run by
/// benches/fuzz.sh): `cargo test -p gigawalk-import --test compressed --
/// --ignored write_fuzz_seeds`.
#[test]
#[ignore]
fn write_fuzz_seeds() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/seeds/import_gltf");
    let mesh = grid();
    for (name, bytes) in [
        ("grid_quantized.glb", quantized_glb(&mesh)),
        ("grid_meshopt.glb", quantized_meshopt_glb(&mesh)),
    ] {
        import(&bytes, name);
        std::fs::write(dir.join(name), bytes).unwrap();
    }
}
