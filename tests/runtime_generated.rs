//! The pipeline's correctness test on generated scenes (conservative
//! occlusion culling must never change the image, so this equality is the
//! correctness test of the whole pipeline): on a plant and
//! a city with a 60-frame walk, pipelined occlusion culling at full detail
//! gives, every frame, the same depth image as drawing every
//! frustum-visible leaf at full detail with the same camera.

use gigawalk_cull::{Camera, TraversalOptions, Viewport};
use gigawalk_gpu::devices_or_skip;
use gigawalk_import::import_glb_bytes;
use gigawalk_preprocess::{preprocess, NoProgress, Params};
use gigawalk_procgen::{generate, Kind};
use gigawalk_runtime::{CameraList, CameraRequest, FrameReport, Runtime, RuntimeOptions, Schedule};
use gigawalk_scene::SceneReader;

const W: u32 = 128;
const H: u32 = 72;
const FRAMES: usize = 60;

fn run(rt: &Runtime, opts: &RuntimeOptions, cameras: &[CameraRequest]) -> Vec<FrameReport> {
    let mut source = CameraList {
        cameras: cameras.to_vec(),
    };
    let mut out = Vec::new();
    rt.run(opts, &mut source, &mut |r| {
        out.push(r);
        true
    })
    .unwrap();
    out
}

fn check(kind: Kind) {
    let Some(devices) = devices_or_skip(2, "runtime on generated scenes") else {
        return;
    };
    let g = generate(kind, 40_000, 3, FRAMES);
    let model = import_glb_bytes(&g.glb_bytes(), kind.name()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.gwk");
    preprocess(&model, &Params::default(), &path, kind.name(), &NoProgress).unwrap();
    let scene = SceneReader::open(&path).unwrap();
    let rt = Runtime::with_devices(&scene, devices).unwrap();
    let cameras: Vec<CameraRequest> = g
        .path
        .poses
        .iter()
        .map(|p| CameraRequest::new(Camera::of_pose(p, Viewport::new(W, H), 0.05), true))
        .collect();
    assert_eq!(cameras.len(), FRAMES);
    let opts = |schedule, occlusion| RuntimeOptions {
        schedule,
        width: W,
        height: H,
        traversal: TraversalOptions {
            occlusion,
            hlod: false,
            pixel_error: 0.0,
        },
        ..Default::default()
    };
    let occ = run(&rt, &opts(Schedule::Pipelined, true), &cameras);
    let reference = run(&rt, &opts(Schedule::Sequential, false), &cameras);
    let mut culled = 0;
    for (o, r) in occ.iter().zip(&reference) {
        let (od, rd) = (
            &o.image.as_ref().unwrap().depth.depth,
            &r.image.as_ref().unwrap().depth.depth,
        );
        // Reversed-Z: the reference nearer = larger = something wrongly culled.
        let missing = rd.iter().zip(od).filter(|(r, o)| r > o).count();
        assert_eq!(
            missing,
            0,
            "{}: frame {}: {missing} pixels lost to occlusion culling",
            kind.name(),
            o.frame
        );
        // Bit-identical: the same rasterizer draws the same triangles for
        // every pixel that shows, so depth ties resolve the same way.
        assert!(
            od == rd,
            "{}: frame {} depth differs without missing pixels",
            kind.name(),
            o.frame
        );
        culled += o.stats.occlusion_culled;
    }
    assert_eq!(occ.len(), FRAMES);
    assert!(
        culled > 0,
        "{}: nothing was occlusion-culled: the check proves nothing",
        kind.name()
    );
    eprintln!(
        "{}: {culled} nodes occlusion-culled over {FRAMES} frames, depth identical",
        kind.name()
    );
}

#[test]
fn plant_pipeline_is_conservative() {
    check(Kind::Plant);
}

#[test]
fn city_pipeline_is_conservative() {
    check(Kind::City);
}
