//! GPU passes on a real adapter (lavapipe in CI): depth values follow the
//! reversed-Z convention, colour shows the scene, and a scene 10^7 units
//! from the origin renders like the same scene at the origin.

use gigawalk_cull::{Camera, Hzb, Reduction};
use gigawalk_gpu::{
    devices_or_skip, ClipPlanes, DecodedLod, DepthPass, DrawStyle, GeometryPool, GpuContext,
    HostGeometry, Look, PyramidPath, ResidentGeometry, VertexLayout, View, VisiblePass,
};
use gigawalk_scene::{Aabb, SceneReader};
use gigawalk_testkit::{box_mesh, write_leaf_scene};
use glam::{DVec3, Vec3};

/// A red 2x2x1 box 5 units ahead on -Z, and a green 6x6x1 box 20 ahead and
/// to the right (x 3..9), all shifted by `shift`, with 16-bit normals
/// (the scene writer's default: drawn in the wide layout).
fn write_scene(path: &std::path::Path, shift: DVec3) {
    write_scene_with(path, shift, 16)
}

/// [`write_scene`] with normals of `normal_bits` (8: the compact layout).
fn write_scene_with(path: &std::path::Path, shift: DVec3, normal_bits: u8) {
    let boxes = [
        (
            Aabb::new(DVec3::new(-1.0, -1.0, -6.0), DVec3::new(1.0, 1.0, -5.0)),
            [255, 0, 0, 255],
        ),
        (
            Aabb::new(DVec3::new(3.0, -3.0, -21.0), DVec3::new(9.0, 3.0, -20.0)),
            [0, 255, 0, 255],
        ),
    ];
    let leaves: Vec<_> = boxes
        .iter()
        .map(|(b, c)| {
            let b = Aabb::new(b.min + shift, b.max + shift);
            (b, box_mesh(&b, *c))
        })
        .collect();
    write_leaf_scene(path, normal_bits, &leaves);
}

/// The two boxes of [`write_scene_with`], shifted by `shift`, resident on
/// `ctx` in `layout`.
fn upload_scene(ctx: &GpuContext, shift: DVec3, layout: VertexLayout) -> ResidentGeometry {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.gwk");
    let normal_bits = match layout {
        VertexLayout::Wide => 16,
        VertexLayout::Compact => 8,
    };
    write_scene_with(&path, shift, normal_bits);
    let scene = SceneReader::open(&path).unwrap();
    let host = HostGeometry::load(&scene, 1 << 20).unwrap();
    let mut counts = [0; 2];
    counts[layout as usize] = 2;
    assert_eq!(host.layout_counts(), counts);
    host.upload(ctx).unwrap()
}

fn view(shift: DVec3, w: u32, h: u32) -> View {
    let cam = Camera::look_at(
        shift,
        shift + DVec3::NEG_Z,
        60f64.to_radians(),
        w as f64 / h as f64,
        0.1,
    );
    View {
        eye: cam.position,
        view_proj: cam.view_projection_rel(),
        forward: cam.forward().as_vec3(),
        clip: ClipPlanes::NONE,
    }
}

/// Renders (depth pass image, visible colour, visible depth) of the scene shifted by `shift`.
fn render(shift: DVec3) -> Option<(Vec<f32>, Vec<u8>, Vec<f32>)> {
    render_in(shift, VertexLayout::Wide)
}

/// [`render`] from geometry in `layout`.
fn render_in(shift: DVec3, layout: VertexLayout) -> Option<(Vec<f32>, Vec<u8>, Vec<f32>)> {
    render_styled(shift, DrawStyle::Shaded, (64, 48), layout).map(|(r, _)| r)
}

