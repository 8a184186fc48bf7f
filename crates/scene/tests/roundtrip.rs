//! Scene file round trips on hand-built tiny scenes, and the writer's and
//! reader's error paths.

mod common;

use common::*;
use gigawalk_scene::{
    Aabb, Colours, LodMesh, Node, Provenance, ReadErrorKind, SceneReader, SceneWriter, WriteError,
    NO_NODE,
};
use glam::DVec3;

fn check_round_trip(spec: &TreeSpec) -> SceneReader {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.gwk");
    let summary = write_tree(&path, spec);
    let r = SceneReader::open(&path).unwrap();
    let s = r.skeleton();
    assert_eq!(s.nodes().len(), spec.parents.len());
    assert_eq!(summary.nodes, s.nodes().len());
    assert_eq!(summary.bytes, std::fs::metadata(&path).unwrap().len());
    for (i, n) in s.nodes().iter().enumerate() {
        assert_eq!(n.parent, spec.parents[i]);
        assert_eq!(n.is_leaf(), spec.leaf_boxes[i].is_some());
        if let Some(b) = spec.leaf_boxes[i] {
            // Boxes may only grow by rounding.
            assert!(n.bounds.contains_box(&b));
            assert!(
                (n.bounds.extent() - b.extent()).abs().max_element()
                    < 1e-5 * b.extent().max_element()
            );
        }
        for l in n.lods() {
            let mesh = r.read_lod(l as u32).unwrap();
            assert_eq!(mesh.triangle_count(), 12);
            assert_eq!(
                mesh.colours,
                Colours::Uniform([(i % 251) as u8, 100, 200, 255])
            );
        }
    }
    assert_eq!(s.provenance().source, "hand-built");
    assert_eq!(
        s.provenance().parameters["nodes"],
        spec.parents.len() as u64
    );
    r.verify().unwrap();
    r
}

#[test]
fn one_node() {
    let spec = TreeSpec {
        parents: vec![NO_NODE],
        leaf_boxes: vec![Some(Aabb::new(DVec3::ZERO, DVec3::ONE))],
    };
    let r = check_round_trip(&spec);
    assert_eq!(r.skeleton().depth(), 1);
    assert_eq!(r.skeleton().finest_triangles(), 12);
}

#[test]
fn deep_chain() {
    let r = check_round_trip(&chain(200));
    assert_eq!(r.skeleton().depth(), 200);
    // Inner errors grow towards the root (by what 16-bit quantization
    // moved, a millionth of the box, on top of what was given).
    let e = r.skeleton().node_lods(0)[0].error;
    assert!((200.0..200.001).contains(&e), "{e}");
}

#[test]
fn wide_node() {
    let r = check_round_trip(&wide(3000, DVec3::ZERO));
    assert_eq!(r.skeleton().depth(), 2);
    assert_eq!(r.skeleton().leaves().count(), 3000);
}

