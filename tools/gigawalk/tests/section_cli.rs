//! `--section` and `--section-box` on the command line: pick finds the
//! nearest surface the section keeps and measures between two pixels;
//! replay reports the section and what it dropped, also from a saved
//! view; bad planes and boxes get clear messages, and a section that
//! keeps nothing a warning.

mod common;

use common::{gigawalk, json, null_replay, s, small_plant as plant};

fn point(v: &serde_json::Value) -> [f64; 3] {
    let p = v["point"].as_array().unwrap();
    [0, 1, 2].map(|i| p[i].as_f64().unwrap())
}

#[test]
fn pick_measures_between_two_pixels_and_respects_the_section() {
    let dir = tempfile::tempdir().unwrap();
    let (path, gwk) = plant(dir.path());
    let pick = |pixels: &[&str], more: &[&str]| {
        let mut a = vec!["pick", s(&gwk), "--path", s(&path), "--frame", "6"];
        for p in pixels {
            a.extend(["--pixel", p]);
        }
        a.extend_from_slice(more);
        gigawalk(&a)
    };
    // Two pixels that show something.
    let mut hits = Vec::new();
    'search: for y in (30..360).step_by(50) {
        for x in (30..640).step_by(70) {
            let pixel = format!("{x},{y}");
            let (ok, out, err) = pick(&[&pixel], &["--json"]);
            assert!(ok, "{err}");
            if !json(&out)["object"].is_null() {
                hits.push(pixel);
                if hits.len() == 2 {
                    break 'search;
                }
            }
        }
    }
    assert_eq!(hits.len(), 2, "the walk's middle pose shows little");
    let (a, b) = (hits[0].as_str(), hits[1].as_str());
    let (ok, out, err) = pick(&[a, b], &["--json", "--units", "mm"]);
    assert!(ok, "{err}");
    let v = json(&out);
    let (p, q) = (point(&v["picks"][0]), point(&v["picks"][1]));
    let d = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
    let distance = v["distance"].as_f64().unwrap();
    assert!(
        (distance - d).abs() <= 1e-12 * d.max(1.0),
        "{distance} against {d}"
    );
    assert!((v["distance_m"].as_f64().unwrap() - d / 1000.0).abs() <= 1e-12 * d);
    assert_eq!(v["units"], "mm");
    let (ok, text, err) = pick(&[a, b], &["--units", "mm"]);
    assert!(
        ok && text.contains("measured  ") && text.contains(" mm (") && text.contains(" m)"),
        "{text}{err}"
    );
    // A section keeping y >= the first hit's y + 0.01 removes that
    // surface: the pick there finds a farther kept point, or nothing.
    let first = json(&pick(&[a], &["--json"]).1);
    let y = point(&first)[1] + 0.01;
    let plane = format!("0 1 0 {}", -y);
    let (ok, out, err) = pick(&[a], &["--json", "--section", &plane]);
    assert!(ok, "{err}");
    let cut = json(&out);
    if !cut["point"].is_null() {
        assert!(point(&cut)[1] >= y - 1e-9, "{out}");
        assert!(cut["distance"].as_f64().unwrap() >= first["distance"].as_f64().unwrap());
    }
    // Nothing at one pixel: no distance.
    let away = dir.path().join("away.path");
    std::fs::write(&away, "0 500 500 500 0 0 0 1 60\n").unwrap();
    let (ok, out, err) = gigawalk(&[
        "pick",
        s(&gwk),
        "--path",
        s(&away),
        "--frame",
        "0",
        "--pixel",
        "1,1",
        "--pixel",
        "2,2",
        "--json",
    ]);
    assert!(ok, "{err}");
    assert!(json(&out)["distance"].is_null(), "{out}");
    // Bad input.
    let (ok, _, err) = pick(&[a, b, a], &[]);
    assert!(!ok && err.contains("--pixel given 3 times"), "{err}");
    let (ok, _, err) = pick(&[a], &["--units", "parsec"]);
    assert!(!ok && err.contains("unknown unit \"parsec\""), "{err}");
    let (ok, _, err) = pick(&[a], &["--section", "0 0 0 1"]);
    assert!(!ok && err.contains("normal is zero"), "{err}");
    let (ok, _, err) = pick(&[a], &["--section", "1 0 0"]);
    assert!(!ok && err.contains("3 numbers"), "{err}");
    let (ok, _, err) = pick(&[a], &["--section-box", "1 1 1 0 0 0"]);
    assert!(!ok && err.contains("inverted"), "{err}");
    let seven: Vec<&str> = (0..7).flat_map(|_| ["--section", "1 0 0 0"]).collect();
    let (ok, _, err) = pick(&[a], &seven);
    assert!(!ok && err.contains("at most 6"), "{err}");
    // A box beside the model keeps nothing: said, and nothing is picked.
    let (ok, out, err) = pick(
        &[a],
        &["--json", "--section-box", "1e6 1e6 1e6 1e6 1e6 1e6"],
    );
    assert!(ok && err.contains("keeps nothing of the model"), "{err}");
    assert!(json(&out)["object"].is_null(), "{out}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn replay_reports_the_section_also_from_a_saved_view() {
    let dir = tempfile::tempdir().unwrap();
    let (path, gwk) = plant(dir.path());
    let out = dir.path().join("report");
    let replay = |more: &[&str]| null_replay(&gwk, &out, more);
    let summary = || json(&std::fs::read_to_string(out.join("summary.json")).unwrap());
    let (ok, _, err) = replay(&["--path", s(&path)]);
    assert!(ok, "{err}");
    let whole = summary();
    assert!(whole["section"].is_null());
    // Keep x <= 0 (the plant straddles it).
    let (ok, _, err) = replay(&["--path", s(&path), "--section", "-1 0 0 0"]);
    assert!(ok, "{err}");
    let cut = summary();
    assert!(
        cut["section"].as_str().unwrap().contains("plane -1 0 0 0"),
        "{cut}"
    );
    let (w, c) = (&whole["modes"][0], &cut["modes"][0]);
    assert!(c["mean_section_culled"].as_f64().unwrap() > 0.0, "{c}");
    assert!(c["mean_triangles"].as_f64().unwrap() < w["mean_triangles"].as_f64().unwrap());
    assert!(std::fs::read_to_string(out.join("summary.md"))
        .unwrap()
        .contains("**Section: plane -1 0 0 0"));
    // A box that keeps nothing: a warning, and empty frames.
    let (ok, _, err) = replay(&[
        "--path",
        s(&path),
        "--section-box",
        "1e6 1e6 1e6 2e6 2e6 2e6",
    ]);
    assert!(ok && err.contains("keeps nothing of the model"), "{err}");
    assert_eq!(
        summary()["modes"][0]["mean_triangles"].as_f64().unwrap(),
        0.0
    );
    // A saved view's section, and a bad one.
    let views = dir.path().join("p.gwk.views.json");
    let view = |section: serde_json::Value| {
        let text = serde_json::json!({
            "version": 1,
            "views": [{
                "name": "cut",
                "position": [40.0, 12.0, 40.0],
                "orientation": [0.0, 0.0, 0.0, 1.0],
                "fovy_deg": 60.0,
                "section": section,
            }]
        });
        std::fs::write(&views, serde_json::to_string(&text).unwrap()).unwrap();
    };
    view(serde_json::json!({"planes": [[0.0, -1.0, 0.0, 5.0]]}));
    let (ok, _, err) = replay(&["--view", "cut"]);
    assert!(ok, "{err}");
    assert!(summary()["section"]
        .as_str()
        .unwrap()
        .contains("plane 0 -1 0 5"));
    // The command line's section replaces the view's.
    let (ok, _, err) = replay(&["--view", "cut", "--section-box", "0 0 0 10 10 10"]);
    assert!(ok, "{err}");
    let s2 = summary()["section"].as_str().unwrap().to_string();
    assert!(
        s2.contains("box 0 0 0 .. 10 10 10") && !s2.contains("plane"),
        "{s2}"
    );
    view(serde_json::json!({"box": [1.0, 0.0, 0.0, 0.0, 1.0, 1.0]}));
    let (ok, _, err) = replay(&["--view", "cut"]);
    assert!(
        !ok && err.contains("the saved view's section") && err.contains("inverted"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}
