//! What the CLI tests share: running the binary (gigawalk-testkit's
//! runner, pointed at the `gigawalk` this package builds).

// Each test file uses what it needs of these.
#![allow(dead_code)]

#[allow(unused_imports)] // as `dead_code` above, for a re-export
pub use gigawalk_testkit::cli::arg as s;
use gigawalk_testkit::cli::{self, Output};

/// The `gigawalk` binary under test (Cargo names it only to this
/// package's own tests).
pub const BIN: &str = env!("CARGO_BIN_EXE_gigawalk");

/// Runs `gigawalk args`: whether it succeeded, its stdout and its stderr.
pub fn gigawalk(args: &[&str]) -> (bool, String, String) {
    cli::run(BIN, args).into_parts()
}

/// Runs `gigawalk args` and panics, showing its stderr, unless it
/// succeeded.
#[track_caller]
pub fn gigawalk_ok(args: &[&str]) -> Output {
    cli::run_ok(BIN, args)
}
