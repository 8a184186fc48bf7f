// Presents the composited frame (RVG colour + overlays) to the window's
// surface texture: one fullscreen triangle, bilinear sampling, so a window
// whose size differs from the render size (mid-resize) is scaled, not cut.

@group(0) @binding(0) var image: texture_2d<f32>;
@group(0) @binding(1) var image_sampler: sampler;

struct BlitOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) uv: vec2<f32>,
};

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> BlitOut {
    // (0,0) (2,0) (0,2) in uv covers the screen with one triangle.
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    var out: BlitOut;
    out.clip = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0);
    out.uv = uv;
    return out;
}

@fragment
fn fs_main(in: BlitOut) -> @location(0) vec4<f32> {
    return textureSample(image, image_sampler, in.uv);
}