/// As [`render`], drawing RVG in `style`; also says whether the device
/// supports wireframe.
#[allow(clippy::type_complexity)]
fn render_styled(
    shift: DVec3,
    style: DrawStyle,
    (w, h): (u32, u32),
    layout: VertexLayout,
) -> Option<((Vec<f32>, Vec<u8>, Vec<f32>), bool)> {
    let ctx = devices_or_skip(1, "gpu render").map(|mut d| d.remove(0))?;
    let geometry = upload_scene(&ctx, shift, layout);
    let v = view(shift, w, h);
    let mut or = DepthPass::new(&ctx, w, h);
    let depth = or.render(&ctx, &geometry, &v, &[0, 1]).unwrap();
    assert_eq!((depth.width, depth.height), (w, h));
    let mut rvg = VisiblePass::new(&ctx, w, h);
    rvg.begin(&ctx, &v, style, Look::PLAIN);
    rvg.draw(&ctx, &geometry, &[1]); // far box first, in its own chunk
    rvg.draw(&ctx, &geometry, &[0]);
    let frame = rvg.finish(&ctx, true).unwrap().unwrap();
    Some((
        (depth.depth, frame.colour, frame.depth.depth),
        ctx.supports_wireframe(),
    ))
}

#[test]
fn depth_and_colour_follow_the_conventions() {
    let Some((depth, colour, vdepth)) = render(DVec3::ZERO) else {
        return;
    };
    let (w, h) = (64usize, 48usize);
    let at = |x: usize, y: usize| y * w + x;
    // Centre: the near box's front face at distance 5: reversed-Z depth = near / 5.
    let centre = depth[at(w / 2, h / 2)];
    assert!((centre - 0.1 / 5.0).abs() < 1e-5, "centre depth {centre}");
    // Corner: nothing drawn, cleared to 0 (infinitely far).
    assert_eq!(depth[at(0, 0)], 0.0);
    // The visible pass agrees with the depth pass.
    assert_eq!(vdepth, depth);
    // Centre pixel is red; to the right, where tan(x) = 0.3, only the far green box is.
    let px = |x: usize, y: usize| &colour[4 * at(x, y)..4 * at(x, y) + 4];
    let c = px(w / 2, h / 2);
    assert!(c[0] > 100 && c[1] < 30, "centre colour {c:?}");
    let f = 1.0 / 30f32.to_radians().tan();
    let x = ((0.3 * f / (w as f32 / h as f32) + 1.0) / 2.0 * w as f32) as usize;
    let g = px(x, h / 2);
    assert!(g[1] > 100 && g[0] < 30, "colour at x = {x}: {g:?}");
    assert!((depth[at(x, h / 2)] - 0.1 / 20.0).abs() < 1e-6);
    // Top row, background.
    let bg = px(w / 2, 0);
    assert!(bg[0] < 60 && bg[1] < 60 && bg[2] < 70, "background {bg:?}");
}

/// OR's depth, RVG's colour, RVG's depth.
type Rendered = (Vec<f32>, Vec<u8>, Vec<f32>);

/// OR's depth and RVG's colour and depth with the camera below the boxes
/// (so they show in the image's upper half), read back as the adapter
/// does it, and then through the depth copy pass.
fn render_both_depth_paths() -> Option<[Rendered; 2]> {
    let mut ctx = devices_or_skip(1, "depth copy pass").map(|mut d| d.remove(0))?;
    let shift = DVec3::new(-3e5, 7e4, 1e6);
    let geometry = upload_scene(&ctx, shift, VertexLayout::Wide);
    let (w, h) = (80, 50);
    let v = view(shift + DVec3::new(0.0, -1.5, 0.0), w, h);
    let mut out = Vec::new();
    for forced in [false, true] {
        if forced {
            ctx.force_depth_copy_pass();
        }
        let depth = DepthPass::new(&ctx, w, h)
            .render(&ctx, &geometry, &v, &[0, 1])
            .unwrap();
        let mut rvg = VisiblePass::new(&ctx, w, h);
        rvg.begin(&ctx, &v, DrawStyle::Shaded, Look::PLAIN);
        rvg.draw(&ctx, &geometry, &[0, 1]);
        let frame = rvg.finish(&ctx, true).unwrap().unwrap();
        out.push((depth.depth, frame.colour, frame.depth.depth));
    }
    out.try_into().ok()
}

