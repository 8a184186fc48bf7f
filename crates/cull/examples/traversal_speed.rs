//! What traversal alone costs a visited node: the frustum test and LOD
//! choice of the `hlod` mode (no occlusion culler, a sink that only
//! counts), over every pose of a camera path, on one core. With nothing
//! around it (no queues, no other stage, no culler) it is the floor under
//! STC's `traversal_ms`.
//!
//! ```text
//! cargo run --release -p gigawalk-cull --example traversal_speed -- \
//!     SCENE.gwk PATH.path [WIDTH HEIGHT PIXEL_ERROR ROUNDS]
//! ```
//! Defaults: 1920 1080 1 5. Prints the median over rounds of ns per visited
//! node and per drawn item, the nodes a pose visits, and a hash of every
//! item drawn in order (two builds that draw the same agree on it).

use std::error::Error;
use std::time::Instant;

use gigawalk_cull::{
    default_near, Camera, CullView, DrawItem, NoOcclusion, TraversalOptions, Traverser, Viewport,
};
use gigawalk_scene::path::CameraPath;
use gigawalk_scene::SceneReader;

mod common;
use common::{arg, median};

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        return Err(
            "usage: traversal_speed SCENE.gwk PATH.path [WIDTH HEIGHT PIXEL_ERROR ROUNDS]".into(),
        );
    }
    let scene = SceneReader::open(args[1].as_ref())?;
    let path = CameraPath::read(args[2].as_ref())?;
    let (w, h): (u32, u32) = (arg(&args, 3, 1920)?, arg(&args, 4, 1080)?);
    let pixel_error: f64 = arg(&args, 5, 1.0)?;
    let rounds: usize = arg::<usize>(&args, 6, 5)?.max(1);
    let sk = scene.skeleton();
    let near = default_near(&sk.bounds());
    let viewport = Viewport::new(w, h);
    let views: Vec<CullView> = path
        .poses
        .iter()
        .map(|pose| CullView::new(Camera::of_pose(pose, viewport, near), viewport))
        .collect();
    let options = TraversalOptions {
        occlusion: false,
        hlod: true,
        pixel_error,
    };
    let mut traverser = Traverser::new();
    let (mut per_node, mut per_item) = (Vec::new(), Vec::new());
    let (mut visited, mut drawn, mut hash) = (0u64, 0u64, 0u64);
    for _ in 0..rounds {
        let (mut v, mut d) = (0u64, 0u64);
        // FNV-1a over (node, lod) in the order drawn.
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        let t = Instant::now();
        for view in &views {
            let mut count = 0u64;
            let stats = traverser.traverse(sk, view, &NoOcclusion, &options, &mut |i: DrawItem| {
                count += 1;
                for x in [i.node, i.lod] {
                    h = (h ^ x as u64).wrapping_mul(0x100_0000_01b3);
                }
            });
            v += stats.visited;
            d += count;
        }
        let ns = t.elapsed().as_secs_f64() * 1e9;
        per_node.push(ns / v.max(1) as f64);
        per_item.push(ns / d.max(1) as f64);
        (visited, drawn, hash) = (v, d, h);
    }
    let poses = views.len().max(1) as f64;
    println!(
        "{}: {} poses, {w}x{h}, {pixel_error} px, {rounds} rounds: {:.0} nodes visited and {:.0} drawn a pose; {:.1} ns a visited node, {:.1} ns a drawn item (medians); items hash {hash:016x}",
        args[1],
        views.len(),
        visited as f64 / poses,
        drawn as f64 / poses,
        median(per_node),
        median(per_item),
    );
    Ok(())
}
