//! The machine hall: a factory floor of CAD-like assemblies (engine gensets,
//! gear drives, robot cells, pump skids, switchgear rows) standing in rows
//! with aisles between them, and nothing else: no walls and no roof, so the
//! only occluders are the machines themselves.
//!
//! Each assembly is hundreds of small disjoint parts, as a CAD export is:
//! sheet-metal shells with both faces modelled, hex bolts with heads and
//! shanks, nuts, washers, rivets in rows, gears, bearings with their balls,
//! hoses and cables as rows of short separate segments, brackets and boxes.
//! Every part is one connected piece once equal positions are welded (a
//! loft, box, sphere or torus whose faces share exact positions), and no two
//! parts share a position: mating parts stand [`GAP`] apart. Parts are merged
//! into one mesh per subassembly and material, as CAD exporters merge by
//! material, so one object holds many disjoint parts; a design is instanced
//! by every machine of its line (one to three identical machines side by
//! side in a row, turned alike).
//!
//! Units are metres. The camera walks the aisle centre lines; every part of
//! a machine lies within [`HALF`] of its slot centre, so at least 2.25 m
//! from them.

mod asm;
mod components;
mod decorate;
mod parts;

// The five designs. Each builds its main parts in order of importance (so a
// small budget still gets a recognisable machine) and leaves the rest of its
// budget to `decorate`.
mod engine;
mod gear_drive;
mod pump_skid;
mod robot_cell;
mod switchgear;

use std::f64::consts::FRAC_PI_2;

use glam::{DQuat, DVec3, Vec3};

use crate::glb::{GlbBuilder, Material};
use crate::plant::mat;
use crate::rng::Rng;
use crate::shapes::Mesh;
use crate::walk::Grid;

use asm::Asm;
use decorate::decorate;
use engine::engine;
use gear_drive::gear_drive;
use pump_skid::pump_skid;
use robot_cell::robot_cell;
use switchgear::switchgear;

/// A machine's square floor slot and the aisle around it: 7 m slots between
/// 3.5 m aisles, a forklift aisle in a machine hall.
const SLOT: f32 = 7.0;
const AISLE: f32 = 3.5;
const PITCH: f32 = SLOT + AISLE;
/// Every part lies within this distance of its slot centre in x and z (and
/// above the floor): half a metre of slot left free around each machine.
const HALF: f32 = 3.0;
/// Triangles per machine: sets how the floor grows with the budget (a
/// 1M-triangle hall has 33 machines on a 6 x 6 grid of slots).
const TRIANGLES_PER_MACHINE: u64 = 30_000;
/// Clearance between mating parts (flange on flange, washer on plate), so
/// that no two parts share a vertex position.
const GAP: f32 = 0.001;
/// Sheet-metal wall thickness of covers and housings.
const SHEET: f32 = 0.004;

const FLOOR: usize = 0;
const MARKING: usize = 1;
const ZINC: usize = 2;
const BLACK: usize = 3;
const RUBBER: usize = 4;
const COPPER: usize = 5;
const BRASS: usize = 6;
const PCB: usize = 7;
const CABLES: [usize; 3] = [8, 9, 10];
const STEEL: usize = 11;
const PAINTS: [usize; 8] = [12, 13, 14, 15, 16, 17, 18, 19];
const LIGHT_GREY: usize = 15;
const SIGNAL_RED: usize = 17;
const SAFETY_YELLOW: usize = 19;