/// Runs of draws recorded as one multi-draw (where the adapter has
/// indirect draws with a first instance) draw what one call a draw does,
/// bit for bit: OR's depth, RVG's colour and depth, in either draw order
/// and with a LOD drawn twice.
#[test]
fn multi_draws_draw_what_one_call_a_draw_does() {
    let Some(mut ctx) = devices_or_skip(1, "multi-draw").map(|mut d| d.remove(0)) else {
        return;
    };
    let multi = ctx.capabilities().multi_draw;
    let shift = DVec3::new(-3e5, 7e4, 1e6);
    let (w, h) = (80, 50);
    let v = view(shift + DVec3::new(0.0, -1.5, 0.0), w, h);
    let mut out = Vec::new();
    for forced in [false, true] {
        if forced {
            ctx.force_draw_calls();
        }
        assert_eq!(ctx.capabilities().multi_draw, multi && !forced);
        for layout in [VertexLayout::Wide, VertexLayout::Compact] {
            let geometry = upload_scene(&ctx, shift, layout);
            for lods in [&[0u32, 1][..], &[1, 0], &[0, 1, 0]] {
                let depth = DepthPass::new(&ctx, w, h)
                    .render(&ctx, &geometry, &v, lods)
                    .unwrap();
                let mut rvg = VisiblePass::new(&ctx, w, h);
                rvg.begin(&ctx, &v, DrawStyle::Shaded, Look::PLAIN);
                rvg.draw(&ctx, &geometry, lods);
                let frame = rvg.finish(&ctx, true).unwrap().unwrap();
                let bits = |d: &[f32]| d.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                out.push((bits(&depth.depth), frame.colour, bits(&frame.depth.depth)));
            }
        }
    }
    let (multi_draws, calls) = out.split_at(out.len() / 2);
    assert_eq!(multi_draws, calls);
    // Something was drawn.
    assert!(calls.iter().all(|(d, _, _)| d.iter().any(|&b| b != 0)));
}

/// The paths a browser's WebGL2 takes (no base vertex: each draw binds
/// its LOD's vertices at their offset; no buffer both vertex and index
/// buffer: a pool of split buffers; no multi-draw; the fragment pyramid)
/// draw what the adapter's own paths draw, bit for bit: RVG's colour and
/// depth, OR's depth and a level of its pyramid, from resident geometry
/// and from a streaming pool.
#[test]
fn the_webgl2_paths_draw_what_the_others_do() {
    let Some(mut ctx) = devices_or_skip(1, "webgl2 paths").map(|mut d| d.remove(0)) else {
        return;
    };
    let shift = DVec3::new(-3e5, 7e4, 1e6);
    let (w, h) = (80, 50);
    let v = view(shift + DVec3::new(0.0, -1.5, 0.0), w, h);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.gwk");
    write_scene_with(&path, shift, 16);
    let scene = SceneReader::open(&path).unwrap();
    let mut out = Vec::new();
    for forced in [false, true] {
        if forced {
            ctx.force_webgl2_paths();
            let c = ctx.capabilities();
            assert!(!(c.base_vertex || c.shared_buffers || c.multi_draw || c.compute_pyramid));
        }
        let resident = upload_scene(&ctx, shift, VertexLayout::Wide);
        let mut pool = GeometryPool::new(&ctx, 2, 1 << 16, 1 << 20).unwrap();
        // LOD 1 first: its vertices do not start the pool's buffer.
        for l in [1, 0] {
            assert!(pool.insert(&ctx, l, &DecodedLod::new(&scene.read_lod(l).unwrap())));
        }
        for geometry in [&resident as &dyn gigawalk_gpu::Residency, &pool] {
            for lods in [&[0u32, 1][..], &[1, 0, 1]] {
                let mut or = DepthPass::new(&ctx, w, h);
                let depth = or.render(&ctx, geometry, &v, lods).unwrap();
                let level = or.render_level(&ctx, geometry, &v, lods, 2).unwrap();
                let mut rvg = VisiblePass::new(&ctx, w, h);
                rvg.begin(&ctx, &v, DrawStyle::Shaded, Look::PLAIN);
                rvg.draw(&ctx, geometry, lods);
                let frame = rvg.finish(&ctx, true).unwrap().unwrap();
                let bits = |d: &[f32]| d.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                out.push((
                    bits(&depth.depth),
                    bits(&level.image.depth),
                    frame.colour,
                    bits(&frame.depth.depth),
                ));
            }
        }
    }
    let (own, webgl2) = out.split_at(out.len() / 2);
    assert_eq!(own, webgl2);
    // Something was drawn, the same from the pool as from resident
    // geometry.
    assert!(own.iter().all(|(d, _, _, _)| d.iter().any(|&b| b != 0)));
    assert_eq!(own[0], own[2]);
}

