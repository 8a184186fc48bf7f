//! The demo's scene cache: built once, reused while its stamp matches,
//! rebuilt when asked or when a cached file is damaged.

use gigawalk_replay::demo::DemoScene;
use gigawalk_scene::SceneReader;

fn tiny() -> DemoScene {
    DemoScene {
        triangles: 20_000,
        seed: 5,
        poses: 8,
    }
}

#[test]
fn demo_cache_is_built_once_and_reused() {
    let dir = tempfile::tempdir().unwrap();
    let mut lines = Vec::new();
    let p = gigawalk_preprocess::NoProgress;
    let a = tiny()
        .prepare(dir.path(), false, &mut |l| lines.push(l.to_string()), &p)
        .unwrap();
    assert!(a.built);
    let scene = SceneReader::open(&a.scene).unwrap();
    assert!(scene.skeleton().nodes().len() > 1);
    let path = gigawalk_scene::path::CameraPath::read(&a.path).unwrap();
    assert_eq!(path.poses.len(), 8);

    let b = tiny().prepare(dir.path(), false, &mut |_| {}, &p).unwrap();
    assert!(!b.built, "second prepare should hit the cache");
    assert_eq!((a.scene.clone(), a.path.clone()), (b.scene, b.path));

    let c = tiny().prepare(dir.path(), true, &mut |_| {}, &p).unwrap();
    assert!(c.built, "--rebuild rebuilds");

    // A damaged scene file is stale, whatever the stamp says.
    std::fs::write(&a.scene, b"not a scene").unwrap();
    let d = tiny().prepare(dir.path(), false, &mut |_| {}, &p).unwrap();
    assert!(d.built);
    assert!(SceneReader::open(&d.scene).is_ok());

    // Another size is another cache entry.
    let other = DemoScene {
        triangles: 25_000,
        ..tiny()
    };
    let e = other.prepare(dir.path(), false, &mut |_| {}, &p).unwrap();
    assert!(e.built && e.scene != a.scene);
    assert!(
        lines.iter().any(|l| l.contains("preprocessing")),
        "{lines:?}"
    );
}
