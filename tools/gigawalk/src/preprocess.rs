//! `gigawalk preprocess`: model -> scene file (work in progress, issue 4).

#[derive(clap::Args)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`gigawalk preprocess` is not implemented yet")
}