/// Adapters without depth-texture copies (GL) read depth through a pass
/// that draws it into an R32Uint target; the HZB and the accuracy
/// reference compare depths exactly, so it must read the same bits, the
/// same way up, as a direct copy.
#[test]
fn depth_through_the_copy_pass_is_the_direct_copy_bit_for_bit() {
    let Some([direct, pass]) = render_both_depth_paths() else {
        return;
    };
    // Where the adapter has no direct depth copy (GL) both halves went
    // through the pass, and only the orientation checks below say much.
    let bits = |d: &[f32]| d.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&direct.0), bits(&pass.0), "OR depth");
    assert_eq!(bits(&direct.2), bits(&pass.2), "RVG depth");
    assert_eq!(direct.1, pass.1, "colour");
    // The right way up: drawn pixels (depth > 0) are where the colour is
    // not background, and in the upper half (row 0 at the top).
    let (w, h) = (80usize, 50usize);
    let drawn: Vec<bool> = pass.0.iter().map(|&d| d > 0.0).collect();
    let coloured: Vec<bool> = pass.1.chunks(4).map(|p| p[0] > 100 || p[1] > 100).collect();
    assert_eq!(
        drawn, coloured,
        "depth and colour disagree on what is drawn"
    );
    let upper = drawn[..w * h / 2].iter().filter(|&&d| d).count();
    let lower = drawn[w * h / 2..].iter().filter(|&&d| d).count();
    assert!(
        upper > 4 * lower.max(1),
        "drawn pixels: {upper} upper, {lower} lower"
    );
}

/// OR's pyramid built on the device, read back level by level, equals
/// the CPU's pyramid of the same depth bit for bit, at odd sizes and
/// one-pixel rows and columns included, through compute passes (where the
/// adapter uses them) and fragment passes alike: each texel the farthest
/// depth of exactly the pixels it covers.
#[test]
fn the_device_pyramid_is_the_cpu_pyramid_of_the_same_depth_level_by_level() {
    let Some(mut ctx) = devices_or_skip(1, "gpu hzb pyramid").map(|mut d| d.remove(0)) else {
        return;
    };
    let shift = DVec3::new(0.3, 0.2, 0.0);
    let geometry = upload_scene(&ctx, shift, VertexLayout::Wide);
    let mut paths = Vec::new();
    for forced in [false, true] {
        if forced {
            ctx.force_fragment_pyramid();
        }
        for (w, h) in [(1, 1), (17, 9), (640, 1), (1, 37), (1023, 769), (64, 48)] {
            let v = view(shift + DVec3::new(1.3, -0.7, 0.0), w, h);
            let mut or = DepthPass::new(&ctx, w, h);
            paths.push(or.pyramid_path(&ctx));
            let whole = or.render_level(&ctx, &geometry, &v, &[0, 1], 0).unwrap();
            assert_eq!(whole.level, 0);
            assert_eq!(whole.figures.read_bytes % 4, 0);
            let cpu = Hzb::build(w, h, &whole.image.depth, Reduction::Farthest).unwrap();
            assert_eq!(cpu.levels().len() as u32, or.top_level() + 1, "{w}x{h}");
            let bits = |d: &[f32]| d.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            for k in 1..=or.top_level() {
                let got = or.render_level(&ctx, &geometry, &v, &[0, 1], k).unwrap();
                let want = &cpu.levels()[k as usize];
                assert_eq!((got.level, got.width, got.height), (k, w, h));
                assert_eq!(
                    (got.image.width, got.image.height),
                    (want.width, want.height),
                    "{w}x{h} level {k}"
                );
                assert_eq!(
                    bits(&got.image.depth),
                    bits(&want.data),
                    "{w}x{h} level {k}, {:?}",
                    or.pyramid_path(&ctx)
                );
                assert!(got.figures.read_bytes >= 4 * want.data.len() as u64);
            }
            // Past the top reads the top.
            let past = or.render_level(&ctx, &geometry, &v, &[0, 1], 40).unwrap();
            assert_eq!(past.level, or.top_level());
        }
    }
    // The second round went through fragment passes.
    assert!(paths[paths.len() / 2..]
        .iter()
        .all(|p| *p == PyramidPath::Fragment));
    // Something was drawn: the test compares more than cleared depth.
    let v = view(shift, 64, 48);
    let d = DepthPass::new(&ctx, 64, 48)
        .render(&ctx, &geometry, &v, &[0, 1])
        .unwrap();
    assert!(d.depth.iter().any(|&z| z > 0.0) && d.depth.contains(&0.0));
}

