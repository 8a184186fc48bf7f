//! `gigawalk view` under Xvfb on a small generated plant. Scripted: a few
//! frames and a screenshot that must show the scene (many colours, most of
//! the image covered), not a blank or background-only frame, and the same
//! in wireframe. Live: xdotool drives it with keys and the mouse (select
//! an object with a click, hide and show it, save and restore a view,
//! find an object, fly, look, wireframe, node boxes, freeze culling,
//! record a path, screenshots, resize, hiding and showing the window,
//! Esc), then a scripted run starts from the saved view; and a second
//! session cuts the model with section planes and a box and measures a
//! distance (checked against `gigawalk pick`).
//! Skips loudly without Xvfb, xdotool or a GPU adapter, unless
//! GIGAWALK_REQUIRE_ADAPTER is set (CI), where all must be there.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use gigawalk_testkit::cli;

mod common;
use common::s;

/// Longest a scripted `gigawalk` or `xdotool` call may take before the test
/// fails instead of hanging CI (coreutils `timeout` kills it).
const CALL_LIMIT_S: &str = "300";

/// Runs `gigawalk args` under `timeout`, on X display `display` if one is
/// given: whether it succeeded, its stdout and its stderr.
fn gigawalk(args: &[&str], display: Option<&str>) -> (bool, String, String) {
    let mut cmd = Command::new("timeout");
    cmd.arg(CALL_LIMIT_S).arg(common::BIN).args(args);
    if let Some(d) = display {
        // Only X11 under Xvfb: a Wayland session variable would win otherwise.
        cmd.env("DISPLAY", d).env_remove("WAYLAND_DISPLAY");
    }
    cli::output(&mut cmd).into_parts()
}

fn skip(why: &str) {
    gigawalk_gpu::skip_test("gigawalk view test", why);
}

/// An Xvfb server on its own display, killed when dropped.
struct Xvfb {
    child: Child,
    display: String,
    /// Xvfb's stderr, for failure messages.
    log: tempfile::NamedTempFile,
}

