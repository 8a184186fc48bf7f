// OR: depth only. Each draw's instance carries the LOD origin minus the
// camera position (computed in f64 on the CPU), so the GPU never sees
// coordinates far from the camera.

@vertex
fn vs_main(@location(0) position: vec3<f32>, @location(3) offset: vec4<f32>) -> @builtin(position) vec4<f32> {
    return frame.view_proj * vec4<f32>(position + offset.xyz, 1.0);
}

// The compact layout: grid coordinates (common.wgsl).
@vertex
fn vs_compact(
    @location(0) q: vec4<u32>,
    @location(3) offset: vec4<f32>,
    @location(4) scale: vec4<f32>,
) -> @builtin(position) vec4<f32> {
    return frame.view_proj * vec4<f32>(compact_position(q, offset, scale), 1.0);
}
