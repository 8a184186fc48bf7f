//! The software depth rasterizer the lazy occlusion grid reads (crates/cull)
//! against the GPU's depth on the same draws: a generated city and plant,
//! full detail, frustum culling only, odd viewport sizes. Never nearer than
//! the GPU at any pixel (the conservative direction); at nearly every
//! pixel it covers, no farther than its documented slack (the depth change
//! over `DEPTH_SLOPE_PX` pixels plus `DEPTH_REL_SLACK`).

use gigawalk_cull::{
    default_near, Camera, SoftDepth, TraversalOptions, Viewport, DEPTH_REL_SLACK, DEPTH_SLOPE_PX,
};
use gigawalk_gpu::devices_or_skip;
use gigawalk_import::import_glb_bytes;
use gigawalk_preprocess::{preprocess, NoProgress, Params};
use gigawalk_procgen::{generate, Kind};
use gigawalk_runtime::{CameraList, CameraRequest, Runtime, RuntimeOptions, Schedule};
use gigawalk_scene::SceneReader;

#[test]
fn software_depth_is_never_nearer_than_the_gpus_and_matches_it_closely() {
    let dir = tempfile::tempdir().unwrap();
    for (kind, w, h) in [(Kind::City, 191, 107), (Kind::Plant, 160, 90)] {
        let g = generate(kind, 40_000, 4, 12);
        let model = import_glb_bytes(&g.glb_bytes(), "m").unwrap();
        let file = dir.path().join(format!("{kind:?}.gwk"));
        preprocess(&model, &Params::default(), &file, "m", &NoProgress).unwrap();
        let scene = SceneReader::open(&file).unwrap();
        let Some(d) = devices_or_skip(1, "software vs GPU depth") else {
            return;
        };
        // GL's depth is off by up to GL_DEPTH_ERROR absolute; the grid
        // culler's software depth leaves that room, and so does this one.
        let slack = f64::from(d[0].depth_error());
        let rt = Runtime::with_devices(&scene, d).unwrap();
        let sk = scene.skeleton();
        let near = default_near(&sk.bounds());
        let cameras: Vec<Camera> = g
            .path
            .poses
            .iter()
            .map(|p| Camera::of_pose(p, Viewport::new(w, h), near))
            .collect();
        let opts = RuntimeOptions {
            schedule: Schedule::Sequential,
            devices: 1,
            width: w,
            height: h,
            traversal: TraversalOptions {
                occlusion: false,
                hlod: false,
                pixel_error: 0.0,
            },
            ..Default::default()
        };
        let mut list = CameraList {
            cameras: cameras
                .iter()
                .map(|&c| CameraRequest::new(c, true))
                .collect(),
        };
        let (mut covered, mut close) = (0u64, 0u64);
        rt.run(&opts, &mut list, &mut |r| {
            let gpu = &r.image.as_ref().expect("read back").depth;
            let camera = cameras[r.frame as usize];
            let view_proj = camera.view_projection_rel_f64();
            let mut soft = SoftDepth::new();
            soft.set_absolute_slack(slack);
            soft.reset(w, h);
            for item in r.visible.iter() {
                let lod = sk.nodes()[item.node as usize].first_lod + item.lod;
                let m = scene.read_lod(lod).unwrap();
                soft.draw_mesh(
                    &view_proj,
                    m.origin - camera.position,
                    &m.positions,
                    &m.indices,
                );
            }
            for (i, (&s, &g)) in soft.depth().iter().zip(&gpu.depth).enumerate() {
                if s == 0.0 {
                    continue;
                }
                covered += 1;
                assert!(
                    s <= g,
                    "{kind:?} frame {} pixel {}: software depth {s} nearer than the GPU's {g}",
                    r.frame,
                    i
                );
                // The documented gap: the depth change over
                // DEPTH_SLOPE_PX pixels (the GPU's own depth slope here,
                // from its neighbours, both axes) and DEPTH_REL_SLACK,
                // with room for f32 rounding.
                let (x, y) = (i as u32 % w, i as u32 / w);
                let at = |x: u32, y: u32| gpu.depth[(y * w + x) as usize];
                let dx = (at(x.saturating_sub(1), y) - g)
                    .abs()
                    .max((at((x + 1).min(w - 1), y) - g).abs());
                let dy = (at(x, y.saturating_sub(1)) - g)
                    .abs()
                    .max((at(x, (y + 1).min(h - 1)) - g).abs());
                let gap = (dx + dy) as f64 * DEPTH_SLOPE_PX
                    + g as f64 * (DEPTH_REL_SLACK + 1e-6)
                    + 2.0 * slack;
                close += u64::from(((g - s) as f64) <= 1.5 * gap);
            }
            true
        })
        .unwrap();
        assert!(
            covered > (w * h) as u64,
            "{kind:?}: the walk covered little"
        );
        // Pixels where a nearer triangle's edge falls within the inner
        // margin (the GPU covers it, the software does not) show a farther
        // surface in software: a few percent at these small viewports.
        assert!(
            close as f64 >= 0.95 * covered as f64,
            "{kind:?}: only {close} of {covered} covered pixels within the slack"
        );
    }
}
