//! SIGINT and SIGTERM sent to a running `gigawalk`: it exits with 130 or
//! 143, leaves no `.gigawalk-*.tmp` file, keeps the previous complete file
//! at the destination, and a replay keeps the report of what it measured.

use std::io::BufRead as _;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::OnceLock;

mod common;
use common::{gigawalk_ok, s};

/// `gigawalk` to spawn: these tests signal it while it runs.
fn gigawalk() -> Command {
    Command::new(common::BIN)
}

/// The hidden temporary files of unfinished writes in `dir`.
fn temp_files(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy();
            name.starts_with(".gigawalk-") && name.ends_with(".tmp")
        })
        .collect()
}

fn kill(child: &Child, signal: &str) {
    let ok = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap()
        .success();
    assert!(ok, "kill {signal} failed");
}

/// Waits until `ready` holds, then sends `signal` and waits for the exit.
/// The process finishing first is a failure: the work was too small to be
/// interrupted.
fn interrupt_when(mut child: Child, signal: &str, ready: impl Fn() -> bool) -> ExitStatus {
    while !ready() {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("finished ({status}) before it could be interrupted");
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    kill(&child, signal);
    child.wait().unwrap()
}

/// A plant big enough that preprocessing it takes seconds (its scene
/// file's temporary file lives that long), generated once per test run.
fn plant() -> &'static Path {
    static PLANT: OnceLock<PathBuf> = OnceLock::new();
    PLANT.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("signals");
        std::fs::create_dir_all(&dir).unwrap();
        let glb = dir.join("plant-300k.glb");
        if !glb.is_file() {
            gigawalk_ok(&["generate", "plant", "--triangles", "300k", "-o", s(&glb)]);
        }
        glb
    })
}

fn preprocess(input: &Path, output: &Path) -> Child {
    gigawalk()
        .args(["preprocess", s(input), "-o", s(output)])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap()
}

#[test]
fn sigint_during_preprocess_leaves_no_temp_file_and_keeps_the_previous_scene() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plant.gwk");
    std::fs::write(&out, b"the previous, complete scene").unwrap();
    let status = interrupt_when(preprocess(plant(), &out), "-INT", || {
        !temp_files(dir.path()).is_empty()
    });
    assert_eq!(status.code(), Some(130), "{status}");
    assert_eq!(temp_files(dir.path()), Vec::<PathBuf>::new());
    assert_eq!(
        std::fs::read(&out).unwrap(),
        b"the previous, complete scene"
    );
}

#[test]
fn sigterm_during_preprocess_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plant.gwk");
    let status = interrupt_when(preprocess(plant(), &out), "-TERM", || {
        !temp_files(dir.path()).is_empty()
    });
    assert_eq!(status.code(), Some(143), "{status}");
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn sigterm_during_generate_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plant.glb");
    let child = gigawalk()
        .args(["generate", "plant", "--triangles", "3M", "-o", s(&out)])
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    // Generating comes first, in memory; the signal lands while the file
    // is written.
    let status = interrupt_when(child, "-TERM", || !temp_files(dir.path()).is_empty());
    assert_eq!(status.code(), Some(143), "{status}");
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn sigint_during_replay_keeps_the_report_of_what_was_measured() {
    if gigawalk_gpu::devices_or_skip(2, "gigawalk replay interrupted").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n);
    let poses = "5000";
    gigawalk_ok(&[
        "generate",
        "plant",
        "--triangles",
        "20k",
        "-o",
        s(&p("p.glb")),
        "--path",
        s(&p("p.path")),
        "--poses",
        poses,
    ]);
    gigawalk_ok(&["preprocess", s(&p("p.glb")), "-o", s(&p("p.gwk"))]);
    let mut child = gigawalk()
        .args(["replay", s(&p("p.gwk")), "--path", s(&p("p.path"))])
        .args([
            "--out",
            s(&p("report")),
            "--modes",
            "vfc",
            "--accuracy-every",
            "0",
        ])
        .args(["--warmup", "0", "--width", "64", "--height", "36"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Without a terminal the replay prints a line as each run starts.
    let mut lines = std::io::BufReader::new(child.stderr.take().unwrap()).lines();
    let started = lines
        .by_ref()
        .map(|l| l.unwrap())
        .any(|l| l.starts_with("vfc:"));
    assert!(started, "the run never started");
    kill(&child, "-INT");
    let rest: Vec<String> = lines.map(|l| l.unwrap()).collect();
    let status = child.wait().unwrap();
    let stdout = std::io::read_to_string(child.stdout.take().unwrap()).unwrap();
    assert_eq!(status.code(), Some(130), "{status}: {rest:?}");
    assert!(stdout.contains("stopped early"), "{stdout}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(p("report").join("summary.json")).unwrap())
            .unwrap();
    assert_eq!(json["complete"], false, "{json}");
    let rows = std::fs::read_to_string(p("report").join("frames.csv"))
        .unwrap()
        .lines()
        .count();
    assert!(rows - 1 < 5000, "{rows} rows: the replay did not stop");
    assert_eq!(temp_files(&p("report")), Vec::<PathBuf>::new());
}
