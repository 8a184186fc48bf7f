//! The forest: trees, bushes and rocks scattered over flat ground, crossed
//! by a grid of trails. Many small occluders and deep visibility with little
//! occlusion: the hard case for HZB culling (Hey et al.; Bartz et al.).
//!
//! Units are metres. The camera walks the trail centre lines; nothing taller
//! than a pebble stands within 2.5 m of them.

use glam::{DQuat, DVec3, Vec3};

use crate::glb::{GlbBuilder, Material, MeshId};
use crate::plant::mat;
use crate::rng::Rng;
use crate::shapes::Mesh;
use crate::walk::Grid;

/// Trail grid pitch: trails 60 m apart.
const CELL: f32 = 60.0;
/// Nothing but ground within this distance of a trail centre line.
const TRAIL_CLEAR: f32 = 2.5;
/// Triangles per trail cell: a 1M-triangle forest has 16 cells (240 m
/// square), 20M has 334 (about 1.1 km square).
const TRIANGLES_PER_CELL: u64 = 60_000;
const TREE_SHARE: f64 = 0.7;
/// Ground patches: one 16 x 16 quad grid per cell.
const GROUND_RES: u32 = 16;

const GROUND: usize = 0;
const BARK: usize = 1;
const LEAVES: [usize; 3] = [2, 3, 4];
const ROCK: usize = 5;
const MUSHROOM: usize = 6;

const MATERIALS: [Material; 7] = [
    mat("forest_floor", [0.25, 0.20, 0.12], 0.0, 1.0),
    mat("bark", [0.28, 0.20, 0.13], 0.0, 0.9),
    mat("conifer", [0.08, 0.25, 0.10], 0.0, 0.9),
    mat("broadleaf", [0.20, 0.42, 0.12], 0.0, 0.9),
    mat("birch_leaf", [0.45, 0.55, 0.15], 0.0, 0.9),
    mat("rock", [0.45, 0.45, 0.43], 0.0, 0.8),
    mat("mushroom", [0.75, 0.15, 0.10], 0.0, 0.7),
];

fn conifer(rng: &mut Rng) -> Mesh {
    let mut m = Mesh::default();
    let h = rng.rangef(10.0, 18.0);
    m.tube(Vec3::ZERO, Vec3::Y * h * 0.5, 0.25, 0.12, 8, 2, false);
    let tiers = 4;
    for t in 0..tiers {
        let y0 = 1.5 + t as f32 * (h - 2.0) / tiers as f32;
        let r = 3.0 * (1.0 - t as f32 / (tiers + 1) as f32);
        m.cone(Vec3::Y * y0, Vec3::Y * (y0 + (h - y0).min(r * 2.2)), r, 12);
    }
    m
}

fn broadleaf(rng: &mut Rng) -> Mesh {
    let mut m = Mesh::default();
    let h = rng.rangef(8.0, 14.0);
    m.tube(Vec3::ZERO, Vec3::Y * h * 0.55, 0.35, 0.2, 10, 3, false);
    for k in 0..4 {
        let a = k as f32 * std::f32::consts::FRAC_PI_2 + rng.rangef(-0.4, 0.4);
        let from = Vec3::Y * h * rng.rangef(0.35, 0.5);
        let to = from + Vec3::new(a.cos() * 2.5, rng.rangef(1.5, 3.0), a.sin() * 2.5);
        m.tube(from, to, 0.12, 0.06, 6, 2, false);
        m.sphere(to, rng.rangef(1.6, 2.4), Vec3::new(1.0, 0.8, 1.0), 6, 10);
    }
    m.sphere(Vec3::Y * h * 0.8, h * 0.25, Vec3::new(1.0, 0.8, 1.0), 8, 14);
    m
}