/// A level submitted without waiting (`submit_level`, as the browser's
/// page does) is the level `render_level` reads, bit for bit, whichever
/// frame takes it; until the device has made it `try_take_level` gives it
/// back instead of blocking, and a second one submitted meanwhile is read
/// on its own.
#[test]
fn a_level_read_without_waiting_is_the_level_read_waiting() {
    let Some(ctx) = devices_or_skip(1, "gpu hzb async level").map(|mut d| d.remove(0)) else {
        return;
    };
    let shift = DVec3::new(0.3, 0.2, 0.0);
    let geometry = upload_scene(&ctx, shift, VertexLayout::Wide);
    let (w, h) = (97, 61);
    let near = view(shift + DVec3::new(1.3, -0.7, 0.0), w, h);
    let far = view(shift + DVec3::new(0.4, 0.1, 0.0), w, h);
    let mut or = DepthPass::new(&ctx, w, h);
    let take = |or: &mut DepthPass, mut p: gigawalk_gpu::PendingLevel| {
        let t = std::time::Instant::now();
        loop {
            match or.try_take_level(&ctx, p) {
                Ok(level) => return level.unwrap(),
                Err(back) => p = back,
            }
            assert!(t.elapsed().as_secs() < 60, "the level never arrived");
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
    };
    for k in [0, 1, 3, or.top_level()] {
        let want_near = or.render_level(&ctx, &geometry, &near, &[0, 1], k).unwrap();
        let want_far = or.render_level(&ctx, &geometry, &far, &[0, 1], k).unwrap();
        if k <= 3 {
            assert_ne!(
                want_near.image, want_far.image,
                "level {k}: the views differ"
            );
        }
        let first = or.submit_level(&ctx, &geometry, &near, &[0, 1], k);
        assert_eq!(first.level(), k);
        let second = or.submit_level(&ctx, &geometry, &far, &[0, 1], k);
        let got_far = take(&mut or, second);
        let got_near = take(&mut or, first);
        for (got, want) in [(&got_near, &want_near), (&got_far, &want_far)] {
            assert_eq!(
                (got.level, got.width, got.height),
                (want.level, want.width, want.height)
            );
            assert_eq!(got.image, want.image, "level {k}");
            assert_eq!(got.figures.read_bytes, want.figures.read_bytes);
        }
    }
}

/// A frame read without waiting (`submit_read_back`, as the browser's
/// page reads its frames for tests) is the frame `read_back` gives, colour
/// and depth bit for bit; until the device has copied it
/// `try_take_frame` gives it back instead of blocking.
#[test]
fn a_frame_read_without_waiting_is_the_frame_read_waiting() {
    let Some(ctx) = devices_or_skip(1, "gpu frame async read").map(|mut d| d.remove(0)) else {
        return;
    };
    let shift = DVec3::new(0.3, 0.2, 0.0);
    let geometry = upload_scene(&ctx, shift, VertexLayout::Wide);
    let (w, h) = (97, 61);
    let v = view(shift + DVec3::new(1.3, -0.7, 0.0), w, h);
    let mut rvg = VisiblePass::new(&ctx, w, h);
    rvg.begin(&ctx, &v, DrawStyle::Shaded, Look::PLAIN);
    rvg.draw(&ctx, &geometry, &[0, 1]);
    rvg.end(&ctx).unwrap();
    let want = rvg.read_back(&ctx).unwrap();
    assert!(want.depth.depth.iter().any(|&z| z > 0.0), "something drawn");
    let mut p = rvg.submit_read_back(&ctx);
    let t = std::time::Instant::now();
    let got = loop {
        match rvg.try_take_frame(&ctx, p) {
            Ok(frame) => break frame.unwrap(),
            Err(back) => p = back,
        }
        assert!(t.elapsed().as_secs() < 60, "the frame never arrived");
        std::thread::sleep(std::time::Duration::from_millis(1));
    };
    assert_eq!(got.colour, want.colour);
    assert_eq!(got.depth, want.depth);
}

/// LODs 0 and 1 of `geometry` drawn at 64x48 by RVG (colour, depth) and
/// OR (depth).
fn draw_both(
    ctx: &GpuContext,
    geometry: &dyn gigawalk_gpu::Residency,
    v: &View,
) -> (Vec<u8>, Vec<f32>, Vec<f32>) {
    let mut rvg = VisiblePass::new(ctx, 64, 48);
    rvg.begin(ctx, v, DrawStyle::Shaded, Look::PLAIN);
    rvg.draw(ctx, geometry, &[0, 1]);
    let frame = rvg.finish(ctx, true).unwrap().unwrap();
    let depth = DepthPass::new(ctx, 64, 48)
        .render(ctx, geometry, v, &[0, 1])
        .unwrap();
    (frame.colour, frame.depth.depth, depth.depth)
}

/// In both vertex layouts: the compact one's grid coordinates are
/// relative to the LOD's box as the wide one's positions are.
#[test]
fn far_from_origin_renders_like_the_origin() {
    for layout in VertexLayout::ALL {
        let Some(near) = render_in(DVec3::ZERO, layout) else {
            return;
        };
        let far = render_in(DVec3::new(1.0e7, -3.0e7, 2.0e7), layout).unwrap();
        let max_diff = near
            .0
            .iter()
            .zip(&far.0)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f32::max);
        assert!(max_diff < 1e-6, "{layout:?}: depth differs by {max_diff}");
        let differing = near
            .1
            .chunks(4)
            .zip(far.1.chunks(4))
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(differing, 0, "{layout:?}: colour pixels differ");
    }
}

