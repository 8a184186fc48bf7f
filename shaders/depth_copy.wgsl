// Depth read-back where the adapter cannot copy a depth texture to a
// buffer (wgpu's GL backend): one fullscreen triangle writes each pixel's
// depth, bit for bit, into an R32Uint colour target, which can be copied.
// Bit for bit matters: the HZB and the accuracy reference compare depths
// exactly, so this path must read what a direct copy reads.

// Bound as unfilterable float, not texture_depth_2d: naga's GLSL output
// cannot textureLoad a depth texture. Read through a nearest sampler at
// the texel's centre, not textureLoad: GL then takes the sampler's
// filter, where a texel fetch takes the texture's own, which wgpu leaves
// at GL's default for depth formats, and WebGL2 counts a float depth
// texture with that filter as incomplete (a fetch reads 0).
@group(0) @binding(0) var depth: texture_2d<f32>;
@group(0) @binding(1) var nearest: sampler;

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    // (0,0) (2,0) (0,2) in uv covers the target with one triangle.
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0);
}

@fragment
fn fs_main(@builtin(position) pixel: vec4<f32>) -> @location(0) u32 {
    // A pixel's centre is at (x + 0.5, y + 0.5), its texel's centre too:
    // nearest sampling there reads that texel.
    let size = vec2<f32>(textureDimensions(depth));
    return bitcast<u32>(textureSampleLevel(depth, nearest, pixel.xy / size, 0.0).x);
}
