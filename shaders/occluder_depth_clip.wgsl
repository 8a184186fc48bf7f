// OR and the query pass's depth with a section of at most eight
// half-spaces on a device with clip distances (appended to
// occluder_depth.wgsl, the module beginning `enable clip_distances;`):
// the rasterizer clips, and the pass keeps no fragment stage.

struct DepthClipOut {
    @builtin(position) clip: vec4<f32>,
    @builtin(clip_distances) distances: array<f32, 8>,
};

fn depth_clipped(rel: vec3<f32>) -> DepthClipOut {
    var out: DepthClipOut;
    out.clip = frame.view_proj * vec4<f32>(rel, 1.0);
    out.distances = section_distances(rel);
    return out;
}

@vertex
fn vs_main_clip(@location(0) position: vec3<f32>, @location(3) offset: vec4<f32>) -> DepthClipOut {
    return depth_clipped(position + offset.xyz);
}

@vertex
fn vs_compact_clip(
    @location(0) q: vec4<u32>,
    @location(3) offset: vec4<f32>,
    @location(4) scale: vec4<f32>,
) -> DepthClipOut {
    return depth_clipped(compact_position(q, offset, scale));
}