#[test]
fn far_from_origin_keeps_precision() {
    // A millimetre-scale triangle fan 10^7 units from the origin: stored
    // naively as f32 world coordinates it would collapse (f32 spacing at
    // 1e7 is 1 unit).
    let base = DVec3::new(1.0e7, -2.5e7, 3.0e7);
    let world: Vec<DVec3> = (0..50)
        .map(|i| {
            base + DVec3::new(
                i as f64 * 1e-3,
                (i * i % 17) as f64 * 1e-3,
                0.25e-3 * i as f64,
            )
        })
        .collect();
    let mesh = LodMesh {
        origin: DVec3::ZERO,
        positions: vec![[0.0; 3]; 50],
        normals: vec![[0.0, 1.0, 0.0]; 50],
        colours: Colours::PerVertex((0..50).map(|i| [i as u8, 0, 0, 255]).collect()),
        indices: (1..49u32).flat_map(|i| [0, i, i + 1]).collect(),
    };
    // Pass world coordinates through `origin` + small offsets.
    let mesh = LodMesh {
        origin: base,
        positions: world
            .iter()
            .map(|p| (*p - base).as_vec3().to_array())
            .collect(),
        ..mesh
    };
    let bounds = Aabb::from_points(world.iter().copied());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("far.gwk");
    let mut w = SceneWriter::create(&path).unwrap();
    w.add_lod(&mesh, 0.0).unwrap();
    let node = Node {
        bounds,
        parent: NO_NODE,
        first_child: 0,
        child_count: 0,
        first_lod: 0,
        lod_count: 1,
    };
    w.finish(vec![node], Provenance::default()).unwrap();
    let r = SceneReader::open(&path).unwrap();
    // Written without occluders: none.
    assert_eq!(r.occluders().unwrap(), None);
    // The same with an OCCL section: read back as written, and a flipped
    // byte in it is a checksum error naming the section.
    let occ = vec![gigawalk_scene::occluders::OccluderRecord {
        vertices: world[..3].to_vec(),
        area: 0.5,
    }];
    let path2 = dir.path().join("far-occl.gwk");
    let mut w = SceneWriter::create(&path2).unwrap();
    w.add_lod(&mesh, 0.0).unwrap();
    w.add_optional_section(
        gigawalk_scene::occluders::TAG_OCCLUDERS,
        gigawalk_scene::occluders::encode_occluders(&occ),
    );
    w.finish(vec![node], Provenance::default()).unwrap();
    let r2 = SceneReader::open(&path2).unwrap();
    assert_eq!(r2.occluders().unwrap(), Some(occ));
    let section = r2
        .sections()
        .iter()
        .find(|s| s.name == "OCCL")
        .unwrap()
        .clone();
    let mut bytes = std::fs::read(&path2).unwrap();
    bytes[section.offset as usize + 9] ^= 1;
    std::fs::write(&path2, &bytes).unwrap();
    let e = SceneReader::open(&path2).unwrap().occluders().unwrap_err();
    assert!(e.to_string().contains("OCCL"), "{e}");
    let back = r.read_lod(0).unwrap();
    for (p, q) in world.iter().zip(&back.positions) {
        let d = (back.origin + glam::Vec3::from(*q).as_dvec3() - *p)
            .abs()
            .max_element();
        // f32 world coordinates would be off by up to 0.5 here; the
        // 16-bit grid over the fan's box moves a vertex by at most half a
        // step (0.4 um), which the LOD's stored error includes.
        let error = r.skeleton().lods()[0].error as f64;
        assert!(
            error < 1e-6 && d <= error + 1e-7,
            "position error {d}, stored {error}"
        );
    }
    assert!((r.skeleton().origin() - bounds.center()).length() < 1e-9);
    assert_eq!(back.colours, mesh.colours);
    assert_eq!(back.indices, mesh.indices);
}

