//! The look on a real adapter (lavapipe in CI, and GL): edges lie on a
//! cube's visible edges and nowhere else (no face diagonal), FXAA leaves
//! intermediate colours on a silhouette, ambient occlusion darkens an
//! inside corner and nothing flat, the sky fills only the background, and
//! the frame read back for accuracy is the same with any look.

use gigawalk_cull::Camera;
use gigawalk_gpu::{
    devices_or_skip, Antialias, ClipPlanes, DrawStyle, GpuContext, HostGeometry, Look,
    ResidentGeometry, View, VisiblePass,
};
use gigawalk_scene::{Aabb, Colours, LodMesh, SceneReader};
use gigawalk_testkit::write_leaf_scene;
use glam::{DVec3, Vec3, Vec4};

const W: u32 = 160;
const H: u32 = 120;

/// A box with a flat normal a face (24 vertices), each face two triangles
/// split along a diagonal.
fn flat_box(b: &Aabb, colour: [u8; 4]) -> LodMesh {
    let e = b.extent().as_vec3();
    let (mut positions, mut normals, mut indices) = (Vec::new(), Vec::new(), Vec::new());
    for axis in 0..3 {
        for side in [0.0f32, 1.0] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let mut n = Vec3::ZERO;
            n[axis] = if side > 0.0 { 1.0 } else { -1.0 };
            let first = positions.len() as u32;
            for (a, c) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
                let mut p = Vec3::ZERO;
                p[axis] = side * e[axis];
                p[u] = a * e[u];
                p[v] = c * e[v];
                positions.push(p.to_array());
                normals.push(n.to_array());
            }
            indices.extend([first, first + 1, first + 2, first, first + 2, first + 3]);
        }
    }
    LodMesh {
        origin: b.min,
        positions,
        normals,
        colours: Colours::Uniform(colour),
        indices,
    }
}

/// The 2x2x2 cube at the origin, and with `floor` a wide slab whose top
/// it stands on (an inside corner all round its foot).
fn scene(ctx: &GpuContext, floor: bool) -> ResidentGeometry {
    let mut boxes = vec![(
        Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)),
        [150, 150, 160, 255],
    )];
    if floor {
        boxes.push((
            Aabb::new(DVec3::new(-8.0, -1.5, -8.0), DVec3::new(8.0, -1.0, 8.0)),
            [200, 190, 170, 255],
        ));
    }
    scene_of(ctx, &boxes)
}

/// One leaf, and LOD, a box.
fn scene_of(ctx: &GpuContext, boxes: &[(Aabb, [u8; 4])]) -> ResidentGeometry {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.gwk");
    let leaves: Vec<_> = boxes.iter().map(|(b, c)| (*b, flat_box(b, *c))).collect();
    write_leaf_scene(&path, 16, &leaves);
    let scene = SceneReader::open(&path).unwrap();
    HostGeometry::load(&scene, 1 << 20)
        .unwrap()
        .upload(ctx)
        .unwrap()
}

/// A camera above and to the side of a corner of the cube, looking at it.
fn camera() -> Camera {
    Camera::look_at(
        DVec3::new(4.0, 3.5, 5.0),
        DVec3::new(0.0, -0.3, 0.0),
        50f64.to_radians(),
        W as f64 / H as f64,
        0.1,
    )
}

fn view(cam: &Camera) -> View {
    View {
        eye: cam.position,
        view_proj: cam.view_projection_rel(),
        forward: cam.forward().as_vec3(),
        clip: ClipPlanes::NONE,
    }
}

/// One frame with `look`: (colour and depth as read back for accuracy,
/// the shown image).
fn frame(
    ctx: &GpuContext,
    geometry: &ResidentGeometry,
    lods: &[u32],
    look: Look,
) -> ((Vec<u8>, Vec<f32>), Vec<u8>) {
    let v = view(&camera());
    let mut rvg = VisiblePass::new(ctx, W, H);
    rvg.begin(ctx, &v, DrawStyle::Shaded, look);
    rvg.draw(ctx, geometry, lods);
    let drawn = rvg.finish(ctx, true).unwrap().unwrap();
    let shown = rvg.read_shown(ctx).unwrap();
    ((drawn.colour, drawn.depth.depth), shown)
}

fn rgb(img: &[u8], i: usize) -> [i32; 3] {
    [
        img[4 * i] as i32,
        img[4 * i + 1] as i32,
        img[4 * i + 2] as i32,
    ]
}

