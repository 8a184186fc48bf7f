//! `gigawalk gpu-run-results DIR` (hidden): `benches/gpu-run.sh`'s last
//! step, turning its step records and reports into results.json and
//! summary.md. The work is in gigawalk_replay::gpu_run.

use std::path::PathBuf;

use anyhow::Context as _;

#[derive(clap::Args)]
pub struct Args {
    /// The run's output directory, holding steps.tsv and run.tsv
    dir: PathBuf,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let results = gigawalk_replay::gpu_run::collect(&args.dir)
        .with_context(|| format!("cannot collect the results in {}", args.dir.display()))?;
    for f in results
        .write(&args.dir)
        .context("cannot write the results")?
    {
        out!("wrote {}", f.display())?;
    }
    Ok(())
}
