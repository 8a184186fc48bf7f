//! End-to-end checks of the pipeline on hand-built models, into memory and
//! into scene files.

use std::convert::Infallible;

use gigawalk_import::{Model, Object};
use gigawalk_scene::{LodMesh, SceneReader};
use glam::DVec3;

use crate::partition::{SplitAt, SplitRule};
use crate::test_models::{bolt_objects, box_object, grid_object, pipe_object, ring_object};
use crate::verify::verify;
use crate::{build, preprocess, Built, LodSink, NoProgress, Params, PreprocessError};

#[derive(Default)]
struct MemorySink(Vec<(LodMesh, f32)>);

impl LodSink for MemorySink {
    type Error = Infallible;
    type Prepared = (LodMesh, f32);
    fn preparer(&self) -> Box<dyn Fn(&LodMesh, f32, &[u32]) -> (LodMesh, f32) + Send + Sync> {
        Box::new(|mesh, error, _| (mesh.clone(), error))
    }
    fn add_prepared(&mut self, lod: (LodMesh, f32)) -> Result<u32, Infallible> {
        self.0.push(lod);
        Ok(self.0.len() as u32 - 1)
    }
}

/// A small "plant": a long pipe run, a bumpy floor, a cluster of boxes and
/// a far-off group of boxes.
fn small_plant() -> Model {
    let mut objects: Vec<Object> = vec![
        pipe_object(DVec3::new(0.0, 2.0, 0.0), 80.0, 0.5, 400, 12),
        grid_object(DVec3::new(0.0, 0.0, -10.0), 40.0, 60, 0.2),
    ];
    for i in 0..40 {
        let min = DVec3::new((i % 8) as f64 * 1.2, 0.0, (i / 8) as f64 * 1.2);
        objects.push(box_object(min, min + DVec3::ONE));
    }
    for i in 0..10 {
        let min = DVec3::new(70.0 + i as f64 * 1.5, 0.0, 30.0);
        objects.push(box_object(min, min + DVec3::splat(0.8)));
    }
    Model {
        objects,
        ..Default::default()
    }
}

fn small_params() -> Params {
    Params {
        t1: 500,
        ..Params::default()
    }
}

fn build_in_memory(model: &Model, params: &Params) -> (Built, MemorySink) {
    let mut sink = MemorySink::default();
    let built = build(model, params, &mut sink, &NoProgress).unwrap();
    (built, sink)
}

fn part2_rule(built: &Built) -> SplitRule {
    let r = built.stats.resolved.as_ref().unwrap();
    SplitRule {
        max_triangles: r.t2,
        max_diagonal: r.s2,
        max_aspect: r.r2,
        at: SplitAt::CentreOfMass,
    }
}

#[test]
fn small_plant_meets_every_property() {
    let model = small_plant();
    let (built, sink) = build_in_memory(&model, &small_params());
    let errors: Vec<f32> = sink.0.iter().map(|l| l.1).collect();
    let v = verify(
        &model,
        &built.nodes,
        &errors,
        &mut |i| sink.0[i as usize].0.clone(),
        Some(&part2_rule(&built)),
    )
    .unwrap();
    let s = &built.stats;
    assert_eq!(v.matched_triangles as u64, s.triangles);
    assert_eq!(s.triangles, 9600 + 7200 + 50 * 12);
    assert_eq!(s.objects_init, 52);
    assert!(s.objects_part1 > s.objects_init, "{s:?}");
    assert!(s.objects_clust < s.objects_part1, "{s:?}");
    assert_eq!(v.leaves, s.objects_part2);
    assert!(
        s.leaf_lod_triangles.len() >= 3,
        "{:?}",
        s.leaf_lod_triangles
    );
    assert!(!s.inner_lod_triangles.is_empty());
}

#[test]
fn single_triangle_model() {
    let o = Object {
        name: "tri".into(),
        positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y],
        normals: vec![glam::Vec3::Z; 3],
        indices: vec![0, 1, 2],
        colour: [1.0, 0.0, 0.0, 1.0],
        vertex_colours: None,
        identity: Default::default(),
    };
    let model = Model {
        objects: vec![o],
        ..Default::default()
    };
    let (built, sink) = build_in_memory(&model, &Params::default());
    assert_eq!(built.nodes.len(), 1);
    assert_eq!(sink.0.len(), 1);
    assert_eq!(sink.0[0].1, 0.0);
}

