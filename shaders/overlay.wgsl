// Viewer overlays drawn over the RVG image before it is presented: node
// bounding boxes as lines (camera-relative, like every other pass) and HUD
// text as quads sampling an 8x8 bitmap-font atlas. Mirrors OverlayUniforms
// in crates/gpu/src/overlay.rs (checked with naga in crates/gpu/tests/present.rs).

struct OverlayUniforms {
    // Projection x camera rotation (no translation: boxes are camera-relative).
    view_proj: mat4x4<f32>,
    // xy: target size in pixels; zw: unused.
    screen: vec4<f32>,
};

@group(0) @binding(0) var<uniform> overlay: OverlayUniforms;
@group(0) @binding(1) var font: texture_2d<f32>;

struct LineOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) colour: vec4<f32>,
};

@vertex
fn vs_line(@location(0) position: vec3<f32>, @location(1) colour: vec4<f32>) -> LineOut {
    var out: LineOut;
    out.clip = overlay.view_proj * vec4<f32>(position, 1.0);
    out.colour = colour;
    return out;
}

@fragment
fn fs_line(in: LineOut) -> @location(0) vec4<f32> {
    return in.colour;
}

struct TextOut {
    @builtin(position) clip: vec4<f32>,
    // Texel coordinates in the font atlas.
    @location(0) texel: vec2<f32>,
    @location(1) colour: vec4<f32>,
};

@vertex
fn vs_text(
    @location(0) pixel: vec2<f32>,
    @location(1) texel: vec2<f32>,
    @location(2) colour: vec4<f32>,
) -> TextOut {
    var out: TextOut;
    // Pixels (row 0 at the top) to NDC.
    let ndc = vec2<f32>(pixel.x / overlay.screen.x * 2.0 - 1.0, 1.0 - pixel.y / overlay.screen.y * 2.0);
    out.clip = vec4<f32>(ndc, 0.0, 1.0);
    out.texel = texel;
    out.colour = colour;
    return out;
}

@fragment
fn fs_text(in: TextOut) -> @location(0) vec4<f32> {
    // Nearest texel: the font is a bitmap, quads are integer multiples of it.
    let coverage = textureLoad(font, vec2<i32>(floor(in.texel)), 0).r;
    return vec4<f32>(in.colour.rgb, in.colour.a * coverage);
}
