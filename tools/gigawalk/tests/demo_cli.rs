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
