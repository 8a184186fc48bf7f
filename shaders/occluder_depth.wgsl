// OR: depth only. Each draw's instance carries the LOD origin minus the
// camera position (computed in f64 on the CPU), so the GPU never sees
// coordinates far from the camera.


struct DepthOut {
    @builtin(position) clip: vec4<f32>,
    // Camera-relative position, for the section's clip test.
    @location(0) rel: vec3<f32>,
};

fn depth_out(rel: vec3<f32>) -> DepthOut {
    var out: DepthOut;
    out.clip = frame.view_proj * vec4<f32>(rel, 1.0);
    out.rel = rel;
    return out;
}

@vertex
fn vs_main(@location(0) position: vec3<f32>, @location(3) offset: vec4<f32>) -> DepthOut {
    return depth_out(position + offset.xyz);
}

// The compact layout: grid coordinates (common.wgsl).
@vertex
fn vs_compact(
    @location(0) q: vec4<u32>,
    @location(3) offset: vec4<f32>,
    @location(4) scale: vec4<f32>,
) -> DepthOut {
    return depth_out(compact_position(q, offset, scale));
}

// With a section: only what it keeps writes depth. (Without one the pass
// has no fragment stage.)
@fragment
fn fs_section(in: DepthOut) {
    if (!section_keeps(in.rel)) {
        discard;
    }
}
