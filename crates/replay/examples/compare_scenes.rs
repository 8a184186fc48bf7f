//! How two scenes of one model differ on screen: each drawn at full
//! detail (frustum culling only, every leaf's finest LOD) from the same
//! cameras along a path, and the images compared pixel by pixel. For
//! storage choices (`preprocess --position-bits`, `--normal-bits`): what
//! a layout changes in the picture, next to what it saves in bytes.
//! Prints PSNR, the share of pixels that differ, the largest channel
//! difference, and the share of pixels whose depth differs by more than
//! a millionth of it (positions moved).
//!
//! `cargo run --release -p gigawalk-replay --example compare_scenes -- A.gwk B.gwk PATH [FRAMES] [WIDTHxHEIGHT]`

use gigawalk_cull::{default_near, Viewport};
use gigawalk_replay::{Accuracy, Mode};
use gigawalk_runtime::{CameraList, FrameImage, Runtime, RuntimeOptions, Schedule};
use gigawalk_scene::path::CameraPath;
use gigawalk_scene::SceneReader;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: compare_scenes A.gwk B.gwk PATH [FRAMES] [WIDTHxHEIGHT]";
    let [a, b, path] = [0, 1, 2].map(|i| args.get(i).cloned());
    let (Some(a), Some(b), Some(path)) = (a, b, path) else {
        return Err(usage.into());
    };
    let frames: usize = args.get(3).map(|f| f.parse()).transpose()?.unwrap_or(40);
    let (w, h) = match args.get(4) {
        Some(s) => {
            let (w, h) = s.split_once('x').ok_or(usage)?;
            (w.parse()?, h.parse()?)
        }
        None => (640, 360),
    };
    let poses = CameraPath::read(std::path::Path::new(&path))?.poses;
    // Every pose when there are fewer than `frames`, else evenly spaced.
    let step = poses.len().div_ceil(frames.max(1)).max(1);
    let poses: Vec<_> = poses.into_iter().step_by(step).collect();
    let scene_a = SceneReader::open(std::path::Path::new(&a))?;
    let scene_b = SceneReader::open(std::path::Path::new(&b))?;
    let near = default_near(&scene_a.skeleton().bounds());
    let viewport = Viewport::new(w, h);
    let opts = RuntimeOptions {
        schedule: Schedule::Sequential,
        devices: 1,
        width: w,
        height: h,
        traversal: Mode::Vfc.traversal(0.0),
        ..Default::default()
    };
    let draw = |scene: &SceneReader| -> Result<Vec<FrameImage>, Box<dyn std::error::Error>> {
        let rt = Runtime::new(scene, 1)?;
        let mut cams = CameraList::from_poses(&poses, viewport, near);
        let mut images = Vec::new();
        rt.run(&opts, &mut cams, &mut |r| {
            images.extend(r.image);
            true
        })?;
        Ok(images)
    };
    let (ia, ib) = (draw(&scene_a)?, draw(&scene_b)?);
    let mut total = Accuracy::default();
    let (mut largest, mut depth_moved) = (0u8, 0u64);
    for (x, y) in ia.iter().zip(&ib) {
        let acc = Accuracy::compare(x, y, 0.0, 1.0).ok_or("the images differ in size")?;
        total.add(&acc);
        for (p, q) in x.colour.chunks_exact(4).zip(y.colour.chunks_exact(4)) {
            for c in 0..3 {
                largest = largest.max(p[c].abs_diff(q[c]));
            }
        }
        depth_moved += x
            .depth
            .depth
            .iter()
            .zip(&y.depth.depth)
            .filter(|(p, q)| (**p - **q).abs() > 1e-6 * p.abs().max(q.abs()))
            .count() as u64;
    }
    let bytes = |p: &str| std::fs::metadata(p).map(|m| m.len()).unwrap_or(0);
    println!(
        "{} frames at {w}x{h}: PSNR {}, {:.3}% of pixels differ, largest channel difference {largest}, \
         {:.3}% of pixels' depth differs; {} against {} bytes ({:.3}x)",
        ia.len().min(ib.len()),
        total
            .psnr_db()
            .map_or("infinite (identical)".to_string(), |d| format!("{d:.1} dB")),
        100.0 * total.differing_fraction(),
        100.0 * depth_moved as f64 / total.pixels.max(1) as f64,
        bytes(&a),
        bytes(&b),
        bytes(&b) as f64 / bytes(&a).max(1) as f64
    );
    Ok(())
}
