//! SIGINT (Ctrl-C) and SIGTERM: every command stops promptly with status
//! 128 + the signal's number (130, 143) and leaves no temporary file.
//!
//! A signal skips every destructor, so the temporary files of unfinished
//! writes (which delete themselves on drop) would stay behind; instead a
//! listener thread deletes them through the scene crate's registry
//! ([`gigawalk_scene::remove_temp_files`]) and exits at once. Once a
//! replay measures frames ([`stop_gracefully`]), the first signal only
//! asks it to stop after the current frame, so that it writes the report
//! of what was measured; a second one exits at once.

use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};

use anyhow::Context as _;
use signal_hook::consts::{SIGINT, SIGTERM};

/// The first signal received, 0 for none.
static RECEIVED: AtomicI32 = AtomicI32::new(0);
/// Whether the first signal only asks the command to stop.
static GRACEFUL: AtomicBool = AtomicBool::new(false);
/// Whether a signal asked the command to stop.
static STOP: AtomicBool = AtomicBool::new(false);

/// Starts the listener. Call once, at the start of `main`.
pub fn install() -> anyhow::Result<()> {
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM])
        .context("cannot install the SIGINT/SIGTERM handler")?;
    std::thread::Builder::new()
        .name("gigawalk-signals".into())
        .spawn(move || {
            for signal in signals.forever() {
                on_signal(signal);
            }
        })
        .context("cannot start the signal listener thread")?;
    Ok(())
}

fn on_signal(signal: i32) {
    let _ = RECEIVED.compare_exchange(0, signal, Ordering::SeqCst, Ordering::SeqCst);
    if GRACEFUL.load(Ordering::SeqCst) && !STOP.swap(true, Ordering::SeqCst) {
        eprintln!("{}: stopping after this frame", name(signal));
        return;
    }
    let removed = gigawalk_scene::remove_temp_files();
    eprintln!(
        "{}: stopped{}",
        name(signal),
        match removed {
            0 => String::new(),
            1 => ", removed 1 unfinished file".into(),
            n => format!(", removed {n} unfinished files"),
        }
    );
    // _exit: no atexit handlers or destructors of other threads' state
    // (the GPU driver's among them) run while those threads still work.
    signal_hook::low_level::exit(exit_code(signal));
}

fn name(signal: i32) -> &'static str {
    match signal {
        SIGINT => "interrupted (SIGINT)",
        SIGTERM => "terminated (SIGTERM)",
        _ => "signal",
    }
}

/// The shell's convention for a process ended by a signal.
fn exit_code(signal: i32) -> i32 {
    128 + signal
}

/// The exit status for a command that finished after a signal (a replay
/// stopped early), if one came.
pub fn exit_status() -> Option<u8> {
    match RECEIVED.load(Ordering::SeqCst) {
        0 => None,
        s => u8::try_from(exit_code(s)).ok(),
    }
}

/// From now until the process ends, the first signal sets
/// [`stop_requested`] instead of exiting: a replay calls it when it starts
/// measuring, so what it measured is written as a report (which is the
/// last thing the replay and demo commands do).
pub fn stop_gracefully() {
    GRACEFUL.store(true, Ordering::SeqCst);
}

/// Whether a signal asked the command to stop (see [`stop_gracefully`]).
pub fn stop_requested() -> bool {
    STOP.load(Ordering::SeqCst)
}
