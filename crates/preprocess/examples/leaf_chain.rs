//! A leaf's LOD chain made again from a scene's stored full detail, to
//! study how a chain steps: for each node given, the stored chain and the
//! chain `leaf_lods` makes now (triangles@error per level, and seconds).
//!
//! `cargo run --release -p gigawalk-preprocess --example leaf_chain -- SCENE NODE... [--obj DIR] [--best]`
//!
//! `--best` makes the chains as `--leaf-chains best` does (both kinds,
//! the one that draws less kept); without it, the default's.
//! `--obj DIR` also writes each node's full detail to `DIR/leaf-NODE.obj`
//! (positions in the scene's model units), for a test or another tool.

use gigawalk_preprocess::hlod::{leaf_lods, ChainParams, Tally, WorkMesh};
use gigawalk_preprocess::{LeafChains, Params};
use gigawalk_scene::{Colours, SceneReader};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let obj_dir = match args.iter().position(|a| a == "--obj") {
        Some(i) => {
            let dir = args.get(i + 1).ok_or("--obj needs a folder")?.clone();
            args.drain(i..i + 2);
            Some(std::path::PathBuf::from(dir))
        }
        None => None,
    };
    let best = match args.iter().position(|a| a == "--best") {
        Some(i) => {
            args.remove(i);
            true
        }
        None => false,
    };
    let [scene, nodes @ ..] = args.as_slice() else {
        return Err("usage: leaf_chain SCENE NODE... [--obj DIR] [--best]".into());
    };
    let reader = SceneReader::open(std::path::Path::new(scene))?;
    let sk = reader.skeleton();
    let chain = ChainParams::of(&Params {
        leaf_chains: if best {
            LeafChains::Best
        } else {
            LeafChains::Kept
        },
        ..Params::default()
    });
    let show = |l: &mut dyn Iterator<Item = (usize, f32)>| {
        l.map(|(t, e)| format!("{t}@{e:.4}"))
            .collect::<Vec<_>>()
            .join(" ")
    };
    for n in nodes {
        let ni: usize = n.parse()?;
        let node = sk.nodes().get(ni).ok_or("no such node")?;
        if !node.is_leaf() {
            return Err(format!("node {ni} is not a leaf").into());
        }
        let lods = &sk.lods()[node.lods()];
        let stored = show(&mut lods.iter().map(|l| (l.triangles as usize, l.error)));
        let full = reader.read_lod(node.first_lod)?;
        let colours = match &full.colours {
            Colours::Uniform(c) => vec![*c; full.positions.len()],
            Colours::PerVertex(v) => v.clone(),
        };
        let mesh = WorkMesh {
            origin: full.origin,
            positions: full.positions.clone(),
            normals: full.normals.clone(),
            colours,
            indices: full.indices.clone(),
        };
        if let Some(dir) = &obj_dir {
            let mut text = String::new();
            for p in &mesh.positions {
                let q = mesh.origin + glam::Vec3::from_array(*p).as_dvec3();
                text += &format!("v {} {} {}\n", q.x, q.y, q.z);
            }
            for t in mesh.indices.chunks_exact(3) {
                text += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
            }
            std::fs::write(dir.join(format!("leaf-{ni}.obj")), text)?;
        }
        let diagonal = node.bounds.diagonal();
        let tally = Tally::default();
        let t = std::time::Instant::now();
        let made = leaf_lods(mesh, diagonal, &chain, &tally);
        let secs = t.elapsed().as_secs_f64();
        let now = show(&mut made.iter().map(|l| (l.mesh.triangles(), l.error)));
        let c = tally.snapshot();
        println!(
            "node {ni} diag {diagonal:.3}\n  stored {stored}\n  now    {now}  ({secs:.2} s; \
             rivals {}/{} won, gentler {}/{} kept{})",
            c.rivals_won,
            c.rivals,
            c.gentler_won,
            c.gentler,
            match (best, c.leaf_cover_chosen) {
                (false, _) => "",
                (true, 0) => "; the kept-pieces chain",
                (true, _) => "; the covering chain",
            }
        );
    }
    Ok(())
}