#[test]
fn big_mesh_uses_32_bit_indices_and_small_uses_16() {
    let n = 70_000u32;
    let positions: Vec<[f32; 3]> = (0..n)
        .map(|i| [i as f32 * 0.01, (i % 2) as f32, 0.0])
        .collect();
    let mesh = LodMesh {
        origin: DVec3::ZERO,
        normals: vec![[0.0, 0.0, 1.0]; n as usize],
        colours: Colours::Uniform([1, 2, 3, 4]),
        indices: (0..n - 2).flat_map(|i| [i, i + 1, i + 2]).collect(),
        positions,
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.gwk");
    let mut w = SceneWriter::create(&path).unwrap();
    w.add_lod(&mesh, 0.0).unwrap();
    w.add_lod(
        &common::box_mesh(&Aabb::new(DVec3::ZERO, DVec3::ONE), [9; 4]),
        1.0,
    )
    .unwrap();
    let bounds = Aabb::new(
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(n as f64 * 0.01, 1.0, 1.0),
    );
    let node = Node {
        bounds,
        parent: NO_NODE,
        first_child: 0,
        child_count: 0,
        first_lod: 0,
        lod_count: 2,
    };
    w.finish(vec![node], Provenance::default()).unwrap();
    let r = SceneReader::open(&path).unwrap();
    assert_eq!(
        r.skeleton().lods()[0].index_format,
        gigawalk_scene::IndexFormat::U32
    );
    assert_eq!(
        r.skeleton().lods()[1].index_format,
        gigawalk_scene::IndexFormat::U16
    );
    // The same triangles, each perhaps rotated (the index codec keeps
    // winding, not the first corner).
    let back = r.read_lod(0).unwrap().indices;
    assert_eq!(back.len(), mesh.indices.len());
    for (a, b) in back.chunks(3).zip(mesh.indices.chunks(3)) {
        let rotations = [[b[0], b[1], b[2]], [b[1], b[2], b[0]], [b[2], b[0], b[1]]];
        assert!(
            rotations.contains(&[a[0], a[1], a[2]]),
            "{a:?} is not {b:?}"
        );
    }
}

#[test]
fn abandoned_writer_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("never.gwk");
    let mut w = SceneWriter::create(&path).unwrap();
    w.add_lod(&box_mesh(&Aabb::new(DVec3::ZERO, DVec3::ONE), [0; 4]), 0.0)
        .unwrap();
    drop(w);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn invalid_scene_is_not_written_and_old_file_survives() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.gwk");
    write_tree(&path, &chain(3));
    let before = std::fs::read(&path).unwrap();
    let mut w = SceneWriter::create(&path).unwrap();
    w.add_lod(&box_mesh(&Aabb::new(DVec3::ZERO, DVec3::ONE), [0; 4]), 0.0)
        .unwrap();
    // Leaf box far from its geometry.
    let node = Node {
        bounds: Aabb::new(DVec3::splat(5.0), DVec3::splat(6.0)),
        parent: NO_NODE,
        first_child: 0,
        child_count: 0,
        first_lod: 0,
        lod_count: 1,
    };
    let err = w.finish(vec![node], Provenance::default()).unwrap_err();
    assert!(
        matches!(
            err,
            WriteError::Invalid(ReadErrorKind::Node { node: 0, .. })
        ),
        "{err}"
    );
    assert_eq!(std::fs::read(&path).unwrap(), before);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

#[test]
fn writer_rejects_bad_meshes() {
    let dir = tempfile::tempdir().unwrap();
    let mut w = SceneWriter::create(&dir.path().join("x.gwk")).unwrap();
    let good = box_mesh(&Aabb::new(DVec3::ZERO, DVec3::ONE), [0; 4]);
    let cases: Vec<(LodMesh, f32, &str)> = vec![
        (
            LodMesh {
                indices: vec![0, 1, 99],
                ..good.clone()
            },
            0.0,
            "index 2 is 99",
        ),
        (
            LodMesh {
                indices: vec![],
                ..good.clone()
            },
            0.0,
            "0 indices",
        ),
        (
            LodMesh {
                normals: vec![],
                ..good.clone()
            },
            0.0,
            "0 normals",
        ),
        (
            LodMesh {
                positions: {
                    let mut p = good.positions.clone();
                    p[3][1] = f32::NAN;
                    p
                },
                ..good.clone()
            },
            0.0,
            "vertex 3 position is not finite",
        ),
        (good.clone(), f32::NAN, "error NaN"),
        (
            LodMesh {
                colours: Colours::PerVertex(vec![[0; 4]; 3]),
                ..good.clone()
            },
            0.0,
            "3 colours for 8",
        ),
    ];
    for (mesh, error, expected) in cases {
        let e = w.add_lod(&mesh, error).unwrap_err().to_string();
        assert!(e.contains(expected), "{e:?} should mention {expected:?}");
    }
}

#[test]
fn non_monotone_errors_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let mut w = SceneWriter::create(&dir.path().join("x.gwk")).unwrap();
    let b = Aabb::new(DVec3::ZERO, DVec3::ONE);
    w.add_lod(&box_mesh(&b, [0; 4]), 0.1).unwrap(); // root
    w.add_lod(&box_mesh(&b, [0; 4]), 0.5).unwrap(); // child: coarser than its parent
    let nodes = vec![
        Node {
            bounds: b,
            parent: NO_NODE,
            first_child: 1,
            child_count: 1,
            first_lod: 0,
            lod_count: 1,
        },
        Node {
            bounds: b,
            parent: 0,
            first_child: 0,
            child_count: 0,
            first_lod: 1,
            lod_count: 1,
        },
    ];
    let e = w
        .finish(nodes, Provenance::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("node 1") && e.contains("errors must not decrease from child to parent"),
        "{e}"
    );
}