impl Xvfb {
    fn log_text(&self) -> String {
        std::fs::read_to_string(self.log.path()).unwrap_or_default()
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        // SIGTERM first, so Xvfb removes its lock file and socket (a
        // SIGKILLed server leaves them behind for the next one to trip on).
        let _ = Command::new("kill")
            .arg(self.child.id().to_string())
            .status();
        let deadline = Instant::now() + Duration::from_secs(5);
        while Instant::now() < deadline {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts Xvfb on a display it picks itself (`-displayfd`: tests running
/// at once must not race for the same number) and waits until it is ready;
/// None when there is no Xvfb binary.
/// What a live test needs: a GPU adapter, xdotool and a started Xvfb
/// server (returned), or `None` with the test skipped and why.
fn live_display(what: &str) -> Option<Xvfb> {
    gigawalk_gpu::devices_or_skip(1, what)?;
    if Command::new("xdotool").arg("version").output().is_err() {
        skip("no xdotool binary (apt-get install xdotool)");
        return None;
    }
    let x = start_xvfb();
    if x.is_none() {
        skip("no Xvfb binary (apt-get install xvfb)");
    }
    x
}

fn start_xvfb() -> Option<Xvfb> {
    use std::io::BufRead as _;
    // One server starts at a time: two starting together can both clear
    // the same stale lock file (left by a killed server) and end up on one
    // display, which the first to finish then takes down.
    static STARTING: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one_at_a_time = STARTING.lock().unwrap_or_else(|e| e.into_inner());
    let log = tempfile::NamedTempFile::new().expect("a temporary file for Xvfb's log");
    let mut child = Command::new("Xvfb")
        .args([
            "-displayfd",
            "1",
            "-screen",
            "0",
            "1024x768x24",
            "-nolisten",
            "tcp",
            // No server reset when the last client leaves: a client that
            // connects during a reset is refused.
            "-noreset",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::from(log.reopen().expect("Xvfb log")))
        .spawn()
        .ok()?;
    let stdout = child.stdout.take().expect("piped stdout");
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        let _ = std::io::BufReader::new(stdout).read_line(&mut line);
        let _ = tx.send(line);
    });
    let mut x = Xvfb {
        child,
        display: String::new(),
        log,
    };
    let line = rx
        .recv_timeout(Duration::from_secs(20))
        .unwrap_or_else(|_| panic!("Xvfb reported no display within 20 s:\n{}", x.log_text()));
    let n: u32 = line
        .trim()
        .parse()
        .unwrap_or_else(|_| panic!("Xvfb -displayfd wrote {line:?}:\n{}", x.log_text()));
    x.display = format!(":{n}");
    // Ready when its socket takes connections (the display number can come
    // a moment before a client can connect).
    let socket = format!("/tmp/.X11-unix/X{n}");
    let deadline = Instant::now() + Duration::from_secs(20);
    while std::os::unix::net::UnixStream::connect(&socket).is_err() {
        assert!(
            Instant::now() < deadline,
            "Xvfb {}: {socket} takes no connections after 20 s:\n{}",
            x.display,
            x.log_text()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    Some(x)
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
        "frame the selected object",
        "find objects",
        "save the view",
        "section plane at the cursor",
        "Shift+scroll",
        "measure: click two points",
        "--section",
        "--section-box",
        "--units",
        "--view",
        "screenshot",
        "--frames",
        "--screenshot",
    ] {
        assert!(out.contains(want), "{want:?} missing from --help:\n{out}");
    }
}

#[test]
fn bad_occluder_budget_is_a_clear_error() {
    let (ok, _, err) = gigawalk(
        &[
            "view",
            "x.gwk",
            "--frames",
            "1",
            "--occluder-budget",
            "many",
        ],
        None,
    );
    assert!(!ok);
    assert!(err.contains("occluder budget \"many\""), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn bad_target_fps_and_tiles_are_clear_errors() {
    for (flag, value, says) in [
        ("--target-fps", "0", "--target-fps 0"),
        ("--tiles", "4", "expected COLSxROWS"),
        ("--tile-culling", "fast", "tile culling \"fast\""),
    ] {
        let (ok, _, err) = gigawalk(&["view", "x.gwk", "--frames", "1", flag, value], None);
        assert!(!ok, "{flag} {value}");
        assert!(err.contains(says), "{flag} {value}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn bad_look_flags_are_clear_errors() {
    for (flag, value, says) in [
        ("--aa", "msaa", "msaa"),
        ("--edges", "yes", "yes"),
        ("--ao", "2", "'2'"),
        ("--sky", "blue", "blue"),
        ("--edge-angle", "0", "--edge-angle 0"),
        ("--edge-angle", "200", "--edge-angle 200"),
        ("--ao-radius", "0", "--ao-radius 0"),
        ("--ao-radius", "nan", "--ao-radius NaN"),
    ] {
        let arg = format!("{flag}={value}");
        for command in ["view", "replay"] {
            let (ok, _, err) = gigawalk(
                &[command, "x.gwk", "--path", "x.path", "--frames", "1", &arg],
                None,
            );
            assert!(!ok, "{command} {arg}");
            assert!(err.contains(says), "{command} {arg}: {err}");
            assert!(!err.contains("panicked"), "{err}");
        }
    }
}

#[test]
fn missing_scene_is_a_clear_error() {
    let (ok, _, err) = gigawalk(&["view", "/nonexistent/scene.gwk", "--frames", "1"], None);
    assert!(!ok);
    assert!(err.contains("scene.gwk"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

/// Generates and preprocesses a 20k-triangle plant with an 8-pose path in
/// `dir`; returns (scene, path).
fn small_plant(dir: &Path) -> (PathBuf, PathBuf) {
    let (glb, path, gwk) = (dir.join("p.glb"), dir.join("p.path"), dir.join("p.gwk"));
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
    (gwk, path)
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
    let (gwk, path) = small_plant(dir.path());
    let png = dir.path().join("shot.png");
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
        // Without the sky and FXAA, unless asked: wireframe is then
        // lines over one background colour.
        if !extra.contains(&"--sky") {
            args.extend(["--sky", "off", "--aa", "off"]);
        }
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

    // A display wall's tiles stitch into the same view (draw order per
    // tile may settle a few coplanar ties differently).
    for extra in [
        &["--tiles", "3x2"][..],
        &["--tiles", "4x4", "--tile-culling", "binning"],
    ] {
        let tiled = shot(&dir.path().join("tiled.png"), extra);
        let differing = shaded
            .chunks(4)
            .zip(tiled.chunks(4))
            .filter(|(a, b)| a != b)
            .count();
        assert!(
            differing * 200 < shaded.len() / 4,
            "{extra:?}: {differing} pixels differ from the single view"
        );
    }

    // The full look (the sky, edges, FXAA, ambient occlusion): the same
    // view with its background and outlines drawn differently.
    let look = shot(
        &dir.path().join("look.png"),
        &["--sky", "on", "--aa", "fxaa", "--edges", "on", "--ao", "on"],
    );
    let lstats = gigawalk_viewer::image_stats(&look);
    assert!(
        lstats.distinct_colours > stats.distinct_colours,
        "{lstats:?} vs {stats:?}"
    );
    let differing = shaded
        .chunks(4)
        .zip(look.chunks(4))
        .filter(|(a, b)| a != b)
        .count();
    assert!(
        differing * 20 > shaded.len() / 4,
        "the look changed only {differing} pixels"
    );

    // Streamed under a budget far below the scene (out of core): six
    // frames at a still start are enough for the view to fill in.
    let streamed = shot(
        &dir.path().join("streamed.png"),
        &["--memory-budget", "200k"],
    );
    let sstats = gigawalk_viewer::image_stats(&streamed);
    assert!(sstats.distinct_colours > 100, "{sstats:?}");
    assert!(sstats.non_background > 0.2, "{sstats:?}");

    // The lazy occlusion grid as the starting culler draws the scene too.
    let grid = shot(&dir.path().join("grid.png"), &["--culler", "grid"]);
    let gstats = gigawalk_viewer::image_stats(&grid);
    assert!(gstats.distinct_colours > 100, "{gstats:?}");
    assert!(gstats.non_background > 0.2, "{gstats:?}");
}

#[test]
fn bad_memory_budget_is_a_clear_error() {
    for bad in ["lots", "-1G", "12T"] {
        let flag = format!("--memory-budget={bad}");
        let (ok, _, err) = gigawalk(&["view", "x.gwk", "--frames", "1", &flag], None);
        assert!(!ok);
        assert!(err.contains("memory budget"), "{bad}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    let (ok, _, err) = gigawalk(&["view", "x.gwk", "--culler", "zbuffer"], None);
    assert!(!ok);
    assert!(
        err.contains("culler \"zbuffer\" is not hzb, grid, oq or ct"),
        "{err}"
    );
}

/// A running `gigawalk view`, killed if the test fails before it quits.
struct Viewer(Child);

impl Drop for Viewer {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn xdotool(display: &str, args: &[&str]) -> String {
    try_xdotool(display, args).unwrap_or_else(|e| panic!("{e}"))
}

/// xdotool's output, or what it said when it failed.
fn try_xdotool(display: &str, args: &[&str]) -> Result<String, String> {
    let out = Command::new("timeout")
        .arg(CALL_LIMIT_S)
        .arg("xdotool")
        .args(args)
        .env("DISPLAY", display)
        .output()
        .unwrap();
    if !out.status.success() {
        return Err(format!(
            "xdotool {args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout).trim().to_string())
}

/// Waits up to 30 s for `file` to exist (and its writer to finish).
fn wait_for(file: &Path, viewer: &mut Viewer) {
    let deadline = Instant::now() + Duration::from_secs(30);
    while !file.exists() {
        if let Ok(Some(status)) = viewer.0.try_wait() {
            panic!(
                "the viewer exited ({status}) before writing {}",
                file.display()
            );
        }
        assert!(
            Instant::now() < deadline,
            "{} never appeared",
            file.display()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    // The viewer writes to a temporary name and renames; give the rename a moment anyway.
    std::thread::sleep(Duration::from_millis(100));
}

fn differing_fraction(a: &[u8], b: &[u8]) -> f64 {
    let n = a.chunks(4).zip(b.chunks(4)).filter(|(x, y)| x != y).count();
    n as f64 / (a.len() / 4) as f64
}

/// Waits up to 30 s for the viewer's log to hold `needle` more than
/// `before` times; the log then.
fn wait_for_log(log: &Path, needle: &str, before: usize, viewer: &mut Viewer) -> String {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let text = std::fs::read_to_string(log).unwrap_or_default();
        if text.matches(needle).count() > before {
            return text;
        }
        if let Ok(Some(status)) = viewer.0.try_wait() {
            panic!("the viewer exited ({status}) before saying {needle:?}:\n{text}");
        }
        assert!(
            Instant::now() < deadline,
            "the viewer did not say {needle:?} within 30 s:\n{text}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// The first of a few pixels of pose 0 of `path`, on a `w` x `h` view,
/// where `gigawalk pick` finds an object: the pixel and the object's name.
fn pixel_on_an_object(gwk: &Path, path: &Path, w: u32, h: u32) -> ((u32, u32), String) {
    let candidates = [
        (w / 2, h / 2),
        (w / 3, h / 2),
        (2 * w / 3, h / 2),
        (w / 2, 2 * h / 3),
        (w / 2, h / 3),
    ];
    let (ws, hs) = (w.to_string(), h.to_string());
    for (x, y) in candidates {
        let pixel = format!("{x},{y}");
        let (ok, out, err) = gigawalk(
            &[
                "pick",
                s(gwk),
                "--path",
                s(path),
                "--frame",
                "0",
                "--pixel",
                &pixel,
                "--width",
                &ws,
                "--height",
                &hs,
                "--json",
            ],
            None,
        );
        assert!(ok, "gigawalk pick: {err}");
        let v: serde_json::Value = serde_json::from_str(&out).unwrap();
        if let Some(name) = v["object"]["name"].as_str() {
            return ((x, y), name.to_string());
        }
    }
    panic!("no object under any of {candidates:?} of the path's first pose");
}

/// The viewer's window id on display `d`, once it is mapped (the viewer
/// logs to `log`).
fn wait_for_window(d: &str, viewer: &mut Viewer, log: &Path) -> String {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let found = Command::new("xdotool")
            .args(["search", "--onlyvisible", "--name", "gigawalk"])
            .env("DISPLAY", d)
            .output()
            .unwrap();
        let id = String::from_utf8_lossy(&found.stdout);
        if let Some(id) = id.lines().next() {
            return id.to_string();
        }
        let log = || std::fs::read_to_string(log).unwrap_or_default();
        if let Some(status) = viewer.0.try_wait().unwrap() {
            panic!(
                "the viewer on {d} exited ({status}) before its window showed:\n{}\nX servers: {:?}",
                log(),
                Command::new("pgrep")
                    .args(["-a", "Xvfb"])
                    .output()
                    .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
            );
        }
        assert!(
            Instant::now() < deadline,
            "no visible gigawalk window after 30 s; windows named gigawalk: {:?}; viewer log:\n{}",
            Command::new("xdotool")
                .args(["search", "--name", "gigawalk"])
                .env("DISPLAY", d)
                .output()
                .map(|o| String::from_utf8_lossy(&o.stdout).into_owned()),
            log()
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// A live session driven like a person would: keys held to fly, a mouse
/// drag to look, toggles, a recorded path, screenshots, a resize, the
/// window hidden and shown, and Esc to quit.
#[test]
fn live_keys_and_mouse_drive_the_viewer() {
    let Some(x) = live_display("gigawalk view (live)") else {
        return;
    };
    let d = x.display.as_str();
    let dir = tempfile::tempdir().unwrap();
    let (gwk, path) = small_plant(dir.path());
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    let log = std::fs::File::create(dir.path().join("view.log")).unwrap();
    let mut viewer = Viewer(
        Command::new(common::BIN)
            .args(["view", s(&gwk), "--path", s(&path), "--no-hud"])
            .args(["--sky", "off", "--aa", "off"])
            .args(["--width", "480", "--height", "300", "--out-dir", s(&out)])
            .env("DISPLAY", d)
            .env_remove("WAYLAND_DISPLAY")
            .stdout(log.try_clone().unwrap())
            .stderr(log)
            .spawn()
            .unwrap(),
    );
    let window = wait_for_window(d, &mut viewer, &dir.path().join("view.log"));
    let w = window.as_str();
    // Keyboard focus, as a click would give it (Xvfb runs no window manager).
    xdotool(d, &["windowfocus", "--sync", w]);
    // A key the window cannot take (it is gone: the viewer exited) fails
    // with what the viewer said.
    let view_log = dir.path().join("view.log");
    let key = |k: &str| {
        if let Err(e) = try_xdotool(d, &["key", "--window", w, k]) {
            panic!(
                "{e}\nthe viewer's output:\n{}",
                std::fs::read_to_string(&view_log).unwrap_or_default()
            );
        }
    };
    let hold = |k: &str, ms: u64| {
        xdotool(d, &["keydown", "--window", w, k]);
        std::thread::sleep(Duration::from_millis(ms));
        xdotool(d, &["keyup", "--window", w, k]);
    };
    let mut shots = 0;
    let mut shot = |viewer: &mut Viewer| {
        // Let a few frames of the last input through first.
        std::thread::sleep(Duration::from_millis(400));
        key("p");
        shots += 1;
        let file = out.join(format!("gigawalk-view-{shots}.png"));
        wait_for(&file, viewer);
        let (w, h, rgba) = gigawalk_viewer::read_png(&file).unwrap();
        (w, h, rgba)
    };

    let (w0, h0, start) = shot(&mut viewer);
    assert_eq!((w0, h0), (480, 300));

    // Objects, while the camera is still at the path's first pose: a
    // click selects what `gigawalk pick` sees at that pixel, tinted.
    let ((px, py), name) = pixel_on_an_object(&gwk, &path, 480, 300);
    let said = |needle: &str| {
        std::fs::read_to_string(&view_log)
            .unwrap_or_default()
            .matches(needle)
            .count()
    };
    let selected_line = format!("selected: {name} (");
    let before = said(&selected_line);
    xdotool(
        d,
        &["mousemove", "--window", w, &px.to_string(), &py.to_string()],
    );
    xdotool(d, &["click", "1"]);
    wait_for_log(&view_log, &selected_line, before, &mut viewer);
    let (_, _, selected) = shot(&mut viewer);
    let tinted: Vec<(&[u8], &[u8])> = start
        .chunks(4)
        .zip(selected.chunks(4))
        .filter(|(a, b)| a != b)
        .collect();
    assert!(!tinted.is_empty(), "selecting {name} changed no pixel");
    // The tint mixes orange in: changed pixels gain red over blue.
    let redder = tinted
        .iter()
        .filter(|(a, b)| b[0] as i32 - b[2] as i32 > a[0] as i32 - a[2] as i32)
        .count();
    assert!(
        redder * 2 > tinted.len(),
        "{redder} of {} changed pixels turned more orange",
        tinted.len()
    );
    // H hides it (and ends the selection), V saves that, U shows all:
    // the start's image again.
    key("h");
    let (_, _, hidden) = shot(&mut viewer);
    let gone = differing_fraction(&selected, &hidden);
    assert!(gone > 0.0005, "hiding {name} changed {gone:.4} of the view");
    let views_file = gwk.with_file_name("p.gwk.views.json");
    key("v");
    wait_for(&views_file, &mut viewer);
    let views = gigawalk_scene::views::Views::read(&views_file).unwrap();
    assert_eq!(views.views.len(), 1);
    let saved = &views.views[0];
    assert_eq!(saved.name, "view 1");
    assert_eq!(saved.hidden.len(), 1, "{saved:?}");
    assert!(saved.hidden[0].path.ends_with(&name), "{saved:?}");
    key("u");
    let (_, _, shown) = shot(&mut viewer);
    let left = differing_fraction(&start, &shown);
    assert!(
        left < 0.002,
        "after U {left:.4} of the view differs from the start"
    );
    // 1 restores view 1: hidden again.
    let before = said("restored \"view 1\"");
    key("1");
    wait_for_log(&view_log, "restored \"view 1\"", before, &mut viewer);
    let (_, _, restored) = shot(&mut viewer);
    let off = differing_fraction(&hidden, &restored);
    assert!(
        off < 0.002,
        "view 1 restored differs from it in {off:.4} of the view"
    );
    key("u");
    // / opens the search prompt; Esc there cancels it (and does not quit).
    key("slash");
    xdotool(d, &["type", "--window", w, "zz"]);
    key("Escape");
    // / NAME Enter selects the first object it matches (the name may
    // appear in others') and flies to frame it.
    let before = said("selected: ");
    key("slash");
    xdotool(d, &["type", "--window", w, &name]);
    key("Return");
    let log = wait_for_log(&view_log, "selected: ", before, &mut viewer);
    let found = log.lines().rfind(|l| l.starts_with("selected: ")).unwrap();
    assert!(
        found.to_lowercase().contains(&name.to_lowercase()),
        "searching {name:?} selected {found:?}"
    );
    let (_, _, framed) = shot(&mut viewer);
    let flew = differing_fraction(&start, &framed);
    assert!(flew > 0.01, "framing {name} changed {flew:.4} of the view");
    // Back to the start's camera for what follows; nothing hidden.
    key("1");
    key("u");
    let (_, _, back_at_start) = shot(&mut viewer);
    let off = differing_fraction(&start, &back_at_start);
    assert!(
        off < 0.002,
        "view 1 is not the start's camera: {off:.4} differs"
    );
    // W held: the view moves forward.
    hold("w", 1500);
    let (_, _, forward) = shot(&mut viewer);
    let moved = differing_fraction(&start, &forward);
    // A still camera redraws the same pixels exactly (0.0); 1.5 s at the
    // default speed changes a few percent of this view.
    assert!(moved > 0.01, "holding W changed {moved:.3} of the view");
    // T: wireframe, then back.
    key("t");
    let (_, _, wire) = shot(&mut viewer);
    let (ws, fs) = (
        gigawalk_viewer::image_stats(&wire),
        gigawalk_viewer::image_stats(&forward),
    );
    assert!(
        ws.distinct_colours * 4 < fs.distinct_colours,
        "wireframe {ws:?} vs shaded {fs:?}"
    );
    key("t");
    // B: node boxes over the same still view; they add lines, mostly the
    // green of drawn nodes (culled ones are off-screen or hidden).
    let (_, _, plain) = shot(&mut viewer);
    // The camera is still: the same frame again, pixel for pixel, so what
    // changes next is the boxes alone.
    let (_, _, again) = shot(&mut viewer);
    assert_eq!(
        differing_fraction(&plain, &again),
        0.0,
        "a still view changed"
    );
    // E, F2 and F3 (edges, ambient occlusion, FXAA) each change the still
    // view, and back; the viewer starts with edges on.
    for k in ["e", "F2", "F3"] {
        key(k);
        let (_, _, toggled) = shot(&mut viewer);
        let d = differing_fraction(&plain, &toggled);
        assert!(d > 0.002, "{k} changed {d:.4} of the view");
        key(k);
        let (_, _, back) = shot(&mut viewer);
        assert_eq!(differing_fraction(&plain, &back), 0.0, "{k} twice");
    }
    key("b");
    let (_, _, boxed) = shot(&mut viewer);
    let changed: Vec<&[u8]> = plain
        .chunks(4)
        .zip(boxed.chunks(4))
        .filter(|(a, b)| a != b)
        .map(|(_, b)| b)
        .collect();
    assert!(
        changed.len() * 200 > plain.len() / 4,
        "boxes changed only {} pixels",
        changed.len()
    );
    let greenish = changed
        .iter()
        .filter(|p| p[1] > p[0] && p[1] > p[2])
        .count();
    assert!(
        greenish > 0,
        "no green (drawn) box pixels among {}",
        changed.len()
    );
    // Z: freeze culling, then fly: the view moves over the frozen set.
    key("z");
    hold("w", 800);
    let (_, _, frozen) = shot(&mut viewer);
    let moved = differing_fraction(&boxed, &frozen);
    assert!(
        moved > 0.01,
        "flying while frozen changed {moved:.3} of the view"
    );
    key("z");
    key("b");
    // R, look around with a drag, strafe, R: a recorded path.
    key("r");
    std::thread::sleep(Duration::from_millis(300));
    xdotool(d, &["mousemove", "--window", w, "240", "150"]);
    xdotool(d, &["mousedown", "1"]);
    for step in 1..=5 {
        let x = (240 + 30 * step).to_string();
        xdotool(d, &["mousemove", "--window", w, &x, "140"]);
        std::thread::sleep(Duration::from_millis(100));
    }
    xdotool(d, &["mouseup", "1"]);
    hold("d", 600);
    key("r");
    let recorded = out.join("gigawalk-view-1.path");
    wait_for(&recorded, &mut viewer);
    let rec = gigawalk_scene::path::CameraPath::read(&recorded).unwrap();
    assert!(rec.poses.len() >= 5, "{} poses recorded", rec.poses.len());
    let (first, last) = (rec.poses.first().unwrap(), rec.poses.last().unwrap());
    assert!(
        first.orientation.dot(last.orientation).abs() < 0.9999,
        "the drag did not turn the camera: {:?} -> {:?}",
        first.orientation,
        last.orientation
    );
    assert!(
        (first.position - last.position).length() > 0.1,
        "D did not move the camera: {:?} -> {:?}",
        first.position,
        last.position
    );
    // Resize: screenshots follow the window's new size.
    xdotool(d, &["windowsize", w, "640", "400"]);
    std::thread::sleep(Duration::from_millis(1000));
    let (w1, h1, _) = shot(&mut viewer);
    assert_eq!((w1, h1), (640, 400), "after the resize");
    // Hide and show the window (Xvfb has no window manager to minimise
    // it, so unmap it directly): the viewer keeps running.
    xdotool(d, &["windowunmap", "--sync", w]);
    std::thread::sleep(Duration::from_millis(1000));
    xdotool(d, &["windowmap", "--sync", w]);
    // Unmapping dropped the keyboard focus; a click would give it back.
    xdotool(d, &["windowfocus", "--sync", w]);
    let (_, _, back) = shot(&mut viewer);
    assert!(gigawalk_viewer::image_stats(&back).distinct_colours > 50);
    // Esc quits cleanly.
    key("Escape");
    let deadline = Instant::now() + Duration::from_secs(30);
    let status = loop {
        if let Some(status) = viewer.0.try_wait().unwrap() {
            break status;
        }
        assert!(Instant::now() < deadline, "Esc did not quit within 30 s");
        std::thread::sleep(Duration::from_millis(100));
    };
    let log = std::fs::read_to_string(dir.path().join("view.log")).unwrap();
    assert!(status.success(), "the viewer failed:\n{log}");
    assert!(!log.contains("panicked"), "{log}");

    // --view: a scripted run from the saved view shows what the live one
    // did with it (its camera, the object hidden).
    let png = dir.path().join("from-view.png");
    let (ok, _, err) = gigawalk(
        &[
            "view",
            s(&gwk),
            "--view",
            "view 1",
            "--frames",
            "4",
            "--screenshot",
            s(&png),
            "--width",
            "480",
            "--height",
            "300",
            "--no-hud",
            "--sky",
            "off",
            "--aa",
            "off",
        ],
        Some(d),
    );
    assert!(ok, "gigawalk view --view: {err}");
    let (_, _, from_view) = gigawalk_viewer::read_png(&png).unwrap();
    let off = differing_fraction(&hidden, &from_view);
    assert!(
        off < 0.002,
        "--view \"view 1\" differs from it live in {off:.4} of the view"
    );
    let (ok, _, err) = gigawalk(
        &["view", s(&gwk), "--view", "view 7", "--frames", "1"],
        Some(d),
    );
    assert!(!ok);
    assert!(
        err.contains("no view named \"view 7\" (the file has: \"view 1\")"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn bad_sections_are_clear_errors() {
    for (args, says) in [
        (&["--section", "0 0 0 1"][..], "normal is zero"),
        (&["--section", "1 0 0"], "3 numbers"),
        (
            &["--section-box", "0 0 0 -1 1 1"],
            "inverted: min x 0 is greater than max x -1",
        ),
    ] {
        let mut all = vec!["view", "x.gwk", "--frames", "1"];
        all.extend_from_slice(args);
        let (ok, _, err) = gigawalk(&all, None);
        assert!(!ok, "{args:?}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    let seven: Vec<&str> = ["--section", "1 0 0 0"].repeat(7);
    let mut all = vec!["view", "x.gwk"];
    all.extend(seven);
    let (ok, _, err) = gigawalk(&all, None);
    assert!(!ok);
    assert!(err.contains("at most 6"), "{err}");
}

/// Yellow pixels: the measurement's line and label (and little else in
/// the plant's greys, blues and greens).
fn measure_yellow(rgba: &[u8]) -> usize {
    rgba.chunks(4)
        .filter(|p| p[0] > 200 && p[1] > 170 && p[2] < 90)
        .count()
}

/// `gigawalk pick` between two pixels of the path's first pose on a 480
/// x 300 view, in millimetres: the distance, when both pixels show a
/// surface.
fn picked_distance(gwk: &Path, path: &Path, a: (u32, u32), b: (u32, u32)) -> Option<f64> {
    let (pa, pb) = (format!("{},{}", a.0, a.1), format!("{},{}", b.0, b.1));
    let (ok, out, err) = gigawalk(
        &[
            "pick",
            s(gwk),
            "--path",
            s(path),
            "--frame",
            "0",
            "--pixel",
            &pa,
            "--pixel",
            &pb,
            "--width",
            "480",
            "--height",
            "300",
            "--units",
            "mm",
            "--json",
        ],
        None,
    );
    assert!(ok, "gigawalk pick: {err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    v["distance"].as_f64()
}

/// Sections and a measurement, live: X places a plane at the cursor, ]
/// and Shift+scroll move it, \ flips it, 0 turns sections off and on, V
/// saves it into a view, Delete clears it, J boxes the selection; M and
/// two clicks measure what `gigawalk pick` measures between the same
/// pixels, drawn as a yellow line and label until M (or Esc) clears it.
/// Then scripted runs from the saved view and from `--section` show the
/// live cut.
#[test]
fn live_sections_and_a_measurement() {
    let Some(x) = live_display("gigawalk view (sections)") else {
        return;
    };
    let d = x.display.as_str();
    let dir = tempfile::tempdir().unwrap();
    let (gwk, path) = small_plant(dir.path());
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    let view_log = dir.path().join("view.log");
    let log = std::fs::File::create(&view_log).unwrap();
    let mut viewer = Viewer(
        Command::new(common::BIN)
            .args(["view", s(&gwk), "--path", s(&path), "--no-hud"])
            .args(["--sky", "off", "--aa", "off"])
            .args(["--width", "480", "--height", "300", "--out-dir", s(&out)])
            .args(["--units", "mm"])
            .env("DISPLAY", d)
            .env_remove("WAYLAND_DISPLAY")
            .stdout(log.try_clone().unwrap())
            .stderr(log)
            .spawn()
            .unwrap(),
    );
    let window = wait_for_window(d, &mut viewer, &view_log);
    let w = window.as_str();
    xdotool(d, &["windowfocus", "--sync", w]);
    let key = |k: &str| {
        if let Err(e) = try_xdotool(d, &["key", "--window", w, k]) {
            panic!(
                "{e}\nthe viewer's output:\n{}",
                std::fs::read_to_string(&view_log).unwrap_or_default()
            );
        }
    };
    let said = |needle: &str| {
        std::fs::read_to_string(&view_log)
            .unwrap_or_default()
            .matches(needle)
            .count()
    };
    let click_at = |(x, y): (u32, u32)| {
        xdotool(
            d,
            &["mousemove", "--window", w, &x.to_string(), &y.to_string()],
        );
        xdotool(d, &["click", "1"]);
    };
    let mut shots = 0;
    let mut shot = |viewer: &mut Viewer| {
        std::thread::sleep(Duration::from_millis(400));
        key("p");
        shots += 1;
        let file = out.join(format!("gigawalk-view-{shots}.png"));
        wait_for(&file, viewer);
        gigawalk_viewer::read_png(&file).unwrap().2
    };
    let start = shot(&mut viewer);
    let ((px, py), _) = pixel_on_an_object(&gwk, &path, 480, 300);

    // X at an object: a plane through it facing the camera cuts away
    // what is in front.
    xdotool(
        d,
        &["mousemove", "--window", w, &px.to_string(), &py.to_string()],
    );
    key("x");
    wait_for_log(&view_log, "section plane 1 of 6", 0, &mut viewer);
    let cut = shot(&mut viewer);
    let changed = differing_fraction(&start, &cut);
    assert!(changed > 0.01, "the plane changed {changed:.4} of the view");
    // ] moves it along its normal: more is cut away.
    for _ in 0..3 {
        key("bracketright");
    }
    let moved = shot(&mut viewer);
    let changed = differing_fraction(&cut, &moved);
    assert!(changed > 0.001, "moving the plane changed {changed:.4}");
    // Shift+scroll moves it too (XTEST, so the modifier state changes).
    xdotool(d, &["keydown", "shift"]);
    for _ in 0..3 {
        xdotool(d, &["click", "4"]);
    }
    xdotool(d, &["keyup", "shift"]);
    let scrolled = shot(&mut viewer);
    let changed = differing_fraction(&moved, &scrolled);
    assert!(changed > 0.001, "Shift+scroll changed {changed:.4}");
    // \ flips it: the other side shows.
    key("backslash");
    let flipped = shot(&mut viewer);
    let changed = differing_fraction(&scrolled, &flipped);
    assert!(changed > 0.01, "flipping changed {changed:.4}");
    // 0: off shows the whole view again; on cuts again.
    key("0");
    let off = shot(&mut viewer);
    let left = differing_fraction(&start, &off);
    assert!(
        left < 0.002,
        "sections off: {left:.4} differs from the start"
    );
    key("0");
    let on = shot(&mut viewer);
    let off_by = differing_fraction(&flipped, &on);
    assert!(off_by < 0.002, "sections on again: {off_by:.4} differs");
    // V saves the plane with the view.
    let views_file = gwk.with_file_name("p.gwk.views.json");
    key("v");
    wait_for(&views_file, &mut viewer);
    let views = gigawalk_scene::views::Views::read(&views_file).unwrap();
    let section = views.views[0].section.clone().expect("the view's section");
    assert_eq!(section.planes.len(), 1, "{section:?}");
    assert_eq!(section.bbox, None);
    // Delete clears it.
    let before = said("sections cleared");
    key("Delete");
    wait_for_log(&view_log, "sections cleared", before, &mut viewer);
    let cleared = shot(&mut viewer);
    let left = differing_fraction(&start, &cleared);
    assert!(
        left < 0.002,
        "after Delete {left:.4} differs from the start"
    );

    // J with an object selected: a box around it; most of the plant goes.
    let before = said("selected: ");
    click_at((px, py));
    wait_for_log(&view_log, "selected: ", before, &mut viewer);
    let selected = shot(&mut viewer);
    key("j");
    wait_for_log(&view_log, "section box", 0, &mut viewer);
    let boxed = shot(&mut viewer);
    let changed = differing_fraction(&selected, &boxed);
    assert!(changed > 0.01, "the box changed {changed:.4} of the view");
    key("Delete");
    // H ends the selection, U shows the object again; J with nothing
    // selected boxes what is in view.
    key("h");
    key("u");
    let before = said("section box");
    key("j");
    wait_for_log(&view_log, "section box", before, &mut viewer);
    let before = said("sections cleared");
    key("Delete");
    wait_for_log(&view_log, "sections cleared", before, &mut viewer);

    // M, then two clicks: the distance `gigawalk pick` measures between
    // the same pixels of the same camera.
    let (a, b, want) = [
        (px, py / 2),
        (px / 2, py),
        (px, (py + 300) / 2),
        (480 - px / 2, py),
    ]
    .into_iter()
    .filter(|&b| b != (px, py))
    .find_map(|b| picked_distance(&gwk, &path, (px, py), b).map(|l| ((px, py), b, l)))
    .expect("a second pixel that shows a surface");
    let before_measure = shot(&mut viewer);
    key("m");
    let before = said("measured ");
    click_at(a);
    // Apart in time: two clicks close together would be a double click.
    std::thread::sleep(Duration::from_millis(500));
    click_at(b);
    let text = wait_for_log(&view_log, "measured ", before, &mut viewer);
    let line = text.lines().rfind(|l| l.starts_with("measured ")).unwrap();
    let got: f64 = line["measured ".len()..]
        .split(' ')
        .next()
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no number in {line:?}"));
    assert!(
        (got - want).abs() <= 1e-5 * want.max(1e-9),
        "the viewer measured {got} ({line:?}), gigawalk pick {want}"
    );
    assert!(
        line.contains(" mm (") && line.contains(" m) between"),
        "{line}"
    );
    let measured = shot(&mut viewer);
    let (y0, y1) = (measure_yellow(&before_measure), measure_yellow(&measured));
    assert!(
        y1 > y0 + 100,
        "the line and label added {} yellow pixels",
        y1 as i64 - y0 as i64
    );
    // M clears it: the view as before.
    key("m");
    let cleared = shot(&mut viewer);
    let left = differing_fraction(&before_measure, &cleared);
    assert!(
        left < 0.002,
        "after M {left:.4} differs from before measuring"
    );
    // Esc clears a measurement rather than quitting; the next Esc quits.
    key("m");
    click_at(a);
    std::thread::sleep(Duration::from_millis(500));
    let before = said("measured ");
    click_at(b);
    wait_for_log(&view_log, "measured ", before, &mut viewer);
    let before = said("measurement cleared");
    key("Escape");
    wait_for_log(&view_log, "measurement cleared", before, &mut viewer);
    assert!(viewer.0.try_wait().unwrap().is_none(), "Esc quit");
    key("Escape");
    let deadline = Instant::now() + Duration::from_secs(30);
    let status = loop {
        if let Some(status) = viewer.0.try_wait().unwrap() {
            break status;
        }
        assert!(Instant::now() < deadline, "Esc did not quit within 30 s");
        std::thread::sleep(Duration::from_millis(100));
    };
    let log = std::fs::read_to_string(&view_log).unwrap();
    assert!(status.success(), "the viewer failed:\n{log}");
    assert!(!log.contains("panicked"), "{log}");

    // Scripted runs show the live cut: from the saved view, and from the
    // same plane on the command line.
    let p = section.planes[0];
    let plane = format!("{} {} {} {}", p[0], p[1], p[2], p[3]);
    // The path's first pose alone: a scripted run follows its path.
    let mut first = gigawalk_scene::path::CameraPath::read(&path).unwrap();
    first.poses.truncate(1);
    let first_path = dir.path().join("first.path");
    first.write(&first_path).unwrap();
    for (what, extra) in [
        ("--view", vec!["--view", "view 1"]),
        (
            "--section",
            vec!["--path", s(&first_path), "--section", &plane],
        ),
    ] {
        let png = dir.path().join("scripted.png");
        let mut args = vec![
            "view",
            s(&gwk),
            "--frames",
            "4",
            "--screenshot",
            s(&png),
            "--width",
            "480",
            "--height",
            "300",
            "--no-hud",
            "--sky",
            "off",
            "--aa",
            "off",
        ];
        args.extend(extra);
        let (ok, _, err) = gigawalk(&args, Some(d));
        assert!(ok, "gigawalk view {what}: {err}");
        let scripted = gigawalk_viewer::read_png(&png).unwrap().2;
        let off = differing_fraction(&flipped, &scripted);
        assert!(off < 0.002, "{what}: {off:.4} differs from the live cut");
    }
}
