//! What hiding costs: och at one pixel of error along a camera path, with
//! every object shown, with one object hidden (the one seen most at the
//! walk's middle pose), with 1% of the objects isolated (every 100th of
//! the object table), and a scene preprocessed from those objects alone.
//! Prints a table of mean triangles drawn and median frame times, and the
//! ratios the targets speak of (docs/results.md, "Object identity").
//!
//! cargo run --release -p gigawalk-replay --example hide_cost -- \
//!     MODEL.glb SCENE.gwk PATH [--frames N] [--width W] [--height H] [--every K]
//!
//! SCENE must be MODEL preprocessed with default parameters; the subset
//! scene is preprocessed with them too, into a temporary directory.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

use gigawalk_cull::{default_near, pick, Camera, Viewport, Visibility};
use gigawalk_replay::{replay, Mode, NoProgress, ReplayOptions};
use gigawalk_runtime::RuntimeOptions;
use gigawalk_scene::path::CameraPath;
use gigawalk_scene::SceneReader;

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

struct Figures {
    triangles: f64,
    frame_ms: f64,
}

fn measure(
    scene: &SceneReader,
    path: &CameraPath,
    opts: &ReplayOptions,
) -> Result<Figures, Box<dyn std::error::Error>> {
    let r = replay(scene, "scene", &path.poses, "path", opts, &mut NoProgress)?;
    let s = r.summary();
    let m = s.modes.first().ok_or("no run")?;
    Ok(Figures {
        triangles: m.mean_triangles,
        frame_ms: m.median_frame_ms,
    })
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let positional: Vec<&String> = args.iter().take_while(|a| !a.starts_with("--")).collect();
    let [model, scene, path] = positional.as_slice() else {
        return Err("usage: hide_cost MODEL.glb SCENE.gwk PATH [--frames N] [--width W] [--height H] [--every K]".into());
    };
    let flag = |name: &str, default: u32| -> Result<u32, String> {
        match args.iter().position(|a| a == name) {
            Some(i) => args
                .get(i + 1)
                .and_then(|v| v.parse().ok())
                .ok_or(format!("{name} needs a number")),
            None => Ok(default),
        }
    };
    let (frames, width, height, every) = (
        flag("--frames", 60)?,
        flag("--width", 640)?,
        flag("--height", 360)?,
        flag("--every", 100)?.max(1),
    );
    let reader = SceneReader::open(&PathBuf::from(scene))?;
    let table = reader.objects()?.ok_or("the scene has no object table")?;
    let path = CameraPath::read(&PathBuf::from(path))?;
    let opts = ReplayOptions {
        modes: vec![Mode::Och],
        pixel_errors: vec![1.0],
        runtime: RuntimeOptions {
            width,
            height,
            ..Default::default()
        },
        frames: Some(frames as usize),
        accuracy_every: 0,
        ..Default::default()
    };
    let skeleton = reader.skeleton();
    let n = table.objects().len() as u32;

    // The object seen most at the middle pose.
    let vp = Viewport::new(width, height);
    let near = default_near(&skeleton.bounds());
    let middle = &path.poses[(frames as usize).min(path.poses.len()) / 2];
    let camera = Camera::of_pose(middle, vp, near);
    let mut seen: HashMap<u32, u32> = HashMap::new();
    for y in (0..height).step_by(16) {
        for x in (0..width).step_by(16) {
            let Some(ray) = camera.pixel_ray(vp, x as f64 + 0.5, y as f64 + 0.5) else {
                continue;
            };
            let (hit, _) = pick(
                skeleton,
                Some(&table),
                &ray,
                &|_| false,
                &|_| false,
                &mut |l| reader.read_lod(l),
            )?;
            if let Some(o) = hit.and_then(|h| h.object) {
                *seen.entry(o).or_default() += 1;
            }
        }
    }
    let one = seen
        .iter()
        .max_by_key(|(o, c)| (**c, std::cmp::Reverse(**o)))
        .map(|(o, _)| *o)
        .ok_or("the middle pose sees nothing")?;
    let isolated: Vec<u32> = (0..n).step_by(every as usize).collect();
    let with = |hidden: &dyn Fn(u32) -> bool| ReplayOptions {
        visibility: Some(Arc::new(Visibility::new(skeleton, &table, hidden, &|_| {
            false
        }))),
        ..opts.clone()
    };
    let all = measure(&reader, &path, &opts)?;
    let hide_one = measure(&reader, &path, &with(&|o| o == one))?;
    let keep: Vec<bool> = (0..n).map(|o| o % every == 0).collect();
    let isolate = measure(&reader, &path, &with(&|o| !keep[o as usize]))?;

    let subset = measure(
        &SceneReader::open(&subset_scene(model, &keep, n, "scattered")?)?,
        &path,
        &opts,
    )?;
    // A region instead: the 1% of objects whose box centres are nearest
    // the middle pose's eye (a unit of the plant, as a reviewer isolates).
    let mut by_distance: Vec<u32> = (0..n).collect();
    let eye = middle.position;
    let dist = |o: u32| {
        table
            .object(o)
            .map_or(f64::INFINITY, |r| r.bounds.center().distance(eye))
    };
    by_distance.sort_by(|&a, &b| dist(a).total_cmp(&dist(b)));
    let mut near_keep = vec![false; n as usize];
    for &o in by_distance.iter().take(isolated.len()) {
        near_keep[o as usize] = true;
    }
    let isolate_near = measure(&reader, &path, &with(&|o| !near_keep[o as usize]))?;
    let subset_near = measure(
        &SceneReader::open(&subset_scene(model, &near_keep, n, "region")?)?,
        &path,
        &opts,
    )?;

    println!(
        "och at 1 px, {frames} frames at {width}x{height}, {} objects; hidden one: #{one} {}",
        n,
        table.object(one).map(|o| o.full_path()).unwrap_or_default()
    );
    println!("| run | mean triangles | median frame ms |");
    println!("|---|---:|---:|");
    for (name, f) in [
        ("every object", &all),
        ("one object hidden", &hide_one),
        (
            &*format!("{} objects isolated (1 in {every})", isolated.len()),
            &isolate,
        ),
        ("a scene of only those objects", &subset),
        (
            &*format!(
                "the {} objects nearest the middle pose isolated",
                isolated.len()
            ),
            &isolate_near,
        ),
        ("a scene of only those objects", &subset_near),
    ] {
        println!("| {name} | {:.0} | {:.2} |", f.triangles, f.frame_ms);
    }
    println!(
        "hiding one: {:.3}x the triangles of showing everything (target <= 1.10x)",
        hide_one.triangles / all.triangles
    );
    println!(
        "isolating 1 in {every}: {:.3}x the triangles of a scene of only those objects (target <= 1.5x)",
        isolate.triangles / subset.triangles
    );
    println!(
        "isolating a region: {:.3}x the triangles of a scene of only those objects (target <= 1.5x)",
        isolate_near.triangles / subset_near.triangles
    );
    std::fs::remove_dir_all(
        std::env::temp_dir().join(format!("gigawalk-hide-cost-{}", std::process::id())),
    )
    .ok();
    Ok(())
}

