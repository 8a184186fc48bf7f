//! Every occlusion culler on a generated plant, city and forest (lavapipe
//! or any adapter): at pixel error 0 each one's image is the full-detail
//! reference's, pixel for pixel (conservative: no wrongly culled pixel),
//! and the lazy occlusion grid culls exactly as its eager twin with fewer
//! depth reads.

use gigawalk_gpu::devices_or_skip;
use gigawalk_procgen::{generate, Generated, Kind};
use gigawalk_replay::FrameRecord;
use gigawalk_replay::{replay_on, Mode, NoProgress, ReplayOptions};
use gigawalk_runtime::{
    CullMethod, CullerWork, GridStats, HzbBuild, HzbLevel, OqStats, Runtime, RuntimeOptions,
    Schedule,
};
use gigawalk_scene::SceneReader;

const TRIANGLES: u64 = 30_000;
const W: u32 = 256;
const H: u32 = 144;

/// A grid run's frame's work.
fn grid(f: &FrameRecord) -> GridStats {
    match f.culler_work {
        Some(CullerWork::Grid(g)) => g,
        w => panic!("grid runs report the grid's work, not {w:?}"),
    }
}

/// An oq run's frame's work.
fn oq(f: &FrameRecord) -> OqStats {
    match f.culler_work {
        Some(CullerWork::Oq(q)) => q,
        w => panic!("oq runs report the queries, not {w:?}"),
    }
}

/// A generated scene of `kind`, preprocessed into `dir`, and its walk.
fn scene(dir: &std::path::Path, kind: Kind, seed: u64, poses: usize) -> (SceneReader, Generated) {
    let g = generate(kind, TRIANGLES, seed, poses);
    let model = gigawalk_import::import_glb_bytes(&g.glb_bytes(), "m").unwrap();
    let file = dir.join(format!("{kind:?}.gwk"));
    gigawalk_preprocess::preprocess(
        &model,
        &gigawalk_preprocess::Params::default(),
        &file,
        "test",
        &gigawalk_preprocess::NoProgress,
    )
    .unwrap();
    (SceneReader::open(&file).unwrap(), g)
}

fn options(cullers: &[CullMethod], schedule: Schedule, frames: usize) -> ReplayOptions {
    ReplayOptions {
        modes: vec![Mode::Occ, Mode::Och],
        pixel_errors: vec![0.0],
        cullers: cullers.to_vec(),
        runtime: RuntimeOptions {
            width: W,
            height: H,
            schedule,
            ..Default::default()
        },
        memory_budget: Default::default(),
        near: None,
        frames: Some(frames),
        accuracy_every: 3,
        warmup: 2,
        target: None,
        adapter: None,
        visibility: None,
        section: None,
        look: Default::default(),
        ghosts: None,
    }
}

#[test]
fn every_culler_draws_the_reference_image_at_pixel_error_0() {
    let dir = tempfile::tempdir().unwrap();
    for kind in [Kind::Plant, Kind::City, Kind::Forest] {
        let (scene, g) = scene(dir.path(), kind, 5, 30);
        let Some(d) = devices_or_skip(2, "cullers on plant, city and forest") else {
            return;
        };
        let rt = Runtime::with_devices(&scene, d).unwrap();
        let mut grid_culled = 0;
        for schedule in [Schedule::Pipelined, Schedule::Sequential] {
            let opts = options(&CullMethod::ALL, schedule, 24);
            let r = replay_on(
                &rt,
                "m.gwk",
                &g.path.poses,
                "m.path",
                &opts,
                &mut NoProgress,
            )
            .unwrap();
            let s = r.summary();
            assert_eq!(
                s.modes.len(),
                2 * CullMethod::ALL.len(),
                "{kind:?}: occ and och, each with both cullers"
            );
            for m in &s.modes {
                let what = format!("{kind:?} {schedule:?} {} {:?}", m.name, m.culler);
                assert_eq!(m.accuracy_frames, 8, "{what}");
                assert_eq!(m.wrongly_culled_pixels, Some(0), "{what}: lost pixels");
                assert_eq!(m.differing_pixels_fraction, Some(0.0), "{what}: differs");
                assert_eq!(m.bound_violating_pixels, Some(0), "{what}");
            }
            for run in r.runs.iter().filter(|r| r.culler == Some(CullMethod::Oq)) {
                for f in &run.frames {
                    let q = oq(f);
                    assert!(f.occlusion_used, "queries cull from frame 0");
                    assert!(q.round_trips > 0 && q.queries >= q.round_trips, "{q:?}");
                }
            }
            for run in r.runs.iter().filter(|r| r.culler == Some(CullMethod::Grid)) {
                for f in &run.frames {
                    let g = grid(f);
                    assert!(f.occlusion_used, "the grid culls from frame 0");
                    assert!(g.tests > 0 && g.triangles_drawn > 0, "{g:?}");
                    grid_culled += f.occlusion_culled;
                }
            }
        }
        assert!(
            grid_culled > 0,
            "{kind:?}: the grid culled nothing, the test means little"
        );
    }
}

