//! The preprocessor's promises on generated plant, city and forest scenes:
//! every triangle in exactly one leaf's finest LOD, a valid tree with
//! nesting boxes and monotone errors, leaves meeting the Partition-II
//! targets, and identical bytes for identical input.

use gigawalk_import::import_glb_bytes;
use gigawalk_preprocess::partition::{SplitAt, SplitRule};
use gigawalk_preprocess::verify::verify;
use gigawalk_preprocess::{preprocess, NoProgress, Params};
use gigawalk_procgen::{generate, Kind};
use gigawalk_scene::SceneReader;

fn check(kind: Kind, triangles: u64) {
    let g = generate(kind, triangles, 7, 2);
    let model = import_glb_bytes(&g.glb_bytes(), kind.name()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.gwk");
    let stats = preprocess(&model, &Params::default(), &path, kind.name(), &NoProgress).unwrap();
    assert_eq!(
        stats.triangles + model.stats.degenerate_triangles_dropped,
        g.report.triangles
    );

    let reader = SceneReader::open(&path).unwrap();
    let sk = reader.skeleton();
    assert_eq!(sk.finest_triangles(), stats.triangles);
    let r = stats.resolved.as_ref().unwrap();
    let rule = SplitRule {
        max_triangles: r.t2,
        max_diagonal: r.s2,
        max_aspect: r.r2,
        at: SplitAt::CentreOfMass,
    };
    let errors: Vec<f32> = sk.lods.iter().map(|l| l.error).collect();
    let v = verify(
        &model,
        &sk.nodes,
        &errors,
        &mut |i| reader.read_lod(i).unwrap(),
        Some(&rule),
    )
    .unwrap_or_else(|e| panic!("{}: {e}", kind.name()));
    assert_eq!(v.matched_triangles as u64, stats.triangles);
    assert_eq!(v.leaves, stats.objects_part2);

    // Same input and flags: the same bytes.
    let again = dir.path().join("again.gwk");
    preprocess(&model, &Params::default(), &again, kind.name(), &NoProgress).unwrap();
    assert!(
        std::fs::read(&path).unwrap() == std::fs::read(&again).unwrap(),
        "{}: reruns differ",
        kind.name()
    );
}

#[test]
fn generated_plant() {
    check(Kind::Plant, 60_000);
}

#[test]
fn generated_city() {
    check(Kind::City, 60_000);
}

#[test]
fn generated_forest() {
    check(Kind::Forest, 60_000);
}