fn differs(a: &[u8], b: &[u8], i: usize, by: i32) -> bool {
    let (x, y) = (rgb(a, i), rgb(b, i));
    (0..3).any(|c| (x[c] - y[c]).abs() > by)
}

fn luma(img: &[u8], i: usize) -> f64 {
    let [r, g, b] = rgb(img, i);
    0.299 * r as f64 + 0.587 * g as f64 + 0.114 * b as f64
}

/// The cube's edges the camera sees (a face on either side faces it), in
/// pixels.
fn visible_edges(cam: &Camera) -> Vec<([f64; 2], [f64; 2])> {
    let m = cam.view_projection_rel();
    let px = |p: DVec3| {
        let c = m * Vec4::from(((p - cam.position).as_vec3(), 1.0));
        let (x, y) = (c.x / c.w, c.y / c.w);
        [
            (x as f64 + 1.0) * 0.5 * W as f64,
            (1.0 - y as f64) * 0.5 * H as f64,
        ]
    };
    let facing = |axis: usize, sign: f64| {
        let mut n = DVec3::ZERO;
        n[axis] = sign;
        // The face's plane is at sign on that axis.
        (cam.position - n).dot(n) > 0.0
    };
    let mut edges = Vec::new();
    // An edge runs along axis a with the other two coordinates fixed.
    for a in 0..3 {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        for sb in [-1.0, 1.0] {
            for sc in [-1.0, 1.0] {
                if !(facing(b, sb) || facing(c, sc)) {
                    continue;
                }
                let mut p = DVec3::ZERO;
                p[b] = sb;
                p[c] = sc;
                let (mut p0, mut p1) = (p, p);
                p0[a] = -1.0;
                p1[a] = 1.0;
                edges.push((px(p0), px(p1)));
            }
        }
    }
    edges
}

fn distance_to_segment(p: [f64; 2], (a, b): ([f64; 2], [f64; 2])) -> f64 {
    let d = [b[0] - a[0], b[1] - a[1]];
    let t = (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / (d[0] * d[0] + d[1] * d[1]))
        .clamp(0.0, 1.0);
    let q = [a[0] + t * d[0], a[1] + t * d[1]];
    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt()
}

fn edges_only() -> Look {
    Look {
        edges: true,
        ..Look::PLAIN
    }
}

#[test]
fn edges_lie_on_the_cubes_visible_edges_and_not_on_a_face_diagonal() {
    let Some(ctx) = devices_or_skip(1, "look edges").map(|mut d| d.remove(0)) else {
        return;
    };
    let geometry = scene(&ctx, false);
    let ((raw, depth), shown) = frame(&ctx, &geometry, &[0], edges_only());
    let edges = visible_edges(&camera());
    // A cube seen from off a corner shows three faces: nine edges.
    assert_eq!(edges.len(), 9);
    let mut lines = Vec::new();
    for (i, &d) in depth.iter().enumerate() {
        if differs(&raw, &shown, i, 8) {
            assert!(d > 0.0, "an edge off the model at pixel {i}");
            let p = [(i % W as usize) as f64 + 0.5, (i / W as usize) as f64 + 0.5];
            let near = edges
                .iter()
                .map(|&e| distance_to_segment(p, e))
                .fold(f64::INFINITY, f64::min);
            assert!(near <= 1.8, "a line at {p:?}, {near:.2} px from every edge");
            lines.push(p);
        }
    }
    for &(a, b) in &edges {
        for t in [0.25, 0.5, 0.75] {
            let p = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
            assert!(
                lines
                    .iter()
                    .any(|&q| ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt() <= 1.5),
                "no line at {p:?}, on the edge {a:?}-{b:?}"
            );
        }
    }
    // With edges off, no line: the model's pixels are as drawn.
    let sky = Look {
        sky: true,
        ..Look::PLAIN
    };
    let ((raw, depth), shown) = frame(&ctx, &geometry, &[0], sky);
    let mut background = 0;
    for (i, &d) in depth.iter().enumerate() {
        if d > 0.0 {
            assert!(!differs(&raw, &shown, i, 1), "pixel {i} changed");
        } else {
            background += 1;
        }
    }
    // ... and the sky fills the background: not the flat clear colour,
    // and shaded from row to row.
    assert!(background > (W * H / 2) as usize);
    let top = luma(&shown, (W / 2) as usize);
    assert!(differs(&raw, &shown, (W / 2) as usize, 8));
    assert!(luma(&shown, 0) > 0.0 && top > 0.0);
    let mut shades: Vec<i64> = depth
        .iter()
        .enumerate()
        .filter(|(_, &d)| d <= 0.0)
        .map(|(i, _)| luma(&shown, i).round() as i64)
        .collect();
    shades.sort_unstable();
    shades.dedup();
    assert!(shades.len() >= 4, "the sky is {} shades", shades.len());
}