/// The compact layout (grid coordinates scaled per draw, snorm8 normals
/// unpacked in the shader) draws what the same LODs decoded into the
/// wide layout draw: the same depth to rounding, the same colours to a
/// level.
#[test]
fn compact_layout_draws_like_the_wide_one() {
    let Some(ctx) = devices_or_skip(1, "compact layout").map(|mut d| d.remove(0)) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.gwk");
    let shift = DVec3::new(3.0e6, 1.0, -2.0e6);
    write_scene_with(&path, shift, 8);
    let scene = SceneReader::open(&path).unwrap();
    let compact = HostGeometry::load(&scene, 1 << 20).unwrap();
    assert_eq!(compact.layout_counts(), [0, 2]);
    // What the streaming plan counts from the records is what a LOD takes.
    for l in 0..2 {
        let d = DecodedLod::read(&scene, l).unwrap();
        assert_eq!(d.layout, VertexLayout::Compact);
        assert_eq!(
            gigawalk_gpu::device_bytes(scene.skeleton().lod(l)),
            d.bytes()
        );
    }
    let compact = compact.upload(&ctx).unwrap();
    let mut wide = GeometryPool::new(&ctx, 2, 1 << 16, 1 << 20).unwrap();
    for l in 0..2 {
        let d = DecodedLod::new(&scene.read_lod(l).unwrap());
        assert_eq!(d.layout, VertexLayout::Wide);
        assert!(wide.insert(&ctx, l, &d));
    }
    let v = view(shift, 64, 48);
    let draw = |geometry: &dyn gigawalk_gpu::Residency| draw_both(&ctx, geometry, &v);
    let (a, b) = (draw(&compact), draw(&wide));
    assert!(
        a.0.chunks_exact(4).any(|p| p[0] > 200),
        "the red box is drawn"
    );
    for (what, x, y) in [("RVG", &a.1, &b.1), ("OR", &a.2, &b.2)] {
        let worst = x
            .iter()
            .zip(y)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f32::max);
        assert!(worst < 1e-5, "{what} depth differs by {worst}");
    }
    let worst =
        a.0.iter()
            .zip(&b.0)
            .map(|(p, q)| p.abs_diff(*q))
            .max()
            .unwrap();
    assert!(worst <= 1, "colours differ by {worst} levels");
}

