//! An IFC file through preprocess to a scene: its object table finds the
//! products by class, by GlobalId and by storey name.

use gigawalk_preprocess::{preprocess_files, NoProgress, Params};
use gigawalk_scene::objects::Pattern;
use gigawalk_scene::SceneReader;

fn models() -> Option<std::path::PathBuf> {
    gigawalk_testkit::models::shared_ifc_models()
}

#[test]
fn an_ifc_scene_finds_products_by_class_global_id_and_storey() {
    let Some(dir) = models() else { return };
    let input = dir.join("AC11-FZK-Haus-IFC.ifc");
    let t = tempfile::tempdir().unwrap();
    let out = t.path().join("haus.gwk");
    let (stats, files) = preprocess_files(
        std::slice::from_ref(&input),
        "AC11-FZK-Haus-IFC.ifc",
        &Params::default(),
        &out,
        None,
        &NoProgress,
    )
    .unwrap();
    assert_eq!(files, vec![input]);
    assert!(stats.input_triangles > 10_000, "{}", stats.input_triangles);

    let scene = SceneReader::open(&out).unwrap();
    let table = scene.objects().unwrap().expect("an object table");
    let objects = table.objects();
    // One entry per product (IfcOpenShell draws 111 here).
    assert_eq!(objects.len(), 111);
    let find = |p: &str| table.find(&Pattern::new(p).unwrap());

    let walls = find("IfcWallStandardCase");
    assert_eq!(walls.len(), 13);
    for &w in &walls {
        let meta = objects[w as usize].metadata.as_deref().unwrap();
        let json: serde_json::Value = serde_json::from_str(meta).unwrap();
        assert_eq!(json["ifc_class"], "IfcWallStandardCase");
    }

    // A GlobalId names one product.
    let wall = find("3VCarUKgH1buLo22Ozxe6J");
    assert_eq!(wall.len(), 1);
    assert_eq!(objects[wall[0] as usize].name, "Wand-Ext-OG-3");

    // A storey name finds what it contains, and only that.
    let upper = find("Dachgeschoss");
    assert!(!upper.is_empty());
    for &o in &upper {
        let r = &objects[o as usize];
        let json: serde_json::Value = serde_json::from_str(r.metadata.as_deref().unwrap()).unwrap();
        assert_eq!(json["storey"], "Dachgeschoss", "{}", r.path);
    }
    let ground = find("Erdgeschoss");
    assert!(ground.iter().all(|o| !upper.contains(o)));
}
