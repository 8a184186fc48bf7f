//! `gigawalk pick`, `find`, and `replay --hide/--isolate/--view` from the
//! command line: what they print, and the clear errors of bad input (a
//! pattern that matches nothing, a pixel outside the viewport, a corrupt
//! views file or one naming objects the scene no longer has, a scene
//! written before object identity).

mod common;

use std::path::Path;

use common::{gigawalk, gigawalk_ok, json, null_replay, s, small_plant as plant};

/// The arguments of `gigawalk pick SCENE --path PATH --frame FRAME
/// --pixel PIXEL MORE...`.
fn pick_args<'a>(
    gwk: &'a Path,
    path: &'a Path,
    frame: &'a str,
    pixel: &'a str,
    more: &[&'a str],
) -> Vec<&'a str> {
    let mut a = vec![
        "pick",
        s(gwk),
        "--path",
        s(path),
        "--frame",
        frame,
        "--pixel",
        pixel,
    ];
    a.extend_from_slice(more);
    a
}

/// CRC-32 (IEEE), as the scene header and table of contents use.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                (c >> 1) ^ 0xEDB8_8320
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// The scene as a writer from before object identity made it: its OBJT
/// section renamed to a tag no reader knows (optional, so skipped), the
/// table of contents' and header's checksums made good again.
fn without_identity(gwk: &Path, out: &Path) {
    let mut b = std::fs::read(gwk).unwrap();
    let u32_at = |b: &[u8], at: usize| u32::from_le_bytes(b[at..at + 4].try_into().unwrap());
    let count = u32_at(&b, 12) as usize;
    let toc = u64::from_le_bytes(b[16..24].try_into().unwrap()) as usize;
    let entry = (0..count)
        .map(|i| toc + 32 * i)
        .find(|&e| &b[e..e + 4] == b"OBJT")
        .expect("a new scene has OBJT");
    b[entry..entry + 4].copy_from_slice(b"ZZZZ");
    let toc_crc = crc32(&b[toc..toc + 32 * count]);
    b[32..36].copy_from_slice(&toc_crc.to_le_bytes());
    let header_crc = crc32(&b[..60]);
    b[60..64].copy_from_slice(&header_crc.to_le_bytes());
    std::fs::write(out, b).unwrap();
}