#[test]
fn wireframe_draws_edges_in_the_unlit_object_colour() {
    // Big enough that faces cover many more pixels than their edges.
    let size = (256, 192);
    let Some(((_, shaded, _), supported)) =
        render_styled(DVec3::ZERO, DrawStyle::Shaded, size, VertexLayout::Wide)
    else {
        return;
    };
    let ((_, wire, wire_depth), _) =
        render_styled(DVec3::ZERO, DrawStyle::Wireframe, size, VertexLayout::Wide).unwrap();
    // CI's adapter (lavapipe) has line mode; a real GPU does too.
    assert!(
        supported || std::env::var_os("GIGAWALK_REQUIRE_ADAPTER").is_none(),
        "the CI adapter must support POLYGON_MODE_LINE"
    );
    if !supported {
        eprintln!("!!! wireframe unsupported on this adapter: RVG drew shaded");
        assert_eq!(wire, shaded);
        return;
    }
    let is_bg = |p: &[u8]| p[0] < 60 && p[1] < 60 && p[2] < 70;
    let covered = |img: &[u8]| img.chunks(4).filter(|p| !is_bg(p)).count();
    let (n_shaded, n_wire) = (covered(&shaded), covered(&wire));
    // Edges only: some pixels, far fewer than the filled faces.
    assert!(n_wire > 20, "wireframe drew {n_wire} pixels");
    assert!(
        n_wire * 3 < n_shaded,
        "wireframe covers {n_wire} pixels, shaded {n_shaded}"
    );
    // Every drawn pixel is an object's own colour, unlit: pure red or pure green.
    for p in wire.chunks(4).filter(|p| !is_bg(p)) {
        let red = p[0] == 255 && p[1] == 0 && p[2] == 0;
        let green = p[0] == 0 && p[1] == 255 && p[2] == 0;
        assert!(red || green, "wireframe pixel {p:?}");
    }
    // Lines write depth, and only where they are drawn.
    let with_depth = wire_depth.iter().filter(|&&d| d > 0.0).count();
    assert_eq!(with_depth, n_wire, "depth written off the lines");
}

#[test]
fn occlusion_queries_count_samples_behind_and_in_front_of_what_was_drawn() {
    let Some(ctx) = devices_or_skip(1, "occlusion queries").map(|mut d| d.remove(0)) else {
        return;
    };
    // lavapipe counts samples; GL's queries say only zero or not
    // (ANY_SAMPLES_PASSED_CONSERVATIVE), and then only that is checked.
    let exact = gigawalk_gpu::query_counts(&ctx).unwrap() == gigawalk_gpu::QueryCounts::Exact;
    if !exact {
        eprintln!(
            "{}: occlusion queries say only zero or not; checking that much",
            ctx.name()
        );
    }
    let shift = DVec3::new(1e6, -2e5, 3e6);
    let geometry = upload_scene(&ctx, shift, VertexLayout::Wide);
    let (w, h) = (64, 48);
    let v = view(shift, w, h);
    let mut q = gigawalk_gpu::QueryPass::new(&ctx, w, h);
    let b = |min: [f32; 3], max: [f32; 3]| {
        gigawalk_gpu::QueryBox::new(Vec3::from(min), Vec3::from(max))
    };
    // Boxes relative to the eye: behind the red box (z -6..-5, x, y
    // -1..1), in front of it, and beside it.
    let behind = b([-0.5, -0.5, -9.0], [0.5, 0.5, -8.0]);
    let front = b([-0.5, -0.5, -4.0], [0.5, 0.5, -3.0]);
    let beside = b([-6.0, -0.5, -9.0], [-5.0, 0.5, -8.0]);
    q.begin(&ctx, &v);
    // Nothing drawn yet: every box in view passes samples.
    let before = q
        .query(&ctx, Some(&geometry), &[behind, front, beside])
        .unwrap();
    assert!(before.iter().all(|&n| n > 0), "{before:?}");
    q.draw(&[0]);
    let after = q
        .query(&ctx, Some(&geometry), &[behind, front, beside])
        .unwrap();
    assert_eq!(
        after[0], 0,
        "a box wholly behind the red box passed samples"
    );
    if exact {
        assert_eq!(after[1], before[1], "a box in front passes its whole area");
        assert_eq!(after[2], before[2], "a box beside it is not hidden");
    } else {
        assert!(after[1] > 0 && after[2] > 0, "{after:?}");
    }
    // More boxes than a query set holds: split into round trips.
    let many = q.query(&ctx, Some(&geometry), &vec![behind; 5000]).unwrap();
    assert_eq!(many.len(), 5000);
    assert!(many.iter().all(|&n| n == 0));
    // A new frame clears the depth.
    q.begin(&ctx, &v);
    assert!(q.query(&ctx, Some(&geometry), &[behind]).unwrap()[0] > 0);
}

