//! Where a walk's triangles come from: the LOD selection (frustum and
//! HLODs, no occlusion: what hlod draws) along a camera path, broken down
//! by the distance of each drawn node and by the kind of level drawn:
//! a leaf's full detail, a coarser leaf level, a leaf's coarsest level
//! (its floor), or an inner node's HLOD by its height above the leaves.
//!
//! For every kind and band it prints the mean triangles a pose, the nodes
//! drawn, and how far each drawn level is from what the screen needs: its
//! triangles over (d / e)^2, d the node's box diagonal and e the error the
//! tolerance allows at the node's distance (a node covering k pixels
//! needs about k^2 pixel-sized triangles at most; a level whose count
//! tracks its projected size keeps this ratio bounded). For leaf floors
//! it also gives the switch gap: the parent's finest stored error over
//! the allowed error (a leaf drawn at its floor because its parent may
//! not be drawn yet), and why (the parent has no levels, or the parent's
//! finest is too coarse).
//!
//! `--worst N` also lists the N leaves that draw the most triangles from
//! the 16-unit band on: the level drawn, the allowed error, and the
//! leaf's and its parent's levels (triangles@error), which shows whether
//! a far leaf is held by its own chain or waits for its parent.
//!
//! cargo run --release -p gigawalk-replay --example far_field -- \
//!     SCENE.gwk PATH [--every K] [--width W] [--height H] [--pixel-error P] [--unit U] [--worst N] [--json OUT]
//!
//! Run it on two scenes walked by the same path (a floor and the same
//! floor with rows added behind it) to see where the extra triangles
//! come from (docs/results.md, "The far field on real CAD").

use std::collections::BTreeMap;
use std::path::PathBuf;

use gigawalk_cull::{
    default_near, traverse, Camera, CullView, DrawItem, NoOcclusion, TraversalOptions, Viewport,
};
use gigawalk_replay::percentile;
use gigawalk_scene::path::CameraPath;
use gigawalk_scene::{SceneReader, Skeleton, NO_NODE};

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

/// Upper edges of the distance bands, in multiples of `--unit` (by
/// default the scene's diagonal / 100, so the bands mean the same on any
/// model's scale; give the same unit to compare two scenes).
const BANDS: [f64; 8] = [1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, f64::INFINITY];

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Kind {
    LeafFull,
    LeafCoarser,
    LeafFloor,
    /// An inner node's HLOD, by the node's height (1: its children are
    /// leaves).
    Inner(u32),
}

impl Kind {
    fn label(self) -> String {
        match self {
            Kind::LeafFull => "leaf, full detail".into(),
            Kind::LeafCoarser => "leaf, coarser level".into(),
            Kind::LeafFloor => "leaf, its floor".into(),
            Kind::Inner(h) => format!("inner, height {h}"),
        }
    }
}

#[derive(Default, Clone)]
struct Cell {
    triangles: u64,
    items: u64,
    /// triangles / (diagonal / allowed error)^2 of each item.
    density: Vec<f64>,
}

/// Leaves drawn at full detail beyond the first bands: why no coarser
/// level was acceptable.
#[derive(Default)]
struct FullDetail {
    /// The next level's error over the allowed error.
    next_error: Vec<f64>,
    /// The next level's triangles over full detail's.
    next_share: Vec<f64>,
    /// Leaves with no coarser level.
    single: u64,
    triangles: u64,
}

#[derive(Default)]
struct FloorGap {
    /// Parent's finest error / allowed error, leaves at their floor whose
    /// parent has levels.
    gaps: Vec<f64>,
    parent_without_levels: u64,
    triangles_parent_without_levels: u64,
}

