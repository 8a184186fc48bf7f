//! `gigawalk info`: what a scene file holds.

use std::path::PathBuf;

use anyhow::Context;
use gigawalk_scene::{SceneReader, SceneStats};

#[derive(clap::Args)]
pub struct Args {
    /// The scene file (.gwk) to describe
    scene: PathBuf,
    /// Print machine-readable JSON instead of text
    #[arg(long)]
    json: bool,
    /// Also read every byte of geometry and check all checksums and bounds
    /// (opening alone reads only the skeleton)
    #[arg(long)]
    verify: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let r = SceneReader::open(&args.scene)?;
    if args.verify {
        r.verify()?;
    }
    let s = SceneStats::of(&r);
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&s).context("serialising stats")?
        );
        return Ok(());
    }
    println!("scene       {}", args.scene.display());
    println!(
        "format      v{}{}",
        s.format_version,
        if args.verify {
            " (verified: every checksum and LOD read)"
        } else {
            ""
        }
    );
    println!(
        "size        {} ({:.1} bytes per triangle)",
        human_bytes(s.file_bytes),
        s.bytes_per_triangle
    );
    println!("triangles   {}", s.triangles);
    println!(
        "nodes       {} ({} leaves, depth {}, up to {} LODs per node)",
        s.nodes, s.leaves, s.depth, s.max_lods_per_node
    );
    println!("bounds      {:?} .. {:?}", s.bounds_min, s.bounds_max);
    println!("origin      {:?}", s.origin);
    println!("leaf triangles per LOD level (level 0 = original):");
    for (k, t) in s.leaf_triangles_per_level.iter().enumerate() {
        println!("  level {k:<3} {t:>14}");
    }
    println!("HLOD triangles per tree depth (finest LOD of every node at that depth):");
    for (d, t) in s.hlod_triangles_per_depth.iter().enumerate() {
        println!("  depth {d:<3} {t:>14}");
    }
    println!("sections:");
    for (name, len) in &s.sections {
        println!("  {name:<6} {:>12}", human_bytes(*len));
    }
    println!("provenance:");
    println!("  source    {}", s.provenance.source);
    println!("  tool      {}", s.provenance.tool);
    for (k, v) in &s.provenance.parameters {
        println!("  {k:<24} {v}");
    }
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
