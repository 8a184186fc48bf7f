//! `gigawalk pick` and `gigawalk find`: what is this, and where is it.

use std::path::PathBuf;

use anyhow::Context;
use gigawalk_review::objects::object_json;
use gigawalk_review::select::{self, PickRequest, Picked};

#[derive(clap::Args)]
pub struct PickArgs {
    /// The scene file (.gwk)
    scene: PathBuf,
    /// Camera path file (docs/path-format.md) holding the pose to look from
    #[arg(long)]
    path: PathBuf,
    /// The pose of the path, counting from 0
    #[arg(long, value_name = "N")]
    frame: usize,
    /// The pixel, X,Y from the top-left pixel (0,0), sampled at its centre;
    /// twice to measure the distance between the two points hit
    #[arg(long, value_name = "X,Y", value_parser = parse_pixel, required = true, num_args = 1)]
    pixel: Vec<(u32, u32)>,
    /// Viewport width, as the replay or screenshot the pixel comes from
    #[arg(long, default_value_t = 640)]
    width: u32,
    /// Viewport height
    #[arg(long, default_value_t = 360)]
    height: u32,
    /// Near plane distance, model units [default: the scene diagonal's
    /// fraction replay and the viewer use]
    #[arg(long)]
    near: Option<f64>,
    #[command(flatten)]
    section: crate::section::SectionArgs,
    /// The model's length unit, for distances also given in metres: m,
    /// mm, cm, km, um, in, ft or yd (glTF is in metres)
    #[arg(long, default_value = "m")]
    units: gigawalk_scene::units::Units,
    /// Print one JSON object: `object` (null when nothing is there), `point`
    /// (world, f64), `distance` (from the eye), and the leaf, LOD and
    /// triangle hit; with two pixels, `picks` (both) and `distance`
    /// between their points, `distance_m` in metres and `units`
    #[arg(long)]
    json: bool,
}

fn parse_pixel(s: &str) -> Result<(u32, u32), String> {
    let (x, y) = s
        .split_once(',')
        .ok_or_else(|| format!("{s:?}: a pixel is X,Y (for example 320,180)"))?;
    let n = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|_| format!("{s:?}: {v:?} is not a pixel coordinate (0 or more)"))
    };
    Ok((n(x)?, n(y)?))
}

pub fn pick(a: PickArgs) -> anyhow::Result<()> {
    if a.near.is_some_and(|n| !(n.is_finite() && n > 0.0)) {
        anyhow::bail!("--near must be a positive distance");
    }
    if a.pixel.len() > 2 {
        anyhow::bail!(
            "--pixel given {} times: one picks, two measure the distance between their points",
            a.pixel.len()
        );
    }
    let bounds = gigawalk_scene::SceneReader::open(&a.scene)
        .context("cannot open the scene")?
        .skeleton()
        .bounds();
    let section = a.section.section(None, &bounds)?;
    let picks = select::pick(&PickRequest {
        scene: a.scene.clone(),
        path: a.path.clone(),
        frame: a.frame,
        pixels: a.pixel.clone(),
        section,
        width: a.width,
        height: a.height,
        near: a.near,
    })?;
    let pick_json = |pixel: (u32, u32), p: &Picked| {
        serde_json::json!({
            "pixel": [pixel.0, pixel.1],
            "object": p.object.as_ref().map(|(id, o)| object_json(*id, o)),
            "point": p.point.map(|q| q.to_array()),
            "distance": p.distance,
            "node": p.node,
            "lod": p.lod,
            "triangle": p.triangle,
            "leaves_read": p.stats.leaves_read,
            "ms": p.ms,
        })
    };
    if let ([pa, pb], [first, second]) = (a.pixel.as_slice(), picks.as_slice()) {
        let (pa, pb) = (*pa, *pb);
        let d = match (first.point, second.point) {
            (Some(p), Some(q)) => Some(q - p),
            _ => None,
        };
        let length = d.map(|d| d.length());
        if a.json {
            let v = serde_json::json!({
                "picks": [pick_json(pa, first), pick_json(pb, second)],
                "distance": length,
                "distance_m": length.map(|l| l * a.units.metres),
                "units": a.units.name,
                "delta": d.map(|d| d.to_array()),
            });
            out!(
                "{}",
                serde_json::to_string_pretty(&v).context("serialising the picks")?
            )?;
            return Ok(());
        }
        for (pixel, p) in [(pa, first), (pb, second)] {
            out!("pixel {},{}", pixel.0, pixel.1)?;
            print_pick(pixel, p)?;
        }
        match (length, d) {
            (Some(l), Some(d)) => {
                out!("measured  {}", a.units.format(l))?;
                out!("delta     {:.9} {:.9} {:.9}", d.x, d.y, d.z)?;
            }
            _ => out!("measured  nothing: a pixel shows no surface")?,
        }
        return Ok(());
    }

    let p = &picks[0];
    if a.json {
        out!(
            "{}",
            serde_json::to_string_pretty(&pick_json(a.pixel[0], p))
                .context("serialising the pick")?
        )?;
        return Ok(());
    }
    print_pick(a.pixel[0], p)
}

fn print_pick(pixel: (u32, u32), p: &Picked) -> anyhow::Result<()> {
    match (&p.object, p.point) {
        (Some((id, o)), Some(q)) => {
            out!("object    {} (#{id})", o.name)?;
            out!("file      {}", o.file)?;
            out!("path      {}", o.path)?;
            out!("metadata  {}", o.metadata.as_deref().unwrap_or("(none)"))?;
            out!("point     {:.9} {:.9} {:.9}", q.x, q.y, q.z)?;
            out!("distance  {:.9}", p.distance.unwrap_or(0.0))?;
        }
        (None, Some(q)) => {
            out!("object    (a surface of no recorded object)")?;
            out!("point     {:.9} {:.9} {:.9}", q.x, q.y, q.z)?;
        }
        _ => out!("nothing under pixel {},{}", pixel.0, pixel.1)?,
    }
    Ok(())
}

#[derive(clap::Args)]
pub struct FindArgs {
    /// The scene file (.gwk)
    scene: PathBuf,
    /// What to look for, case-insensitive: text that appears in an object's
    /// name or its path in its file (with a / in it, also in `file/path`,
    /// so `unit2.glb/` finds a file's objects); with * (any run) or ? (any
    /// one character) the whole name or path must match
    pattern: String,
    /// Print a JSON array of objects (id, name, file, path, metadata,
    /// triangles, bounds)
    #[arg(long)]
    json: bool,
}

pub fn find(a: FindArgs) -> anyhow::Result<()> {
    let found = select::find(&a.scene, &a.pattern)?;
    if a.json {
        let v: Vec<serde_json::Value> = found.iter().map(|(id, o)| object_json(*id, o)).collect();
        out!(
            "{}",
            serde_json::to_string_pretty(&v).context("serialising objects")?
        )?;
    } else {
        for (id, o) in &found {
            let (lo, hi) = (o.bounds.min, o.bounds.max);
            out!(
                "#{id:<7} {}  [{:.6} {:.6} {:.6} .. {:.6} {:.6} {:.6}]  {} triangles",
                o.full_path(),
                lo.x,
                lo.y,
                lo.z,
                hi.x,
                hi.y,
                hi.z,
                o.triangles
            )?;
        }
    }
    if found.is_empty() {
        anyhow::bail!(
            "no object matches {:?} in {} (patterns are case-insensitive text or globs with * and ?)",
            a.pattern,
            a.scene.display()
        );
    }
    if !a.json {
        eprintln!("{} object(s) match", found.len());
    }
    Ok(())
}