/// A streaming pool holds LODs of any mix of vertices and indices up to its
/// bytes, and draws them as the resident geometry does. (Its vertex and
/// index buffers were once split in the scene's proportions: a working set
/// richer in vertices than the scene found no vertex room with a fifth of
/// the pool free, and a held camera never settled.)
#[test]
fn a_pool_takes_any_mix_of_vertices_and_indices_and_draws_like_resident_geometry() {
    let Some(ctx) = devices_or_skip(1, "geometry pool").map(|mut d| d.remove(0)) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.gwk");
    write_scene(&path, DVec3::ZERO);
    let scene = SceneReader::open(&path).unwrap();
    let boxes: Vec<DecodedLod> = (0..2)
        .map(|l| DecodedLod::new(&scene.read_lod(l).unwrap()))
        .collect();
    // Fillers of equal bytes: all vertices but one triangle, and all
    // indices (degenerate triangles) but two vertices.
    let filler = |vertices: usize, indices: usize| DecodedLod {
        vertices: boxes[0].vertices[..20].repeat(vertices),
        index_format: wgpu::IndexFormat::Uint16,
        indices: vec![0; (2 * indices).next_multiple_of(4)],
        index_count: indices as u32,
        ..boxes[0].clone()
    };
    let (vertex_heavy, index_heavy) = (filler(50, 6), filler(2, 486));
    assert_eq!(vertex_heavy.bytes(), index_heavy.bytes());
    // A LOD takes its bytes and room to start its vertices on a whole
    // vertex (16 bytes for a wide one): the pool is exactly full once
    // all three are in.
    let units = |l: &DecodedLod| l.bytes() + 16;
    let bytes = boxes.iter().map(units).sum::<u64>() + units(&vertex_heavy);
    let mut pool = GeometryPool::new(&ctx, 4, bytes, 1 << 20).unwrap();
    assert_eq!(pool.capacity_bytes(), bytes);
    assert!(pool.insert(&ctx, 2, &vertex_heavy));
    assert!(pool.insert(&ctx, 1, &boxes[1]));
    assert!(pool.insert(&ctx, 0, &boxes[0]));
    assert_eq!(pool.used_bytes(), bytes);
    assert!(!pool.insert(&ctx, 3, &filler(1, 0)), "a full pool refuses");
    pool.remove(2);
    assert!(
        pool.insert(&ctx, 2, &index_heavy),
        "the index-heavy LOD fits where the vertex-heavy one was"
    );
    assert_eq!(pool.used_bytes(), bytes);

    let resident = HostGeometry::load(&scene, 1 << 20)
        .unwrap()
        .upload(&ctx)
        .unwrap();
    let v = view(DVec3::ZERO, 64, 48);
    let draw = |geometry: &dyn gigawalk_gpu::Residency| draw_both(&ctx, geometry, &v);
    let (from_pool, from_resident) = (draw(&pool), draw(&resident));
    assert!(
        from_resident.0.chunks_exact(4).any(|p| p[0] > 200),
        "the red box is drawn"
    );
    assert_eq!(from_pool, from_resident);
}
