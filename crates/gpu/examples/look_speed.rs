//! What each part of the look costs the device: an empty frame (the clear
//! alone) with each look, at a size, timed over frames that wait for the
//! device; the median per frame.
//!
//! `cargo run --release -p gigawalk-gpu --example look_speed -- 1280 720`

use std::time::Instant;

use gigawalk_cull::Camera;
use gigawalk_gpu::{open_devices, Antialias, ClipPlanes, DrawStyle, Look, View, VisiblePass};
use glam::DVec3;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<u32> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("WIDTH HEIGHT"))
        .collect();
    let (w, h) = match args[..] {
        [w, h] => (w, h),
        _ => (1280, 720),
    };
    let ctx = open_devices(1)?.remove(0);
    let cam = Camera::look_at(DVec3::ZERO, DVec3::NEG_Z, 1.0, w as f64 / h as f64, 0.1);
    let view = View {
        eye: cam.position,
        view_proj: cam.view_projection_rel(),
        forward: cam.forward().as_vec3(),
        clip: ClipPlanes::NONE,
    };
    let plain = Look::PLAIN;
    let looks = [
        ("plain", plain),
        ("sky", Look { sky: true, ..plain }),
        (
            "edges",
            Look {
                edges: true,
                ..plain
            },
        ),
        ("ao", Look { ao: true, ..plain }),
        (
            "fxaa",
            Look {
                aa: Antialias::Fxaa,
                ..plain
            },
        ),
        (
            "all",
            Look {
                ao: true,
                ..Look::auto(false)
            },
        ),
    ];
    println!(
        "{} at {w}x{h}: median ms a frame (empty scene, waited for)",
        ctx.name()
    );
    for (name, look) in looks {
        let mut pass = VisiblePass::new(&ctx, w, h);
        let mut times = Vec::new();
        for _ in 0..25 {
            let t = Instant::now();
            pass.begin(&ctx, &view, DrawStyle::Shaded, look);
            pass.end(&ctx)?;
            pass.read_shown(&ctx)?;
            times.push(t.elapsed().as_secs_f64() * 1e3);
        }
        times.sort_by(f64::total_cmp);
        println!("{name:>6} {:8.2}", times[times.len() / 2]);
    }
    Ok(())
}
