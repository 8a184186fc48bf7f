//! Pipelined against sequential throughput on the generated plant's walk
//! (the pipeline's speed-up target): median frame time, each stage's median
//! time, and latency, per schedule, measured in one run.
//!
//! Run: `cargo bench -p gigawalk-suite --bench pipeline` (env: OCCLUDER_BUDGET, PLANT_TRIANGLES
//! default 1000000, FRAMES default 200, WIDTH/HEIGHT default 640x360,
//! PIXEL_ERROR default 1). The scene is cached under target/gigawalk-bench-cache.

use std::path::PathBuf;

use gigawalk_cull::{default_near, Camera, TraversalOptions, Viewport};
use gigawalk_import::import_glb_bytes;
use gigawalk_preprocess::{preprocess, NoProgress, Params};
use gigawalk_procgen::{generate, Kind};
use gigawalk_runtime::{
    CameraList, CameraRequest, FrameReport, OccluderBudget, Runtime, RuntimeOptions, Schedule,
};
use gigawalk_scene::path::CameraPath;
use gigawalk_scene::SceneReader;

/// The environment variable `name` parsed, or `default` when unset; a
/// value that does not parse stops the bench (a typo must not silently
/// measure the default).
fn env<T: std::str::FromStr>(name: &str, default: T) -> T {
    match std::env::var(name) {
        Err(_) => default,
        Ok(v) => v
            .parse()
            .unwrap_or_else(|_| panic!("{name}={v:?} is not a valid value")),
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}

fn main() {
    // `cargo bench` passes --bench; `cargo test --benches` passes nothing
    // useful either: run only when invoked as a bench.
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    let triangles: u64 = env("PLANT_TRIANGLES", 1_000_000);
    let frames: usize = env("FRAMES", 200);
    let (w, h): (u32, u32) = (env("WIDTH", 640), env("HEIGHT", 360));
    let pixel_error: f64 = env("PIXEL_ERROR", 1.0);
    // `auto` (the default: 30k triangles on lavapipe), `all`, or a count.
    let occluder_budget: OccluderBudget = env("OCCLUDER_BUDGET", OccluderBudget::All);

    let cache = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/gigawalk-bench-cache");
    std::fs::create_dir_all(&cache).unwrap();
    let scene_path = cache.join(format!("plant-{triangles}-s1.gwk"));
    let path_path = cache.join(format!("plant-{triangles}-s1.path"));
    if !scene_path.exists() || !path_path.exists() {
        eprintln!(
            "generating and preprocessing a {triangles}-triangle plant (cached for later runs)..."
        );
        let g = generate(Kind::Plant, triangles, 1, 600);
        let model = import_glb_bytes(&g.glb_bytes(), "plant").unwrap();
        preprocess(
            &model,
            &Params::default(),
            &scene_path,
            "generated plant",
            &NoProgress,
        )
        .unwrap();
        g.path.write(&path_path).unwrap();
    }
    let scene = SceneReader::open(&scene_path).unwrap();
    let path = CameraPath::read(&path_path).unwrap();
    let rt = Runtime::new(&scene, 2).expect("this bench needs a GPU adapter (lavapipe is fine)");
    let near = default_near(&scene.skeleton().bounds());
    let cameras: Vec<CameraRequest> = path
        .poses
        .iter()
        .take(frames)
        .map(|p| CameraRequest::new(Camera::of_pose(p, Viewport::new(w, h), near), false))
        .collect();
    println!(
        "plant {} triangles, {} frames at {w}x{h}, och pixel error {pixel_error}, occluder budget {occluder_budget} ({}), devices {:?}",
        scene.skeleton().finest_triangles(),
        cameras.len(),
        rt.occluder_selection(occluder_budget),
        rt.device_names()
    );
    println!("| schedule | median frame ms | fps | OR ms | STC ms (HZB) | RVG ms | latency ms | triangles/frame |");
    println!("|---|---|---|---|---|---|---|---|");
    let schedules = [
        ("sequential (1 thread, 1 device)", Schedule::Sequential, 1),
        ("pipelined, 1 device", Schedule::Pipelined, 1),
        ("pipelined, 2 devices", Schedule::Pipelined, 2),
    ];
    // Rounds interleave the schedules, each round on its own stretch of the
    // walk, so load changes on a shared machine hit every schedule alike.
    let rounds = env("ROUNDS", 4usize).max(1);
    let per_round = (cameras.len() / rounds).max(12);
    let mut all: Vec<Vec<FrameReport>> = vec![Vec::new(); schedules.len()];
    let mut intervals: Vec<Vec<f64>> = vec![Vec::new(); schedules.len()];
    for round in 0..rounds {
        let stretch: Vec<CameraRequest> = cameras
            .iter()
            .skip(round * per_round)
            .take(per_round)
            .cloned()
            .collect();
        for (k, &(_, schedule, devices)) in schedules.iter().enumerate() {
            let opts = RuntimeOptions {
                schedule,
                devices,
                width: w,
                height: h,
                traversal: TraversalOptions {
                    occlusion: true,
                    hlod: true,
                    pixel_error,
                },
                occluder_budget,
                ..Default::default()
            };
            let mut reports: Vec<FrameReport> = Vec::new();
            rt.run(
                &opts,
                &mut CameraList {
                    cameras: stretch.clone(),
                },
                &mut |r| {
                    reports.push(r);
                    true
                },
            )
            .unwrap();
            // Skip warm-up frames (startup bypass, pipeline filling).
            let steady: Vec<FrameReport> = reports.into_iter().skip(5).collect();
            intervals[k].extend(
                steady
                    .windows(2)
                    .map(|p| (p[1].finished_at - p[0].finished_at).as_secs_f64() * 1e3),
            );
            all[k].extend(steady);
        }
    }
    let mut frame_ms = Vec::new();
    for (k, (name, _, _)) in schedules.iter().enumerate() {
        let m = median(intervals[k].clone());
        frame_ms.push(m);
        let steady = &all[k];
        let med = |f: fn(&FrameReport) -> f64| median(steady.iter().map(f).collect());
        println!(
            "| {name} | {m:.1} | {:.1} | {:.1} | {:.1} ({:.1}) | {:.1} | {:.1} | {:.0} |",
            1e3 / m,
            med(|r| r.or_ms),
            med(|r| r.stc_ms),
            med(|r| r.hzb_ms),
            med(|r| r.rvg_ms),
            med(|r| r.latency_ms()),
            med(|r| r.stats.drawn_triangles as f64),
        );
    }
    println!(
        "speed-up over sequential: pipelined 1 device {:.2}x, pipelined 2 devices {:.2}x",
        frame_ms[0] / frame_ms[1],
        frame_ms[0] / frame_ms[2]
    );
}
