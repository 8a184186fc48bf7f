// The HZB pyramid built on OR's device (GigaWalk Section 5.1.2, after
// Greene et al.): each texel of level k + 1 holds the farthest depth of the
// 2x2 texels of level k it covers. Reversed-Z: farther is smaller, so the
// reduction is a minimum.
//
// Levels halve rounding up, as the CPU's pyramid (crates/cull/src/hzb.rs):
// a border texel of an odd-sized level covers its one or two real
// children. The loads clamp to the source's last column and row, which
// repeats an edge texel and changes no minimum.
//
// Depth travels as its f32 bits in a u32 (R32Uint targets render and store
// everywhere, R32Float not on every GL). For depths >= +0 the bits order as
// the values; a depth that is not > 0 (-0, NaN) becomes 0, infinitely far,
// which only ever culls less.
//
// Two ways, one per adapter kind: compute entries write every level into
// one storage buffer (`pyramid`, rows packed tightly, so the level read
// back is copied without row padding); fragment entries draw each level
// into a texture of its own, where the adapter has no compute (or on GL).

struct Level {
    // Source and destination size in texels.
    src_size: vec2<u32>,
    dst_size: vec2<u32>,
    // Where the source and destination start in `pyramid` (compute only).
    src_offset: u32,
    dst_offset: u32,
    _pad: vec2<u32>,
}

// Bound as unfilterable float, not texture_depth_2d: naga's GLSL output
// cannot textureLoad a depth texture. Read through a nearest sampler at
// texel centres (as shaders/depth_copy.wgsl): a texel fetch would take
// the texture's own filter, GL's default, with which WebGL2 reads a
// float depth texture as 0.
@group(0) @binding(0) var depth: texture_2d<f32>;
@group(0) @binding(1) var<uniform> level: Level;
@group(0) @binding(2) var<storage, read_write> pyramid: array<u32>;
@group(0) @binding(3) var src_bits: texture_2d<u32>;
@group(0) @binding(4) var nearest: sampler;

fn depth_bits(d: f32) -> u32 {
    return select(0u, bitcast<u32>(d), d > 0.0);
}

// The source texel (x, y), clamped to the source.
fn clamped(p: vec2<u32>) -> vec2<u32> {
    return min(p, level.src_size - vec2<u32>(1u));
}

// The depth of texel p (clamped to the source), read at its centre.
fn depth_at(p: vec2<u32>) -> u32 {
    let size = vec2<f32>(textureDimensions(depth));
    let uv = (vec2<f32>(clamped(p)) + vec2<f32>(0.5)) / size;
    return depth_bits(textureSampleLevel(depth, nearest, uv, 0.0).x);
}

fn farthest_of_depth(dst: vec2<u32>) -> u32 {
    let p = dst * 2u;
    let a = depth_at(p);
    let b = depth_at(p + vec2<u32>(1u, 0u));
    let c = depth_at(p + vec2<u32>(0u, 1u));
    let d = depth_at(p + vec2<u32>(1u, 1u));
    return min(min(a, b), min(c, d));
}

fn pyramid_at(p: vec2<u32>) -> u32 {
    let q = clamped(p);
    return pyramid[level.src_offset + q.y * level.src_size.x + q.x];
}

fn bits_at(p: vec2<u32>) -> u32 {
    return textureLoad(src_bits, vec2<i32>(clamped(p)), 0).x;
}

@compute @workgroup_size(8, 8)
fn cs_from_depth(@builtin(global_invocation_id) id: vec3<u32>) {
    if (any(id.xy >= level.dst_size)) {
        return;
    }
    pyramid[level.dst_offset + id.y * level.dst_size.x + id.x] = farthest_of_depth(id.xy);
}

@compute @workgroup_size(8, 8)
fn cs_from_level(@builtin(global_invocation_id) id: vec3<u32>) {
    if (any(id.xy >= level.dst_size)) {
        return;
    }
    let p = id.xy * 2u;
    let m = min(
        min(pyramid_at(p), pyramid_at(p + vec2<u32>(1u, 0u))),
        min(pyramid_at(p + vec2<u32>(0u, 1u)), pyramid_at(p + vec2<u32>(1u, 1u))),
    );
    pyramid[level.dst_offset + id.y * level.dst_size.x + id.x] = m;
}

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    // (0,0) (2,0) (0,2) in uv covers the target with one triangle.
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0);
}

// A pixel's centre is at (x + 0.5, y + 0.5): truncation gives its texel.
@fragment
fn fs_from_depth(@builtin(position) pixel: vec4<f32>) -> @location(0) u32 {
    return farthest_of_depth(vec2<u32>(pixel.xy));
}

@fragment
fn fs_from_level(@builtin(position) pixel: vec4<f32>) -> @location(0) u32 {
    let p = vec2<u32>(pixel.xy) * 2u;
    return min(
        min(bits_at(p), bits_at(p + vec2<u32>(1u, 0u))),
        min(bits_at(p + vec2<u32>(0u, 1u)), bits_at(p + vec2<u32>(1u, 1u))),
    );
}