#[test]
fn fxaa_leaves_intermediate_colours_on_a_silhouette() {
    let Some(ctx) = devices_or_skip(1, "look fxaa").map(|mut d| d.remove(0)) else {
        return;
    };
    let geometry = scene(&ctx, false);
    let fxaa = Look {
        aa: Antialias::Fxaa,
        ..Look::PLAIN
    };
    let ((raw, depth), shown) = frame(&ctx, &geometry, &[0], fxaa);
    // The colours as drawn: the background and each face's one shade.
    let mut drawn: Vec<[i32; 3]> = Vec::new();
    for i in 0..(W * H) as usize {
        let c = rgb(&raw, i);
        if !drawn
            .iter()
            .any(|d| (0..3).all(|k| (d[k] - c[k]).abs() <= 1))
        {
            drawn.push(c);
        }
    }
    assert!(
        drawn.len() <= 8,
        "flat faces drawn in {} colours",
        drawn.len()
    );
    // With FXAA, pixels on the silhouette (a background neighbour) take
    // colours between: none of those drawn.
    let w = W as usize;
    let mut between = 0;
    for y in 1..H as usize - 1 {
        for x in 1..w - 1 {
            let i = y * w + x;
            let silhouette = [i - 1, i + 1, i - w, i + w]
                .iter()
                .any(|&j| (depth[i] > 0.0) != (depth[j] > 0.0));
            let c = rgb(&shown, i);
            let new = !drawn
                .iter()
                .any(|d| (0..3).all(|k| (d[k] - c[k]).abs() <= 2));
            if silhouette && new {
                between += 1;
            }
        }
    }
    assert!(between >= 20, "{between} blended silhouette pixels");
}

#[test]
fn ambient_occlusion_darkens_an_inside_corner_and_nothing_flat() {
    let Some(ctx) = devices_or_skip(1, "look ao").map(|mut d| d.remove(0)) else {
        return;
    };
    let geometry = scene(&ctx, true);
    let ao = Look {
        ao: true,
        ao_radius: 0.6,
        ..Look::PLAIN
    };
    let ((raw, depth), shown) = frame(&ctx, &geometry, &[0, 1], ao);
    // The floor's pixels by distance from the cube's foot: the points of
    // the floor's top within 0.15 of the cube, and those over 2.5 away.
    let cam = camera();
    let (near, far) = floor_pixels(&cam, &depth);
    assert!(
        near.len() > 20 && far.len() > 200,
        "{} {}",
        near.len(),
        far.len()
    );
    let mean =
        |img: &[u8], px: &[usize]| px.iter().map(|&i| luma(img, i)).sum::<f64>() / px.len() as f64;
    let (before, after) = (mean(&raw, &near), mean(&shown, &near));
    eprintln!("the corner: {before:.1} -> {after:.1}");
    assert!(
        after < 0.93 * before,
        "the corner: {before:.1} -> {after:.1}"
    );
    // Open floor far from the cube stays as drawn.
    for &i in &far {
        assert!(
            !differs(&raw, &shown, i, 2),
            "flat floor pixel {i} darkened"
        );
    }
}

/// Pixels showing the floor's top (y = -1) within 0.15 of the cube's foot
/// and over 2.5 from it, by casting each pixel's ray.
fn floor_pixels(cam: &Camera, depth: &[f32]) -> (Vec<usize>, Vec<usize>) {
    let inv = cam.view_projection_rel().inverse();
    let (mut near, mut far) = (Vec::new(), Vec::new());
    for (i, &d) in depth.iter().enumerate() {
        if d <= 0.0 {
            continue;
        }
        let (x, y) = ((i % W as usize) as f32 + 0.5, (i / W as usize) as f32 + 0.5);
        let ndc = Vec4::new(x / W as f32 * 2.0 - 1.0, 1.0 - y / H as f32 * 2.0, d, 1.0);
        let h = inv * ndc;
        let p = cam.position + (h.truncate() / h.w).as_dvec3();
        if (p.y + 1.0).abs() > 0.02 {
            continue;
        }
        // Distance on the floor from the cube's square foot.
        let dx = (p.x.abs() - 1.0).max(0.0);
        let dz = (p.z.abs() - 1.0).max(0.0);
        let d = (dx * dx + dz * dz).sqrt();
        if d > 0.0 && d < 0.15 {
            near.push(i);
        } else if d > 2.5 {
            far.push(i);
        }
    }
    (near, far)
}