/// The HZB built on OR's device and read back at a coarse level culls
/// conservatively: at pixel error 0, occ and och draw the full-detail
/// reference image pixel for pixel on the plant, city and forest, at odd
/// viewports and one-pixel rows, whatever level is read back; and the
/// coarse HZB still culls.
#[test]
fn the_device_built_hzb_read_at_any_level_draws_the_reference_image() {
    let dir = tempfile::tempdir().unwrap();
    let mut culled = 0;
    for kind in [Kind::Plant, Kind::City, Kind::Forest] {
        let (scene, g) = scene(dir.path(), kind, 7, 12);
        let Some(d) = devices_or_skip(2, "device HZB on plant, city and forest") else {
            return;
        };
        let rt = Runtime::with_devices(&scene, d).unwrap();
        for ((w, h), level) in [((17, 9), 1), ((640, 1), 3), ((1023, 769), 2), ((W, H), 4)] {
            let mut opts = options(&[CullMethod::Hzb], Schedule::Pipelined, 12);
            opts.runtime.width = w;
            opts.runtime.height = h;
            opts.runtime.hzb = HzbBuild::Gpu(HzbLevel::Fixed(level));
            let r = replay_on(
                &rt,
                "m.gwk",
                &g.path.poses,
                "m.path",
                &opts,
                &mut NoProgress,
            )
            .unwrap();
            for m in &r.summary().modes {
                let what = format!("{kind:?} {w}x{h} level {level} {}", m.name);
                assert_eq!(m.accuracy_frames, 4, "{what}");
                assert_eq!(m.wrongly_culled_pixels, Some(0), "{what}: lost pixels");
                assert_eq!(m.differing_pixels_fraction, Some(0.0), "{what}: differs");
            }
            for f in r.runs.iter().flat_map(|r| &r.frames) {
                if f.occlusion_used {
                    assert_eq!(f.cpu.hzb_level, level, "{kind:?} {w}x{h}");
                }
                culled += f.occlusion_culled;
            }
        }
    }
    assert!(
        culled > 0,
        "the coarse HZB culled nothing: the test means little"
    );
}

#[test]
fn the_lazy_grid_culls_as_the_eager_one_with_fewer_depth_reads() {
    let Some(d) = devices_or_skip(1, "lazy vs eager grid") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (scene, g) = scene(dir.path(), Kind::City, 2, 20);
    let rt = Runtime::with_devices(&scene, d).unwrap();
    let mut runs = Vec::new();
    for lazy in [true, false] {
        let mut opts = options(&[CullMethod::Grid], Schedule::Sequential, 20);
        opts.modes = vec![Mode::Occ];
        opts.accuracy_every = 0;
        opts.runtime.cullers.grid.lazy = lazy;
        opts.runtime.cullers.grid.cell = 8;
        let r = replay_on(
            &rt,
            "c.gwk",
            &g.path.poses,
            "c.path",
            &opts,
            &mut NoProgress,
        )
        .unwrap();
        runs.push(r.runs.into_iter().next().unwrap());
    }
    let (lazy, eager) = (&runs[0], &runs[1]);
    let reads = |r: &gigawalk_replay::RunRecord| -> u64 {
        r.frames.iter().map(|f| grid(f).pixel_reads).sum()
    };
    for (a, b) in lazy.frames.iter().zip(&eager.frames) {
        assert_eq!(a.occlusion_culled, b.occlusion_culled, "frame {}", a.frame);
        assert_eq!(a.drawn_triangles, b.drawn_triangles, "frame {}", a.frame);
    }
    assert!(
        reads(lazy) < reads(eager),
        "lazy {} vs eager {} depth reads",
        reads(lazy),
        reads(eager)
    );
}

