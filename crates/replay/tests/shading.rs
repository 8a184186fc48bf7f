//! Shading through preprocessing: a sphere with smooth normals, made into
//! a scene with levels of detail, renders without facets at every level
//! (leaves' coarser levels and inner nodes' merged ones), drawn alone.

mod common;

use gigawalk_cull::Camera;
use gigawalk_gpu::{devices_or_skip, ClipPlanes, DrawStyle, HostGeometry, Look, View, VisiblePass};
use glam::DVec3;

const SIZE: u32 = 160;

/// A UV sphere of radius 1 at the origin as OBJ text, with a normal per
/// vertex (the smooth surface's), or with `faceted` each triangle's own.
fn sphere_obj(rings: u32, segments: u32, faceted: bool) -> String {
    let mut s = String::from("o sphere\n");
    for i in 0..(rings + 1) * segments {
        let p = vertex(rings, segments, i);
        s += &format!("v {} {} {}\nvn {} {} {}\n", p.x, p.y, p.z, p.x, p.y, p.z);
    }
    let at = |r: u32, k: u32| r * segments + k % segments + 1;
    for r in 0..rings {
        for k in 0..segments {
            let (a, b, c, d) = (at(r, k), at(r, k + 1), at(r + 1, k + 1), at(r + 1, k));
            for (keep, [a, b, c]) in [(r > 0, [a, b, c]), (r + 1 < rings, [a, c, d])] {
                if !keep {
                    continue;
                }
                if faceted {
                    let p = |i: u32| vertex(rings, segments, i - 1);
                    let n = (p(b) - p(a)).cross(p(c) - p(a)).normalize();
                    s += &format!("vn {} {} {}\nf {a}//-1 {b}//-1 {c}//-1\n", n.x, n.y, n.z);
                } else {
                    s += &format!("f {a}//{a} {b}//{b} {c}//{c}\n");
                }
            }
        }
    }
    s
}

/// The sphere's vertex `i`: ring `i / segments`, segment `i % segments`.
fn vertex(rings: u32, segments: u32, i: u32) -> DVec3 {
    let (r, k) = (i / segments, i % segments);
    let phi = std::f64::consts::PI * r as f64 / rings as f64;
    let theta = 2.0 * std::f64::consts::PI * k as f64 / segments as f64;
    DVec3::new(phi.sin() * theta.cos(), phi.cos(), phi.sin() * theta.sin())
}

/// Each LOD of `obj` preprocessed, drawn alone: (LOD, triangles, error,
/// the largest step in shade between horizontal neighbours on one smooth
/// stretch of surface), and the pixel pairs tested.
fn shade_steps(ctx: &gigawalk_gpu::GpuContext, obj: &str) -> (Vec<(u32, u32, f32, f64)>, usize) {
    let dir = tempfile::tempdir().unwrap();
    let model = gigawalk_import::import_obj_str(obj, "sphere.obj").unwrap();
    let scene = common::preprocess(dir.path(), "sphere", &model, Default::default());
    let geometry = HostGeometry::load(&scene, 1 << 24)
        .unwrap()
        .upload(ctx)
        .unwrap();
    let cam = Camera::look_at(
        DVec3::new(0.0, 0.4, 3.2),
        DVec3::ZERO,
        50f64.to_radians(),
        1.0,
        0.05,
    );
    let v = View {
        eye: cam.position,
        view_proj: cam.view_projection_rel(),
        forward: cam.forward().as_vec3(),
        clip: ClipPlanes::NONE,
    };
    // The sphere's outline: its centre and radius in pixels.
    let centre = SIZE as f64 * 0.5;
    let radius = (1.0 / cam.position.length()).asin().tan() / 25f64.to_radians().tan() * centre;
    let n = SIZE as usize;
    let mut tested = 0;
    let mut steps = Vec::new();
    for lod in 0..scene.skeleton().lods().len() as u32 {
        let mut rvg = VisiblePass::new(ctx, SIZE, SIZE);
        rvg.begin(ctx, &v, DrawStyle::Shaded, Look::PLAIN);
        rvg.draw(ctx, &geometry, &[lod]);
        let f = rvg.finish(ctx, true).unwrap().unwrap();
        let luma = |i: usize| {
            let c = &f.colour[4 * i..4 * i + 3];
            0.299 * c[0] as f64 + 0.587 * c[1] as f64 + 0.114 * c[2] as f64
        };
        let covered = |x: usize, y: usize| f.depth.depth[y * n + x] > 0.0;
        // Neighbours well inside the level's own outline and the
        // sphere's (where shading is steep at grazing angles).
        let mut worst: f64 = 0.0;
        for y in 2..n - 2 {
            for x in 2..n - 3 {
                let (dx, dy) = (x as f64 + 0.5 - centre, y as f64 + 0.5 - centre);
                if (dx * dx + dy * dy).sqrt() > 0.75 * radius {
                    continue;
                }
                let inside = (x - 2..=x + 3).all(|a| (y - 2..=y + 2).all(|b| covered(a, b)));
                // One surface: no depth step between the pair (a piece
                // seen over its own far side is not a facet).
                let (d0, d1) = (f.depth.depth[y * n + x], f.depth.depth[y * n + x + 1]);
                if !inside || (d1 - d0).abs() > 0.01 * d0 {
                    continue;
                }
                tested += 1;
                worst = worst.max((luma(y * n + x + 1) - luma(y * n + x)).abs());
            }
        }
        let info = scene.skeleton().lod(lod);
        steps.push((lod, info.triangles, info.error, worst));
    }
    (steps, tested)
}

/// The most a smooth sphere's shade steps between neighbours here (a
/// facet's edge steps by several times it).
const SMOOTH_STEP: f64 = 8.0;

#[test]
fn a_smooth_sphere_shades_without_facets_at_every_level() {
    let Some(ctx) = devices_or_skip(1, "sphere levels").map(|mut d| d.remove(0)) else {
        return;
    };
    let (steps, tested) = shade_steps(&ctx, &sphere_obj(96, 192, false));
    let full = steps.iter().filter(|s| s.2 == 0.0).count();
    // Levels coarser than full detail, leaves' and inner nodes', to test.
    assert!(
        steps.len() > 2 * full,
        "{} LODs, {full} at full detail",
        steps.len()
    );
    assert!(tested > 1000, "{tested} pixel pairs tested");
    for (lod, triangles, error, worst) in steps {
        assert!(
            worst <= SMOOTH_STEP,
            "LOD {lod} ({triangles} triangles, error {error}): the shade steps by {worst:.1} between neighbours: facets"
        );
    }
    // The measure sees facets: a sphere of 15-degree facets, a normal a
    // triangle.
    let (faceted, _) = shade_steps(&ctx, &sphere_obj(12, 24, true));
    let worst = faceted.iter().map(|s| s.3).fold(0.0, f64::max);
    assert!(worst > SMOOTH_STEP, "a faceted sphere steps by {worst:.1}");
}
