//! The `gigawalk` command line: argument parsing, progress and error
//! printing only. Every subcommand's logic lives in a crate.

mod generate;
mod info;
mod preprocess;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "gigawalk", version, about = "Interactive walkthroughs of huge 3D models", long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Print what a scene file holds: counts, bounds, bytes per section and per triangle, provenance
    Info(info::Args),
    /// Generate a procedural test scene (glTF binary) and optionally a camera path through it
    Generate(generate::Args),
    /// Turn a glTF/OBJ model into a scene file: partition, cluster, AABB hierarchy, HLODs
    Preprocess(preprocess::Args),
}

fn main() -> std::process::ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .with_writer(std::io::stderr)
        .init();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Info(a) => info::run(a),
        Command::Generate(a) => generate::run(a),
        Command::Preprocess(a) => preprocess::run(a),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
