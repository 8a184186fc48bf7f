//! `gigawalk generate`: procedural test scenes (work in progress, issue 3).

#[derive(clap::Args)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`gigawalk generate` is not implemented yet")
}