#[test]
fn pick_and_find_answer_and_bad_input_gets_a_clear_message() {
    let dir = tempfile::tempdir().unwrap();
    let (path, gwk) = plant(dir.path());
    // Find: text and JSON, every object with a box.
    let out = gigawalk_ok(&["find", s(&gwk), "pipe", "--json"]);
    let found = json(&out.stdout);
    let found = found.as_array().unwrap();
    assert!(!found.is_empty());
    for o in found {
        assert!(
            o["name"].as_str().unwrap().to_lowercase().contains("pipe")
                || o["path"].as_str().unwrap().to_lowercase().contains("pipe")
        );
        assert_eq!(o["bounds"]["min"].as_array().unwrap().len(), 3);
    }
    let (ok, _, err) = gigawalk(&["find", s(&gwk), "no-such-object"]);
    assert!(
        !ok && err.contains("no object matches \"no-such-object\""),
        "{err}"
    );
    // Pick: some pixel of the walk's middle pose shows an object.
    let mut hit = None;
    'search: for y in (20..360).step_by(40) {
        for x in (20..640).step_by(60) {
            let pixel = format!("{x},{y}");
            let out = gigawalk_ok(&pick_args(&gwk, &path, "6", &pixel, &["--json"]));
            let v = json(&out.stdout);
            if !v["object"].is_null() {
                hit = Some((pixel, v));
                break 'search;
            }
        }
    }
    let (pixel, v) = hit.expect("the walk's middle pose shows something");
    assert!(
        v["object"]["name"].is_string() && v["object"]["file"].as_str().unwrap().ends_with("p.glb")
    );
    assert_eq!(v["point"].as_array().unwrap().len(), 3);
    assert!(v["distance"].as_f64().unwrap() > 0.0);
    let text = gigawalk_ok(&pick_args(&gwk, &path, "6", &pixel, &[]));
    assert!(
        text.stdout.contains(v["object"]["name"].as_str().unwrap()),
        "{}",
        text.stdout
    );
    // Nothing there: looking away from the plant.
    let away = dir.path().join("away.path");
    std::fs::write(&away, "0 500 500 500 0 0 0 1 60\n").unwrap();
    let out = gigawalk_ok(&pick_args(&gwk, &away, "0", "10,10", &["--json"]));
    assert!(json(&out.stdout)["object"].is_null(), "{}", out.stdout);
    // Bad pixels, frames and viewports.
    let (ok, _, err) = gigawalk(&pick_args(&gwk, &path, "0", "640,10", &[]));
    assert!(!ok && err.contains("outside the 640x360 viewport"), "{err}");
    let (ok, _, err) = gigawalk(&pick_args(
        &gwk,
        &path,
        "0",
        "5,5",
        &["--width", "4", "--height", "4"],
    ));
    assert!(!ok && err.contains("outside the 4x4 viewport"), "{err}");
    let (ok, _, err) = gigawalk(&pick_args(&gwk, &path, "12", "1,1", &[]));
    assert!(
        !ok && err.contains("pose 12 asked for, the path has 12"),
        "{err}"
    );
    let (ok, _, err) = gigawalk(&pick_args(&gwk, &path, "0", "1;1", &[]));
    assert!(!ok && err.contains("a pixel is X,Y"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn a_scene_from_before_object_identity_says_to_preprocess_again() {
    let dir = tempfile::tempdir().unwrap();
    let (path, gwk) = plant(dir.path());
    let old = dir.path().join("old.gwk");
    without_identity(&gwk, &old);
    let again = "preprocess the model again";
    let (ok, _, err) = gigawalk(&["find", s(&old), "pipe"]);
    assert!(
        !ok && err.contains(again) && err.contains("old.gwk"),
        "{err}"
    );
    let (ok, _, err) = gigawalk(&pick_args(&old, &path, "0", "1,1", &[]));
    assert!(!ok && err.contains(again), "{err}");
    // Everything else still works.
    let info = gigawalk_ok(&["info", s(&old), "--verify"]);
    assert!(info.stdout.contains("none recorded"), "{}", info.stdout);
    let out = dir.path().join("report");
    gigawalk_ok(&[
        "replay",
        s(&old),
        "--path",
        s(&path),
        "--out",
        s(&out),
        "--adapter",
        "null",
        "--modes",
        "vfc",
    ]);
    let (ok, _, err) = gigawalk(&[
        "replay",
        s(&old),
        "--path",
        s(&path),
        "--out",
        s(&out),
        "--adapter",
        "null",
        "--hide",
        "pipe",
    ]);
    assert!(!ok && err.contains(again), "{err}");
}

#[test]
fn replay_hides_what_is_asked_and_says_what_it_cannot() {
    let dir = tempfile::tempdir().unwrap();
    let (path, gwk) = plant(dir.path());
    let out = dir.path().join("report");
    let replay = |more: &[&str]| null_replay(&gwk, &out, more);
    let (ok, _, err) = replay(&["--path", s(&path), "--hide", "pipe"]);
    assert!(ok, "{err}");
    assert!(err.contains("hiding ") && err.contains(" objects"), "{err}");
    let (ok, _, err) = replay(&["--path", s(&path), "--isolate", "pipe"]);
    assert!(ok, "{err}");
    let (ok, _, err) = replay(&["--path", s(&path), "--hide", "no-such-object"]);
    assert!(
        !ok && err.contains("\"no-such-object\": matches none of the scene's"),
        "{err}"
    );
    // A streamed scene hides too: no stand-in holds a hidden object.
    let (ok, _, err) = replay(&[
        "--path",
        s(&path),
        "--hide",
        "pipe",
        "--memory-budget",
        "64k",
    ]);
    assert!(ok && err.contains("hiding "), "{err}");
    // Saved views: a view replays alone, with its hidden objects; names
    // the scene no longer has are a warning; a corrupt file an error.
    let views = dir.path().join("p.gwk.views.json");
    let pipe = json(&gigawalk_ok(&["find", s(&gwk), "pipe", "--json"]).stdout)[0].clone();
    let text = serde_json::json!({
        "version": 1,
        "views": [{
            "name": "pipes gone",
            "position": [40.0, 12.0, 40.0],
            "orientation": [0.0, 0.0, 0.0, 1.0],
            "fovy_deg": 60.0,
            "hidden": [
                {"id": pipe["id"], "path": format!("{}/{}", pipe["file"].as_str().unwrap(), pipe["path"].as_str().unwrap())},
                {"id": 999999, "path": "gone.glb/nothing"}
            ]
        }]
    });
    std::fs::write(&views, serde_json::to_string(&text).unwrap()).unwrap();
    let (ok, _, err) = replay(&["--view", "pipes gone"]);
    assert!(ok, "{err}");
    assert!(
        err.contains("names 1 object(s) this scene no longer has")
            && err.contains("gone.glb/nothing"),
        "{err}"
    );
    let (ok, _, err) = replay(&["--view", "no such view"]);
    assert!(
        !ok && err.contains("no view named \"no such view\"") && err.contains("\"pipes gone\""),
        "{err}"
    );
    std::fs::write(&views, "{\"version\": 1, \"views\": [{\"name\": ").unwrap();
    let (ok, _, err) = replay(&["--view", "pipes gone"]);
    assert!(
        !ok && err.contains("p.gwk.views.json") && err.contains("not a saved-views file"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}