#[test]
fn the_frame_read_back_for_accuracy_is_the_same_with_any_look() {
    let Some(ctx) = devices_or_skip(1, "look accuracy").map(|mut d| d.remove(0)) else {
        return;
    };
    let geometry = scene(&ctx, true);
    let (plain, shown_plain) = frame(&ctx, &geometry, &[0, 1], Look::PLAIN);
    assert_eq!(
        plain.0, shown_plain,
        "a plain look shows the frame as drawn"
    );
    let everything = Look {
        ao: true,
        ..Look::auto(false)
    };
    let (with_look, shown) = frame(&ctx, &geometry, &[0, 1], everything);
    assert_eq!(plain.0, with_look.0);
    assert_eq!(
        plain.1.iter().map(|d| d.to_bits()).collect::<Vec<_>>(),
        with_look.1.iter().map(|d| d.to_bits()).collect::<Vec<_>>()
    );
    assert_ne!(shown, plain.0);
}

fn linear(c: u8) -> f64 {
    let c = c as f64 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[test]
fn a_ghost_is_see_through_and_hides_nothing() {
    let Some(ctx) = devices_or_skip(1, "ghosts").map(|mut d| d.remove(0)) else {
        return;
    };
    // A red wall to the right, far; the ghost, a box in the middle, near,
    // half over the wall and half over the background.
    let geometry = scene_of(
        &ctx,
        &[
            (
                Aabb::new(DVec3::new(0.0, -3.0, -11.0), DVec3::new(5.0, 3.0, -10.0)),
                [230, 30, 30, 255],
            ),
            (
                Aabb::new(DVec3::new(-2.0, -1.0, -6.0), DVec3::new(2.0, 1.0, -5.0)),
                [120, 160, 120, 255],
            ),
        ],
    );
    let cam = Camera::look_at(
        DVec3::ZERO,
        DVec3::NEG_Z,
        60f64.to_radians(),
        W as f64 / H as f64,
        0.1,
    );
    let v = view(&cam);
    let draw = |ghost: bool| {
        let mut rvg = VisiblePass::new(&ctx, W, H);
        rvg.begin(&ctx, &v, DrawStyle::Shaded, Look::PLAIN);
        rvg.draw(&ctx, &geometry, &[0]);
        if ghost {
            rvg.draw_ghosts(&ctx, &geometry, &[1]);
        }
        rvg.finish(&ctx, true).unwrap().unwrap()
    };
    let (plain, ghosted) = (draw(false), draw(true));
    // Ghosts write no depth.
    assert_eq!(plain.depth, ghosted.depth);
    let m = cam.view_projection_rel();
    let pixel = |p: DVec3| {
        let c = m * Vec4::from(((p - cam.position).as_vec3(), 1.0));
        let x = ((c.x / c.w + 1.0) * 0.5 * W as f32) as usize;
        let y = ((1.0 - c.y / c.w) * 0.5 * H as f32) as usize;
        y * W as usize + x
    };
    let (over_wall, over_sky) = (
        pixel(DVec3::new(1.0, 0.0, -5.0)),
        pixel(DVec3::new(-1.0, 0.0, -5.0)),
    );
    let red = |img: &[u8], i: usize| linear(img[4 * i]);
    // Without ghosts: the wall, and the background.
    let (u1, u2) = (red(&plain.colour, over_wall), red(&plain.colour, over_sky));
    assert!(u1 - u2 > 0.3, "{u1} {u2}");
    // The ghost lets through part of what is behind it: the difference
    // behind shows, scaled by what the ghost's layers (its front and
    // back faces, each at alpha 0.22) transmit.
    let (g1, g2) = (
        red(&ghosted.colour, over_wall),
        red(&ghosted.colour, over_sky),
    );
    let transmitted = (g1 - g2) / (u1 - u2);
    assert!(
        (0.35..0.9).contains(&transmitted),
        "the ghost transmits {transmitted:.2} of what is behind it"
    );
    assert!(g2 > u2, "the ghost shows over the background");
}
