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

// What a fragment writes: its colour, and for the look's edges and
// ambient occlusion its triangle's own normal turned to face the eye
// (0.5 n + 0.5, alpha 1: a surface is here), so an edge is where the
// surfaces themselves meet at an angle, whatever normals the model gives
// for shading. A pass without the normal target drops it.
struct FsOut {
    @location(0) colour: vec4<f32>,
    @location(1) normal: vec4<f32>,
};

fn facing(normal: vec3<f32>, rel: vec3<f32>) -> vec3<f32> {
    let n = normalize(normal);
    return select(n, -n, dot(n, rel) > 0.0);
}

// The triangle's plane normal from the position's screen derivatives;
// taken at the top of each entry point, in uniform control flow.
fn face_normal(rel: vec3<f32>) -> vec3<f32> {
    let n = cross(dpdx(rel), dpdy(rel));
    let l = length(n);
    if (l <= 0.0) {
        return -normalize(rel);
    }
    return facing(n / l, rel);
}

fn shaded(colour: vec4<f32>, face: vec3<f32>) -> FsOut {
    return FsOut(colour, vec4<f32>(face * 0.5 + 0.5, 1.0));
}

// X-ray's ghosts (pipelines that draw them set this): a pale, see-through
// tint of the object, blended over the frame and writing neither depth
// nor the normal target, so ghosts hide nothing and draw no edges.
override GHOST: bool = false;
const GHOST_ALPHA: f32 = 0.22;
const GHOST_TINT: vec3<f32> = vec3<f32>(0.62, 0.72, 0.88);

fn ghost(in: VsOut) -> FsOut {
    let lambert = abs(dot(normalize(in.normal), frame.light_dir.xyz));
    let c = mix(in.colour.rgb, GHOST_TINT, 0.6) * (0.55 + 0.45 * lambert);
    return FsOut(vec4<f32>(c, GHOST_ALPHA), vec4<f32>(0.0));
}

// The head light (two-sided: imported models' winding and normals are not
// trusted) over a hemisphere term: a face turned to the sky (world +Y)
// takes more of the ambient light than one turned to the ground, so no
// face is black and up reads from down.
fn lit(colour: vec3<f32>, normal: vec3<f32>, rel: vec3<f32>) -> vec4<f32> {
    let n = facing(normal, rel);
    let lambert = abs(dot(n, -frame.light_dir.xyz));
    let ambient = frame.params.x * mix(HEMI_GROUND, HEMI_SKY, 0.5 + 0.5 * n.y);
    return vec4<f32>(colour * (ambient + (1.0 - frame.params.x) * lambert), 1.0);
}

// The hemisphere's ambient from straight below and straight above, as
// multiples of the ambient term.
const HEMI_GROUND: f32 = 0.45;
const HEMI_SKY: f32 = 1.6;

@fragment
fn fs_main(in: VsOut) -> FsOut {
    let face = face_normal(in.rel);
    if (GHOST) {
        return ghost(in);
    }
    // Wireframe: the object's colour, unlit, so edges read on any side.
    if (frame.params.y > 0.5) {
        return shaded(vec4<f32>(in.colour.rgb, 1.0), face);
    }
    return shaded(lit(in.colour.rgb, in.normal, in.rel), face);
}

// With a section: what it removes is discarded, and the inside of a cut
// solid (its back faces, by the model's winding, seen through a cut the
// eye looks in by) is the cap: the object's colour darkened and hatched,
// lit as the cutting plane, so the cut reads as a filled face.
@fragment
fn fs_section(in: VsOut, @builtin(front_facing) front: bool) -> FsOut {
    let face = face_normal(in.rel);
    if (!section_keeps(in.rel)) {
        discard;
    }
    return cut_surface(in, front, face);
}

// With a section the rasterizer already clipped (clip distances,
// visible_clip.wgsl): caps only, no discard, so depth tests stay early.
@fragment
fn fs_cap(in: VsOut, @builtin(front_facing) front: bool) -> FsOut {
    return cut_surface(in, front, face_normal(in.rel));
}

fn cut_surface(in: VsOut, front: bool, face: vec3<f32>) -> FsOut {
    if (GHOST) {
        return ghost(in);
    }
    if (frame.params.y > 0.5) {
        return shaded(vec4<f32>(in.colour.rgb, 1.0), face);
    }
    if (!front) {
        let entry = section_entry(in.rel);
        if (entry >= 0) {
            let plane = frame.clip[entry].xyz;
            // Diagonal hatching in screen space, a line every CAP_HATCH
            // pixels.
            let stripe = fract((in.clip.x + in.clip.y) / CAP_HATCH) < 0.25;
            let darken = select(CAP_DARKEN, CAP_DARKEN * 0.45, stripe);
            return shaded(lit(in.colour.rgb * darken, plane, in.rel), facing(plane, in.rel));
        }
    }
    return shaded(lit(in.colour.rgb, in.normal, in.rel), face);
}

// How much darker a cap is than its object, and its hatching's period in
// pixels.
const CAP_DARKEN: f32 = 0.5;
const CAP_HATCH: f32 = 8.0;
