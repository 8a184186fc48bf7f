//! Where the triangles of an HLOD traversal come from: frustum culling and
//! LOD selection only (the `hlod` mode without a GPU), over a camera path,
//! broken down by leaf/inner node, LOD level, tree depth and how far below
//! the tolerance the drawn level's pixel error is: the "frustum-only"
//! triangle counts of the LOD measurements.
//!
//! ```text
//! cargo run --release -p gigawalk-cull --example lod_breakdown -- \
//!     SCENE.gwk PATH.path [WIDTH HEIGHT PIXEL_ERROR EVERY]
//! ```
//! Defaults: 640 360 1 5 (every 5th pose).

use std::error::Error;

use gigawalk_cull::lod::pixel_error;
use gigawalk_cull::{
    default_near, Camera, CullView, NoOcclusion, TraversalOptions, Traverser, Viewport,
};
use gigawalk_scene::path::CameraPath;
use gigawalk_scene::SceneReader;

mod common;
use common::arg;

const LEVELS: usize = 8;

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        return Err(
            "usage: lod_breakdown SCENE.gwk PATH.path [WIDTH HEIGHT PIXEL_ERROR EVERY]".into(),
        );
    }
    let scene = SceneReader::open(args[1].as_ref())?;
    let path = CameraPath::read(args[2].as_ref())?;
    let (w, h): (u32, u32) = (arg(&args, 3, 640)?, arg(&args, 4, 360)?);
    let tolerance: f64 = arg(&args, 5, 1.0)?;
    let every: usize = arg::<usize>(&args, 6, 5)?.max(1);
    let sk = scene.skeleton();
    let mut depth = vec![0usize; sk.nodes().len()];
    for i in 1..sk.nodes().len() {
        let parent = sk.nodes()[i].parent as usize;
        if parent < i {
            depth[i] = depth[parent] + 1;
        }
    }
    let near = default_near(&sk.bounds());
    let options = TraversalOptions {
        occlusion: false,
        hlod: true,
        pixel_error: tolerance,
    };
    let mut traverser = Traverser::new();
    let (mut frames, mut leaf_nodes, mut inner_nodes) = (0u64, 0u64, 0u64);
    let (mut leaf, mut inner) = ([0u64; LEVELS], [0u64; LEVELS]);
    let mut by_depth = vec![0u64; depth.iter().max().map_or(1, |d| d + 1)];
    // Drawn level's pixel error / tolerance: <= 1/4, 1/2, 3/4, 1, above
    // (the finest is drawn when nothing is acceptable), exact (error 0).
    let mut slack = [0u64; 6];
    // The same, for items drawn at their node's coarsest level (the
    // parent's finest HLOD was not acceptable: the switch from a node to
    // its children is where error slack comes from).
    let mut slack_coarsest = [0u64; 6];
    // Items with a coarser level in their node: that level's pixel error /
    // tolerance (<= 1.5, 2, 4, 8, above), and the triangles it would have
    // drawn instead, by the same buckets (how much a level between the
    // two could save).
    let (mut next, mut next_tris) = ([0u64; 5], [0u64; 5]);
    let mut items = Vec::new();
    for pose in path.poses.iter().step_by(every) {
        frames += 1;
        let viewport = Viewport::new(w, h);
        let camera = Camera::of_pose(pose, viewport, near);
        let view = CullView::new(camera, viewport);
        items.clear();
        traverser.traverse(sk, &view, &NoOcclusion, &options, &mut |it| items.push(it));
        for it in &items {
            let n = &sk.nodes()[it.node as usize];
            let Some(l) = sk.lods().get(n.first_lod as usize + it.lod as usize) else {
                continue;
            };
            let t = l.triangles as u64;
            let (min, max) = view.rel_f64(&n.bounds);
            // The distance traversal chose the level by (off-axis bound).
            let distance = view.lod_distance(min, max);
            let pe = pixel_error(l.error, distance, view.pixels_per_radian);
            by_depth[depth[it.node as usize]] += t;
            let bucket = if l.error == 0.0 {
                5
            } else if pe > tolerance {
                4
            } else {
                ((pe / tolerance * 4.0).ceil() as usize).clamp(1, 4) - 1
            };
            slack[bucket] += t;
            if it.lod + 1 == n.lod_count {
                slack_coarsest[bucket] += t;
            } else if let Some(c) = sk.lods().get(n.first_lod as usize + it.lod as usize + 1) {
                let r = pixel_error(c.error, distance, view.pixels_per_radian) / tolerance;
                let b = [1.5, 2.0, 4.0, 8.0].iter().filter(|&&x| r > x).count();
                next[b] += t;
                next_tris[b] += c.triangles as u64;
            }
            let level = (it.lod as usize).min(LEVELS - 1);
            if n.is_leaf() {
                leaf_nodes += 1;
                leaf[level] += t;
            } else {
                inner_nodes += 1;
                inner[level] += t;
            }
        }
    }
    let per = |x: u64| x / frames.max(1);
    let row = |a: &[u64]| {
        a.iter()
            .map(|&x| per(x).to_string())
            .collect::<Vec<_>>()
            .join(" ")
    };
    println!(
        "{} poses (every {every}), {w}x{h}, pixel error {tolerance}, frustum culling only",
        frames
    );
    println!("triangles a frame:       {}", per(by_depth.iter().sum()));
    println!(
        "drawn leaves / inner:    {} / {} a frame",
        per(leaf_nodes),
        per(inner_nodes)
    );
    println!("leaf triangles by level:  {}", row(&leaf));
    println!("inner triangles by level: {}", row(&inner));
    println!("triangles by tree depth:  {}", row(&by_depth));
    println!(
        "by drawn error / tolerance (<=1/4 <=1/2 <=3/4 <=1 >1 exact): {}",
        row(&slack)
    );
    println!(
        "  of which at the node's coarsest level:                      {}",
        row(&slack_coarsest)
    );
    println!(
        "next coarser level's error / tolerance (<=1.5 <=2 <=4 <=8 >8): {}",
        row(&next)
    );
    println!(
        "  its triangles:                                               {}",
        row(&next_tris)
    );
    Ok(())
}
