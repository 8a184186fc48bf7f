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
    // z: depth bias toward the eye (query boxes), w: unused.
    params: vec4<f32>,
};

@group(0) @binding(0) var<uniform> frame: FrameUniforms;

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