#[test]
fn scene_far_from_origin_verifies() {
    let mut model = small_plant();
    for o in &mut model.objects {
        for p in &mut o.positions {
            *p += DVec3::new(1e7, -3e6, 2e7);
        }
    }
    let (built, sink) = build_in_memory(&model, &small_params());
    let errors: Vec<f32> = sink.0.iter().map(|l| l.1).collect();
    verify(
        &model,
        &built.nodes,
        &errors,
        &mut |i| sink.0[i as usize].0.clone(),
        Some(&part2_rule(&built)),
    )
    .unwrap();
}

#[test]
fn scene_file_round_trips_and_verifies() {
    let model = small_plant();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plant.gwk");
    let stats = preprocess(&model, &small_params(), &path, "small_plant", &NoProgress).unwrap();
    assert_eq!(stats.output_bytes, std::fs::metadata(&path).unwrap().len());
    let reader = SceneReader::open(&path).unwrap();
    let sk = reader.skeleton();
    assert_eq!(sk.finest_triangles(), stats.triangles);
    assert_eq!(sk.provenance().source, "small_plant");
    assert_eq!(sk.provenance().parameters["t1"], 500);
    let errors: Vec<f32> = sk.lods().iter().map(|l| l.error).collect();
    verify(
        &model,
        sk.nodes(),
        &errors,
        &mut |i| reader.read_lod(i).unwrap(),
        None,
    )
    .unwrap();
}

#[test]
fn same_input_gives_identical_bytes_with_one_thread_or_many() {
    let model = small_plant();
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str, threads: usize| {
        let path = dir.path().join(name);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| preprocess(&model, &small_params(), &path, "m", &NoProgress))
            .unwrap();
        std::fs::read(&path).unwrap()
    };
    let a = run("a.gwk", 1);
    let b = run("b.gwk", 4);
    let c = run("c.gwk", 4);
    assert!(a == b, "1 thread and 4 threads differ");
    assert!(b == c, "two 4-thread runs differ");
}

