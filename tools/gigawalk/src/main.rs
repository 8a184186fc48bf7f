//! The `gigawalk` command line: argument parsing, progress and error
//! printing only. Every subcommand's logic lives in a crate.

#![forbid(unsafe_code)]

/// `println!` for results on standard output, as an expression of type
/// `anyhow::Result<()>`: use it with `?`. A reader that stops early
/// (`gigawalk info scene.gwk | head`) closes the pipe; that comes back as
/// [`StdoutClosed`], which `main` treats as a quiet end after everything
/// else has been written and dropped, instead of the panic `println!` gives.
macro_rules! out {
    ($($t:tt)*) => {
        $crate::write_stdout(format_args!($($t)*), true)
    };
}

mod adapters;
mod demo;
mod export_tiles;
mod generate;
mod gpu_run;
mod info;
mod look;
mod objects;
mod preprocess;
mod replay;
mod section;
mod serve;
mod signals;
mod view;
mod web;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "gigawalk", version, about = "Interactive walkthroughs of huge 3D models", long_about = None)]
struct Cli {
    /// Write a Chrome/Perfetto trace of every span (pipeline stages per
    /// frame, preprocess phases) to this JSON file; open it in
    /// https://ui.perfetto.dev or chrome://tracing
    #[arg(long, global = true, value_name = "FILE")]
    trace: Option<std::path::PathBuf>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Print what a scene file holds: counts, bounds, bytes per section and per triangle, provenance
    Info(info::Args),
    /// Generate a procedural test scene (glTF binary) and optionally a camera path through it
    Generate(generate::Args),
    /// Turn a glTF/OBJ/IFC model into a scene file: partition, cluster, AABB hierarchy, HLODs
    Preprocess(preprocess::Args),
    /// Replay a camera path in the Table 2 modes and write a frame-time and accuracy report
    Replay(Box<replay::Args>),
    /// The whole story on the built-in plant: generate, preprocess, replay all modes, report
    Demo(demo::Args),
    /// Walk through a scene in a window: fly, toggle culling and LODs, see what they do
    View(view::Args),
    /// Which object is under a pixel of a camera path's pose, exact against full detail
    Pick(objects::PickArgs),
    /// List the objects whose name or path matches a pattern, with their boxes
    Find(objects::FindArgs),
    /// Write a scene as a 3D Tiles 1.1 tileset (CesiumJS, three.js): HLOD tiles with measured geometric errors, objects as features
    ExportTiles(export_tiles::Args),
    /// Write the browser viewer and a scene as a static site (served by anything that answers HTTP range requests)
    #[command(long_about = web::LONG_ABOUT)]
    Web(web::Args),
    /// Serve the browser viewer of a scene over HTTP, with the range requests it reads the scene by
    #[command(long_about = serve::LONG_ABOUT)]
    Serve(serve::Args),
    /// benches/gpu-run.sh's last step: results.json and summary.md from its step records
    #[command(hide = true)]
    GpuRunResults(gpu_run::Args),
}

/// Standard output was closed by its reader: not a failure of ours.
#[derive(Debug)]
pub(crate) struct StdoutClosed;

impl std::fmt::Display for StdoutClosed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("standard output was closed")
    }
}

impl std::error::Error for StdoutClosed {}

/// Writes to standard output, with a newline if `line` (see [`out!`]).
pub(crate) fn write_stdout(args: std::fmt::Arguments, line: bool) -> anyhow::Result<()> {
    use std::io::Write as _;
    let mut o = std::io::stdout().lock();
    let written = o
        .write_fmt(args)
        .and_then(|()| if line { o.write_all(b"\n") } else { Ok(()) })
        .and_then(|()| o.flush());
    match written {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Err(StdoutClosed.into()),
        Err(e) => Err(anyhow::anyhow!("cannot write to standard output: {e}")),
    }
}

