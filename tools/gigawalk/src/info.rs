//! `gigawalk info`: what a scene file holds; with `--adapters`, the GPU
//! adapters this machine has and whether gigawalk can use them.

use std::path::PathBuf;

use anyhow::Context;
use gigawalk_scene::{SceneReader, SceneStats};

#[derive(clap::Args)]
pub struct Args {
    /// The scene file (.gwk) to describe
    #[arg(required_unless_present = "adapters")]
    scene: Option<PathBuf>,
    /// List every GPU adapter on every backend instead: type, backend,
    /// driver, whether gigawalk can use it and why not, and which one a run
    /// would use (with --adapter NAME: which one that picks)
    #[arg(long, conflicts_with_all = ["verify", "scene"])]
    adapters: bool,
    /// With --adapters: the name a run's --adapter would be given
    #[arg(long, value_name = "NAME", requires = "adapters")]
    adapter: Option<String>,
    /// Print machine-readable JSON instead of text
    #[arg(long)]
    json: bool,
    /// Also read every byte of geometry and check all checksums and bounds
    /// (opening alone reads only the skeleton)
    #[arg(long)]
    verify: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let scene = match (&args.scene, args.adapters) {
        (_, true) => return crate::adapters::print(args.json, args.adapter.as_deref()),
        (Some(scene), false) => scene,
        (None, false) => anyhow::bail!("gigawalk info needs a scene file or --adapters"),
    };
    let r = SceneReader::open(scene)?;
    if args.verify {
        r.verify()?;
    }
    let s = SceneStats::of(&r);
    let device = DeviceFigures::of(r.skeleton());
    if args.json {
        let mut v = serde_json::to_value(&s).context("serialising stats")?;
        if let Some(map) = v.as_object_mut() {
            map.insert(
                "device".into(),
                serde_json::json!({
                    "bytes": device.bytes,
                    "triangles": device.triangles,
                    "lods": device.lods,
                    "compact_lods": device.compact_lods,
                    "unstated_lods": device.unstated_lods,
                }),
            );
        }
        out!(
            "{}",
            serde_json::to_string_pretty(&v).context("serialising stats")?
        )?;
        return Ok(());
    }
    out!("scene       {}", scene.display())?;
    out!(
        "format      v{}{}",
        s.format_version,
        if args.verify {
            " (verified: every checksum and LOD read)"
        } else {
            ""
        }
    )?;
    out!(
        "size        {} ({:.1} bytes per triangle)",
        human_bytes(s.file_bytes),
        s.bytes_per_triangle
    )?;
    print_positions(&s)?;
    out!(
        "device      {} resident ({:.2} bytes a stored triangle): {} LODs in 12-byte compact \
         vertices, {} in 20-byte wide ones{}",
        human_bytes(device.bytes),
        device.bytes as f64 / device.triangles.max(1) as f64,
        device.compact_lods,
        device.lods - device.compact_lods,
        if device.unstated_lods > 0 {
            format!(
                " (the {} encoded LODs of this format 2.0 file do not state their bits and \
                 are counted wide; preprocess again for exact figures)",
                device.unstated_lods
            )
        } else {
            String::new()
        }
    )?;
    out!("triangles   {}", s.triangles)?;
    let identity = s
        .sections
        .iter()
        .find(|(n, _)| n == "OBJT")
        .map_or(0, |(_, b)| *b);
    match r.objects()? {
        Some(t) => out!(
            "objects     {} named ({} of identity, {:.2}% of the file: names, files, paths, \
             metadata, boxes, and each leaf's runs of triangles per object)",
            t.objects().len(),
            human_bytes(identity),
            100.0 * identity as f64 / s.file_bytes.max(1) as f64
        )?,
        None => out!(
            "objects     none recorded (written before scenes kept object identity: pick, \
             find and hiding need it; preprocess the model again)"
        )?,
    }
    out!(
        "nodes       {} ({} leaves, depth {}, up to {} LODs per node)",
        s.nodes,
        s.leaves,
        s.depth,
        s.max_lods_per_node
    )?;
    out!("bounds      {:?} .. {:?}", s.bounds_min, s.bounds_max)?;
    out!("origin      {:?}", s.origin)?;
    out!("leaf triangles per LOD level (level 0 = original):")?;
    for (k, t) in s.leaf_triangles_per_level.iter().enumerate() {
        out!("  level {k:<3} {t:>14}")?;
    }
    out!("HLOD triangles per tree depth (finest LOD of every node at that depth):")?;
    for (d, t) in s.hlod_triangles_per_depth.iter().enumerate() {
        out!("  depth {d:<3} {t:>14}")?;
    }
    out!("HLOD levels per tree depth (inner nodes; finest HLOD's median triangles and error / box diagonal;")?;
    out!("  switch: triangles the children draw at that error / the finest HLOD's, median and largest):")?;
    out!(
        "  depth  inner  leaves  levels min/median/max  finest tris  finest error  switch med/max"
    )?;
    for l in &s.hlod_levels_per_depth {
        out!(
            "  {:<5} {:>6} {:>7}  {:>6}/{}/{:<12} {:>11}  {:>11.2}%  {:>6.2}/{:.2}",
            l.depth,
            l.inner_nodes,
            l.leaves,
            l.levels_min,
            l.levels_median,
            l.levels_max,
            l.finest_triangles_median,
            100.0 * l.finest_error_median,
            l.switch_factor_median,
            l.switch_factor_max
        )?;
    }
    print_lod_health(&s)?;
    out!("whole-scene triangles at one error (each node its coarsest level within it):")?;
    for (e, t) in &s.triangles_at_error {
        out!("  error {e:<12.4e} {t:>14}")?;
    }
    out!("sections:")?;
    for (name, len) in &s.sections {
        out!("  {name:<6} {:>12}", human_bytes(*len))?;
    }
    out!("provenance:")?;
    out!("  source    {}", s.provenance.source)?;
    out!("  tool      {}", s.provenance.tool)?;
    for (k, v) in &s.provenance.parameters {
        out!("  {k:<24} {v}")?;
    }
    Ok(())
}