pub(crate) fn build(generator: String, target: u64, rng: &mut Rng) -> (GlbBuilder, Grid) {
    let mut b = GlbBuilder::new(generator, &MATERIALS);
    let cells = (target / TRIANGLES_PER_CELL).max(1);
    let nx = (cells as f64).sqrt().ceil() as usize;
    let nz = (cells as usize).div_ceil(nx);
    let (w, d) = (nx as f32 * CELL, nz as f32 * CELL);

    // Prototypes: a dozen tree shapes, bushes, rocks, fallen logs, mushrooms.
    let trees: Vec<(MeshId, usize)> = (0..12)
        .map(|k| {
            let (m, leaf) = if k % 2 == 0 {
                (conifer(rng), LEAVES[0])
            } else {
                (broadleaf(rng), LEAVES[1 + k % 4 / 2])
            };
            (b.add_mesh("tree", leaf, &m), leaf)
        })
        .collect();
    let mut m = Mesh::default();
    m.sphere(Vec3::Y * 0.5, 0.9, Vec3::new(1.0, 0.7, 1.0), 6, 10);
    let bush = b.add_mesh("bush", LEAVES[1], &m);
    let mut m = Mesh::default();
    m.sphere(Vec3::ZERO, 1.0, Vec3::new(1.3, 0.6, 1.0), 5, 8);
    let rock = b.add_mesh("rock", ROCK, &m);
    let mut m = Mesh::default();
    m.tube(
        Vec3::new(-3.0, 0.25, 0.0),
        Vec3::new(3.0, 0.3, 0.0),
        0.3,
        0.22,
        10,
        3,
        true,
    );
    let log = b.add_mesh("log", BARK, &m);
    let mut m = Mesh::default();
    m.tube(Vec3::ZERO, Vec3::Y * 0.05, 0.008, 0.008, 6, 1, false);
    m.cone(Vec3::Y * 0.045, Vec3::Y * 0.075, 0.03, 8);
    let mushroom = b.add_mesh("mushroom", MUSHROOM, &m);

    for j in 0..nz {
        for i in 0..nx {
            let mut m = Mesh::default();
            m.ground(
                Vec3::new(i as f32 * CELL, 0.0, j as f32 * CELL),
                CELL,
                CELL,
                GROUND_RES,
                GROUND_RES,
            );
            b.object("ground", "ground", GROUND, m);
        }
    }
    let trails_x: Vec<f32> = (0..=nx).map(|i| i as f32 * CELL).collect();
    let trails_z: Vec<f32> = (0..=nz).map(|j| j as f32 * CELL).collect();
    let clear_of_trails = |p: Vec3, r: f32| {
        trails_x.iter().all(|&x| (p.x - x).abs() > TRAIL_CLEAR + r)
            && trails_z.iter().all(|&z| (p.z - z).abs() > TRAIL_CLEAR + r)
    };

    // Trees on a jittered grid whose spacing spends the tree share of the
    // budget over the whole area.
    let avg_tree: f64 = trees
        .iter()
        .map(|t| b.mesh_triangles(t.0) as f64)
        .sum::<f64>()
        / trees.len() as f64;
    let tree_budget = b.triangles() + (target as f64 * TREE_SHARE) as u64;
    let count = (target as f64 * TREE_SHARE / avg_tree).max(1.0);
    let spacing = ((w * d) as f64 / count).sqrt() as f32;
    let (gx, gz) = ((w / spacing) as usize + 1, (d / spacing) as usize + 1);
    'trees: for a in 0..gz {
        for c in 0..gx {
            let p = Vec3::new(
                (c as f32 + rng.rangef(0.1, 0.9)) * spacing,
                0.0,
                (a as f32 + rng.rangef(0.1, 0.9)) * spacing,
            );
            let (mesh, _) = trees[rng.below(trees.len())];
            let s = rng.range(0.7, 1.3);
            if p.x >= w || p.z >= d || !clear_of_trails(p, 1.0) {
                continue;
            }
            if b.triangles() + b.mesh_triangles(mesh) > tree_budget {
                break 'trees;
            }
            let q = DQuat::from_rotation_y(rng.range(0.0, std::f64::consts::TAU));
            b.instance(
                "trees",
                "tree",
                mesh,
                p.as_dvec3(),
                Some(q),
                Some(DVec3::splat(s)),
            );
        }
    }

    // Undergrowth fills the rest: bushes, rocks, logs, and mushrooms last
    // (the smallest objects, centimetres across).
    let smallest = b.mesh_triangles(mushroom);
    while b.triangles() + smallest <= target {
        let left = target - b.triangles();
        let roll = rng.below(10);
        let (mesh, clear, scale) = match roll {
            0..=3 => (bush, 1.2, DVec3::splat(rng.range(0.6, 1.6))),
            4..=5 => {
                let s = rng.range(0.15, 1.8);
                (
                    rock,
                    2.0 * s as f32,
                    DVec3::new(s, s * rng.range(0.6, 1.2), s),
                )
            }
            6 => (log, 3.2, DVec3::ONE),
            _ => (mushroom, 0.1, DVec3::splat(rng.range(0.7, 1.5))),
        };
        let mesh = if b.mesh_triangles(mesh) > left {
            mushroom
        } else {
            mesh
        };
        let p = Vec3::new(rng.rangef(0.0, w), 0.0, rng.rangef(0.0, d));
        if !clear_of_trails(p, clear) {
            continue;
        }
        let q = DQuat::from_rotation_y(rng.range(0.0, std::f64::consts::TAU));
        b.instance(
            "undergrowth",
            "undergrowth",
            mesh,
            p.as_dvec3(),
            Some(q),
            Some(scale),
        );
    }
    let _ = BARK;
    let grid = Grid {
        xs: trails_x.iter().map(|&x| x as f64).collect(),
        zs: trails_z.iter().map(|&z| z as f64).collect(),
        floor: 0.0,
    };
    (b, grid)
}
