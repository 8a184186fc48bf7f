//! What the CLI tests share: running the binary.

// Each test file uses what it needs of these.
#![allow(dead_code)]

use std::path::Path;
use std::process::Command;

/// Runs `gigawalk args`: whether it succeeded, its stdout and its stderr.
pub fn gigawalk(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_gigawalk"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

/// A path as an argument.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}
