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

/// A generated plant (8k triangles, seed 2) with a 12-pose walk,
/// preprocessed in `dir`: its path and scene files.
pub fn small_plant(dir: &std::path::Path) -> (std::path::PathBuf, std::path::PathBuf) {
    plant(dir, "8k")
}

/// A generated plant of `triangles` (seed 2) with a 12-pose walk,
/// preprocessed in `dir`: its path and scene files.
pub fn plant(dir: &std::path::Path, triangles: &str) -> (std::path::PathBuf, std::path::PathBuf) {
    let (glb, path, gwk) = (dir.join("p.glb"), dir.join("p.path"), dir.join("p.gwk"));
    gigawalk_ok(&[
        "generate",
        "plant",
        "--triangles",
        triangles,
        "--seed",
        "2",
        "-o",
        s(&glb),
        "--path",
        s(&path),
        "--poses",
        "12",
    ]);
    gigawalk_ok(&["preprocess", s(&glb), "-o", s(&gwk)]);
    (path, gwk)
}

/// A command's JSON output, or a panic showing the text.
#[track_caller]
pub fn json(text: &str) -> serde_json::Value {
    serde_json::from_str(text).unwrap_or_else(|e| panic!("{e}: {text}"))
}

/// Runs `gigawalk replay GWK --out OUT --adapter null --modes vfc,och
/// MORE...` (no GPU work): whether it succeeded, its stdout and stderr.
pub fn null_replay(
    gwk: &std::path::Path,
    out: &std::path::Path,
    more: &[&str],
) -> (bool, String, String) {
    let mut a = vec![
        "replay",
        s(gwk),
        "--out",
        s(out),
        "--adapter",
        "null",
        "--modes",
        "vfc,och",
    ];
    a.extend_from_slice(more);
    gigawalk(&a)
}
