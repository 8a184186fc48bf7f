//! Generate -> import: what the generator reports is what an importer
//! reads back, for every kind; same seed, same bytes.

use gigawalk_import::import_glb_bytes;
use gigawalk_procgen::{generate, Kind, EYE_HEIGHT};
use gigawalk_scene::Aabb;

const KINDS: [Kind; 4] = [Kind::Plant, Kind::City, Kind::Forest, Kind::Machine];

fn check_round_trip(kind: Kind, triangles: u64) {
    let g = generate(kind, triangles, 7, 200);
    let bytes = g.glb_bytes();
    let model = import_glb_bytes(&bytes, kind.name()).unwrap();
    let r = &g.report;
    assert_eq!(model.stats.degenerate_triangles_dropped, 0, "{kind:?}");
    assert_eq!(model.stats.triangles, r.triangles, "{kind:?}");
    assert_eq!(model.objects.len(), r.objects, "{kind:?}");
    let bounds = Aabb::from_points(
        model
            .objects
            .iter()
            .flat_map(|o| o.positions.iter().copied()),
    );
    // Same f64 arithmetic on both sides; rotated and scaled instances may
    // still differ in the last bit.
    let tol = 1e-12 * r.bounds.diagonal();
    assert!(
        (bounds.min - r.bounds.min).abs().max_element() <= tol
            && (bounds.max - r.bounds.max).abs().max_element() <= tol,
        "{kind:?}: imported {bounds:?}, reported {:?}",
        r.bounds
    );
    // Within 3 % of the request (the small parts fill the remainder).
    let err = (r.triangles as f64 - triangles as f64).abs() / triangles as f64;
    assert!(
        err < 0.03,
        "{kind:?}: asked {triangles}, got {}",
        r.triangles
    );
    assert!(r.triangles <= triangles, "{kind:?} overshoots");
}

#[test]
fn plant_round_trips() {
    check_round_trip(Kind::Plant, 60_000);
}

#[test]
fn city_round_trips() {
    check_round_trip(Kind::City, 70_000);
}

#[test]
fn forest_round_trips() {
    check_round_trip(Kind::Forest, 60_000);
}

#[test]
fn machine_round_trips() {
    check_round_trip(Kind::Machine, 120_000);
}

#[test]
fn tiny_budgets_still_round_trip() {
    for kind in KINDS {
        check_round_trip(kind, 10_000);
    }
}

#[test]
fn same_seed_same_bytes_other_seed_other_scene() {
    for kind in KINDS {
        let a = generate(kind, 20_000, 3, 50);
        let b = generate(kind, 20_000, 3, 50);
        let c = generate(kind, 20_000, 4, 50);
        assert!(a.glb_bytes() == b.glb_bytes(), "{kind:?}");
        assert_eq!(a.path, b.path);
        assert!(a.glb_bytes() != c.glb_bytes(), "{kind:?}");
        assert_ne!(a.path, c.path);
    }
}

#[test]
fn scenes_have_many_objects_over_orders_of_magnitude() {
    // A machine's objects are whole subassemblies (one mesh per
    // subassembly and material); its parts' sizes are checked over its
    // connected pieces in tests/machine.rs.
    for kind in [Kind::Plant, Kind::City, Kind::Forest] {
        let g = generate(kind, 100_000, 1, 10);
        let model = import_glb_bytes(&g.glb_bytes(), kind.name()).unwrap();
        let diag =
            |o: &gigawalk_import::Object| Aabb::from_points(o.positions.iter().copied()).diagonal();
        let sizes: Vec<f64> = model.objects.iter().map(diag).collect();
        let max = sizes.iter().cloned().fold(0.0, f64::max);
        let min = sizes.iter().cloned().fold(f64::INFINITY, f64::min);
        assert!(max / min >= 1e3, "{kind:?}: sizes {min}..{max}");
        assert!(
            model.objects.len() >= 300,
            "{kind:?}: {} objects",
            model.objects.len()
        );
    }
}

#[test]
fn path_walks_at_eye_height_inside_the_scene() {
    for kind in KINDS {
        let g = generate(kind, 50_000, 2, 300);
        let p = &g.path.poses;
        assert_eq!(p.len(), 300);
        let b = g.report.bounds;
        let mut moved = 0.0;
        let mut max_step: f64 = 0.0;
        for w in p.windows(2) {
            assert!(w[1].time > w[0].time);
            let step = (w[1].position - w[0].position).length();
            moved += step;
            max_step = max_step.max(step);
        }
        for pose in p {
            assert!((pose.position.y - EYE_HEIGHT).abs() < 1e-9, "{kind:?}");
            assert!(
                b.contains_point(pose.position),
                "{kind:?}: {:?} outside {b:?}",
                pose.position
            );
            assert!((pose.orientation.length() - 1.0).abs() < 1e-12);
        }
        assert!(moved > 20.0, "{kind:?}: walked only {moved} m");
        assert!(
            max_step <= 1.2 + 1e-9,
            "{kind:?}: fastest step {max_step} m"
        );
        // The written text parses back.
        let back = gigawalk_scene::path::CameraPath::parse(&g.path.to_text()).unwrap();
        assert_eq!(back.poses.len(), 300);
    }
}

/// A scene written in pieces imports as the whole: every object once, the
/// reported triangles and bounds, and pieces of about equal triangles.
#[test]
fn pieces_import_as_the_whole_scene() {
    for (kind, parts) in [(Kind::Plant, 3), (Kind::Machine, 4), (Kind::City, 1)] {
        let g = generate(kind, 80_000, 5, 50);
        let whole = import_glb_bytes(&g.glb_bytes(), "whole").unwrap();
        let pieces = g.split(parts);
        assert_eq!(pieces.len(), parts, "{kind:?}");
        let mut objects = Vec::new();
        let mut bounds = Aabb::EMPTY;
        for (k, piece) in pieces.iter().enumerate() {
            let mut bytes = Vec::new();
            let (n, report) = g.write_glb_part(piece, &mut bytes).unwrap();
            assert_eq!(n as usize, bytes.len());
            let model = import_glb_bytes(&bytes, &format!("piece {k}")).unwrap();
            assert_eq!(
                model.stats.triangles, report.triangles,
                "{kind:?} piece {k}"
            );
            assert_eq!(model.objects.len(), report.objects, "{kind:?} piece {k}");
            let share = g.report.triangles as f64 / parts as f64;
            assert!(
                (report.triangles as f64 - share).abs() < 0.5 * share,
                "{kind:?} piece {k}: {} triangles of {}",
                report.triangles,
                g.report.triangles
            );
            bounds = bounds.union(&report.bounds);
            objects.extend(model.objects);
        }
        // The same objects, in whatever order the pieces list them (and
        // numbered in each file's own node and mesh lists).
        let key = |o: &gigawalk_import::Object| {
            let p = o.positions[0];
            (
                o.identity.name.clone(),
                o.indices.len(),
                [p.x, p.y, p.z].map(f64::to_bits),
            )
        };
        let mut got: Vec<_> = objects.iter().map(key).collect();
        let mut want: Vec<_> = whole.objects.iter().map(key).collect();
        got.sort();
        want.sort();
        assert_eq!(got, want, "{kind:?}");
        assert_eq!(bounds, g.report.bounds, "{kind:?}");
    }
    // More pieces than objects: one object each, none empty.
    let g = generate(Kind::Plant, 2_000, 1, 10);
    let pieces = g.split(g.report.objects + 5);
    assert_eq!(pieces.len(), g.report.objects);
}
