// Shared by occluder_depth.wgsl and visible.wgsl (concatenated in front of
// each by crates/gpu). Mirrors crates/gpu/src/shader_types.rs: a test checks
// sizes and offsets with naga.

// Per-frame uniforms. Positions reaching the GPU are camera-relative.
struct FrameUniforms {
    // Projection x rotation only: the camera sits at the origin.
    view_proj: mat4x4<f32>,
    // Direction the head light shines (the view direction), world axes.
    light_dir: vec4<f32>,
    // x: ambient term, y: 1 to draw the unlit object colour (wireframe),
    // z: depth bias toward the eye (query boxes), w: how many of clip
    // the section uses.
    params: vec4<f32>,
    // The section's half-spaces, camera-relative: a point p (relative to
    // the eye) is kept when dot(xyz, p) + w >= 0 for each one used.
    clip: array<vec4<f32>, 12>,
};

@group(0) @binding(0) var<uniform> frame: FrameUniforms;

// Whether the section keeps the camera-relative point p.
fn section_keeps(p: vec3<f32>) -> bool {
    let count = u32(frame.params.w);
    for (var i = 0u; i < count; i = i + 1u) {
        let h = frame.clip[i];
        if (dot(h.xyz, p) + h.w < 0.0) {
            return false;
        }
    }
    return true;
}

// The signed distances of the camera-relative point p from the first
// eight half-spaces (1 past the section's count), for the rasterizer's
// clip distances.
fn section_distances(p: vec3<f32>) -> array<f32, 8> {
    let count = u32(frame.params.w);
    var d = array<f32, 8>(1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0);
    for (var i = 0u; i < min(count, 8u); i = i + 1u) {
        let h = frame.clip[i];
        d[i] = dot(h.xyz, p) + h.w;
    }
    return d;
}

// The half-space through whose plane the ray from the eye to the kept
// point p enters the kept region (the last one crossed), or -1 when the
// eye is kept by all of them (the ray crosses no cut).
fn section_entry(p: vec3<f32>) -> i32 {
    let count = u32(frame.params.w);
    var entry = -1;
    var t_entry = 0.0;
    for (var i = 0u; i < count; i = i + 1u) {
        let h = frame.clip[i];
        // The eye is on the removed side: the ray crosses this plane at
        // t = -w / dot(n, p) in (0, 1].
        if (h.w < 0.0) {
            let t = -h.w / max(dot(h.xyz, p), 1e-30);
            if (t >= t_entry) {
                t_entry = t;
                entry = i32(i);
            }
        }
    }
    return entry;
}

// The compact vertex layout (CompactVertex): grid coordinates in xyz,
// scaled per draw by the instance's scale (the grid's step) and moved by
// its offset (where coordinate 0 lies relative to the camera).
fn compact_position(q: vec4<u32>, offset: vec4<f32>, scale: vec4<f32>) -> vec3<f32> {
    return vec3<f32>(q.xyz) * scale.xyz + offset.xyz;
}

// The compact layout's octahedral normal: two snorm8 in w (u low byte,
// v high), sign-extended by the arithmetic shift of an i32.
fn compact_normal(q: vec4<u32>) -> vec2<f32> {
    let u = bitcast<i32>(q.w << 24u) >> 24u;
    let v = bitcast<i32>(q.w << 16u) >> 24u;
    return clamp(vec2<f32>(f32(u), f32(v)) / 127.0, vec2<f32>(-1.0), vec2<f32>(1.0));
}

// Octahedral decoding of snorm16x2 normals (crates/scene/src/mesh.rs).
fn decode_normal(e: vec2<f32>) -> vec3<f32> {
    var n = vec3<f32>(e.x, e.y, 1.0 - abs(e.x) - abs(e.y));
    if (n.z < 0.0) {
        let s = select(vec2<f32>(-1.0), vec2<f32>(1.0), n.xy >= vec2<f32>(0.0));
        n = vec3<f32>((1.0 - abs(n.yx)) * s, n.z);
    }
    return normalize(n);
}
