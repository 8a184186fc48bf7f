//! `gigawalk demo` on a machine without a desktop session (no
//! XDG_RUNTIME_DIR, no Wayland display): a successful run writes no line
//! that says "error" (Mesa's device-selection layer made libwayland print
//! one on every adapter enumeration).

use std::process::Command;

#[test]
fn a_successful_demo_without_a_desktop_session_writes_no_error_line() {
    if gigawalk_gpu::devices_or_skip(2, "gigawalk demo").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (cache, out) = (dir.path().join("cache"), dir.path().join("out"));
    let run = Command::new(env!("CARGO_BIN_EXE_gigawalk"))
        .args(["demo", "--triangles", "20000", "--frames", "12"])
        .args(["--width", "64", "--height", "36"])
        .arg("--cache")
        .arg(&cache)
        .arg("--out")
        .arg(&out)
        // A headless machine's environment, whatever this one has.
        .env_remove("XDG_RUNTIME_DIR")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("NODEVICE_SELECT")
        .env_remove("MESA_VK_DEVICE_SELECT")
        .env_remove("DRI_PRIME")
        .env_remove("RUST_LOG")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    // Standard output is the results table, whose columns may name pixel
    // errors; messages go to standard error.
    let errors: Vec<&str> = stderr
        .lines()
        .filter(|l| l.to_lowercase().contains("error"))
        .collect();
    assert!(errors.is_empty(), "a successful demo printed {errors:?}");
    assert!(out.join("summary.json").is_file());
}

/// Hides every Vulkan driver (the loader finds no ICD) from `cmd`.
fn hide_vulkan(cmd: &mut Command) -> &mut Command {
    cmd.env("VK_ICD_FILENAMES", "/nonexistent")
        .env("VK_DRIVER_FILES", "/nonexistent")
        .env_remove("WGPU_BACKEND")
        .env_remove("RUST_LOG")
}

/// Hides GL too: glvnd's EGL finds no vendor library, so wgpu's GL backend
/// has no adapter.
fn hide_every_backend(cmd: &mut Command) -> &mut Command {
    hide_vulkan(cmd).env("__EGL_VENDOR_LIBRARY_FILENAMES", "/nonexistent")
}

fn demo_command(cache: &std::path::Path, out: &std::path::Path) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_gigawalk"));
    cmd.args(["demo", "--triangles", "20000", "--frames", "12"])
        .args(["--width", "64", "--height", "36"])
        .arg("--cache")
        .arg(cache)
        .arg("--out")
        .arg(out);
    cmd
}

/// A machine that cannot render hears so before minutes of generating and
/// preprocessing, in one line that says what to install, and the demo
/// leaves nothing behind.
#[test]
fn with_every_backend_hidden_the_demo_fails_at_once_in_one_line_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (cache, out) = (dir.path().join("cache"), dir.path().join("out"));
    let started = std::time::Instant::now();
    let run = hide_every_backend(&mut demo_command(&cache, &out))
        .output()
        .unwrap();
    let seconds = started.elapsed().as_secs_f64();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success(), "{stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{stderr}");
    assert!(lines[0].starts_with("error: "), "{stderr}");
    assert!(lines[0].contains("no GPU adapter"), "{stderr}");
    assert!(
        lines[0].contains("apt-get install mesa-vulkan-drivers"),
        "{stderr}"
    );
    assert!(seconds < 10.0, "took {seconds:.1} s to fail");
    assert!(!cache.exists() && !out.exists(), "the demo wrote files");
}

/// Whether `gigawalk info --adapters` finds a usable adapter with `hide`
/// applied; without one (and without GIGAWALK_REQUIRE_ADAPTER) the test
/// skips loudly.
fn usable_adapter_with(hide: fn(&mut Command) -> &mut Command, what: &str) -> bool {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_gigawalk"));
    let run = hide(cmd.args(["info", "--adapters", "--json"]))
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    if v["error"].is_null() {
        return true;
    }
    gigawalk_gpu::skip_test(what, &format!("no usable adapter ({})", v["error"]));
    false
}

/// Where Vulkan is missing (many VMs, remote desktops, CI runners), the
/// demo runs on wgpu's GL backend (Mesa's llvmpipe here) and says so.
#[test]
fn the_demo_runs_on_gl_with_the_vulkan_driver_hidden() {
    if !usable_adapter_with(hide_vulkan, "the demo on GL") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (cache, out) = (dir.path().join("cache"), dir.path().join("out"));
    let run = hide_vulkan(&mut demo_command(&cache, &out))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(stderr.contains("rendering on A ("), "{stderr}");
    assert!(stderr.contains(", Gl)"), "not on GL: {stderr}");
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    assert!(summary.contains("Gl"), "the report does not name GL");
}

/// `--adapter` that matches no usable adapter fails at once, listing the
/// usable ones, before anything is generated.
#[test]
fn an_adapter_name_that_matches_nothing_fails_at_once_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (cache, out) = (dir.path().join("cache"), dir.path().join("out"));
    let run = demo_command(&cache, &out)
        .args(["--adapter", "no-such-gpu-xyz"])
        .env_remove("RUST_LOG")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success(), "{stderr}");
    // With a usable adapter: the name matched nothing; without one at
    // all: the machine cannot render.
    assert!(
        stderr.contains("no usable GPU adapter's name contains \"no-such-gpu-xyz\"")
            || stderr.contains("no GPU adapter gigawalk can use"),
        "{stderr}"
    );
    assert!(!cache.exists() && !out.exists(), "the demo wrote files");
}
