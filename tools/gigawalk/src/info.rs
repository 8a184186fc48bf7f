//! `gigawalk info`: what a scene file holds.

#[derive(clap::Args)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`gigawalk info` is not implemented yet")
}
