//! IFC through gigawalk-import: one object per product with its IFC
//! identity, mixed with other formats, unsupported geometry counted in the
//! stats and their summary, errors naming the file.

use gigawalk_import::{import, import_all, is_model_file, ImportError};

fn models() -> Option<std::path::PathBuf> {
    gigawalk_testkit::models::shared_ifc_models()
}

/// The smallest IFC4 file with one product: a 2 x 1 x 3 m block
/// (millimetre units) in a storey.
const BLOCK: &str = "ISO-10303-21;
HEADER;
FILE_DESCRIPTION(('ViewDefinition [test]'),'2;1');
FILE_NAME('block.ifc','2024-01-01T00:00:00',(''),(''),'','','');
FILE_SCHEMA(('IFC4'));
ENDSEC;
DATA;
#1=IFCPROJECT('0YvctVUKr0kugbFTf53O9L',$,'P',$,$,$,$,$,#2);
#2=IFCUNITASSIGNMENT((#3));
#3=IFCSIUNIT(*,.LENGTHUNIT.,.MILLI.,.METRE.);
#4=IFCBUILDINGSTOREY('1YvctVUKr0kugbFTf53O9L',$,'Level 1',$,$,$,$,$,.ELEMENT.,0.);
#5=IFCRELAGGREGATES('2YvctVUKr0kugbFTf53O9L',$,$,$,#1,(#4));
#6=IFCWALL('3YvctVUKr0kugbFTf53O9L',$,$,$,$,#7,#10,$,$);
#7=IFCLOCALPLACEMENT($,#8);
#8=IFCAXIS2PLACEMENT3D(#9,$,$);
#9=IFCCARTESIANPOINT((1000.,0.,0.));
#10=IFCPRODUCTDEFINITIONSHAPE($,$,(#11));
#11=IFCSHAPEREPRESENTATION($,'Body','SweptSolid',(#12));
#12=IFCEXTRUDEDAREASOLID(#13,$,#15,3000.);
#13=IFCRECTANGLEPROFILEDEF(.AREA.,$,#14,2000.,1000.);
#14=IFCAXIS2PLACEMENT2D(#9,$);
#15=IFCDIRECTION((0.,0.,1.));
#16=IFCRELCONTAINEDINSPATIALSTRUCTURE('4YvctVUKr0kugbFTf53O9L',$,$,$,(#6),#4);
ENDSEC;
END-ISO-10303-21;
";

#[test]
fn a_block_in_millimetres_is_one_object_in_metres_with_its_identity() {
    let t = tempfile::tempdir().unwrap();
    let path = t.path().join("block.IFC");
    std::fs::write(&path, BLOCK).unwrap();
    assert!(is_model_file(&path));
    let model = import(&path).unwrap();
    assert_eq!(model.objects.len(), 1);
    let o = &model.objects[0];
    assert_eq!(o.triangle_count(), 12);
    let (lo, hi) = o.positions.iter().fold(
        (glam::DVec3::splat(f64::MAX), glam::DVec3::splat(f64::MIN)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    // The profile's centre is at x = 1000 mm, and the wall placed 1 m on;
    // IFC's z (the 3 m extrusion) is the scene's y, its y the scene's -z.
    assert!(
        (lo - glam::DVec3::new(1.0, 0.0, -0.5)).length() < 1e-9,
        "{lo}"
    );
    assert!(
        (hi - glam::DVec3::new(3.0, 3.0, 0.5)).length() < 1e-9,
        "{hi}"
    );
    let id = &o.identity;
    assert_eq!(id.name, "IfcWall 3YvctVUKr0kugbFTf53O9L");
    assert_eq!(id.path, "P/Level 1/IfcWall 3YvctVUKr0kugbFTf53O9L");
    assert_eq!(id.node, Some(6));
    let extras: serde_json::Value = serde_json::from_str(id.extras.as_deref().unwrap()).unwrap();
    assert_eq!(extras["ifc_class"], "IfcWall");
    assert_eq!(extras["storey"], "Level 1");
    assert_eq!(model.stats.triangles, 12);
    assert!(model.stats.unsupported.is_empty());
}

#[test]
fn an_ifc_file_without_geometry_is_an_error_naming_it() {
    let t = tempfile::tempdir().unwrap();
    let path = t.path().join("empty.ifc");
    let text = BLOCK.replace(",#7,#10,$,$);", ",#7,$,$,$);");
    std::fs::write(&path, text).unwrap();
    let e = import(&path).unwrap_err();
    assert!(matches!(e, ImportError::Ifc(_)), "{e}");
    assert!(e.to_string().contains("empty.ifc"), "{e}");
    assert!(e.to_string().contains("no product with geometry"), "{e}");
}

#[test]
fn ifc_and_obj_import_as_one_model() {
    let t = tempfile::tempdir().unwrap();
    let ifc = t.path().join("block.ifc");
    std::fs::write(&ifc, BLOCK).unwrap();
    let obj = t.path().join("tri.obj");
    std::fs::write(&obj, "o tri\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let model = import_all(&[t.path().to_path_buf()], &mut |_, _, _| {}).unwrap();
    assert_eq!(model.objects.len(), 2);
    assert!(model.objects[0]
        .name
        .ends_with("block.ifc/IfcWall 3YvctVUKr0kugbFTf53O9L"));
    assert!(model.objects[1].name.ends_with("tri.obj/tri"));
    assert_eq!(model.stats.triangles, 13);
}

#[test]
fn revit_japanese_names_decode_and_every_product_is_its_own_object() {
    let Some(dir) = models() else { return };
    let model = import(&dir.join("revit2014_unicode.ifc")).unwrap();
    assert_eq!(model.objects.len(), 22);
    let mut nodes: Vec<usize> = model
        .objects
        .iter()
        .map(|o| o.identity.node.unwrap())
        .collect();
    nodes.sort_unstable();
    nodes.dedup();
    assert_eq!(nodes.len(), 22);
    for o in &model.objects {
        assert!(!o.name.contains("\\X2\\"), "{}", o.name);
        let id = &o.identity;
        let extras: serde_json::Value =
            serde_json::from_str(id.extras.as_deref().unwrap()).unwrap();
        let class = extras["ifc_class"].as_str().unwrap();
        let gid = extras["GlobalId"].as_str().unwrap();
        assert!(id.path.ends_with(&format!("/{class} {gid}")), "{}", id.path);
        assert!(extras["psets"].is_object());
    }
    // The project, named プロジェクト番号 in the file, heads every path.
    assert!(model
        .objects
        .iter()
        .all(|o| o.identity.path.starts_with("プロジェクト番号/")));
    assert!(model.objects.iter().any(|o| !o.name.is_ascii()));
}

#[test]
fn geometry_not_read_is_counted_in_the_stats_and_summary() {
    let t = tempfile::tempdir().unwrap();
    let path = t.path().join("sphere.ifc");
    let text = BLOCK
        .replace("'SweptSolid',(#12));", "'SweptSolid',(#12,#17));")
        .replace(
            "ENDSEC;\nEND-ISO",
            "#17=IFCSPHERE(#8,1.);\nENDSEC;\nEND-ISO",
        );
    std::fs::write(&path, text).unwrap();
    let model = import(&path).unwrap();
    assert_eq!(model.objects.len(), 1);
    let u = &model.stats.unsupported["IfcSphere"];
    assert_eq!(u.items, 1);
    assert_eq!(u.products["IfcWall"], 1);
    let summary = model.stats.summary(model.objects.len());
    assert_eq!(
        summary,
        "12 triangles in 1 objects; not read: IfcSphere: 1 items in 1 IfcWall"
    );
}
