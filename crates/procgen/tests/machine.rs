//! The machine hall: its name, and what the scene is for: every machine
//! an assembly of hundreds of small disjoint parts, walked past along
//! aisles that no machine blocks (generate -> import and same seed, same
//! bytes are in tests/roundtrip.rs, as for every kind).

use gigawalk_import::{import_glb_bytes, Model};
use gigawalk_procgen::{generate, Kind, EYE_HEIGHT};
use gigawalk_scene::Aabb;

#[test]
fn machine_kind_parses_and_round_trips_its_name() {
    let k: Kind = "machine".parse().unwrap();
    assert_eq!(k, Kind::Machine);
    assert_eq!(k.name(), "machine");
    assert_eq!(k.name().parse::<Kind>(), Ok(k));
    let err = "machines".parse::<Kind>().unwrap_err();
    assert!(err.contains("machine"), "{err}");
}

/// The machine an object belongs to: its node's name up to the dot
/// ("engine_007.block" -> "engine_007"); `None` for the floor.
fn machine_of(label: &str) -> Option<&str> {
    let node = label.strip_prefix("node \"")?;
    let node = &node[..node.find('"')?];
    Some(&node[..node.find('.')?])
}

/// Each machine's objects, in the order first seen.
fn machines(model: &Model) -> Vec<(String, Vec<usize>)> {
    let mut out: Vec<(String, Vec<usize>)> = Vec::new();
    for (k, o) in model.objects.iter().enumerate() {
        let Some(m) = machine_of(&o.name) else {
            continue;
        };
        match out.iter_mut().find(|(n, _)| n == m) {
            Some((_, v)) => v.push(k),
            None => out.push((m.to_owned(), vec![k])),
        }
    }
    out
}

/// The connected pieces of a set of objects once equal positions are
/// welded (what a simplifier sees as separate parts): triangles and box
/// diagonal of each.
fn pieces(model: &Model, objects: &[usize]) -> Vec<(usize, f64)> {
    let mut pos = Vec::new();
    let mut tris = Vec::new();
    for &k in objects {
        let o = &model.objects[k];
        let base = pos.len() as u32;
        pos.extend(o.positions.iter().copied());
        tris.extend(o.indices.iter().map(|i| i + base));
    }
    let keys: Vec<[u64; 3]> = pos.iter().map(|p| p.to_array().map(f64::to_bits)).collect();
    let mut out: Vec<(usize, Aabb)> = Vec::new();
    for (t, p) in tris
        .chunks_exact(3)
        .zip(gigawalk_procgen::shapes::welded_pieces(&keys, &tris))
    {
        if p == out.len() {
            out.push((0, Aabb::EMPTY));
        }
        out[p].0 += 1;
        for &v in t {
            out[p].1.grow(pos[v as usize]);
        }
    }
    out.into_iter().map(|(n, b)| (n, b.diagonal())).collect()
}

#[test]
fn machines_are_hundreds_of_small_disjoint_parts() {
    let g = generate(Kind::Machine, 200_000, 5, 10);
    let model = import_glb_bytes(&g.glb_bytes(), "machine").unwrap();
    let machines = machines(&model);
    assert!(machines.len() >= 5, "{} machines", machines.len());
    let mut all: Vec<(usize, f64)> = Vec::new();
    let mut counts = Vec::new();
    for (name, objects) in &machines {
        let p = pieces(&model, objects);
        assert!(p.len() >= 100, "{name}: {} parts", p.len());
        assert!(p.len() <= 1500, "{name}: {} parts", p.len());
        // Parts merged into one object by material: many parts an object.
        assert!(p.len() >= 5 * objects.len(), "{name}");
        counts.push(p.len());
        all.extend(p);
    }
    let mean = counts.iter().sum::<usize>() as f64 / counts.len() as f64;
    assert!(mean >= 200.0, "{mean} parts a machine: {counts:?}");
    let mut tris: Vec<usize> = all.iter().map(|p| p.0).collect();
    tris.sort_unstable();
    let median = tris[tris.len() / 2];
    assert!(median <= 500, "median part of {median} triangles");
    assert!(
        tris[0] >= 12 && tris[tris.len() - 1] <= 500,
        "parts of {}..{} triangles",
        tris[0],
        tris[tris.len() - 1]
    );
    // Mostly parts a few centimetres across, next to housings of metres.
    let mut sizes: Vec<f64> = all.iter().map(|p| p.1).collect();
    sizes.sort_by(f64::total_cmp);
    let median = sizes[sizes.len() / 2];
    assert!(median <= 0.15, "median part {median} m across");
    assert!(
        sizes[sizes.len() - 1] >= 1.0,
        "largest part {} m",
        sizes[sizes.len() - 1]
    );
    println!(
        "{} machines, parts a machine {counts:?} (mean {mean:.0}), part triangles median {} max {}, size median {:.3} m",
        machines.len(),
        tris[tris.len() / 2],
        tris[tris.len() - 1],
        median
    );
}

#[test]
fn machine_walk_stays_in_the_aisles_at_eye_height() {
    let g = generate(Kind::Machine, 200_000, 2, 600);
    let model = import_glb_bytes(&g.glb_bytes(), "machine").unwrap();
    let boxes: Vec<(String, Aabb)> = machines(&model)
        .into_iter()
        .map(|(name, objects)| {
            let b = Aabb::from_points(
                objects
                    .iter()
                    .flat_map(|&k| model.objects[k].positions.iter().copied()),
            );
            (name, b)
        })
        .collect();
    let b = g.report.bounds;
    let p = &g.path.poses;
    assert_eq!(p.len(), 600);
    let mut moved = 0.0;
    for w in p.windows(2) {
        moved += (w[1].position - w[0].position).length();
    }
    assert!(moved > 20.0, "walked only {moved} m");
    // A walker half a metre wide, from the floor to the eyes.
    let body = 0.5;
    for pose in p {
        let e = pose.position;
        assert!((e.y - EYE_HEIGHT).abs() < 1e-9);
        assert!(b.contains_point(e), "{e:?} outside {b:?}");
        for (name, m) in &boxes {
            let inside = e.x > m.min.x - body
                && e.x < m.max.x + body
                && e.z > m.min.z - body
                && e.z < m.max.z + body;
            assert!(!inside, "pose {e:?} walks through {name} {m:?}");
        }
    }
}
