// The look: what the shown image adds to RVG's frame, in up to three
// fullscreen passes over its colour, depth and normal targets.
//   fs_ao       ambient occlusion from depth and normals (an R8 target)
//   fs_compose  the sky behind the model, occlusion (blurred 4x4) and edges
//   fs_fxaa     anti-aliasing of the composed image
// Accuracy never reads these: RVG's own colour and depth stay as drawn.

struct LookUniforms {
    // Clip space (reversed-Z, infinite far) to camera-relative positions
    // on world axes: the inverse of the frame's projection x rotation.
    inv_view_proj: mat4x4<f32>,
    // x, y: target size in pixels; z: ambient occlusion's reach in model
    // units; w: pixels per radian (the projection's scale).
    size: vec4<f32>,
    // x: the cosine of the crease angle; y, z, w: unused.
    params: vec4<f32>,
};

// Which of the composition's parts run: each pipeline is made for one
// set, so a part left out costs nothing (CPU rasterizers such as
// llvmpipe run both sides of a branch).
override EDGES: bool = false;
override AO: bool = false;
override SKY: bool = false;

@group(0) @binding(0) var<uniform> look: LookUniforms;
// Depth bound as unfilterable float (naga's GLSL output cannot textureLoad
// a depth texture) and read through the nearest sampler at the texel's
// centre, as in depth_copy.wgsl: a texel fetch takes the texture's own
// filter, with which WebGL2 reads a float depth texture as 0.
@group(0) @binding(1) var depth_tex: texture_2d<f32>;
// The eye-facing unit normal, 0.5 n + 0.5, alpha 1 where a surface is.
@group(0) @binding(2) var normal_tex: texture_2d<f32>;
@group(0) @binding(3) var colour_tex: texture_2d<f32>;
@group(0) @binding(4) var ao_tex: texture_2d<f32>;
@group(0) @binding(5) var image_sampler: sampler;
@group(0) @binding(6) var nearest: sampler;

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    // (0,0) (2,0) (0,2) in uv covers the target with one triangle.
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0);
}

// The pixel nearest `p` inside the image (neighbours of an edge pixel
// read the edge).
fn inside(p: vec2<i32>) -> vec2<i32> {
    return clamp(p, vec2<i32>(0), vec2<i32>(look.size.xy) - vec2<i32>(1));
}

fn depth_at(p: vec2<i32>) -> f32 {
    let uv = (vec2<f32>(inside(p)) + 0.5) / look.size.xy;
    return textureSampleLevel(depth_tex, nearest, uv, 0.0).x;
}

fn normal_at(p: vec2<i32>) -> vec4<f32> {
    let n = textureLoad(normal_tex, inside(p), 0);
    return vec4<f32>(n.xyz * 2.0 - 1.0, n.w);
}

// The camera-relative point a pixel (its centre) shows at depth d.
fn position_at(p: vec2<i32>, d: f32) -> vec3<f32> {
    let uv = (vec2<f32>(p) + 0.5) / look.size.xy;
    let ndc = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, d, 1.0);
    let h = look.inv_view_proj * ndc;
    return h.xyz / h.w;
}

// Ambient occlusion (after McGuire et al.'s Alchemy and SAO): each of
// AO_SAMPLES points on a spiral within the reach, projected, occludes by
// the cosine between the normal and the direction to it, fading out with
// distance. The spiral turns by a 4x4 pattern that fs_compose's 4x4 blur
// averages away.
const AO_SAMPLES: i32 = 12;
const AO_TURNS: f32 = 7.0;
// Cosine below which a sample does not occlude (tessellation of curved
// surfaces must not darken them).
const AO_BIAS: f32 = 0.15;
const AO_STRENGTH: f32 = 2.5;
const AO_DISTANCE_SHARE: f32 = 0.1;

