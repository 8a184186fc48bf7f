//! Tiled displays: the viewport split into tiles, each drawn from its own
//! list under its own scissor, stitches into the single view's image. At
//! pixel error 0 the depth is bit-identical to drawing the same camera in
//! one view, for grids 1x1 to 16x16 and 3x2, every way of sending items to
//! tiles and every schedule; on the CPU (no adapter needed) and, where an
//! adapter exists (CI's lavapipe), on the device.

use gigawalk_cull::{default_near, Camera, TraversalOptions, Viewport};
use gigawalk_gpu::devices_or_skip;
use gigawalk_import::import_glb_bytes;
use gigawalk_preprocess::{preprocess, NoProgress, Params};
use gigawalk_procgen::{generate, Kind};
use gigawalk_runtime::{
    run_on_cpu, CameraList, CameraRequest, CullMethod, FrameReport, Runtime, RuntimeOptions,
    Schedule, TileGrid, TileMethod,
};
use gigawalk_scene::SceneReader;

const W: u32 = 160;
const H: u32 = 90;
const FRAMES: usize = 8;

const GRIDS: [(u32, u32); 7] = [(1, 1), (2, 2), (3, 2), (4, 4), (7, 5), (8, 8), (16, 16)];

fn scene(kind: Kind, dir: &std::path::Path) -> (SceneReader, Vec<CameraRequest>) {
    let g = generate(kind, 40_000, 3, FRAMES);
    let model = import_glb_bytes(&g.glb_bytes(), kind.name()).unwrap();
    let file = dir.join("scene.gwk");
    preprocess(&model, &Params::default(), &file, kind.name(), &NoProgress).unwrap();
    let scene = SceneReader::open(&file).unwrap();
    let near = default_near(&scene.skeleton().bounds());
    let cameras = g
        .path
        .poses
        .iter()
        .map(|p| {
            let c = Camera::of_pose(p, Viewport::new(W, H), near);
            CameraRequest::new(c, true)
        })
        .collect();
    (scene, cameras)
}

fn options(
    schedule: Schedule,
    occlusion: bool,
    culler: CullMethod,
    tiles: Option<(TileGrid, TileMethod)>,
) -> RuntimeOptions {
    RuntimeOptions {
        schedule,
        width: W,
        height: H,
        culler,
        traversal: TraversalOptions {
            occlusion,
            hlod: false,
            pixel_error: 0.0,
        },
        tiles: tiles.map(|t| t.0),
        tile_culling: tiles.map_or(TileMethod::Adaptive, |t| t.1),
        ..Default::default()
    }
}

fn depth(r: &FrameReport) -> &[f32] {
    &r.image.as_ref().expect("read back").depth.depth
}

/// Every frame's depth equals the reference's, bit for bit.
fn same(label: &str, got: &[FrameReport], reference: &[FrameReport]) {
    assert_eq!(got.len(), reference.len(), "{label}");
    for (g, r) in got.iter().zip(reference) {
        let (gd, rd) = (depth(g), depth(r));
        let missing = rd.iter().zip(gd).filter(|(r, g)| r > g).count();
        assert_eq!(
            missing, 0,
            "{label}: frame {}: {missing} pixels lost",
            g.frame
        );
        assert!(gd == rd, "{label}: frame {} depth differs", g.frame);
    }
}

fn tile_figures(label: &str, frames: &[FrameReport], grid: TileGrid) {
    for f in frames {
        let t = f
            .tiles
            .as_ref()
            .unwrap_or_else(|| panic!("{label}: no tile figures"));
        assert_eq!(t.grid, grid);
        assert_eq!((t.rects.len(), t.lists.len()), (grid.count(), grid.count()));
        assert!(t.ms_adaptive >= 0.0 && t.ms_naive >= 0.0);
        // Every drawn item is in some tile's list (at pixel error 0 every
        // item the view draws covers some tile's frustum or sits at the
        // near plane, so a tile's list holds it).
        let mut seen = vec![false; f.visible.len()];
        for l in &t.lists {
            for &i in l {
                seen[i as usize] = true;
            }
        }
        let listed = seen.iter().filter(|s| **s).count();
        assert!(
            listed * 10 >= f.visible.len() * 9,
            "{label}: {listed} of {} items in a tile",
            f.visible.len()
        );
        assert!(t.max_triangles as f64 >= t.mean_triangles);
    }
}