/// The objects `keep` names (of `n` in the table) preprocessed alone,
/// with default parameters, into a temporary file: the import's objects
/// grouped as the object table groups them (consecutive primitives of a
/// node are one object).
fn subset_scene(
    model: &str,
    keep: &[bool],
    n: u32,
    name: &str,
) -> Result<PathBuf, Box<dyn std::error::Error>> {
    let mut m = gigawalk_import::import(&PathBuf::from(model))?;
    let mut entry = 0u32;
    let mut last: Option<gigawalk_import::Identity> = None;
    let mut kept = Vec::new();
    for o in m.objects.drain(..) {
        let joins = !o.identity.path.is_empty()
            && last.as_ref().is_some_and(|l| l.same_object(&o.identity));
        if !joins && last.is_some() {
            entry += 1;
        }
        last = Some(o.identity.clone());
        if keep.get(entry as usize).copied().unwrap_or(false) {
            kept.push(o);
        }
    }
    if entry + 1 != n {
        return Err(format!(
            "the model groups into {} objects, the scene's table has {n}: not this scene's model",
            entry + 1
        )
        .into());
    }
    m.objects = kept;
    let dir = std::env::temp_dir().join(format!("gigawalk-hide-cost-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let file = dir.join(format!("{name}.gwk"));
    gigawalk_preprocess::preprocess(
        &m,
        &Default::default(),
        &file,
        name,
        &gigawalk_preprocess::NoProgress,
    )?;
    Ok(file)
}
