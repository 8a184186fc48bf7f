//! `gigawalk demo`: the whole story on the built-in plant: generate and
//! preprocess it (cached), replay its walk in all four modes, write the
//! report and print the summary. The work is in gigawalk-replay.

use std::path::PathBuf;

use anyhow::Context as _;
use gigawalk_replay::demo::{self, DemoScene};
use gigawalk_scene::path::CameraPath;
use gigawalk_scene::SceneReader;

use crate::replay::{run_replay, write_and_print};

#[derive(clap::Args)]
pub struct Args {
    /// Report directory
    #[arg(long, default_value = "demo-out")]
    out: PathBuf,
    /// Where the generated and preprocessed plant is kept between runs
    #[arg(long, default_value = "target/gigawalk-demo-cache")]
    cache: PathBuf,
    /// Plant size in triangles
    #[arg(long, default_value_t = demo::DEFAULT_TRIANGLES)]
    triangles: u64,
    /// Frames: poses of the walk, 10 a second
    #[arg(long, default_value_t = demo::DEFAULT_FRAMES)]
    frames: usize,
    /// Generate and preprocess again even if the cache looks current
    #[arg(long)]
    rebuild: bool,
    #[command(flatten)]
    runtime: crate::replay::RuntimeArgs,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let spec = DemoScene {
        triangles: args.triangles,
        poses: args.frames,
        ..DemoScene::default()
    };
    let mut opts = demo::replay_options(args.frames, args.runtime.width, args.runtime.height);
    opts.runtime = args.runtime.options();
    opts.near = args.runtime.near;
    opts.memory_budget = args.runtime.memory_budget;
    opts.adapter = args.runtime.adapter.clone();
    // Before minutes of generating and preprocessing: can this machine
    // render at all?
    let devices =
        gigawalk_replay::probe_devices(&opts).context("gigawalk demo cannot render here")?;
    eprintln!("rendering on {}", devices.join(" and "));
    let progress = PhaseLines;
    let prepared = spec
        .prepare(
            &args.cache,
            args.rebuild,
            &mut |line| eprintln!("{line}"),
            &progress,
        )
        .context("cannot prepare the demo scene")?;
    let scene = SceneReader::open(&prepared.scene).context("cannot open the demo scene")?;
    let path = CameraPath::read(&prepared.path).context("cannot read the demo path")?;
    let replay = run_replay(
        &scene,
        &prepared.scene.display().to_string(),
        &path,
        &prepared.path.display().to_string(),
        &opts,
        &args.out,
    )?;
    write_and_print(&replay, &args.out)
}

/// The preprocessor's phases as plain lines: the demo's preprocessing is
/// about a minute, so a line per phase is enough.
struct PhaseLines;

impl gigawalk_preprocess::Progress for PhaseLines {
    fn finish(&self, phase: gigawalk_preprocess::Phase, seconds: f64) {
        eprintln!("{:>13} done in {seconds:.2} s", phase.name());
    }
}