#[test]
fn newer_major_version_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.gwk");
    write_tree(&path, &chain(2));
    let mut bytes = std::fs::read(&path).unwrap();
    bytes[8..10].copy_from_slice(&(gigawalk_scene::FORMAT_MAJOR + 1).to_le_bytes());
    let e = SceneReader::from_source(bytes, "future.gwk")
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.starts_with(&format!(
            "future.gwk: file is format version {}.{}",
            gigawalk_scene::FORMAT_MAJOR + 1,
            gigawalk_scene::FORMAT_MINOR
        )) && e.contains("newer gigawalk"),
        "{e}"
    );
}

#[test]
fn not_a_scene_and_missing_file() {
    let e = SceneReader::from_source(
        b"glTF\x02\0\0\0 and more bytes than a header would need, surely, yes, many more".to_vec(),
        "model.glb",
    )
    .err()
    .unwrap();
    assert!(matches!(e.kind, ReadErrorKind::NotAScene), "{e}");
    let e = SceneReader::open(std::path::Path::new("/no/such/dir/scene.gwk"))
        .err()
        .unwrap();
    assert!(
        e.to_string()
            .starts_with("/no/such/dir/scene.gwk: cannot read"),
        "{e}"
    );
}

#[test]
fn truncation_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.gwk");
    write_tree(&path, &chain(2));
    let bytes = std::fs::read(&path).unwrap();
    let e = SceneReader::from_source(bytes[..bytes.len() - 1].to_vec(), "cut.gwk")
        .err()
        .unwrap();
    assert!(
        matches!(e.kind, ReadErrorKind::LengthMismatch { .. }),
        "{e}"
    );
}

/// A stored optional section that fails its checksum or its checks is an
/// error naming the file and the section, from `verify` (what `gigawalk
/// info --verify` runs) and from the reader that decodes it; only a section
/// the table of contents does not list reads as absent.
#[test]
fn a_damaged_optional_section_is_an_error_naming_it_never_absent() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.gwk");
    let mut optional = occluder_sections();
    optional.push((*b"XTRA", b"a section no gigawalk knows".to_vec()));
    write_tree_with(&path, &wide(3, DVec3::ZERO), optional);
    let good = std::fs::read(&path).unwrap();
    let r = SceneReader::from_source(good.clone(), "s.gwk").unwrap();
    assert_eq!(r.occluders().unwrap().map(|o| o.len()), Some(2));
    assert_eq!(r.occluder_cells(2).unwrap().map(|c| c.leaves()), Some(2));
    r.verify().unwrap();
    let sections = r.sections().to_vec();

    for tag in ["OCCL", "OCVC", "XTRA"] {
        let s = sections.iter().find(|s| s.name == tag).unwrap();
        let mut bytes = good.clone();
        bytes[(s.offset + s.len / 2) as usize] ^= 0x10;
        // Opening reads no optional section.
        let r = SceneReader::from_source(bytes, "damaged.gwk").unwrap();
        let e = r.verify().unwrap_err();
        assert!(
            matches!(&e.kind, ReadErrorKind::Checksum { section, .. } if section == tag),
            "{tag}: {e}"
        );
        assert!(e.to_string().starts_with("damaged.gwk: "), "{e}");
        assert!(
            e.to_string()
                .contains(&format!("checksum mismatch in {tag}")),
            "{e}"
        );
        let occluders = r.occluders();
        let cells = r.occluder_cells(2);
        match tag {
            "OCCL" => {
                let e = occluders.unwrap_err();
                assert!(
                    matches!(&e.kind, ReadErrorKind::Checksum { section, .. } if section == "OCCL"),
                    "{e}"
                );
                assert!(cells.unwrap().is_some());
            }
            "OCVC" => {
                assert_eq!(occluders.unwrap().map(|o| o.len()), Some(2));
                let e = cells.unwrap_err();
                assert!(
                    matches!(&e.kind, ReadErrorKind::Checksum { section, .. } if section == "OCVC"),
                    "{e}"
                );
            }
            _ => {
                assert!(occluders.unwrap().is_some());
                assert!(cells.unwrap().is_some());
            }
        }
    }

    // Contents that fail their checks under a valid checksum: OCCL of an
    // unknown version, OCVC naming an occluder OCCL does not hold.
    let mut sections = occluder_sections();
    sections[0].1[0] = 9;
    let bad_occl = dir.path().join("bad-occl.gwk");
    write_tree_with(&bad_occl, &wide(3, DVec3::ZERO), sections);
    let r = SceneReader::open(&bad_occl).unwrap();
    for e in [r.verify().unwrap_err(), r.occluders().unwrap_err()] {
        assert!(
            matches!(&e.kind, ReadErrorKind::Corrupt { section, .. } if section == "OCCL"),
            "{e}"
        );
        assert!(e.to_string().contains("bad-occl.gwk"), "{e}");
    }
    let mut sections = occluder_sections();
    sections[0].1 = gigawalk_scene::occluders::encode_occluders(&[]);
    let bad_ocvc = dir.path().join("bad-ocvc.gwk");
    write_tree_with(&bad_ocvc, &wide(3, DVec3::ZERO), sections);
    let r = SceneReader::open(&bad_ocvc).unwrap();
    for e in [r.verify().unwrap_err(), r.occluder_cells(0).unwrap_err()] {
        assert!(
            matches!(&e.kind, ReadErrorKind::Corrupt { section, .. } if section == "OCVC"),
            "{e}"
        );
        assert!(e.to_string().contains("names occluder"), "{e}");
    }

    // Truly absent: none, and the scene verifies.
    let plain = dir.path().join("plain.gwk");
    write_tree(&plain, &wide(3, DVec3::ZERO));
    let r = SceneReader::open(&plain).unwrap();
    assert_eq!(r.occluders().unwrap(), None);
    assert_eq!(r.occluder_cells(0).unwrap(), None);
    r.verify().unwrap();
}