/// What the scene takes on a device when every LOD is resident (what
/// `--memory-budget all` loads), from the LOD records.
struct DeviceFigures {
    bytes: u64,
    /// Triangles over every LOD.
    triangles: u64,
    lods: usize,
    /// LODs drawn from their grid coordinates (12-byte vertices).
    compact_lods: usize,
    /// Encoded LODs whose records do not state their bits (format 2.0).
    unstated_lods: usize,
}

impl DeviceFigures {
    fn of(s: &gigawalk_scene::Skeleton) -> DeviceFigures {
        let lods = s.lods();
        DeviceFigures {
            bytes: gigawalk_runtime::scene_device_bytes(s),
            triangles: lods.iter().map(|l| l.triangles as u64).sum(),
            lods: lods.len(),
            compact_lods: lods
                .iter()
                .filter(|l| {
                    gigawalk_gpu::VertexLayout::of(l) == gigawalk_gpu::VertexLayout::Compact
                })
                .count(),
            unstated_lods: lods
                .iter()
                .filter(|l| l.encoded && l.grid.is_none())
                .count(),
        }
    }
}

/// How positions are stored, and what the grid's step means on screen:
/// in pixels at the near plane of a 1920x1080 view with a 60-degree field
/// of view (the finest detail a camera can ever see of it).
fn print_positions(s: &SceneStats) -> anyhow::Result<()> {
    let p = &s.positions;
    match p.bits {
        Some(bits) if p.encoded_lods > 0 => {
            let b = gigawalk_scene::Aabb::new(s.bounds_min.into(), s.bounds_max.into());
            let near = gigawalk_runtime::default_near(&b);
            let pixels_per_radian = 1080.0 / (2.0 * 30f64.to_radians().tan());
            out!(
                "positions   {bits}-bit grid over each LOD's box, meshopt-encoded ({} of {} LODs; \
                 {} of them zstd-compressed); step <= {:.3e} (median {:.3e}) model units: {:.1} px \
                 at the near plane ({near:.3e}), under 1 px from {:.3e} away (1080p, 60 deg)",
                p.encoded_lods,
                p.encoded_lods + p.raw_lods,
                p.compressed_lods,
                p.step_max,
                p.step_median,
                p.step_max / near * pixels_per_radian,
                p.step_max * pixels_per_radian
            )
        }
        _ if p.encoded_lods > 0 => out!(
            "positions   quantized and meshopt-encoded ({} of {} LODs)",
            p.encoded_lods,
            p.encoded_lods + p.raw_lods
        ),
        _ => out!("positions   raw f32 ({} LODs)", p.raw_lods),
    }
}

/// The leaf floor and the switch factors over every inner node: whether
/// the hierarchy can draw a far view cheaply, and how much a switch costs.
fn print_lod_health(s: &SceneStats) -> anyhow::Result<()> {
    let f = &s.switch_factors;
    out!("LOD health (switch: triangles the children draw at an inner node's finest HLOD error / the HLOD's):")?;
    out!(
        "  leaf floor     {} triangles (every leaf at its coarsest LOD)",
        s.leaf_floor_triangles
    )?;
    let Some(w) = &f.worst else {
        out!("  switch         no inner node has LODs")?;
        return Ok(());
    };
    out!(
        "  switch         median {:.2}  p90 {:.2}  p99 {:.2}  max {:.2}  ({} inner nodes with LODs)",
        f.median,
        f.p90,
        f.p99,
        f.max,
        f.count
    )?;
    out!(
        "  switch above   2: {}  4: {}  8: {}",
        f.over_2,
        f.over_4,
        f.over_8
    )?;
    out!(
        "  worst switch   node {} (depth {}): {} triangles at error {:.4e} (box diagonal {:.4e}); children {} ({:.2}x)",
        w.node,
        w.depth,
        w.triangles,
        w.error,
        w.diagonal,
        w.children_triangles,
        w.factor
    )?;
    Ok(())
}

fn human_bytes(b: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = b as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{b} B")
    } else {
        format!("{v:.2} {} ({b} B)", UNITS[u])
    }
}