fn heights(s: &Skeleton) -> Vec<u32> {
    // Children have larger indices than their parent: one backward pass.
    let mut h = vec![0u32; s.nodes().len()];
    for i in (0..s.nodes().len()).rev() {
        let n = s.node(i as u32);
        if !n.is_leaf() {
            h[i] = n.children().map(|c| h[c as usize] + 1).max().unwrap_or(0);
        }
    }
    h
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let positional: Vec<&String> = args.iter().take_while(|a| !a.starts_with("--")).collect();
    let [scene, path] = positional.as_slice() else {
        return Err("usage: far_field SCENE.gwk PATH [--every K] [--width W] [--height H] [--pixel-error P] [--unit U] [--json OUT]".into());
    };
    let flag = |name: &str| args.iter().position(|a| a == name).map(|i| args.get(i + 1));
    let num = |name: &str, default: f64| -> Result<f64, String> {
        match flag(name) {
            None => Ok(default),
            Some(v) => v
                .and_then(|v| v.parse::<f64>().ok())
                .filter(|v| v.is_finite() && *v > 0.0)
                .ok_or(format!("{name} needs a positive number")),
        }
    };
    let every = num("--every", 10.0)? as usize;
    let (width, height) = (
        num("--width", 640.0)? as u32,
        num("--height", 360.0)? as u32,
    );
    let tolerance = num("--pixel-error", 1.0)?;
    let json_out = flag("--json").map(|v| v.cloned().ok_or("--json needs a file"));
    let worst_n = match flag("--worst") {
        None => 0,
        Some(v) => v
            .and_then(|v| v.parse::<usize>().ok())
            .ok_or("--worst needs a count")?,
    };
    // Per far leaf: triangles summed over poses, and the last level drawn
    // with the error it was allowed.
    let mut far: BTreeMap<u32, (u64, u32, f64)> = BTreeMap::new();
    let reader = SceneReader::open(&PathBuf::from(scene))?;
    let skeleton = reader.skeleton();
    let path = CameraPath::read(&PathBuf::from(path))?;
    let heights = heights(skeleton);
    let near = default_near(&skeleton.bounds());
    let unit = num("--unit", skeleton.bounds().diagonal() / 100.0)?;
    let vp = Viewport::new(width, height);
    let opts = TraversalOptions {
        occlusion: false,
        hlod: true,
        pixel_error: tolerance,
    };
    let mut cells: BTreeMap<(Kind, usize), Cell> = BTreeMap::new();
    let mut floor = FloorGap::default();
    let mut full = FullDetail::default();
    let mut poses = 0u64;
    for pose in path.poses.iter().step_by(every.max(1)) {
        poses += 1;
        let camera = Camera::of_pose(pose, vp, near);
        let view = CullView::new(camera, vp);
        let mut items = Vec::new();
        traverse(skeleton, &view, &NoOcclusion, &opts, &mut |i: DrawItem| {
            items.push(i)
        });
        for i in items {
            let n = skeleton.node(i.node);
            let lods = skeleton.node_lods(i.node);
            let level = &lods[i.lod as usize];
            let (min, max) = view.rel_f64(&n.bounds);
            let distance = view.lod_distance(min, max);
            let allowed = tolerance * distance / view.pixels_per_radian;
            let kind = if !n.is_leaf() {
                Kind::Inner(heights[i.node as usize])
            } else if i.lod == 0 {
                Kind::LeafFull
            } else if i.lod as usize + 1 == lods.len() {
                Kind::LeafFloor
            } else {
                Kind::LeafCoarser
            };
            let band = BANDS
                .iter()
                .position(|&b| distance < b * unit)
                .unwrap_or(BANDS.len() - 1);
            let cell = cells.entry((kind, band)).or_default();
            cell.triangles += level.triangles as u64;
            cell.items += 1;
            let diagonal = (max - min).length();
            if allowed > 0.0 {
                cell.density
                    .push(level.triangles as f64 / (diagonal / allowed).powi(2));
            }
            if n.is_leaf() && band >= 5 {
                let e = far.entry(i.node).or_default();
                *e = (e.0 + level.triangles as u64, i.lod, allowed);
            }
            if kind == Kind::LeafFull && band >= 3 {
                full.triangles += level.triangles as u64;
                match lods.get(1) {
                    Some(next) if allowed > 0.0 => {
                        full.next_error.push(next.error as f64 / allowed);
                        full.next_share
                            .push(next.triangles as f64 / level.triangles.max(1) as f64);
                    }
                    Some(_) => {}
                    None => full.single += 1,
                }
            }
            if kind == Kind::LeafFloor && n.parent != NO_NODE {
                let parent = skeleton.node_lods(n.parent);
                match parent.first() {
                    Some(p) if allowed > 0.0 => floor.gaps.push(p.error as f64 / allowed),
                    Some(_) => {}
                    None => {
                        floor.parent_without_levels += 1;
                        floor.triangles_parent_without_levels += level.triangles as u64;
                    }
                }
            }
        }
    }
    let poses_f = poses.max(1) as f64;
    let total: u64 = cells.values().map(|c| c.triangles).sum();
    println!(
        "{scene}: {poses} poses (every {every}th of {}), {width}x{height}, {tolerance} px, \
         frustum and HLODs (no occlusion); {:.0} triangles a pose; bands in units of \
         {unit:.3} model units",
        path.poses.len(),
        total as f64 / poses_f
    );
    println!(
        "{:<22} {:>10} {:>12} {:>7} {:>9} {:>10} {:>10}",
        "kind", "band", "tris/pose", "share", "nodes", "dens p50", "dens p90"
    );
    let mut rows = Vec::new();
    for ((kind, band), cell) in &cells {
        let lo = if *band == 0 { 0.0 } else { BANDS[band - 1] };
        let band_label = if BANDS[*band].is_finite() {
            format!("{lo:.0}-{:.0}", BANDS[*band])
        } else {
            format!("{lo:.0}+")
        };
        let (p50, p90) = (
            percentile(&cell.density, 50.0),
            percentile(&cell.density, 90.0),
        );
        println!(
            "{:<22} {:>10} {:>12.0} {:>6.1}% {:>9.1} {:>10.3} {:>10.3}",
            kind.label(),
            band_label,
            cell.triangles as f64 / poses_f,
            100.0 * cell.triangles as f64 / total.max(1) as f64,
            cell.items as f64 / poses_f,
            p50,
            p90
        );
        rows.push(serde_json::json!({
            "kind": kind.label(), "band": band_label,
            "band_from": lo * unit, "band_to": BANDS[*band] * unit,
            "triangles_per_pose": cell.triangles as f64 / poses_f,
            "nodes_per_pose": cell.items as f64 / poses_f,
            "density_p50": p50, "density_p90": p90,
        }));
    }
    let mut by_kind: BTreeMap<Kind, u64> = BTreeMap::new();
    for ((kind, _), cell) in &cells {
        *by_kind.entry(*kind).or_default() += cell.triangles;
    }
    for (kind, t) in &by_kind {
        println!(
            "  {:<22} {:>10.0} a pose ({:.1}%)",
            kind.label(),
            *t as f64 / poses_f,
            100.0 * *t as f64 / total.max(1) as f64
        );
    }
    let n_gaps = floor.gaps.len();
    let gaps = [50.0, 90.0, 99.0].map(|p| percentile(&floor.gaps, p));
    println!(
        "leaf floors drawn: {:.1} a pose whose parent has levels (parent's finest error over \
         the allowed: p50 {:.2}, p90 {:.2}, p99 {:.2}); {:.1} a pose ({:.0} triangles) whose \
         parent stores no level",
        n_gaps as f64 / poses_f,
        gaps[0],
        gaps[1],
        gaps[2],
        floor.parent_without_levels as f64 / poses_f,
        floor.triangles_parent_without_levels as f64 / poses_f
    );
    let n_full = full.next_error.len();
    let next_error = [50.0, 90.0].map(|p| percentile(&full.next_error, p));
    let next_share = [50.0, 90.0].map(|p| percentile(&full.next_share, p));
    println!(
        "leaves at full detail from band {:.0} on: {:.0} triangles a pose; {:.1} a pose \
         with a coarser level (its error over the allowed: p50 {:.2}, p90 {:.2}; its \
         triangles over full detail's: p50 {:.2}, p90 {:.2}), {:.1} a pose without one",
        BANDS[2],
        full.triangles as f64 / poses_f,
        n_full as f64 / poses_f,
        next_error[0],
        next_error[1],
        next_share[0],
        next_share[1],
        full.single as f64 / poses_f
    );
    let mut worst: Vec<(&u32, &(u64, u32, f64))> = far.iter().collect();
    worst.sort_by_key(|(node, (t, _, _))| (std::cmp::Reverse(*t), **node));
    let levels = |lods: &[gigawalk_scene::LodInfo]| {
        lods.iter()
            .map(|l| format!("{}@{:.4}", l.triangles, l.error))
            .collect::<Vec<_>>()
            .join(" ")
    };
    for (node, (t, lod, allowed)) in worst.into_iter().take(worst_n) {
        let n = skeleton.node(*node);
        let parent = if n.parent != NO_NODE {
            levels(skeleton.node_lods(n.parent))
        } else {
            "none".into()
        };
        println!(
            "far leaf {node}: {:.0} triangles a pose, level {lod} at allowed {allowed:.4}; \
             levels {}; parent {parent}",
            *t as f64 / poses_f,
            levels(skeleton.node_lods(*node))
        );
    }
    if let Some(out) = json_out {
        let doc = serde_json::json!({
            "scene": scene, "poses": poses, "width": width, "height": height,
            "pixel_error": tolerance, "triangles_per_pose": total as f64 / poses_f,
            "rows": rows,
            "leaf_floor_gap": {"p50": gaps[0], "p90": gaps[1], "p99": gaps[2]},
        });
        std::fs::write(out?, serde_json::to_string_pretty(&doc)?)?;
    }
    Ok(())
}