@fragment
fn fs_ao(@builtin(position) pixel: vec4<f32>) -> @location(0) vec4<f32> {
    let p = vec2<i32>(pixel.xy);
    let d = depth_at(p);
    let n4 = normal_at(p);
    if (d <= 0.0 || n4.w < 0.5) {
        return vec4<f32>(1.0);
    }
    let at = position_at(p, d);
    let n = normalize(n4.xyz);
    let dist = length(at);
    // The reach: the given one, but at most a tenth of the distance (a
    // close-up of a small part darkens at its own scale), and on screen
    // at most a tenth of the image's height.
    let reach_world = min(look.size.z, AO_DISTANCE_SHARE * dist);
    let reach_px = min(reach_world * look.size.w / max(dist, 1e-6), 0.1 * look.size.y);
    if (reach_px < 1.5) {
        return vec4<f32>(1.0);
    }
    let reach = reach_px * dist / look.size.w;
    let pattern = f32((p.x & 3) + 4 * (p.y & 3));
    let spin = pattern * (6.2831853 / 16.0);
    var sum = 0.0;
    for (var i = 0; i < AO_SAMPLES; i = i + 1) {
        let a = (f32(i) + 0.5) / f32(AO_SAMPLES);
        let theta = a * AO_TURNS * 6.2831853 + spin;
        let off = vec2<f32>(cos(theta), sin(theta)) * a * reach_px;
        let q = p + vec2<i32>(off);
        let dq = depth_at(q);
        if (dq <= 0.0) {
            continue;
        }
        let v = position_at(q, dq) - at;
        let vv = dot(v, v);
        if (vv <= 1e-12) {
            continue;
        }
        let cosine = dot(v, n) * inverseSqrt(vv);
        let fade = max(1.0 - vv / (reach * reach), 0.0);
        sum = sum + max(cosine - AO_BIAS, 0.0) * fade;
    }
    let ao = clamp(1.0 - AO_STRENGTH * sum / f32(AO_SAMPLES), 0.0, 1.0);
    return vec4<f32>(ao, ao, ao, 1.0);
}

// The sky and ground behind the model (world +Y is up), linear colours.
fn sky(p: vec2<i32>) -> vec3<f32> {
    let dir = normalize(position_at(p, 1.0));
    let y = dir.y;
    let horizon = vec3<f32>(0.58, 0.62, 0.67);
    if (y >= 0.0) {
        let zenith = vec3<f32>(0.20, 0.29, 0.44);
        return mix(horizon, zenith, sqrt(y));
    }
    let ground = vec3<f32>(0.16, 0.155, 0.15);
    return mix(vec3<f32>(0.36, 0.35, 0.33), ground, sqrt(-y));
}

// Whether a pixel is on the near side of a depth discontinuity: some
// neighbour lies farther than the plane through the pixel and the
// opposite neighbour puts it (reversed-Z depth is affine in screen space
// on a plane, so a plane at any slant never shows one).
fn depth_edge(p: vec2<i32>, d: f32) -> bool {
    let l = depth_at(p + vec2<i32>(-1, 0));
    let r = depth_at(p + vec2<i32>(1, 0));
    let u = depth_at(p + vec2<i32>(0, -1));
    let b = depth_at(p + vec2<i32>(0, 1));
    let jump = max(
        max((2.0 * d - l) - r, (2.0 * d - r) - l),
        max((2.0 * d - u) - b, (2.0 * d - b) - u),
    );
    return jump > EDGE_DEPTH_JUMP * d;
}

// A jump of this fraction of the pixel's depth (about that share of its
// distance) is a silhouette.
const EDGE_DEPTH_JUMP: f32 = 0.02;
// How dark an edge is drawn over the surface.
const EDGE_ALPHA: f32 = 0.7;
const EDGE_COLOUR: vec3<f32> = vec3<f32>(0.02, 0.02, 0.025);

// Whether the normals of the pixel and its right or lower neighbour part
// by more than the crease angle (a line one pixel wide).
fn crease_edge(p: vec2<i32>, n: vec3<f32>) -> bool {
    let r = normal_at(p + vec2<i32>(1, 0));
    let b = normal_at(p + vec2<i32>(0, 1));
    let cosine = look.params.x;
    return (r.w > 0.5 && dot(n, r.xyz) < cosine) || (b.w > 0.5 && dot(n, b.xyz) < cosine);
}

