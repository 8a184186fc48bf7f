// RVG: colour + depth with a head light, so shapes read clearly.

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) colour: vec4<f32>,
    // Camera-relative position, for the section's clip test.
    @location(2) rel: vec3<f32>,
};

// A highlighted draw (the instance offset's w is 1): the selection's tint.
fn tinted(c: vec4<f32>, offset: vec4<f32>) -> vec4<f32> {
    if (offset.w > 0.5) {
        return vec4<f32>(mix(c.rgb, vec3<f32>(1.0, 0.45, 0.05), 0.65), c.a);
    }
    return c;
}

fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    let lo = c / 12.92;
    let hi = pow((c + 0.055) / 1.055, vec3<f32>(2.4));
    return select(hi, lo, c <= vec3<f32>(0.04045));
}

// A vertex at `rel` (camera-relative) with its normal and sRGB colour.
fn visible_out(rel: vec3<f32>, normal: vec3<f32>, colour: vec4<f32>, offset: vec4<f32>) -> VsOut {
    var out: VsOut;
    out.rel = rel;
    out.clip = frame.view_proj * vec4<f32>(rel, 1.0);
    out.normal = normal;
    out.colour = tinted(vec4<f32>(srgb_to_linear(colour.rgb), colour.a), offset);
    return out;
}

@vertex
fn vs_main(
    @location(0) position: vec3<f32>,
    @location(1) normal: vec2<f32>,
    @location(2) colour: vec4<f32>,
    @location(3) offset: vec4<f32>,
) -> VsOut {
    return visible_out(position + offset.xyz, decode_normal(normal), colour, offset);
}

// The compact layout: grid coordinates and snorm8 normals (common.wgsl).
@vertex
fn vs_compact(
    @location(0) q: vec4<u32>,
    @location(2) colour: vec4<f32>,
    @location(3) offset: vec4<f32>,
    @location(4) scale: vec4<f32>,
) -> VsOut {
    return visible_out(
        compact_position(q, offset, scale),
        decode_normal(compact_normal(q)),
        colour,
        offset,
    );
}

fn lit(colour: vec3<f32>, normal: vec3<f32>) -> vec4<f32> {
    // Two-sided: imported models' winding and normals are not trusted.
    let lambert = abs(dot(normalize(normal), -frame.light_dir.xyz));
    let ambient = frame.params.x;
    return vec4<f32>(colour * (ambient + (1.0 - ambient) * lambert), 1.0);
}

@fragment
fn fs_main(in: VsOut) -> @location(0) vec4<f32> {
    // Wireframe: the object's colour, unlit, so edges read on any side.
    if (frame.params.y > 0.5) {
        return vec4<f32>(in.colour.rgb, 1.0);
    }
    return lit(in.colour.rgb, in.normal);
}

// With a section: what it removes is discarded, and the inside of a cut
// solid (its back faces, by the model's winding, seen through a cut the
// eye looks in by) is the cap: the object's colour darkened, lit as the
// cutting plane, so the cut reads as a filled face.
@fragment
fn fs_section(in: VsOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    if (!section_keeps(in.rel)) {
        discard;
    }
    return cut_surface(in, front);
}

// With a section the rasterizer already clipped (clip distances,
// visible_clip.wgsl): caps only, no discard, so depth tests stay early.
@fragment
fn fs_cap(in: VsOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    return cut_surface(in, front);
}

fn cut_surface(in: VsOut, front: bool) -> vec4<f32> {
    if (frame.params.y > 0.5) {
        return vec4<f32>(in.colour.rgb, 1.0);
    }
    if (!front) {
        let entry = section_entry(in.rel);
        if (entry >= 0) {
            return lit(in.colour.rgb * CAP_DARKEN, frame.clip[entry].xyz);
        }
    }
    return lit(in.colour.rgb, in.normal);
}

// How much darker a cap is than its object.
const CAP_DARKEN: f32 = 0.5;
