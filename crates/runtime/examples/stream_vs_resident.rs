//! och along a camera path streamed under a memory budget against the
//! same frames with the whole scene resident, pixel by pixel: per frame,
//! the stand-ins drawn and the pixels whose depth differs. The 256M check
//! of docs/results.md ("First frame and memory") comes from it.
//!
//! ```text
//! cargo run --release -p gigawalk-runtime --example stream_vs_resident -- \
//!     SCENE.gwk PATH.path BUDGET_BYTES FRAMES
//! ```
//! It runs the resident runtime first (the whole scene in memory), then
//! the streamed one, one after the other.

use std::error::Error;

use gigawalk_cull::{default_near, TraversalOptions, Viewport};
use gigawalk_runtime::{CameraList, Runtime, RuntimeOptions};
use gigawalk_scene::path::CameraPath;
use gigawalk_scene::SceneReader;

fn main() -> Result<(), Box<dyn Error>> {
    let a: Vec<String> = std::env::args().collect();
    if a.len() != 5 {
        return Err("usage: stream_vs_resident SCENE.gwk PATH.path BUDGET_BYTES FRAMES".into());
    }
    let scene = SceneReader::open(a[1].as_ref())?;
    let path = CameraPath::read(a[2].as_ref())?;
    let budget: u64 = a[3].parse()?;
    let frames: usize = a[4].parse::<usize>()?.min(path.poses.len());
    let (w, h) = (640, 360);
    let near = default_near(&scene.skeleton().bounds());
    let cams = || CameraList::from_poses(&path.poses[..frames], Viewport::new(w, h), near);
    let o = RuntimeOptions {
        width: w,
        height: h,
        traversal: TraversalOptions {
            occlusion: true,
            hlod: true,
            pixel_error: 1.0,
        },
        ..Default::default()
    };
    let mut res = Vec::new();
    {
        let rt = Runtime::new(&scene, 2)?;
        rt.run(&o, &mut cams(), &mut |r| {
            res.push(r.image.map(|i| i.depth.depth).unwrap_or_default());
            true
        })?;
    }
    let rt = Runtime::streaming(&scene, gigawalk_gpu::open_devices(2)?, budget)?;
    let mut i = 0;
    rt.run(&o, &mut cams(), &mut |r| {
        let d = r.image.as_ref().map_or(&[][..], |i| &i.depth.depth[..]);
        let diff = d.iter().zip(&res[i]).filter(|(x, y)| x != y).count();
        println!(
            "frame {i}: substituted {} missing {} differing depth px {diff}",
            r.streaming.substituted, r.streaming.missing
        );
        i += 1;
        true
    })?;
    Ok(())
}