// Occlusion blurred over the 4x4 block its pattern repeats in, from
// samples at about the pixel's depth only.
fn blurred_ao(p: vec2<i32>, d: f32) -> f32 {
    var sum = 0.0;
    var weight = 0.0;
    for (var y = -2; y < 2; y = y + 1) {
        for (var x = -2; x < 2; x = x + 1) {
            let q = p + vec2<i32>(x, y);
            let dq = depth_at(q);
            if (abs(dq - d) <= 0.05 * d) {
                sum = sum + textureLoad(ao_tex, inside(q), 0).x;
                weight = weight + 1.0;
            }
        }
    }
    return select(1.0, sum / weight, weight > 0.0);
}

@fragment
fn fs_compose(@builtin(position) pixel: vec4<f32>) -> @location(0) vec4<f32> {
    let p = vec2<i32>(pixel.xy);
    let d = depth_at(p);
    var c = textureLoad(colour_tex, p, 0).rgb;
    if (d <= 0.0) {
        if (SKY) {
            c = sky(p);
        }
        return vec4<f32>(c, 1.0);
    }
    if (AO) {
        c = c * blurred_ao(p, d);
    }
    if (EDGES) {
        let n = normal_at(p);
        if (depth_edge(p, d) || (n.w > 0.5 && crease_edge(p, n.xyz))) {
            c = mix(c, EDGE_COLOUR, EDGE_ALPHA);
        }
    }
    return vec4<f32>(c, 1.0);
}

// FXAA (after Lottes' FXAA, its small "console" form): where luma varies
// across the pixel, blend along the edge's direction, up to FXAA_SPAN
// pixels, unless that blend leaves the local luma range.
const FXAA_SPAN: f32 = 8.0;
const FXAA_REDUCE_MUL: f32 = 0.125;
const FXAA_REDUCE_MIN: f32 = 0.0078125;

fn luma(c: vec3<f32>) -> f32 {
    // Perceptual enough: the square root of linear luminance.
    return sqrt(dot(c, vec3<f32>(0.299, 0.587, 0.114)));
}

fn sample(uv: vec2<f32>) -> vec3<f32> {
    return textureSampleLevel(colour_tex, image_sampler, uv, 0.0).rgb;
}

@fragment
fn fs_fxaa(@builtin(position) pixel: vec4<f32>) -> @location(0) vec4<f32> {
    let texel = 1.0 / look.size.xy;
    let uv = pixel.xy * texel;
    let m = sample(uv);
    let nw = luma(sample(uv + vec2<f32>(-0.5, -0.5) * texel));
    let ne = luma(sample(uv + vec2<f32>(0.5, -0.5) * texel));
    let sw = luma(sample(uv + vec2<f32>(-0.5, 0.5) * texel));
    let se = luma(sample(uv + vec2<f32>(0.5, 0.5) * texel));
    let lm = luma(m);
    let lo = min(lm, min(min(nw, ne), min(sw, se)));
    let hi = max(lm, max(max(nw, ne), max(sw, se)));
    var dir = vec2<f32>(-((nw + ne) - (sw + se)), (nw + sw) - (ne + se));
    let reduce = max((nw + ne + sw + se) * 0.25 * FXAA_REDUCE_MUL, FXAA_REDUCE_MIN);
    let scale = 1.0 / (min(abs(dir.x), abs(dir.y)) + reduce);
    dir = clamp(dir * scale, vec2<f32>(-FXAA_SPAN), vec2<f32>(FXAA_SPAN)) * texel;
    let a = 0.5 * (sample(uv + dir * (1.0 / 3.0 - 0.5)) + sample(uv + dir * (2.0 / 3.0 - 0.5)));
    let b = a * 0.5 + 0.25 * (sample(uv - dir * 0.5) + sample(uv + dir * 0.5));
    let lb = luma(b);
    if (lb < lo || lb > hi) {
        return vec4<f32>(a, 1.0);
    }
    return vec4<f32>(b, 1.0);
}