const MATERIALS: [Material; 20] = [
    mat("floor_concrete", [0.55, 0.55, 0.52], 0.0, 0.85),
    mat("floor_marking", [0.90, 0.75, 0.05], 0.0, 0.6),
    mat("zinc", [0.72, 0.73, 0.74], 0.9, 0.35),
    mat("black_oxide", [0.10, 0.10, 0.11], 0.7, 0.5),
    mat("rubber", [0.05, 0.05, 0.05], 0.0, 0.9),
    mat("copper", [0.72, 0.42, 0.25], 0.9, 0.3),
    mat("brass", [0.70, 0.55, 0.25], 0.9, 0.3),
    mat("pcb_green", [0.05, 0.35, 0.15], 0.1, 0.6),
    mat("cable_grey", [0.45, 0.46, 0.48], 0.0, 0.7),
    mat("cable_orange", [0.85, 0.35, 0.05], 0.0, 0.7),
    mat("cable_blue", [0.10, 0.25, 0.65], 0.0, 0.7),
    mat("steel", [0.56, 0.57, 0.58], 0.9, 0.4),
    mat("machine_green", [0.30, 0.45, 0.35], 0.3, 0.5),
    mat("signal_blue", [0.10, 0.30, 0.55], 0.3, 0.5),
    mat("pure_orange", [0.90, 0.40, 0.05], 0.3, 0.5),
    mat("light_grey", [0.78, 0.78, 0.75], 0.3, 0.5),
    mat("cream", [0.85, 0.80, 0.65], 0.3, 0.5),
    mat("traffic_red", [0.70, 0.10, 0.08], 0.3, 0.5),
    mat("anthracite", [0.22, 0.24, 0.26], 0.4, 0.5),
    mat("zinc_yellow", [0.90, 0.75, 0.10], 0.3, 0.5),
];

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Design {
    Engine,
    GearDrive,
    RobotCell,
    PumpSkid,
    Switchgear,
}

impl Design {
    fn name(self) -> &'static str {
        match self {
            Design::Engine => "engine",
            Design::GearDrive => "gear_drive",
            Design::RobotCell => "robot_cell",
            Design::PumpSkid => "pump_skid",
            Design::Switchgear => "switchgear",
        }
    }
}

pub(crate) fn build(generator: String, target: u64, rng: &mut Rng) -> (GlbBuilder, Grid) {
    let mut b = GlbBuilder::new(generator, &MATERIALS);
    let machines = (target / TRIANGLES_PER_MACHINE).max(1) as usize;
    let nx = (machines as f64).sqrt().ceil() as usize;
    let nz = machines.div_ceil(nx);
    let (w, d) = (nx as f32 * PITCH + AISLE, nz as f32 * PITCH + AISLE);
    let slot_centre = |i: usize, j: usize| {
        Vec3::new(
            AISLE + i as f32 * PITCH + 0.5 * SLOT,
            0.0,
            AISLE + j as f32 * PITCH + 0.5 * SLOT,
        )
    };

    // The floor: a slab and a painted line around every slot.
    let mut m = Mesh::default();
    m.aabox(
        Vec3::new(-1.0, -0.3, -1.0),
        Vec3::new(w + 1.0, 0.0, d + 1.0),
    );
    b.object("floor", "floor", FLOOR, m);
    let mut m = Mesh::default();
    for k in 0..machines {
        let c = slot_centre(k % nx, k / nx);
        let (h, line) = (0.5 * SLOT, 0.08);
        for (min, max) in [
            (Vec3::new(-h, 0.0, -h), Vec3::new(h, 0.003, -h + line)),
            (Vec3::new(-h, 0.0, h - line), Vec3::new(h, 0.003, h)),
            (
                Vec3::new(-h, 0.0, -h + line),
                Vec3::new(-h + line, 0.003, h - line),
            ),
            (
                Vec3::new(h - line, 0.0, -h + line),
                Vec3::new(h, 0.003, h - line),
            ),
        ] {
            m.aabox(c + min, c + max);
        }
    }
    if b.triangles() + m.triangles() as u64 <= target {
        b.object("floor", "floor_marking", MARKING, m);
    }

    // Machines row by row; a line of identical machines shares one design's
    // meshes. Each design gets an even share of what is left, so the total
    // never passes the target.
    let mut design = 0usize;
    let mut k = 0usize;
    while k < machines {
        let in_row = nx - k % nx;
        let copies = (1 + rng.below(3)).min(in_row).min(machines - k);
        let budget = (target.saturating_sub(b.triangles())) / (machines - k) as u64;
        let kind = match rng.below(5) {
            0 => Design::Engine,
            1 => Design::GearDrive,
            2 => Design::RobotCell,
            3 => Design::PumpSkid,
            _ => Design::Switchgear,
        };
        let asm = assembly(kind, budget, &mut rng.fork());
        let yaw = rng.below(4);
        let ids: Vec<_> = asm
            .meshes
            .iter()
            .map(|(sub, material, mesh)| {
                let name = format!(
                    "{}_d{design:03}.{sub}.{}",
                    kind.name(),
                    MATERIALS[*material].name
                );
                (*sub, b.add_mesh(&name, *material, mesh))
            })
            .collect();
        for _ in 0..copies {
            let c = slot_centre(k % nx, k / nx);
            let rotation = (yaw > 0).then(|| DQuat::from_rotation_y(yaw as f64 * FRAC_PI_2));
            for (sub, id) in &ids {
                b.instance(
                    "machines",
                    &format!("{}_{k:03}.{sub}", kind.name()),
                    *id,
                    DVec3::new(c.x as f64, 0.0, c.z as f64),
                    rotation,
                    None,
                );
            }
            k += 1;
        }
        design += 1;
    }

    let grid = Grid {
        xs: (0..=nx)
            .map(|i| (i as f32 * PITCH + 0.5 * AISLE) as f64)
            .collect(),
        zs: (0..=nz)
            .map(|j| (j as f32 * PITCH + 0.5 * AISLE) as f64)
            .collect(),
        floor: 0.0,
    };
    (b, grid)
}