#[test]
fn bad_input_leaves_no_file() {
    let mut model = small_plant();
    model.objects[3].indices[5] = 999;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.gwk");
    let e = preprocess(&model, &Params::default(), &path, "m", &NoProgress).unwrap_err();
    assert!(matches!(e, PreprocessError::Input(_)), "{e}");
    assert!(e.to_string().contains("object 3"), "{e}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    let e = preprocess(
        &small_plant(),
        &Params {
            r1: 0.5,
            ..Params::default()
        },
        &path,
        "m",
        &NoProgress,
    )
    .unwrap_err();
    assert!(matches!(e, PreprocessError::Params(_)), "{e}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// Builds `objects` and checks every node's every stored error against
/// brute-force samples; returns the check's figures.
fn bounds_hold(objects: Vec<Object>, params: &Params) -> crate::verify::BoundCheck {
    bounds_hold_built(objects, params).0
}

/// [`bounds_hold`], and what was built.
fn bounds_hold_built(objects: Vec<Object>, params: &Params) -> (crate::verify::BoundCheck, Built) {
    let model = Model {
        objects,
        ..Default::default()
    };
    let (built, sink) = build_in_memory(&model, params);
    let errors: Vec<f32> = sink.0.iter().map(|l| l.1).collect();
    let check = crate::verify::check_error_bounds(
        &built.nodes,
        &errors,
        &mut |i| sink.0[i as usize].0.clone(),
        None,
        2000,
        7,
    )
    .unwrap();
    assert!(check.lods > 1, "{check:?}");
    (check, built)
}

#[test]
fn thin_box_errors_are_bounds() {
    // 10 x 0.01 x 10: the slab's two faces are simplified onto each other
    // early. Its 12 triangles are slivers on the sides; finely gridded top
    // and bottom faces give the simplifier something to remove.
    let objects = vec![
        box_object(DVec3::ZERO, DVec3::new(10.0, 0.01, 10.0)),
        grid_object(DVec3::new(0.0, 0.01, 0.0), 10.0, 40, 0.0),
        grid_object(DVec3::ZERO, 10.0, 40, 0.0),
    ];
    bounds_hold(objects, &Params::default());
}

#[test]
fn parallel_sheets_keep_both_or_pay_the_gap() {
    let gap = 0.3;
    let objects = vec![
        grid_object(DVec3::ZERO, 10.0, 48, 0.0),
        grid_object(DVec3::new(0.0, gap, 0.0), 10.0, 48, 0.0),
    ];
    let params = Params {
        node_budget: 64,
        ..Params::default()
    };
    let model = Model {
        objects: objects.clone(),
        ..Default::default()
    };
    let (built, sink) = build_in_memory(&model, &params);
    // The root stands for both sheets.
    for (mesh, error) in &sink.0[built.nodes[0].lods()] {
        // A level that lost one sheet has no vertex near its height.
        let ys: Vec<f64> = mesh
            .positions
            .iter()
            .map(|p| mesh.origin.y + p[1] as f64)
            .collect();
        let near = |h: f64| ys.iter().any(|y| (y - h).abs() < gap / 4.0);
        if !(near(0.0) && near(gap)) {
            assert!(
                *error as f64 >= gap * 0.99,
                "a sheet vanished at error {error}"
            );
        }
    }
    bounds_hold(objects, &params);
}

#[test]
fn ring_of_thin_pipes_errors_are_bounds() {
    let objects: Vec<Object> = (0..24)
        .map(|i| {
            let a = i as f64 / 24.0 * std::f64::consts::TAU;
            let start = DVec3::new(20.0 * a.cos(), 0.0, 20.0 * a.sin());
            pipe_object(start, 6.0, 0.05, 40, 8)
        })
        .collect();
    let check = bounds_hold(objects, &Params::default());
    assert!(check.worst_ratio <= 1.0);
}

#[test]
fn small_plant_errors_are_bounds() {
    let model = small_plant();
    let check = bounds_hold(model.objects, &small_params());
    // How tight: some sample comes close to its bound.
    assert!(check.worst_ratio > 0.3, "{check:?}");
}

#[test]
fn small_plant_errors_are_bounds_with_the_better_of_two_leaf_chains() {
    let model = small_plant();
    let params = Params {
        leaf_chains: crate::LeafChains::Best,
        ..small_params()
    };
    let (check, built) = bounds_hold_built(model.objects, &params);
    assert!(check.worst_ratio <= 1.0, "{check:?}");
    let chosen = built.stats.certification.leaf_cover_chosen;
    assert!(
        chosen > 0 && (chosen as usize) < built.stats.leaves,
        "{chosen} of {} leaves",
        built.stats.leaves
    );
    // The kept-pieces chains alone choose nothing.
    let (_, kept) = bounds_hold_built(small_plant().objects, &small_params());
    assert_eq!(kept.stats.certification.leaf_cover_chosen, 0);
}

#[test]
fn merged_proxies_are_bounds_on_thin_open_shells_and_small_parts() {
    // Single-sided sheets (no volume at all) a little apart, thin pipes
    // and rows of small boxes: the parts proxies merge. Every stored
    // error, proxies' included, must bound brute-force samples, and the
    // shells must not vanish (a sample on a sheet far from its level is
    // what the check would find).
    let objects =
        sheets_pipes_and_boxes(grid_object(DVec3::new(0.0, 1.0, 0.0), 10.0, 24, 0.1), 0.3);
    let on = Params {
        proxies: true,
        ..small_params()
    };
    let (check, built) = bounds_hold_built(objects.clone(), &on);
    assert!(check.worst_ratio <= 1.0, "{check:?}");
    let c = built.stats.certification;
    assert!(c.proxies_kept > 0 && c.proxies >= c.proxies_kept, "{c:?}");
    // Off (the default), none is made.
    let (_, without) = bounds_hold_built(objects, &small_params());
    assert_eq!(without.stats.certification.proxies, 0);
}

/// Triangles the subtree of `node` draws at `error`: each node its
/// coarsest level within it, else its children's; a leaf with none its
/// finest (as traversal and `gigawalk info` count it).
fn drawn_at(built: &Built, sink: &MemorySink, node: u32, error: f32) -> u64 {
    let n = &built.nodes[node as usize];
    let level = n.lods().rev().find(|&l| sink.0[l].1 <= error);
    match level {
        Some(l) => sink.0[l].0.triangle_count() as u64,
        None if n.is_leaf() => n
            .lods()
            .next()
            .map_or(0, |l| sink.0[l].0.triangle_count() as u64),
        None => n.children().map(|c| drawn_at(built, sink, c, error)).sum(),
    }
}

/// Per inner node with levels: the triangles its children draw at its
/// finest level's error over that level's triangles.
fn switch_factors(built: &Built, sink: &MemorySink) -> Vec<(u32, f64)> {
    (0..built.nodes.len() as u32)
        .filter_map(|i| {
            let n = &built.nodes[i as usize];
            let l = n.lods().next().filter(|_| !n.is_leaf())?;
            let (mesh, error) = &sink.0[l];
            let below: u64 = n.children().map(|c| drawn_at(built, sink, c, *error)).sum();
            Some((i, below as f64 / mesh.triangle_count().max(1) as f64))
        })
        .collect()
}

/// Builds a model of many small disjoint parts and checks what the
/// hierarchy makes of it: drawn at an error of `max_error` (a fraction of
/// the root's box diagonal), it costs at most an eighth of its
/// triangles, through HLODs whose errors brute-force sampling confirms,
/// and no node's switch to its children multiplies triangles by more
/// than 8.
fn disjoint_parts_aggregate(name: &str, objects: Vec<Object>, max_error: f64) {
    let model = Model {
        objects,
        ..Default::default()
    };
    // With the chains alone, and with merged proxies beside them.
    for proxies in [false, true] {
        let params = Params {
            proxies,
            ..Params::default()
        };
        parts_aggregate_with(
            &format!("{name}, proxies {proxies}"),
            &model,
            &params,
            max_error,
        );
    }
}

fn parts_aggregate_with(name: &str, model: &Model, params: &Params, max_error: f64) {
    let (built, sink) = build_in_memory(model, params);
    let full = built.stats.triangles;
    let diagonal = built.nodes[0].bounds.diagonal();
    let drawn = drawn_at(&built, &sink, 0, (max_error * diagonal) as f32);
    assert!(
        8 * drawn <= full,
        "{name}: {drawn} of {full} triangles at {:.1}% of the diagonal",
        100.0 * max_error
    );
    // The nodes drawn at that error, brute-force checked.
    let mut top = Vec::new();
    let mut stack = vec![0u32];
    let e = (max_error * diagonal) as f32;
    while let Some(n) = stack.pop() {
        let node = &built.nodes[n as usize];
        if node.lods().any(|l| sink.0[l].1 <= e) {
            top.push(n);
        } else {
            stack.extend(node.children());
        }
    }
    let errors: Vec<f32> = sink.0.iter().map(|l| l.1).collect();
    let check = crate::verify::check_error_bounds(
        &built.nodes,
        &errors,
        &mut |i| sink.0[i as usize].0.clone(),
        Some(&top),
        4000,
        11,
    )
    .unwrap();
    assert!(check.worst_ratio <= 1.0, "{name}: {check:?}");
    let switches = switch_factors(&built, &sink);
    let worst = switches
        .iter()
        .copied()
        .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
    assert!(
        worst.1 <= 8.0,
        "{name}: node {} switches by {:.1}x",
        worst.0,
        worst.1
    );
}

#[test]
fn a_grid_of_1000_bolts_aggregates() {
    // 40 x 25 bolts on a 5 cm pitch: 2,000 disjoint closed pieces.
    let mut objects = Vec::new();
    for i in 0..1000 {
        let base = DVec3::new(0.05 * (i % 40) as f64, 0.0, 0.05 * (i / 40) as f64);
        objects.extend(bolt_objects(base, 0.01));
    }
    disjoint_parts_aggregate("1000 bolts", objects, 0.02);
}

#[test]
fn a_plate_with_200_rivets_aggregates() {
    // A 2 x 1 m plate, 5 mm thick, finely gridded on top, with 200 rivet
    // heads in rows (closed octagonal studs, 1 cm across).
    let mut objects = vec![
        box_object(DVec3::ZERO, DVec3::new(2.0, 0.005, 1.0)),
        grid_object(DVec3::new(0.0, 0.005, 0.0), 1.0, 30, 0.0),
        grid_object(DVec3::new(1.0, 0.005, 0.0), 1.0, 30, 0.0),
    ];
    for i in 0..200 {
        let base = DVec3::new(
            0.05 + 0.095 * (i % 20) as f64,
            0.005,
            0.05 + 0.1 * (i / 20) as f64,
        );
        objects.push(crate::test_models::prism_object(base, 0.005, 0.004, 8));
    }
    disjoint_parts_aggregate("plate with 200 rivets", objects, 0.01);
}

#[test]
fn a_hose_of_300_rings_aggregates() {
    // A hose 6 m long along a gentle arc, made of 300 separate rings
    // (tori of 96 triangles), as CAD exports a corrugated hose.
    let mut objects = Vec::new();
    for i in 0..300 {
        let t = i as f64 / 300.0;
        let centre = DVec3::new(6.0 * t, 0.8 * (3.0 * t).sin(), 0.0);
        let mut ring = ring_object(DVec3::ZERO, 0.04, 0.008, 16, 6);
        // Each ring faces along the hose (+X): swap X and Z.
        for p in &mut ring.positions {
            *p = centre + DVec3::new(p.z, p.y, p.x);
        }
        for n in &mut ring.normals {
            *n = glam::Vec3::new(n.z, n.y, n.x);
        }
        objects.push(ring);
    }
    disjoint_parts_aggregate("hose of 300 rings", objects, 0.02);
}

/// The switch factors of a generated scene of about `triangles`.
fn generated_switches(kind: gigawalk_procgen::Kind, triangles: u64, params: &Params) -> Vec<f64> {
    let g = gigawalk_procgen::generate(kind, triangles, 3, 2);
    let model = gigawalk_import::import_glb_bytes(&g.glb_bytes(), kind.name()).unwrap();
    let (built, sink) = build_in_memory(&model, params);
    let mut f: Vec<f64> = switch_factors(&built, &sink).iter().map(|s| s.1).collect();
    f.sort_by(f64::total_cmp);
    f
}

#[test]
fn switch_factors_are_bounded_on_generated_scenes() {
    use gigawalk_procgen::Kind;
    // With merged proxies too: an inner node keeps one only where its
    // children draw at most 8 times its triangles.
    let proxies = Params {
        proxies: true,
        ..Params::default()
    };
    for (kind, params) in [
        (Kind::Plant, Params::default()),
        (Kind::City, Params::default()),
        (Kind::Forest, Params::default()),
        (Kind::Machine, Params::default()),
        (Kind::Machine, proxies),
    ] {
        let f = generated_switches(kind, 80_000, &params);
        let median = f[f.len() / 2];
        let max = f.last().copied().unwrap_or(0.0);
        eprintln!(
            "{}: {} inner nodes, switch median {median:.2}, max {max:.2}",
            kind.name(),
            f.len()
        );
        assert!(median <= 2.0, "{}: median switch {median}", kind.name());
        assert!(max <= 8.0, "{}: largest switch {max}", kind.name());
    }
}

/// Two single-sided 10 x 10 sheets 0.05 apart, `third` above them, six
/// thin pipes and 300 boxes of 0.2 on a grid of `pitch`: small, thin,
/// disjoint parts that simplifiers merge.
fn sheets_pipes_and_boxes(third: Object, pitch: f64) -> Vec<Object> {
    let mut objects = vec![
        grid_object(DVec3::ZERO, 10.0, 40, 0.0),
        grid_object(DVec3::new(0.0, 0.05, 0.0), 10.0, 40, 0.0),
        third,
    ];
    for i in 0..6 {
        objects.push(pipe_object(
            DVec3::new(0.0, 2.0, 1.5 * i as f64),
            10.0,
            0.02,
            40,
            6,
        ));
    }
    for i in 0..300 {
        let min = DVec3::new(pitch * (i % 30) as f64, 3.0, pitch * (i / 30) as f64);
        objects.push(box_object(min, min + DVec3::splat(0.2)));
    }
    objects
}

/// A `cells` x `cells` open sheet at `origin` with the middle cell of
/// every three by three left out: a perforated plate, whose holes pair
/// contraction may close.
fn perforated_sheet(origin: DVec3, size: f64, cells: u32) -> Object {
    let mut o = grid_object(origin, size, cells, 0.0);
    let kept: Vec<u32> = o
        .indices
        .chunks_exact(6)
        .enumerate()
        .filter(|(c, _)| {
            let (i, j) = (*c as u32 / cells, *c as u32 % cells);
            !(i % 3 == 1 && j % 3 == 1)
        })
        .flat_map(|(_, q)| q.iter().copied())
        .collect();
    o.indices = kept;
    o
}

#[test]
fn gaps_levels_are_bounds_on_open_sheets_closing_holes_and_merging_parts() {
    // Open sheets a little apart, a perforated plate, rows of cubes a
    // hair apart and thin pipes: what pair contraction joins, closes and
    // folds. Every stored error must bound brute-force samples.
    let objects =
        sheets_pipes_and_boxes(perforated_sheet(DVec3::new(0.0, 1.0, 0.0), 10.0, 36), 0.21);
    let on = Params {
        gaps: true,
        ..small_params()
    };
    let (check, built) = bounds_hold_built(objects.clone(), &on);
    assert!(check.worst_ratio <= 1.0, "{check:?}");
    let c = built.stats.certification;
    assert!(c.gaps_won > 0 && c.gaps >= c.gaps_won, "{c:?}");
    // Off, none is made.
    let off = Params {
        gaps: false,
        ..small_params()
    };
    let (_, without) = bounds_hold_built(objects, &off);
    assert_eq!(without.stats.certification.gaps, 0);
}