#[test]
fn raw_f32_layout_round_trips_exactly_and_format_1_files_are_still_read() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("raw.gwk");
    let b = Aabb::new(
        DVec3::new(1.0e7, 0.0, 0.0),
        DVec3::new(1.0e7 + 0.013, 0.7, 0.3),
    );
    let mesh = common::box_mesh(&b, [7, 8, 9, 255]);
    let mut w = SceneWriter::create(&path).unwrap();
    assert!(w.set_position_bits(Some(7)).is_err());
    w.set_position_bits(None).unwrap();
    w.add_lod(&mesh, 0.0).unwrap();
    let node = Node {
        bounds: b,
        parent: NO_NODE,
        first_child: 0,
        child_count: 0,
        first_lod: 0,
        lod_count: 1,
    };
    w.finish(vec![node], Provenance::default()).unwrap();
    let check = |r: &SceneReader| {
        assert!(!r.skeleton().lods()[0].encoded);
        assert_eq!(r.skeleton().lods()[0].error, 0.0, "nothing moved");
        let back = r.read_lod(0).unwrap();
        assert_eq!(back.indices, mesh.indices);
        for (p, q) in mesh.positions.iter().zip(&back.positions) {
            let (p, q) = (
                mesh.origin + glam::Vec3::from(*p).as_dvec3(),
                back.origin + glam::Vec3::from(*q).as_dvec3(),
            );
            assert!((p - q).abs().max_element() < 1e-9, "{p} {q}");
        }
    };
    check(&SceneReader::open(&path).unwrap());
    // The same file as format 1 wrote it: major version 1, header CRC anew.
    let mut bytes = std::fs::read(&path).unwrap();
    bytes[8..10].copy_from_slice(&1u16.to_le_bytes());
    let crc = crc32fast::hash(&bytes[..60]);
    bytes[60..64].copy_from_slice(&crc.to_le_bytes());
    let v1 = dir.path().join("v1.gwk");
    std::fs::write(&v1, &bytes).unwrap();
    check(&SceneReader::open(&v1).unwrap());
}