/// One machine in its slot's frame (origin at the slot centre on the floor),
/// at most `budget` triangles.
fn assembly(kind: Design, budget: u64, rng: &mut Rng) -> Asm {
    let mut a = new_asm(budget, rng);
    build_design(kind, &mut a, rng);
    decorate(&mut a, rng);
    a
}

fn new_asm(budget: u64, rng: &mut Rng) -> Asm {
    let paint = PAINTS[rng.below(PAINTS.len())];
    let mut trim = PAINTS[rng.below(PAINTS.len())];
    if trim == paint {
        trim = BLACK;
    }
    Asm {
        budget,
        tris: 0,
        parts: 0,
        paint,
        trim,
        meshes: Vec::new(),
        log: Vec::new(),
        faces: Vec::new(),
        scratch: Mesh::default(),
    }
}

fn build_design(kind: Design, a: &mut Asm, rng: &mut Rng) {
    let s = rng.rangef(0.85, 1.15);
    match kind {
        Design::Engine => engine(a, rng, s),
        Design::GearDrive => gear_drive(a, rng, s),
        Design::RobotCell => robot_cell(a, rng, s.min(1.05)),
        Design::PumpSkid => pump_skid(a, rng, s),
        Design::Switchgear => switchgear(a, rng, s),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DESIGNS: [Design; 5] = [
        Design::Engine,
        Design::GearDrive,
        Design::RobotCell,
        Design::PumpSkid,
        Design::Switchgear,
    ];

    /// Triangles of each connected piece of all of `a`'s meshes together,
    /// equal positions welded (as a simplifier sees them).
    fn pieces(a: &Asm) -> Vec<usize> {
        let mut pos = Vec::new();
        let mut tris = Vec::new();
        for (_, _, m) in &a.meshes {
            let base = pos.len() as u32;
            pos.extend(m.positions.iter().map(|p| p.to_array().map(f32::to_bits)));
            tris.extend(m.indices.iter().map(|i| i + base));
        }
        let mut count = Vec::new();
        for p in crate::shapes::welded_pieces(&pos, &tris) {
            if p == count.len() {
                count.push(0);
            }
            count[p] += 1;
        }
        count
    }

    /// Names the parts that share a position with another part.
    fn report_touching(a: &Asm) {
        let mut start = vec![0usize; a.meshes.len()];
        let mut owner: std::collections::BTreeMap<[u32; 3], (usize, usize)> = Default::default();
        for (k, &(mi, t)) in a.log.iter().enumerate() {
            let m = &a.meshes[mi].2;
            let tris = start[mi]..start[mi] + t as usize;
            start[mi] += t as usize;
            let mut mine: Vec<[u32; 3]> = m.indices[3 * tris.start..3 * tris.end]
                .iter()
                .map(|&i| m.positions[i as usize].to_array().map(f32::to_bits))
                .collect();
            mine.sort_unstable();
            mine.dedup();
            for p in mine {
                if let Some(&(other, omi)) = owner.get(&p) {
                    println!(
                        "part {k} ({}, {} tris) shares {:?} with part {other} ({}, {} tris)",
                        a.meshes[mi].0,
                        t,
                        p.map(f32::from_bits),
                        a.meshes[omi].0,
                        a.log[other].1
                    );
                } else {
                    owner.insert(p, (k, mi));
                }
            }
        }
    }

    #[test]
    fn every_part_is_one_piece_and_no_two_parts_touch() {
        for kind in DESIGNS {
            for seed in 0..4 {
                let a = assembly(kind, TRIANGLES_PER_MACHINE, &mut Rng::new(seed));
                let p = pieces(&a);
                if p.len() != a.parts {
                    report_touching(&a);
                }
                assert_eq!(p.len(), a.parts, "{kind:?} seed {seed}");
                assert_eq!(p.iter().sum::<usize>() as u64, a.tris);
                assert!(a.tris <= TRIANGLES_PER_MACHINE);
                assert!(
                    a.tris + 12 > TRIANGLES_PER_MACHINE,
                    "{kind:?} seed {seed}: {} of {TRIANGLES_PER_MACHINE}",
                    a.tris
                );
                let (min, max) = (p.iter().min().unwrap(), p.iter().max().unwrap());
                assert!(*min >= 12 && *max <= 500, "{kind:?}: parts of {min}..{max}");
                assert!(
                    (200..=1500).contains(&a.parts),
                    "{kind:?} seed {seed}: {} parts",
                    a.parts
                );
            }
        }
    }

    /// A design's own parts, without the detail that fills its budget.
    fn core(kind: Design, rng: &mut Rng) -> Asm {
        let mut a = new_asm(1 << 40, rng);
        build_design(kind, &mut a, rng);
        a
    }

    #[test]
    fn every_face_of_every_design_faces_its_normals() {
        for (kind, seed) in DESIGNS
            .into_iter()
            .flat_map(|k| (0..4).map(move |s| (k, s)))
        {
            let a = assembly(kind, TRIANGLES_PER_MACHINE, &mut Rng::new(seed));
            for (sub, _, m) in &a.meshes {
                for t in m.indices.chunks_exact(3) {
                    let [p, q, r] = [0, 1, 2].map(|k| m.positions[t[k] as usize]);
                    let n = (q - p).cross(r - p);
                    let vn: Vec3 = t.iter().map(|&i| m.normals[i as usize]).sum();
                    assert!(
                        n.dot(vn) > 0.0,
                        "{kind:?} {sub}: triangle {t:?} faces inward"
                    );
                }
            }
        }
    }

    #[test]
    fn designs_have_hundreds_of_parts_before_any_detail() {
        for kind in DESIGNS {
            for seed in 0..4 {
                let a = core(kind, &mut Rng::new(seed));
                assert!(a.parts >= 300, "{kind:?} seed {seed}: {} parts", a.parts);
                assert!(!a.faces.is_empty(), "{kind:?}: nowhere to put detail");
            }
        }
    }
}
