//! What sending culled items to the tiles of a tiled display costs, by
//! method and tile grid (Nirnimesh, Harish and Narayanan's
//! Fig. 4): for each pose, the frustum-culled, LOD-selected items of the
//! whole view (no occlusion, so most of the model is in play), then each
//! method's milliseconds (median over poses) for grids 1x1 to 16x16 and
//! 3x2. Poses: an orbit around the scene looking at its centre from 0.8 of
//! its diagonal (the whole model in view), or a camera path's.
//!
//! ```text
//! cargo run --release -p gigawalk-cull --example tile_culling -- \
//!     SCENE.gwk [PATH.path|orbit] [WIDTH HEIGHT PIXEL_ERROR POSES]
//! ```
//! Defaults: orbit, 1920 1080, pixel error 1, 24 poses.

use std::error::Error;
use std::time::Instant;

use gigawalk_cull::tiles::{assign, TileFrustums, TileGrid, TileMethod};
use gigawalk_cull::{
    default_near, Camera, CullView, NoOcclusion, TraversalOptions, Traverser, Viewport,
};
use gigawalk_scene::path::CameraPath;
use gigawalk_scene::SceneReader;
use glam::DVec3;

mod common;
use common::{arg, median};

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 2 {
        return Err(
            "usage: tile_culling SCENE.gwk [PATH.path|orbit] [WIDTH HEIGHT PIXEL_ERROR POSES]"
                .into(),
        );
    }
    let scene = SceneReader::open(args[1].as_ref())?;
    let sk = scene.skeleton();
    let (w, h): (u32, u32) = (arg(&args, 3, 1920)?, arg(&args, 4, 1080)?);
    let tolerance: f64 = arg(&args, 5, 1.0)?;
    let poses: usize = arg::<usize>(&args, 6, 24)?.max(1);
    let viewport = Viewport::new(w, h);
    let near = default_near(&sk.bounds());
    let cameras: Vec<Camera> = match args.get(2).map(String::as_str) {
        None | Some("orbit") => {
            let c = sk.bounds().center();
            let r = 0.8 * sk.bounds().diagonal();
            (0..poses)
                .map(|i| {
                    let a = i as f64 / poses as f64 * std::f64::consts::TAU;
                    let eye = c + DVec3::new(a.cos() * r, 0.35 * r, a.sin() * r);
                    let mut cam =
                        Camera::look_at(eye, c, 60f64.to_radians(), viewport.aspect(), near);
                    cam.aspect = viewport.aspect();
                    cam
                })
                .collect()
        }
        Some(p) => {
            let path = CameraPath::read(p.as_ref())?;
            let every = (path.poses.len() / poses).max(1);
            path.poses
                .iter()
                .step_by(every)
                .map(|p| Camera::of_pose(p, viewport, near))
                .collect()
        }
    };
    let options = TraversalOptions {
        occlusion: false,
        hlod: tolerance > 0.0,
        pixel_error: tolerance,
    };
    let grids = [(1, 1), (2, 2), (3, 2), (4, 4), (8, 8), (16, 16)];
    let mut traverser = Traverser::new();
    let mut items = Vec::new();
    // (grid, method) -> ms per pose; and tests, list entries.
    let mut ms = vec![vec![Vec::new(); TileMethod::ALL.len()]; grids.len()];
    let mut tests = vec![vec![0u64; TileMethod::ALL.len()]; grids.len()];
    let mut entries = vec![vec![0u64; TileMethod::ALL.len()]; grids.len()];
    let mut item_count = 0;
    for cam in &cameras {
        let view = CullView::new(*cam, viewport);
        items.clear();
        traverser.traverse(sk, &view, &NoOcclusion, &options, &mut |it| items.push(it));
        item_count += items.len();
        for (g, &(c, r)) in grids.iter().enumerate() {
            let grid = TileGrid { cols: c, rows: r };
            for (m, &method) in TileMethod::ALL.iter().enumerate() {
                // Best of 3, to keep scheduler noise out.
                let mut best = f64::INFINITY;
                for _ in 0..3 {
                    let t = Instant::now();
                    let tiles = TileFrustums::new(&view, grid);
                    let lists = assign(sk, &view, &tiles, &items, method);
                    best = best.min(t.elapsed().as_secs_f64() * 1e3);
                    tests[g][m] = lists.tests;
                    entries[g][m] += lists.lists.iter().map(|l| l.len() as u64).sum::<u64>();
                }
                ms[g][m].push(best);
            }
        }
    }
    println!(
        "{} poses, {}x{}, pixel error {tolerance}, {:.0} items a pose ({} nodes in the scene)\n",
        cameras.len(),
        w,
        h,
        item_count as f64 / cameras.len() as f64,
        sk.nodes().len()
    );
    let names: Vec<&str> = TileMethod::ALL.iter().map(|m| m.name()).collect();
    println!(
        "median ms sending items to tiles (box tests of the last pose; list entries a pose)\n"
    );
    println!("| tiles | {} |", names.join(" | "));
    println!("|---|{}", "---:|".repeat(names.len()));
    for (g, &(c, r)) in grids.iter().enumerate() {
        let cells: Vec<String> = (0..names.len())
            .map(|m| {
                format!(
                    "{:.3} ({} tests, {:.0} entries)",
                    median(ms[g][m].clone()),
                    tests[g][m],
                    entries[g][m] as f64 / (3 * cameras.len()) as f64
                )
            })
            .collect();
        println!("| {c}x{r} | {} |", cells.join(" | "));
    }
    Ok(())
}
