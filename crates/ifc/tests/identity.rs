//! Identity on a real file: the spatial path goes through the storey and,
//! for an element's parts, through the element; property sets and
//! quantities land in the metadata.

use gigawalk_ifc::{IfcFile, IfcObject};

fn models() -> Option<std::path::PathBuf> {
    gigawalk_testkit::models::shared_ifc_models()
}

fn objects(name: &str) -> Vec<IfcObject> {
    let dir = models().expect("checked by the caller");
    let f = IfcFile::open(&dir.join(name)).unwrap();
    let mut out = Vec::new();
    f.read(&mut |o| {
        out.push(o);
        true
    })
    .unwrap();
    out
}

#[test]
fn parts_are_found_under_their_element_and_storey() {
    if models().is_none() {
        return;
    }
    let all = objects("WallStandardCase-01A.ifc");
    let parts: Vec<&IfcObject> = all
        .iter()
        .filter(|o| o.class == "IfcBuildingElementPart")
        .collect();
    assert_eq!(parts.len(), 8);
    for p in parts {
        assert!(
            p.path.ends_with(&format!(
                "/WallStandardCase-01A (Design Model)/CompWalls--Two Layer Wall/IfcBuildingElementPart {}",
                p.global_id
            )),
            "{}",
            p.path
        );
        assert_eq!(
            p.storey.as_deref(),
            Some("WallStandardCase-01A (Design Model)")
        );
    }
}

#[test]
fn property_sets_quantities_and_type_reach_the_metadata() {
    if models().is_none() {
        return;
    }
    let all = objects("AC11-FZK-Haus-IFC.ifc");
    let wall = all
        .iter()
        .find(|o| o.global_id == "3rPX_Juz59peXXY6wDJl18")
        .unwrap();
    assert_eq!(wall.name, "Wand-Ext-ERDG-1");
    assert_eq!(
        wall.path,
        "Projekt-FZK-Haus/Gelaende/FZK-Haus/Erdgeschoss/IfcWallStandardCase 3rPX_Juz59peXXY6wDJl18"
    );
    let json: serde_json::Value = serde_json::from_str(&wall.extras).unwrap();
    assert_eq!(json["psets"]["Pset_WallCommon"]["IsExternal"], true);
    assert_eq!(json["quantities"]["BaseQuantities"]["Length"], 10.0);
    assert_eq!(json["type"], "IfcWallType Leichtbeton");
    assert_eq!(json["storey"], "Erdgeschoss");
}
