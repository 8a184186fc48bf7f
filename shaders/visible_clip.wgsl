// RVG with a section of at most eight half-spaces on a device with clip
// distances (appended to visible.wgsl, the module beginning `enable
// clip_distances;`): the rasterizer clips each triangle by the
// half-spaces, so the fragment stage (fs_cap) only paints caps and never
// discards, and depth tests stay early.

struct VsClipOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) colour: vec4<f32>,
    @location(2) rel: vec3<f32>,
    @builtin(clip_distances) distances: array<f32, 8>,
};

fn clipped(v: VsOut) -> VsClipOut {
    var out: VsClipOut;
    out.clip = v.clip;
    out.normal = v.normal;
    out.colour = v.colour;
    out.rel = v.rel;
    out.distances = section_distances(v.rel);
    return out;
}

@vertex
fn vs_main_clip(
    @location(0) position: vec3<f32>,
    @location(1) normal: vec2<f32>,
    @location(2) colour: vec4<f32>,
    @location(3) offset: vec4<f32>,
) -> VsClipOut {
    return clipped(visible_out(position + offset.xyz, decode_normal(normal), colour, offset));
}

@vertex
fn vs_compact_clip(
    @location(0) q: vec4<u32>,
    @location(2) colour: vec4<f32>,
    @location(3) offset: vec4<f32>,
    @location(4) scale: vec4<f32>,
) -> VsClipOut {
    return clipped(visible_out(
        compact_position(q, offset, scale),
        decode_normal(compact_normal(q)),
        colour,
        offset,
    ));
}
