//! `gigawalk view` scripted under Xvfb: a small generated plant, a few
//! frames, and a screenshot that must show the scene (many colours, most of
//! the image covered), not a blank or background-only frame. Skips loudly
//! without Xvfb or a GPU adapter, unless GIGAWALK_REQUIRE_ADAPTER is set
//! (CI), where both must be there.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

fn gigawalk(args: &[&str], display: Option<&str>) -> (bool, String, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_gigawalk"));
    cmd.args(args);
    if let Some(d) = display {
        // Only X11 under Xvfb: a Wayland session variable would win otherwise.
        cmd.env("DISPLAY", d).env_remove("WAYLAND_DISPLAY");
    }
    let out = cmd.output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn required() -> bool {
    std::env::var_os("GIGAWALK_REQUIRE_ADAPTER").is_some()
}

fn skip(why: &str) {
    assert!(!required(), "GIGAWALK_REQUIRE_ADAPTER is set but {why}");
    eprintln!("\n!!! SKIPPING gigawalk view test: {why} !!!\n");
}

/// An Xvfb server on its own display, killed when dropped.
struct Xvfb {
    child: Child,
    display: String,
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts Xvfb on the first free display from :99 up (several test runs
/// may share a machine); None when there is no Xvfb binary.
fn start_xvfb() -> Option<Xvfb> {
    for n in 99..120 {
        let lock = format!("/tmp/.X{n}-lock");
        if Path::new(&lock).exists() {
            continue;
        }
        let display = format!(":{n}");
        let child = match Command::new("Xvfb")
            .args([
                display.as_str(),
                "-screen",
                "0",
                "1024x768x24",
                "-nolisten",
                "tcp",
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
        {
            Ok(c) => c,
            Err(_) => return None,
        };
        let mut x = Xvfb { child, display };
        // Ready when its socket exists; gone if the display was taken.
        let deadline = Instant::now() + Duration::from_secs(10);
        while Instant::now() < deadline {
            if Path::new(&format!("/tmp/.X11-unix/X{n}")).exists() {
                return Some(x);
            }
            if let Ok(Some(_)) = x.child.try_wait() {
                break;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        drop(x);
    }
    None
}

#[test]
fn help_lists_the_controls() {
    let (ok, out, err) = gigawalk(&["view", "--help"], None);
    assert!(ok, "{err}");
    for want in [
        "W / Up",
        "scroll",
        "walk mode",
        "freeze culling",
        "screenshot",
        "--frames",
        "--screenshot",
    ] {
        assert!(out.contains(want), "{want:?} missing from --help:\n{out}");
    }
}

#[test]
fn missing_scene_is_a_clear_error() {
    let (ok, _, err) = gigawalk(&["view", "/nonexistent/scene.gwk", "--frames", "1"], None);
    assert!(!ok);
    assert!(err.contains("scene.gwk"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn scripted_view_of_a_small_plant_shows_the_scene() {
    if gigawalk_gpu::devices_or_skip(1, "gigawalk view").is_none() {
        return;
    }
    let Some(x) = start_xvfb() else {
        skip("no Xvfb binary (apt-get install xvfb)");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (glb, path, gwk, png) = (
        dir.path().join("p.glb"),
        dir.path().join("p.path"),
        dir.path().join("p.gwk"),
        dir.path().join("shot.png"),
    );
    let (ok, _, err) = gigawalk(
        &[
            "generate",
            "plant",
            "--triangles",
            "20k",
            "--seed",
            "3",
            "-o",
            s(&glb),
            "--path",
            s(&path),
            "--poses",
            "8",
        ],
        None,
    );
    assert!(ok, "{err}");
    let (ok, _, err) = gigawalk(&["preprocess", s(&glb), "-o", s(&gwk)], None);
    assert!(ok, "{err}");
    // The same frames shaded, then in wireframe.
    let shot = |png: &Path, extra: &[&str]| {
        let mut args = vec![
            "view",
            s(&gwk),
            "--path",
            s(&path),
            "--frames",
            "6",
            "--screenshot",
            s(png),
            "--width",
            "320",
            "--height",
            "200",
            "--no-hud",
        ];
        args.extend_from_slice(extra);
        let (ok, _, err) = gigawalk(&args, Some(&x.display));
        assert!(ok, "gigawalk view {extra:?} failed:\n{err}");
        let (w, h, rgba) = gigawalk_viewer::read_png(png).unwrap();
        assert_eq!((w, h), (320, 200));
        rgba
    };
    let shaded = shot(&png, &[]);
    let stats = gigawalk_viewer::image_stats(&shaded);
    // A lit plant interior: hundreds of shades (a blank or clear-only frame
    // has one), and no single colour (the clear colour, or a flat-lit floor
    // or wall) over more than 80% of the view.
    assert!(stats.distinct_colours > 100, "{stats:?}");
    assert!(stats.non_background > 0.2, "{stats:?}");

    // Wireframe: edges in each object's unlit colour over the background,
    // so far fewer distinct colours, yet lines all over the view.
    let wire = shot(&dir.path().join("wire.png"), &["--wireframe"]);
    let wstats = gigawalk_viewer::image_stats(&wire);
    assert!(
        wstats.distinct_colours * 4 < stats.distinct_colours,
        "wireframe {wstats:?} vs shaded {stats:?}"
    );
    assert!(wstats.non_background > 0.05, "{wstats:?}");
    let differing = shaded
        .chunks(4)
        .zip(wire.chunks(4))
        .filter(|(a, b)| a != b)
        .count();
    assert!(
        differing * 4 > shaded.len() / 4,
        "only {differing} pixels differ from the shaded frame"
    );
}
