//! Geometry on tiny hand-built files, checked against what the solids
//! are: boxes, volumes, holes, clipped halves, mapped copies, units,
//! colours; and the small buildingSMART cases.

use gigawalk_ifc::{IfcFile, IfcObject, IfcStats};
use glam::DVec3;

const HEADER: &str = "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION((''),'2;1');\nFILE_NAME('t','',(''),(''),'','','');\nFILE_SCHEMA(('IFC4'));\nENDSEC;\nDATA;\n";

/// A project in metres (or `unit`) with the given entities; #100.. are
/// free for the caller, who places products with #90 (the origin).
fn ifc(unit: &str, data: &str) -> String {
    format!(
        "{HEADER}#1=IFCPROJECT('0YvctVUKr0kugbFTf53O9L',$,'P',$,$,$,$,$,#2);\n#2=IFCUNITASSIGNMENT((#3,#4));\n{unit}\n#4=IFCSIUNIT(*,.PLANEANGLEUNIT.,$,.RADIAN.);\n#90=IFCLOCALPLACEMENT($,#91);\n#91=IFCAXIS2PLACEMENT3D(#92,$,$);\n#92=IFCCARTESIANPOINT((0.,0.,0.));\n#93=IFCDIRECTION((0.,0.,1.));\n{data}ENDSEC;\nEND-ISO-10303-21;\n"
    )
}

const METRES: &str = "#3=IFCSIUNIT(*,.LENGTHUNIT.,$,.METRE.);";

fn read(text: &str) -> (Vec<IfcObject>, IfcStats) {
    let f = IfcFile::parse(text.as_bytes().to_vec(), "t.ifc").unwrap();
    let mut objects = Vec::new();
    let stats = f
        .read(&mut |o| {
            objects.push(o);
            true
        })
        .unwrap();
    (objects, stats)
}