#[test]
fn tiles_on_the_cpu_stitch_into_the_single_view_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, cameras) = scene(Kind::City, dir.path());
    let run = |opts: &RuntimeOptions| {
        let mut list = CameraList {
            cameras: cameras.clone(),
        };
        let mut frames = Vec::new();
        run_on_cpu(scene.skeleton(), &scene, opts, &mut list, &mut |r| {
            frames.push(r);
            true
        })
        .unwrap();
        frames
    };
    let reference = run(&options(Schedule::Sequential, false, CullMethod::Hzb, None));
    for (c, r) in GRIDS {
        let grid = TileGrid { cols: c, rows: r };
        for method in TileMethod::ALL {
            let label = format!("cpu vfc {grid} {}", method.name());
            let got = run(&options(
                Schedule::Sequential,
                false,
                CullMethod::Hzb,
                Some((grid, method)),
            ));
            same(&label, &got, &reference);
            tile_figures(&label, &got, grid);
        }
        // Occlusion is decided once for the view; the tiles only share
        // out what it keeps. Every schedule.
        for (schedule, culler) in [
            (Schedule::Pipelined, CullMethod::Hzb),
            (Schedule::Sequential, CullMethod::Grid),
            (Schedule::Pipelined, CullMethod::Ct),
        ] {
            let label = format!("cpu occ {culler:?} {schedule:?} {grid}");
            let tiles = Some((grid, TileMethod::Adaptive));
            let got = run(&options(schedule, true, culler, tiles));
            same(&label, &got, &reference);
        }
    }
    // Asynchronous RVG draws the tiles of the set it has.
    let grid = TileGrid { cols: 3, rows: 2 };
    let opts = RuntimeOptions {
        async_rvg: true,
        ..options(
            Schedule::Pipelined,
            false,
            CullMethod::Hzb,
            Some((grid, TileMethod::Adaptive)),
        )
    };
    let got = run(&opts);
    assert_eq!(got.len(), FRAMES);
    for f in &got {
        assert!(f.tiles.is_some());
    }
}

#[test]
fn tiles_on_the_device_stitch_into_the_single_view_bit_for_bit() {
    let Some(devices) = devices_or_skip(2, "tiled display on the device") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (scene, cameras) = scene(Kind::Plant, dir.path());
    let rt = Runtime::with_devices(&scene, devices).unwrap();
    let run = |opts: &RuntimeOptions| {
        let mut source = CameraList {
            cameras: cameras.clone(),
        };
        let mut out = Vec::new();
        rt.run(opts, &mut source, &mut |r| {
            out.push(r);
            true
        })
        .unwrap();
        out
    };
    let reference = run(&options(Schedule::Sequential, false, CullMethod::Hzb, None));
    for (c, r) in GRIDS {
        let grid = TileGrid { cols: c, rows: r };
        let label = format!("device vfc {grid}");
        let got = run(&options(
            Schedule::Pipelined,
            false,
            CullMethod::Hzb,
            Some((grid, TileMethod::Adaptive)),
        ));
        same(&label, &got, &reference);
        tile_figures(&label, &got, grid);
        let label = format!("device occ {grid} naive");
        let got = run(&options(
            Schedule::Pipelined,
            true,
            CullMethod::Hzb,
            Some((grid, TileMethod::Naive)),
        ));
        same(&label, &got, &reference);
    }
}

#[test]
fn a_grid_with_more_tiles_than_pixels_is_refused() {
    let opts = RuntimeOptions {
        width: 10,
        height: 10,
        tiles: Some(TileGrid { cols: 11, rows: 1 }),
        ..Default::default()
    };
    let e = opts.validate().unwrap_err().to_string();
    assert!(e.contains("11x1") && e.contains("10x10"), "{e}");
}