#[test]
fn occlusion_query_variants_coherent_batched_budgeted_and_adaptive() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, g) = scene(dir.path(), Kind::City, 4, 20);
    let Some(d) = devices_or_skip(2, "occlusion-query variants") else {
        return;
    };
    let rt = Runtime::with_devices(&scene, d).unwrap();
    let try_replay = |f: &dyn Fn(&mut RuntimeOptions)| {
        let mut opts = options(&[CullMethod::Oq], Schedule::Pipelined, 20);
        opts.modes = vec![Mode::Occ];
        f(&mut opts.runtime);
        replay_on(
            &rt,
            "c.gwk",
            &g.path.poses,
            "c.path",
            &opts,
            &mut NoProgress,
        )
    };
    let replay = |f: &dyn Fn(&mut RuntimeOptions)| {
        let r = try_replay(f).unwrap();
        let s = r.summary();
        (r.runs.into_iter().next().unwrap(), s.modes[0].clone())
    };
    // The paper (a round trip per test, leaves untested), batched, and
    // coherent: all conservative.
    let (paper, ps) = replay(&|o| {
        o.cullers.oq.batch = 1;
        o.cullers.oq.test_leaves = false;
    });
    let (batched, bs) = replay(&|o| o.cullers.oq.batch = 64);
    let (coherent, cs) = replay(&|o| o.cullers.oq.coherent = true);
    for (name, m) in [("paper", &ps), ("batched", &bs), ("coherent", &cs)] {
        assert_eq!(m.wrongly_culled_pixels, Some(0), "{name}");
        assert_eq!(m.differing_pixels_fraction, Some(0.0), "{name}");
    }
    let trips = |r: &gigawalk_replay::RunRecord| -> u64 {
        r.frames.iter().map(|f| oq(f).round_trips).sum()
    };
    let queries =
        |r: &gigawalk_replay::RunRecord| -> u64 { r.frames.iter().map(|f| oq(f).queries).sum() };
    // One query per round trip as written; batches need fewer trips.
    assert_eq!(trips(&paper), queries(&paper));
    assert!(
        trips(&batched) < trips(&paper),
        "{} vs {}",
        trips(&batched),
        trips(&paper)
    );
    // Coherent: visible nodes of the last frame are not waited for.
    let passed: u64 = coherent.frames.iter().map(|f| oq(f).coherent).sum();
    assert!(passed > 0);
    // A budget of 0: frustum culling only, and every frame finishes.
    let (zero, _) = replay(&|o| o.cullers.oq.budget = Some(0.0));
    assert_eq!(zero.frames.len(), 20);
    assert!(zero.frames.iter().all(|f| f.occlusion_culled == 0));
    assert!(zero.frames.iter().all(|f| oq(f).queries == 0));
    // Adaptive culling culls more than conservative queries (approximate:
    // what it costs is in the accuracy figures). It needs queries that
    // count samples (GL's say only zero or not, and the runtime refuses).
    if gigawalk_gpu::query_counts(rt.device(1)).unwrap() != gigawalk_gpu::QueryCounts::Exact {
        let e = try_replay(&|o| o.cullers.oq.adaptive = 400)
            .expect_err("adaptive culling refused without sample counts");
        assert!(e.to_string().contains("sample counts"), "{e}");
        return;
    }
    let (adaptive, _) = replay(&|o| o.cullers.oq.adaptive = 400);
    let tris = |r: &gigawalk_replay::RunRecord| -> u64 {
        r.frames.iter().map(|f| f.drawn_triangles).sum()
    };
    assert!(
        tris(&adaptive) < tris(&batched),
        "{} vs {}",
        tris(&adaptive),
        tris(&batched)
    );
}

#[test]
fn a_tiled_replay_matches_the_single_view_reference_and_reports_its_tiles() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, g) = scene(dir.path(), Kind::City, 7, 12);
    let Some(d) = devices_or_skip(2, "tiled replay") else {
        return;
    };
    let rt = Runtime::with_devices(&scene, d).unwrap();
    for (grid, method) in [
        ("4x4", gigawalk_runtime::TileMethod::Adaptive),
        ("3x2", gigawalk_runtime::TileMethod::Binning),
    ] {
        let mut opts = options(&[CullMethod::Hzb, CullMethod::Ct], Schedule::Pipelined, 12);
        opts.runtime.tiles = Some(grid.parse().unwrap());
        opts.runtime.tile_culling = method;
        let r = replay_on(
            &rt,
            "m.gwk",
            &g.path.poses,
            "m.path",
            &opts,
            &mut NoProgress,
        )
        .unwrap();
        let s = r.summary();
        for m in &s.modes {
            let what = format!("{grid} {} {:?}", m.name, m.culler);
            assert_eq!(m.tiles.as_deref(), Some(grid), "{what}");
            assert_eq!(m.tile_culling.as_deref(), Some(method.name()), "{what}");
            assert!(
                m.cull_ms_adaptive.is_some() && m.cull_ms_naive.is_some(),
                "{what}"
            );
            let (max, mean) = (
                m.max_tile_triangles.unwrap(),
                m.mean_tile_triangles.unwrap(),
            );
            assert!(max >= mean && mean > 0.0, "{what}: {max} {mean}");
            // The stitched tiles are the single view's image.
            assert_eq!(m.wrongly_culled_pixels, Some(0), "{what}");
            assert_eq!(m.differing_pixels_fraction, Some(0.0), "{what}");
            if m.culler.as_deref() == Some("ct") {
                // The scene's view cells list the candidates.
                assert!(
                    m.culler_figures.get("mean_ct_candidates").unwrap() <= 32.0,
                    "{what}"
                );
            }
        }
        let csv = r.csv();
        let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
        let col = header
            .iter()
            .position(|h| *h == "max_tile_triangles")
            .unwrap();
        for line in csv.lines().skip(1) {
            let v: Vec<&str> = line.split(',').collect();
            assert!(v[col].parse::<u64>().is_ok(), "{line}");
        }
        assert!(gigawalk_replay::markdown(&s).contains("## Tiled display"));
    }
}
