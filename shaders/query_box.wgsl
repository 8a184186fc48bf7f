// Occlusion queries (Bartz et al.): a node's box, camera-relative (its
// corners made relative to the eye in f64 on the CPU), drawn inside an
// occlusion query with the depth test on and no depth or colour writes.
// The 36 vertices of its 12 triangles come from the vertex index.

@vertex
fn vs_main(
    @builtin(vertex_index) i: u32,
    @location(4) box_min: vec4<f32>,
    @location(5) box_max: vec4<f32>,
) -> @builtin(position) vec4<f32> {
    // Corner index per vertex (bit 0: x, bit 1: y, bit 2: z), two
    // triangles per face.
    var corners = array<u32, 36>(
        0u, 2u, 6u, 0u, 6u, 4u,
        1u, 5u, 7u, 1u, 7u, 3u,
        0u, 4u, 5u, 0u, 5u, 1u,
        2u, 3u, 7u, 2u, 7u, 6u,
        0u, 1u, 3u, 0u, 3u, 2u,
        4u, 6u, 7u, 4u, 7u, 5u,
    );
    let c = corners[i];
    let p = vec3<f32>(
        select(box_min.x, box_max.x, (c & 1u) != 0u),
        select(box_min.y, box_max.y, (c & 2u) != 0u),
        select(box_min.z, box_max.z, (c & 4u) != 0u),
    );
    // Moved toward the eye by frame.params.z in depth: twice the device's
    // absolute depth error (GL's), so a box passes wherever the node's own
    // triangles, rounded the other way, could.
    var clip = frame.view_proj * vec4<f32>(p, 1.0);
    clip.z = clip.z + frame.params.z * clip.w;
    return clip;
}