fn bounds(o: &IfcObject) -> (DVec3, DVec3) {
    o.positions.iter().fold(
        (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    )
}

/// The enclosed volume (divergence theorem): right only when the mesh is
/// closed and faces outward.
fn volume(o: &IfcObject) -> f64 {
    o.indices
        .chunks_exact(3)
        .map(|t| {
            let [a, b, c] = [0, 1, 2].map(|i| o.positions[t[i] as usize]);
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

fn area(o: &IfcObject) -> f64 {
    o.indices
        .chunks_exact(3)
        .map(|t| {
            let [a, b, c] = [0, 1, 2].map(|i| o.positions[t[i] as usize]);
            (b - a).cross(c - a).length() / 2.0
        })
        .sum()
}

fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).length() < 1e-9
}

/// A product #10 with body items `items` (a list like `#20,#21`).
fn product(class: &str, items: &str) -> String {
    format!("#10={class}('1YvctVUKr0kugbFTf53O9L',$,'thing',$,$,#90,#11,$,$);\n#11=IFCPRODUCTDEFINITIONSHAPE($,$,(#12));\n#12=IFCSHAPEREPRESENTATION($,'Body','SweptSolid',({items}));\n")
}

/// A rectangle `x` by `y` centred on (cx, cy), extruded by `depth` along
/// `dir` (#id, #id+1.. used).
fn extrusion(id: u32, cx: f64, cy: f64, x: f64, y: f64, depth: f64, dir: &str) -> String {
    format!(
        "#{id}=IFCEXTRUDEDAREASOLID(#{a},$,#{d},{depth:?});\n#{a}=IFCRECTANGLEPROFILEDEF(.AREA.,$,#{p},{x:?},{y:?});\n#{p}=IFCAXIS2PLACEMENT2D(#{c},$);\n#{c}=IFCCARTESIANPOINT(({cx:?},{cy:?}));\n#{d}=IFCDIRECTION(({dir}));\n",
        a = id + 1,
        p = id + 2,
        c = id + 3,
        d = id + 4
    )
}

#[test]
fn an_extruded_rectangle_is_a_closed_box() {
    let text = ifc(
        METRES,
        &(product("IFCWALL", "#20") + &extrusion(20, 1.0, 2.0, 2.0, 4.0, 3.0, "0.,0.,1.")),
    );
    let (objects, stats) = read(&text);
    assert_eq!(objects.len(), 1);
    let o = &objects[0];
    assert_eq!(o.indices.len() / 3, 12);
    let (lo, hi) = bounds(o);
    assert!(close(lo, DVec3::new(0.0, 0.0, 0.0)), "{lo}");
    assert!(close(hi, DVec3::new(2.0, 4.0, 3.0)), "{hi}");
    assert!((volume(o) - 24.0).abs() < 1e-9, "{}", volume(o));
    assert_eq!(stats.objects, 1);
    assert!(stats.unsupported.is_empty());
    for n in &o.normals {
        assert!((n.length() - 1.0).abs() < 1e-5);
    }
}

#[test]
fn an_oblique_downward_extrusion_stays_outward() {
    let text = ifc(
        METRES,
        &(product("IFCCOLUMN", "#20") + &extrusion(20, 0.0, 0.0, 1.0, 1.0, 2.0, "0.6,0.,-0.8")),
    );
    let (objects, _) = read(&text);
    let o = &objects[0];
    let (lo, hi) = bounds(o);
    assert!(close(lo, DVec3::new(-0.5, -0.5, -1.6)), "{lo}");
    assert!(close(hi, DVec3::new(1.7, 0.5, 0.0)), "{hi}");
    // A sheared box keeps its volume: base 1 x height 1.6.
    assert!((volume(o) - 1.6).abs() < 1e-9, "{}", volume(o));
}

#[test]
fn feet_convert_to_metres() {
    let feet = "#3=IFCCONVERSIONBASEDUNIT(#5,.LENGTHUNIT.,'FOOT',#6);\n#5=IFCDIMENSIONALEXPONENTS(1,0,0,0,0,0,0);\n#6=IFCMEASUREWITHUNIT(IFCLENGTHMEASURE(0.3048),#7);\n#7=IFCSIUNIT(*,.LENGTHUNIT.,$,.METRE.);";
    let text = ifc(
        feet,
        &(product("IFCSLAB", "#20") + &extrusion(20, 0.5, 0.5, 1.0, 1.0, 1.0, "0.,0.,1.")),
    );
    let (objects, _) = read(&text);
    let (_, hi) = bounds(&objects[0]);
    assert!(close(hi, DVec3::splat(0.3048)), "{hi}");
}

#[test]
fn an_opening_cuts_a_hole_through_a_wall() {
    // A 4 x 0.2 x 3 wall with a 1 x 1 window hole through it.
    let data = product("IFCWALL", "#20")
        + &extrusion(20, 2.0, 0.1, 4.0, 0.2, 3.0, "0.,0.,1.")
        + "#30=IFCOPENINGELEMENT('2YvctVUKr0kugbFTf53O9L',$,$,$,$,#90,#31,$,$);\n#31=IFCPRODUCTDEFINITIONSHAPE($,$,(#32));\n#32=IFCSHAPEREPRESENTATION($,'Body','SweptSolid',(#40));\n"
        + &extrusion(40, 2.0, 0.1, 1.0, 1.0, 1.0, "0.,0.,1.")
            .replace("#40=IFCEXTRUDEDAREASOLID(#41,$,", "#40=IFCEXTRUDEDAREASOLID(#41,#49,")
        + "#49=IFCAXIS2PLACEMENT3D(#48,$,$);\n#48=IFCCARTESIANPOINT((0.,0.,1.));\n"
        + "#35=IFCRELVOIDSELEMENT('3YvctVUKr0kugbFTf53O9L',$,$,$,#10,#30);\n";
    let (objects, stats) = read(&ifc(METRES, &data));
    assert_eq!(objects.len(), 1, "the opening is not drawn");
    assert_eq!(stats.openings_subtracted, 1);
    let o = &objects[0];
    // Two 1 m² faces gone, four 1 x 0.2 m reveals come.
    let full = 2.0 * (4.0 * 0.2 + 4.0 * 3.0 + 0.2 * 3.0);
    assert!((area(o) - (full - 2.0 + 0.8)).abs() < 1e-9, "{}", area(o));
    // Closed and facing outward: the wall's volume less the hole's.
    assert!((volume(o) - (2.4 - 0.2)).abs() < 1e-9, "{}", volume(o));
    // No triangle inside the hole.
    for t in o.indices.chunks_exact(3) {
        let c = t.iter().map(|&i| o.positions[i as usize]).sum::<DVec3>() / 3.0;
        let inside = c.x > 1.5 + 1e-9 && c.x < 2.5 - 1e-9 && c.z > 1.0 + 1e-9 && c.z < 2.0 - 1e-9;
        assert!(!inside, "triangle at {c} is in the hole");
    }
}

#[test]
fn a_half_space_clips_a_box_in_two() {
    // A unit cube minus the half space above z = 0.25 (AgreementFlag
    // false: the material is on the side the normal points to).
    let data = product("IFCBEAM", "#30")
        + &extrusion(20, 0.5, 0.5, 1.0, 1.0, 1.0, "0.,0.,1.")
        + "#30=IFCBOOLEANCLIPPINGRESULT(.DIFFERENCE.,#20,#31);\n#31=IFCHALFSPACESOLID(#32,.F.);\n#32=IFCPLANE(#33);\n#33=IFCAXIS2PLACEMENT3D(#34,#93,$);\n#34=IFCCARTESIANPOINT((0.,0.,0.25));\n";
    let (objects, _) = read(&ifc(METRES, &data));
    let (lo, hi) = bounds(&objects[0]);
    assert!(close(lo, DVec3::ZERO), "{lo}");
    assert!(close(hi, DVec3::new(1.0, 1.0, 0.25)), "{hi}");
    // Capped where it was cut: closed, a quarter of the cube.
    assert!(
        (volume(&objects[0]) - 0.25).abs() < 1e-9,
        "{}",
        volume(&objects[0])
    );
}

#[test]
fn an_intersection_with_a_block_keeps_what_both_hold() {
    // A unit cube and a block from (0.5, 0.5, -1) of 2 x 2 x 3: their
    // common part is 0.5 x 0.5 x 1.
    let data = product("IFCBEAM", "#30")
        + &extrusion(20, 0.5, 0.5, 1.0, 1.0, 1.0, "0.,0.,1.")
        + "#30=IFCBOOLEANRESULT(.INTERSECTION.,#20,#31);\n#31=IFCBLOCK(#32,2.,2.,3.);\n#32=IFCAXIS2PLACEMENT3D(#33,$,$);\n#33=IFCCARTESIANPOINT((0.5,0.5,-1.));\n";
    let (objects, stats) = read(&ifc(METRES, &data));
    assert!(
        stats.unsupported.is_empty(),
        "{}",
        stats.unsupported_summary()
    );
    let o = &objects[0];
    assert!((volume(o) - 0.25).abs() < 1e-9, "{}", volume(o));
    let (lo, hi) = bounds(o);
    assert!(
        close(lo, DVec3::new(0.5, 0.5, 0.0)) && close(hi, DVec3::ONE),
        "{lo} {hi}"
    );
}

#[test]
fn a_polygonal_bounded_half_space_cuts_a_notch() {
    // A unit cube minus what lies above z = 0.5 within x < 0.5 (the
    // boundary, a rectangle larger than the cube in y).
    let data = product("IFCWALL", "#30")
        + &extrusion(20, 0.5, 0.5, 1.0, 1.0, 1.0, "0.,0.,1.")
        + "#30=IFCBOOLEANCLIPPINGRESULT(.DIFFERENCE.,#20,#31);\n#31=IFCPOLYGONALBOUNDEDHALFSPACE(#32,.F.,#91,#35);\n#32=IFCPLANE(#33);\n#33=IFCAXIS2PLACEMENT3D(#34,#93,$);\n#34=IFCCARTESIANPOINT((0.,0.,0.5));\n#35=IFCPOLYLINE((#36,#37,#38,#39,#36));\n#36=IFCCARTESIANPOINT((-1.,-1.));\n#37=IFCCARTESIANPOINT((0.5,-1.));\n#38=IFCCARTESIANPOINT((0.5,2.));\n#39=IFCCARTESIANPOINT((-1.,2.));\n";
    let (objects, _) = read(&ifc(METRES, &data));
    let o = &objects[0];
    assert!((volume(o) - 0.75).abs() < 1e-9, "{}", volume(o));
    let (lo, hi) = bounds(o);
    assert!(close(lo, DVec3::ZERO) && close(hi, DVec3::ONE), "{lo} {hi}");
}

#[test]
fn an_opening_through_an_l_shaped_wall_gets_its_reveals() {
    // An L of two 1 x 0.2 legs, 1 high; a 0.2 x 0.2 hole through the
    // leg along x, at its middle.
    let data = product("IFCWALL", "#20")
        + "#20=IFCEXTRUDEDAREASOLID(#21,$,#93,1.);\n#21=IFCARBITRARYCLOSEDPROFILEDEF(.AREA.,$,#22);\n#22=IFCPOLYLINE((#23,#24,#25,#26,#27,#28,#23));\n#23=IFCCARTESIANPOINT((0.,0.));\n#24=IFCCARTESIANPOINT((1.,0.));\n#25=IFCCARTESIANPOINT((1.,0.2));\n#26=IFCCARTESIANPOINT((0.2,0.2));\n#27=IFCCARTESIANPOINT((0.2,1.));\n#28=IFCCARTESIANPOINT((0.,1.));\n"
        + "#30=IFCOPENINGELEMENT('2YvctVUKr0kugbFTf53O9L',$,$,$,$,#90,#31,$,$);\n#31=IFCPRODUCTDEFINITIONSHAPE($,$,(#32));\n#32=IFCSHAPEREPRESENTATION($,'Body','SweptSolid',(#40));\n"
        + &extrusion(40, 0.6, 0.1, 0.2, 1.0, 0.2, "0.,0.,1.")
            .replace("#40=IFCEXTRUDEDAREASOLID(#41,$,", "#40=IFCEXTRUDEDAREASOLID(#41,#49,")
        + "#49=IFCAXIS2PLACEMENT3D(#48,$,$);\n#48=IFCCARTESIANPOINT((0.,0.,0.4));\n"
        + "#35=IFCRELVOIDSELEMENT('3YvctVUKr0kugbFTf53O9L',$,$,$,#10,#30);\n";
    let (objects, stats) = read(&ifc(METRES, &data));
    assert_eq!(stats.openings_subtracted, 1);
    let o = &objects[0];
    // 0.36 of L less the 0.2 x 0.2 x 0.2 hole, closed by its reveals.
    assert!((volume(o) - (0.36 - 0.008)).abs() < 1e-9, "{}", volume(o));
}

#[test]
fn a_mapped_item_is_placed_and_scaled_non_uniformly() {
    let data = product("IFCFURNITURE", "#30")
        + &extrusion(20, 0.5, 0.5, 1.0, 1.0, 1.0, "0.,0.,1.")
        + "#30=IFCMAPPEDITEM(#31,#34);\n#31=IFCREPRESENTATIONMAP(#91,#32);\n#32=IFCSHAPEREPRESENTATION($,'Body','SweptSolid',(#20));\n#34=IFCCARTESIANTRANSFORMATIONOPERATOR3DNONUNIFORM($,$,#35,2.,$,3.,4.);\n#35=IFCCARTESIANPOINT((10.,0.,0.));\n";
    let (objects, _) = read(&ifc(METRES, &data));
    let (lo, hi) = bounds(&objects[0]);
    assert!(close(lo, DVec3::new(10.0, 0.0, 0.0)), "{lo}");
    assert!(close(hi, DVec3::new(12.0, 3.0, 4.0)), "{hi}");
    assert!((volume(&objects[0]) - 24.0).abs() < 1e-9);
}

#[test]
fn a_styled_item_colours_the_product_in_linear_rgb() {
    let data = product("IFCSLAB", "#20")
        + &extrusion(20, 0.5, 0.5, 1.0, 1.0, 1.0, "0.,0.,1.")
        + "#50=IFCSTYLEDITEM(#20,(#51),$);\n#51=IFCSURFACESTYLE($,.BOTH.,(#52));\n#52=IFCSURFACESTYLERENDERING(#53,0.25,$,$,$,$,$,$,.NOTDEFINED.);\n#53=IFCCOLOURRGB($,1.,0.5,0.);\n";
    let (objects, _) = read(&ifc(METRES, &data));
    let c = objects[0].colour;
    assert_eq!(c[0], 1.0);
    assert!((c[1] - 0.214).abs() < 1e-3, "{c:?}");
    assert_eq!(c[2], 0.0);
    assert_eq!(c[3], 0.75);
    assert!(objects[0].vertex_colours.is_none());
}

#[test]
fn unsupported_items_are_counted_by_kind_and_product() {
    let data = product("IFCFLOWFITTING", "#20,#60")
        + &extrusion(20, 0.5, 0.5, 1.0, 1.0, 1.0, "0.,0.,1.")
        + "#60=IFCSPHERE(#91,1.);\n";
    let (objects, stats) = read(&ifc(METRES, &data));
    assert_eq!(objects.len(), 1);
    let u = &stats.unsupported["IfcSphere"];
    assert_eq!(u.items, 1);
    assert_eq!(u.products["IfcFlowFitting"], 1);
    assert_eq!(
        stats.unsupported_summary(),
        "IfcSphere: 1 items in 1 IfcFlowFitting"
    );
}

#[test]
fn a_revolved_rectangle_is_a_ring_of_the_right_volume() {
    // A 1 x 2 rectangle from x = 2 to 3 turned a quarter about the Y
    // axis: a quarter of a ring of radii 2 and 3, 2 high.
    let data = product("IFCFLOWFITTING", "#60")
        + &extrusion(20, 2.5, 1.0, 1.0, 2.0, 1.0, "0.,0.,1.")
        + "#60=IFCREVOLVEDAREASOLID(#21,$,#61,1.5707963267948966);\n#61=IFCAXIS1PLACEMENT(#92,#62);\n#62=IFCDIRECTION((0.,1.,0.));\n";
    let (objects, stats) = read(&ifc(METRES, &data));
    assert!(
        stats.unsupported.is_empty(),
        "{}",
        stats.unsupported_summary()
    );
    let o = &objects[0];
    let exact = std::f64::consts::PI / 4.0 * (9.0 - 4.0) * 2.0;
    // Chords cut inside the arcs: a little less than the exact volume.
    let v = volume(o);
    assert!(v < exact && v > 0.99 * exact, "{v} against {exact}");
    let (lo, hi) = bounds(o);
    assert!((hi.y - 2.0).abs() < 1e-9 && lo.y.abs() < 1e-9, "{lo} {hi}");
    assert!((hi.x - 3.0).abs() < 1e-9, "{hi}");
}

fn models() -> Option<std::path::PathBuf> {
    gigawalk_testkit::models::shared_ifc_models()
}

fn read_model(name: &str) -> Result<(Vec<IfcObject>, IfcStats), gigawalk_ifc::IfcError> {
    let dir = models().expect("checked by the caller");
    let f = IfcFile::open(&dir.join(name))?;
    let mut objects = Vec::new();
    let stats = f.read(&mut |o| {
        objects.push(o);
        true
    })?;
    Ok((objects, stats))
}

#[test]
fn cube_advanced_brep_reads_its_b_spline_faces_closed_and_outward() {
    if models().is_none() {
        return;
    }
    let (objects, stats) = read_model("Ifc4_CubeAdvancedBrep.ifc").unwrap();
    assert_eq!(objects.len(), 1);
    assert!(
        stats.unsupported.is_empty(),
        "{}",
        stats.unsupported_summary()
    );
    // Four B-spline sides between two planar faces: a positive volume
    // means they face outward.
    assert!(volume(&objects[0]) > 0.0, "{}", volume(&objects[0]));
}

#[test]
fn basin_advanced_brep_reads_its_b_spline_edges_and_surfaces() {
    if models().is_none() {
        return;
    }
    let (objects, stats) = read_model("basin-advanced-brep.ifc").unwrap();
    assert_eq!(objects.len(), 1);
    assert!(
        stats.unsupported.is_empty(),
        "{}",
        stats.unsupported_summary()
    );
}

#[test]
fn slab_standard_case_reads_its_indexed_poly_curve() {
    if models().is_none() {
        return;
    }
    let (objects, stats) = read_model("slab-standard-case.ifc").unwrap();
    assert_eq!(objects.len(), 1);
    assert_eq!(objects[0].class, "IfcSlab");
    assert!(stats.unsupported.is_empty());
    assert!(volume(&objects[0]) > 0.0);
}

#[test]
fn tessellation_with_individual_colours_keeps_per_face_colours() {
    if models().is_none() {
        return;
    }
    let (objects, _) = read_model("tessellation-with-individual-colors.ifc").unwrap();
    let o = &objects[0];
    assert_eq!(o.indices.len() / 3, 12);
    let colours = o.vertex_colours.as_ref().expect("per-face colours");
    let mut distinct: Vec<[u32; 4]> = colours.iter().map(|c| c.map(f32::to_bits)).collect();
    distinct.sort_unstable();
    distinct.dedup();
    assert!(distinct.len() >= 3, "{distinct:?}");
}

#[test]
fn wall_standard_case_reads_every_wall() {
    if models().is_none() {
        return;
    }
    let (objects, stats) = read_model("WallStandardCase-01A.ifc").unwrap();
    assert_eq!(objects.len(), 18);
    assert!(stats.unsupported.is_empty());
    for o in &objects {
        assert!(volume(o) > 0.0, "{} faces inward", o.name);
    }
}

#[test]
fn a_swept_disk_is_a_closed_tube_of_the_right_volume() {
    // Radius 0.1 along an L of two 1 m legs, and a bore of 0.05.
    let data = product("IFCPIPESEGMENT", "#60,#70")
        + "#60=IFCSWEPTDISKSOLID(#61,0.1,$,$,$);\n#61=IFCPOLYLINE((#62,#63,#64));\n#62=IFCCARTESIANPOINT((0.,0.,0.));\n#63=IFCCARTESIANPOINT((1.,0.,0.));\n#64=IFCCARTESIANPOINT((1.,1.,0.));\n"
        + "#70=IFCSWEPTDISKSOLID(#71,0.1,0.05,$,$);\n#71=IFCPOLYLINE((#72,#73));\n#72=IFCCARTESIANPOINT((0.,0.,5.));\n#73=IFCCARTESIANPOINT((0.,0.,6.));\n";
    let (objects, stats) = read(&ifc(METRES, &data));
    assert!(
        stats.unsupported.is_empty(),
        "{}",
        stats.unsupported_summary()
    );
    let o = &objects[0];
    // A polygon of n sides inscribed in the circle holds n/2 sin(2pi/n)
    // r^2; the mitred bend keeps the L's volume that of 2 m of tube.
    let n = (o.indices.len() / 3) as f64;
    assert!(n > 0.0);
    let v = volume(o);
    let disk = std::f64::consts::PI * 0.01;
    let (solid, bored) = (2.0 * disk, disk * 0.75);
    assert!(v < solid + bored && v > 0.95 * (solid + bored), "{v}");
    let (lo, hi) = bounds(o);
    // The ring is a polygon: within its sag of the radius.
    assert!(
        (hi.z - 6.0).abs() < 1e-9 && (lo.z + 0.1).abs() < 1e-3,
        "{lo} {hi}"
    );
}

#[test]
fn a_polygonal_face_set_with_a_void_is_triangulated_around_it() {
    // A 2 x 2 square with a 1 x 1 hole: 3 m² of one face, no volume.
    let data = product("IFCPLATE", "#60")
        + "#60=IFCPOLYGONALFACESET(#61,$,(#62),$);\n#61=IFCCARTESIANPOINTLIST3D(((0.,0.,0.),(2.,0.,0.),(2.,2.,0.),(0.,2.,0.),(0.5,0.5,0.),(0.5,1.5,0.),(1.5,1.5,0.),(1.5,0.5,0.)));\n#62=IFCINDEXEDPOLYGONALFACEWITHVOIDS((1,2,3,4),((5,6,7,8)));\n";
    let (objects, _) = read(&ifc(METRES, &data));
    let o = &objects[0];
    assert!((area(o) - 3.0).abs() < 1e-9, "{}", area(o));
    for t in o.indices.chunks_exact(3) {
        let c = t.iter().map(|&i| o.positions[i as usize]).sum::<DVec3>() / 3.0;
        assert!(
            !(c.x > 0.5 && c.x < 1.5 && c.y > 0.5 && c.y < 1.5),
            "{c} in the void"
        );
    }
    assert!(o.normals.iter().all(|n| n.z > 0.99));
}

#[test]
fn a_faceted_brep_face_with_an_inner_bound_has_a_hole() {
    let data = product("IFCBUILDINGELEMENTPROXY", "#60")
        + "#60=IFCFACETEDBREP(#61);\n#61=IFCCLOSEDSHELL((#62));\n#62=IFCFACE((#63,#65));\n#63=IFCFACEOUTERBOUND(#64,.T.);\n#64=IFCPOLYLOOP((#70,#71,#72,#73));\n#65=IFCFACEBOUND(#66,.T.);\n#66=IFCPOLYLOOP((#74,#75,#76,#77));\n#70=IFCCARTESIANPOINT((0.,0.,0.));\n#71=IFCCARTESIANPOINT((0.,2.,0.));\n#72=IFCCARTESIANPOINT((0.,2.,2.));\n#73=IFCCARTESIANPOINT((0.,0.,2.));\n#74=IFCCARTESIANPOINT((0.,0.5,0.5));\n#75=IFCCARTESIANPOINT((0.,0.5,1.5));\n#76=IFCCARTESIANPOINT((0.,1.5,1.5));\n#77=IFCCARTESIANPOINT((0.,1.5,0.5));\n";
    let (objects, _) = read(&ifc(METRES, &data));
    let o = &objects[0];
    assert!((area(o) - 3.0).abs() < 1e-9, "{}", area(o));
    // The outer loop's winding (Y then Z) faces +X.
    assert!(o.normals.iter().all(|n| n.x > 0.99));
}

#[test]
fn an_ifc4x3_file_reads() {
    let text = ifc(
        METRES,
        &(product("IFCWALL", "#20") + &extrusion(20, 0.5, 0.5, 1.0, 1.0, 1.0, "0.,0.,1.")),
    )
    .replace("FILE_SCHEMA(('IFC4'))", "FILE_SCHEMA(('IFC4X3_ADD2'))");
    let f = IfcFile::parse(text.into_bytes(), "t.ifc").unwrap();
    assert_eq!(f.schema(), gigawalk_ifc::Schema::Ifc4x3);
    let mut n = 0;
    f.read(&mut |_| {
        n += 1;
        true
    })
    .unwrap();
    assert_eq!(n, 1);
}