fn main() -> std::process::ExitCode {
    // First, while this is the only thread (it changes the environment).
    quiet_headless_vulkan_device_select();
    let cli = Cli::parse();
    // Keep the trace writer alive until the end: dropping it flushes the file.
    let _trace_guard = init_tracing(cli.trace.as_deref());
    if let Err(e) = signals::install() {
        eprintln!("warning: {}", error_chain(&e));
    }
    let result = match cli.command {
        Command::Info(a) => info::run(a),
        Command::Generate(a) => generate::run(a),
        Command::Preprocess(a) => preprocess::run(a),
        Command::Replay(a) => replay::run(*a),
        Command::Demo(a) => demo::run(a),
        Command::View(a) => view::run(a),
        Command::Pick(a) => objects::pick(a),
        Command::Find(a) => objects::find(a),
        Command::ExportTiles(a) => export_tiles::run(a),
        Command::Web(a) => web::run(a),
        Command::Serve(a) => serve::run(a),
        Command::GpuRunResults(a) => gpu_run::run(a),
    };
    // Temporaries of killed gigawalk runs found beside this run's outputs.
    let stale = gigawalk_scene::stale_temp_files_removed();
    if !stale.is_empty() {
        eprintln!(
            "removed {} temporary file(s) left by gigawalk runs that are gone: {}",
            stale.len(),
            stale
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    // A command that finished after a signal (a replay that stopped early
    // and wrote what it measured) still reports the signal.
    let interrupted = signals::exit_status().map(std::process::ExitCode::from);
    match result {
        Ok(()) => interrupted.unwrap_or(std::process::ExitCode::SUCCESS),
        // The reader has what it wanted (`| head`); everything else was
        // already written.
        Err(e) if e.downcast_ref::<StdoutClosed>().is_some() => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", error_chain(&e));
            interrupted.unwrap_or(std::process::ExitCode::FAILURE)
        }
    }
}

/// Mesa's Vulkan device-selection layer (VK_LAYER_MESA_device_select, an
/// implicit layer that Mesa's Vulkan drivers install) looks for the GPU
/// that drives the desktop each time wgpu enumerates adapters: since wgpu
/// enables VK_KHR_wayland_surface, the layer calls `wl_display_connect`,
/// and without a desktop session libwayland-client prints "error:
/// XDG_RUNTIME_DIR is invalid or not set in the environment." on every
/// enumeration, although nothing failed. Without XDG_RUNTIME_DIR (or an
/// absolute WAYLAND_DISPLAY) there is no Wayland display to ask, so this
/// turns the layer off with its documented switch, NODEVICE_SELECT=1;
/// gigawalk orders adapters itself (hardware first). Left alone when the
/// user steers the layer (MESA_VK_DEVICE_SELECT, DRI_PRIME, NODEVICE_SELECT).
fn quiet_headless_vulkan_device_select() {
    let set = |name: &str| std::env::var_os(name).is_some_and(|v| !v.is_empty());
    let absolute =
        |name: &str| std::env::var_os(name).is_some_and(|v| v.to_string_lossy().starts_with('/'));
    let no_wayland = !absolute("XDG_RUNTIME_DIR") && !absolute("WAYLAND_DISPLAY");
    let steered = ["MESA_VK_DEVICE_SELECT", "DRI_PRIME", "NODEVICE_SELECT"]
        .iter()
        .any(|v| set(v));
    if no_wayland && !steered {
        // Sound only while no other thread can read the environment: main
        // calls this before anything else.
        std::env::set_var("NODEVICE_SELECT", "1");
    }
}

/// Logs to stderr filtered by RUST_LOG (default: warnings); with `--trace`,
/// also every span to a Chrome trace file.
fn init_tracing(trace: Option<&std::path::Path>) -> Option<tracing_chrome::FlushGuard> {
    use tracing_subscriber::prelude::*;
    // Probing backends makes their loaders log errors that are not
    // failures: EGL one for each platform it tries before the one that
    // works (on a headless machine with Mesa: "DRI2: failed to load
    // driver", then llvmpipe runs fine), the Vulkan loader "Found no
    // drivers!" where there is a loader and no driver. gigawalk itself
    // reports an adapter it cannot use and a machine with none. RUST_LOG
    // shows them again.
    let filter = tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
        tracing_subscriber::EnvFilter::new(
            "warn,wgpu_hal::gles::egl=off,wgpu_hal::vulkan::instance=off",
        )
    });
    let fmt = tracing_subscriber::fmt::layer()
        .with_writer(std::io::stderr)
        .with_filter(filter);
    let (chrome, guard) = match trace {
        Some(path) => {
            let (layer, guard) = tracing_chrome::ChromeLayerBuilder::new()
                .file(path)
                .include_args(true)
                .build();
            (Some(layer), Some(guard))
        }
        None => (None, None),
    };
    tracing_subscriber::registry().with(fmt).with(chrome).init();
    guard
}

/// The error and its causes joined by ": ", leaving out a cause whose text
/// the message before it already contains (library errors often quote
/// their source, e.g. "x.glb: cannot read: No such file or directory").
fn error_chain(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.contains(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}
