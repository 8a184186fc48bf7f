//! The industrial plant (GigaWalk's Power Plant, paper Section 6): a grid of
//! equipment bays between aisles under one building shell, pipe runs
//! spanning the whole site above the aisles, catwalks and ladders, and small
//! parts (flanges, bolts, valves) filling the rest of the triangle budget.
//!
//! Units are metres. The camera walks the aisle centre lines, which nothing
//! below 5 m crosses.

use glam::{DQuat, DVec3, Vec3};

use crate::glb::{GlbBuilder, Material, MeshId};
use crate::rng::Rng;
use crate::shapes::Mesh;
use crate::walk::Grid;

/// Bay and aisle widths: an 18 m equipment bay and a 6 m aisle, roughly a
/// power-plant turbine hall's column grid.
const BAY: f32 = 18.0;
const AISLE: f32 = 6.0;
const PITCH: f32 = BAY + AISLE;
const STOREY: f32 = 8.0;
const ROOF: f32 = 3.0 * STOREY;
/// Triangles per bay: sets how the site grows with the budget (a 1M-triangle
/// plant has 25 bays, 20M has 500).
const TRIANGLES_PER_BAY: u64 = 40_000;
/// Shares of the budget per phase; the small parts take what is left.
const EQUIPMENT_SHARE: f64 = 0.45;
const PIPE_SHARE: f64 = 0.15;
const ACCESS_SHARE: f64 = 0.10;

const CONCRETE: usize = 0;
const STEEL: usize = 1;
const PIPE_COLOURS: [usize; 4] = [2, 3, 4, 5];
const SAFETY: usize = 6;
const DARK: usize = 7;
const WHITE: usize = 8;
const BOILER: usize = 9;
const BRASS: usize = 10;

const MATERIALS: [Material; 11] = [
    mat("concrete", [0.50, 0.50, 0.47], 0.0, 0.9),
    mat("steel", [0.56, 0.57, 0.58], 0.9, 0.4),
    mat("pipe_red", [0.60, 0.12, 0.08], 0.3, 0.5),
    mat("pipe_yellow", [0.75, 0.60, 0.10], 0.3, 0.5),
    mat("pipe_green", [0.15, 0.45, 0.20], 0.3, 0.5),
    mat("pipe_blue", [0.12, 0.25, 0.60], 0.3, 0.5),
    mat("safety_yellow", [0.90, 0.75, 0.05], 0.2, 0.6),
    mat("dark_grey", [0.15, 0.15, 0.16], 0.5, 0.6),
    mat("white", [0.85, 0.85, 0.82], 0.1, 0.5),
    mat("boiler_blue", [0.30, 0.38, 0.45], 0.6, 0.5),
    mat("brass", [0.70, 0.55, 0.25], 0.9, 0.3),
];

pub(crate) const fn mat(
    name: &'static str,
    c: [f32; 3],
    metallic: f32,
    roughness: f32,
) -> Material {
    Material {
        name,
        colour: [c[0], c[1], c[2], 1.0],
        metallic,
        roughness,
    }
}

#[derive(Clone, Copy, PartialEq)]
enum BayKind {
    Boiler,
    Turbine,
    Tanks,
    Room,
    Pumps,
}

struct Pipe {
    a: Vec3,
    b: Vec3,
    r: f32,
    /// Centre line of the aisle a rack pipe runs over (branches land
    /// outside the aisle so the walkway stays clear).
    aisle: f32,
}

/// Prototypes of the small parts, instanced many times.
struct Parts {
    flange: MeshId,
    bolt: MeshId,
    valve: MeshId,
    pump: [MeshId; 2],
}

/// Reference pipe radius the part prototypes are modelled for; instances
/// scale with the pipe they sit on.
const PART_REF_RADIUS: f32 = 0.2;

fn parts(b: &mut GlbBuilder) -> Parts {
    let r = PART_REF_RADIUS;
    let mut m = Mesh::default();
    m.tube(
        Vec3::new(0.0, -0.04, 0.0),
        Vec3::new(0.0, 0.04, 0.0),
        1.6 * r,
        1.6 * r,
        24,
        1,
        true,
    );
    let flange = b.add_mesh("flange", STEEL, &m);
    let mut m = Mesh::default();
    // Hex bolt, 6 cm long, 1.6 cm across.
    m.tube(
        Vec3::new(0.0, -0.03, 0.0),
        Vec3::new(0.0, 0.03, 0.0),
        0.008,
        0.008,
        6,
        1,
        true,
    );
    let bolt = b.add_mesh("bolt", DARK, &m);
    let mut m = Mesh::default();
    m.sphere(Vec3::ZERO, 1.3 * r, Vec3::ONE, 8, 12);
    m.tube(
        Vec3::ZERO,
        Vec3::new(0.0, 3.0 * r + 0.2, 0.0),
        0.025,
        0.025,
        8,
        1,
        true,
    );
    m.torus(
        Vec3::new(0.0, 3.0 * r + 0.2, 0.0),
        Vec3::Y,
        0.12 + r,
        0.015,
        20,
        6,
    );
    let valve = b.add_mesh("valve", BRASS, &m);
    let mut pump = [flange; 2];
    for (k, p) in pump.iter_mut().enumerate() {
        let mut m = Mesh::default();
        let s = 1.0 + 0.5 * k as f32;
        m.aabox(
            Vec3::new(-1.2 * s, 0.0, -0.5 * s),
            Vec3::new(1.2 * s, 0.2, 0.5 * s),
        );
        m.tube(
            Vec3::new(-1.1 * s, 0.55 * s, 0.0),
            Vec3::new(0.0, 0.55 * s, 0.0),
            0.3 * s,
            0.3 * s,
            20,
            4,
            true,
        );
        m.torus(
            Vec3::new(0.1 * s, 0.55 * s, 0.0),
            Vec3::X,
            0.12 * s,
            0.05 * s,
            12,
            6,
        );
        m.sphere(
            Vec3::new(0.65 * s, 0.55 * s, 0.0),
            0.4 * s,
            Vec3::new(1.0, 1.0, 0.8),
            8,
            16,
        );
        m.tube(
            Vec3::new(0.65 * s, 0.9 * s, 0.0),
            Vec3::new(0.65 * s, 1.6 * s, 0.0),
            0.1 * s,
            0.1 * s,
            12,
            2,
            true,
        );
        *p = b.add_mesh("pump", DARK, &m);
    }
    Parts {
        flange,
        bolt,
        valve,
        pump,
    }
}

pub(crate) fn build(generator: String, target: u64, rng: &mut Rng) -> (GlbBuilder, Grid) {
    let mut b = GlbBuilder::new(generator, &MATERIALS);
    let bays = (target / TRIANGLES_PER_BAY).max(1);
    let nx = (bays as f64).sqrt().ceil() as usize;
    let nz = (bays as usize).div_ceil(nx);
    let w = nx as f32 * PITCH + AISLE;
    let d = nz as f32 * PITCH + AISLE;
    let kinds: Vec<BayKind> = (0..nx * nz)
        .map(|_| match rng.below(20) {
            0..=3 => BayKind::Boiler,
            4..=6 => BayKind::Turbine,
            7..=10 => BayKind::Tanks,
            11..=14 => BayKind::Room,
            _ => BayKind::Pumps,
        })
        .collect();
    let bay_min =
        |i: usize, j: usize| Vec3::new(i as f32 * PITCH + AISLE, 0.0, j as f32 * PITCH + AISLE);
    let parts = parts(&mut b);

    // Shell: ground, outer walls with doors at the aisle ends, roof, columns,
    // mezzanine floors. These are the big occluders seen from inside.
    let mut m = Mesh::default();
    m.aabox(
        Vec3::new(-1.0, -0.4, -1.0),
        Vec3::new(w + 1.0, 0.0, d + 1.0),
    );
    b.object("structure", "ground", CONCRETE, m);
    for (side, len) in [(0, w), (1, w), (2, d), (3, d)] {
        let mut m = Mesh::default();
        let lines = if side < 2 { nx } else { nz };
        for k in 0..=lines {
            // Door opening over each aisle: wall above 5 m only.
            let a0 = k as f32 * PITCH;
            let a1 = a0 + AISLE;
            let b1 = (a1 + BAY).min(len);
            for (s0, s1, y0) in [(a0, a1, 5.0), (a1, b1, 0.0)] {
                if s1 <= s0 {
                    continue;
                }
                let (min, max) = match side {
                    0 => (Vec3::new(s0, y0, -0.3), Vec3::new(s1, ROOF, 0.0)),
                    1 => (Vec3::new(s0, y0, d), Vec3::new(s1, ROOF, d + 0.3)),
                    2 => (Vec3::new(-0.3, y0, s0), Vec3::new(0.0, ROOF, s1)),
                    _ => (Vec3::new(w, y0, s0), Vec3::new(w + 0.3, ROOF, s1)),
                };
                m.aabox(min, max);
            }
        }
        b.object("structure", "outer_wall", CONCRETE, m);
    }
    for j in 0..nz {
        let mut m = Mesh::default();
        let z0 = j as f32 * PITCH;
        let z1 = if j + 1 == nz { d } else { z0 + PITCH };
        m.aabox(Vec3::new(0.0, ROOF, z0), Vec3::new(w, ROOF + 0.4, z1));
        b.object("structure", "roof", CONCRETE, m);
    }
    for i in 0..=nx {
        let mut m = Mesh::default();
        for j in 0..=nz {
            for (cx, cz) in [(0.0, 0.0), (AISLE, 0.0), (0.0, AISLE), (AISLE, AISLE)] {
                let c = Vec3::new(i as f32 * PITCH + cx, 0.0, j as f32 * PITCH + cz);
                if c.x > w || c.z > d {
                    continue;
                }
                m.aabox(
                    c + Vec3::new(-0.2, 0.0, -0.2),
                    c + Vec3::new(0.2, ROOF, 0.2),
                );
            }
        }
        b.object("structure", "columns", STEEL, m);
    }

    // Equipment bays.
    let per_bay = (target as f64 * EQUIPMENT_SHARE / (nx * nz) as f64) as u64;
    for j in 0..nz {
        for i in 0..nx {
            let lo = bay_min(i, j);
            let budget = b.triangles() + per_bay;
            bay(&mut b, rng, kinds[j * nx + i], lo, budget, &parts);
        }
    }

    // Pipe racks: several parallel pipes over every aisle line, spanning the
    // whole site. These are the huge thin objects Partition-I must split
    // (paper Section 4.1).
    let pipe_budget = b.triangles() + (target as f64 * PIPE_SHARE) as u64;
    let mut pipes: Vec<Pipe> = Vec::new();
    let mut lines: Vec<(bool, usize)> = (0..=nx)
        .map(|i| (true, i))
        .chain((0..=nz).map(|j| (false, j)))
        .collect();
    // Interleave so a small budget spreads over both directions.
    lines.sort_by_key(|&(_, k)| k);
    'racks: for round in 0..6 {
        for &(along_z, k) in &lines {
            let r = [0.35, 0.15, 0.5, 0.1, 0.25, 0.6][round];
            let off = -2.4 + 0.8 * round as f32;
            let y = 5.5 + 0.9 * (round % 3) as f32 + r;
            let c = k as f32 * PITCH + AISLE * 0.5 + off;
            let (a, e) = if along_z {
                (Vec3::new(c, y, 0.5), Vec3::new(c, y, d - 0.5))
            } else {
                (Vec3::new(0.5, y + 1.6, c), Vec3::new(w - 0.5, y + 1.6, c))
            };
            let seg = 16 + 8 * (r > 0.3) as u32;
            let sections = ((e - a).length() / 3.0).ceil() as u32;
            let cost = (2 * seg * sections + 2 * seg) as u64;
            if b.triangles() + cost > pipe_budget {
                break 'racks;
            }
            let mut m = Mesh::default();
            m.tube(a, e, r, r, seg, sections, true);
            b.object("pipes", "pipe_run", PIPE_COLOURS[(round + k) % 4], m);
            pipes.push(Pipe {
                a,
                b: e,
                r,
                aisle: k as f32 * PITCH + AISLE * 0.5,
            });
        }
    }
    let racks = pipes.len();
    // Branches: drops from the racks down into the bays.
    while racks > 0 && b.triangles() + 400 < pipe_budget {
        let p = &pipes[rng.below(racks)];
        let t = rng.rangef(0.05, 0.95);
        let top = p.a + (p.b - p.a) * t;
        let r = (p.r * 0.5).max(0.05);
        let side = if rng.chance(0.5) { 1.0 } else { -1.0 };
        let mut lateral = p.aisle + side * rng.rangef(3.5, 6.0);
        let extent = if (p.b - p.a).z.abs() > 0.0 { w } else { d };
        if lateral < 0.5 || lateral > extent - 0.5 {
            // Edge aisle: branch inward, never through the outer wall.
            lateral = 2.0 * p.aisle - lateral;
        }
        let along_z = (p.b - p.a).z.abs() > 0.0;
        let out = if along_z {
            Vec3::new(lateral, top.y, top.z)
        } else {
            Vec3::new(top.x, top.y, lateral)
        };
        let bottom = Vec3::new(out.x, rng.rangef(0.5, 2.0), out.z);
        let mut m = Mesh::default();
        m.tube(top, out, r, r, 12, 3, false);
        m.sphere(out, r * 1.05, Vec3::ONE, 6, 12);
        m.tube(out, bottom, r, r, 12, 3, true);
        let colour = PIPE_COLOURS[rng.below(4)];
        b.object("pipes", "branch", colour, m);
        pipes.push(Pipe {
            a: out,
            b: bottom,
            r,
            aisle: f32::NAN,
        });
    }

    // Catwalks with railings along the aisles at each storey, and ladders.
    let access_budget = b.triangles() + (target as f64 * ACCESS_SHARE) as u64;
    'access: for storey in 1..3 {
        for (along_z, k) in lines.clone() {
            let segments = if along_z { nz } else { nx };
            for s in 0..segments {
                let y = storey as f32 * STOREY;
                let c = k as f32 * PITCH + AISLE * 0.5 + 2.2;
                let (s0, s1) = (s as f32 * PITCH + AISLE, (s + 1) as f32 * PITCH);
                let (a, e) = if along_z {
                    (Vec3::new(c, y, s0), Vec3::new(c, y, s1))
                } else {
                    (Vec3::new(s0, y, c), Vec3::new(s1, y, c))
                };
                let m = catwalk(a, e);
                if b.triangles() + m.triangles() as u64 > access_budget {
                    break 'access;
                }
                b.object("access", "catwalk", SAFETY, m);
                if rng.chance(0.3) {
                    let m = ladder(a + Vec3::new(0.0, -y, 0.0), y, along_z);
                    if b.triangles() + m.triangles() as u64 > access_budget {
                        break 'access;
                    }
                    b.object("access", "ladder", SAFETY, m);
                }
            }
        }
    }

    // Small parts fill the rest: flanges with their bolts and valves on the
    // pipes. Object sizes now span site (hundreds of metres) to bolt
    // (centimetres): four to five orders of magnitude.
    let flange_set = b.mesh_triangles(parts.flange) + 8 * b.mesh_triangles(parts.bolt);
    let bolt = b.mesh_triangles(parts.bolt);
    let valve = b.mesh_triangles(parts.valve);
    while !pipes.is_empty() && b.triangles() + bolt <= target {
        let p = &pipes[rng.below(pipes.len())];
        let axis = (p.b - p.a).normalize();
        let at = p.a + (p.b - p.a) * rng.rangef(0.02, 0.98);
        let scale = (p.r / PART_REF_RADIUS).clamp(0.4, 3.0);
        let q = DQuat::from_rotation_arc(DVec3::Y, axis.as_dvec3());
        let left = target - b.triangles();
        if left >= valve && rng.chance(0.1) {
            let q2 = q * DQuat::from_rotation_y(rng.range(0.0, std::f64::consts::TAU));
            b.instance(
                "parts",
                "valve",
                parts.valve,
                at.as_dvec3(),
                Some(q2),
                Some(DVec3::splat(scale as f64)),
            );
        } else if left >= flange_set {
            b.instance(
                "parts",
                "flange",
                parts.flange,
                at.as_dvec3(),
                Some(q),
                Some(DVec3::splat(scale as f64)),
            );
            let (u, v) = perpendiculars(axis);
            for k in 0..8 {
                let ang = k as f32 * std::f32::consts::TAU / 8.0;
                let pos = at + (u * ang.cos() + v * ang.sin()) * (1.3 * p.r);
                b.instance(
                    "parts",
                    "bolt",
                    parts.bolt,
                    pos.as_dvec3(),
                    Some(q),
                    Some(DVec3::splat(scale as f64)),
                );
            }
        } else {
            let ang = rng.rangef(0.0, std::f32::consts::TAU);
            let (u, v) = perpendiculars(axis);
            let pos = at + (u * ang.cos() + v * ang.sin()) * (1.3 * p.r);
            b.instance(
                "parts",
                "bolt",
                parts.bolt,
                pos.as_dvec3(),
                Some(q),
                Some(DVec3::splat(scale as f64)),
            );
        }
    }

    let grid = Grid {
        xs: (0..=nx)
            .map(|i| (i as f32 * PITCH + AISLE * 0.5) as f64)
            .collect(),
        zs: (0..=nz)
            .map(|j| (j as f32 * PITCH + AISLE * 0.5) as f64)
            .collect(),
        floor: 0.0,
    };
    (b, grid)
}

fn perpendiculars(d: Vec3) -> (Vec3, Vec3) {
    let u = if d.y.abs() < 0.9 {
        d.cross(Vec3::Y).normalize()
    } else {
        d.cross(Vec3::X).normalize()
    };
    (u, d.cross(u))
}

/// A 1.2 m grating walkway from `a` to `e` (level, axis-aligned) with posts
/// every 1.5 m and two rails on each side.
fn catwalk(a: Vec3, e: Vec3) -> Mesh {
    let mut m = Mesh::default();
    let dir = (e - a).normalize();
    let side = Vec3::new(dir.z, 0.0, -dir.x).abs();
    let half = side * 0.6;
    m.aabox(
        (a - half).min(e + half) - Vec3::Y * 0.05,
        (a - half).max(e + half),
    );
    let len = (e - a).length();
    let posts = (len / 1.5) as u32;
    for s in [-1.0f32, 1.0] {
        let off = half * s;
        for p in 0..=posts {
            let c = a + dir * (len * p as f32 / posts as f32) + off;
            m.aabox(
                c - Vec3::new(0.025, 0.0, 0.025),
                c + Vec3::new(0.025, 1.1, 0.025),
            );
        }
        for h in [0.55f32, 1.1] {
            m.tube(
                a + off + Vec3::Y * h,
                e + off + Vec3::Y * h,
                0.025,
                0.025,
                8,
                1,
                true,
            );
        }
    }
    m
}

/// A ladder from the floor up to `height`, beside the catwalk start.
fn ladder(foot: Vec3, height: f32, along_z: bool) -> Mesh {
    let mut m = Mesh::default();
    let across = if along_z { Vec3::X } else { Vec3::Z };
    let base = foot + across * 0.9;
    let rail = if along_z {
        Vec3::Z * 0.22
    } else {
        Vec3::X * 0.22
    };
    for s in [-1.0f32, 1.0] {
        m.tube(
            base + rail * s,
            base + rail * s + Vec3::Y * (height + 1.0),
            0.03,
            0.03,
            6,
            1,
            true,
        );
    }
    let rungs = (height / 0.3) as u32;
    for k in 1..=rungs {
        let y = Vec3::Y * (k as f32 * 0.3);
        m.tube(base - rail + y, base + rail + y, 0.015, 0.015, 6, 1, false);
    }
    m
}

/// Fills one bay (min corner `lo`) up to `budget` total triangles.
fn bay(b: &mut GlbBuilder, rng: &mut Rng, kind: BayKind, lo: Vec3, budget: u64, parts: &Parts) {
    let c = lo + Vec3::new(BAY * 0.5, 0.0, BAY * 0.5);
    let fits = |b: &GlbBuilder, m: &Mesh| b.triangles() + m.triangles() as u64 <= budget;
    let mut mezzanine = false;
    match kind {
        BayKind::Boiler => {
            let r = rng.rangef(3.5, 5.5);
            let h = rng.rangef(14.0, 21.0);
            let mut m = Mesh::default();
            m.tube(c, c + Vec3::Y * h, r, r, 48, h as u32, true);
            m.sphere(c + Vec3::Y * h, r, Vec3::new(1.0, 0.4, 1.0), 8, 48);
            for k in 0..16 {
                let a = k as f32 * std::f32::consts::TAU / 16.0;
                let p = c + Vec3::new(a.cos(), 0.0, -a.sin()) * (r + 0.15);
                m.aabox(p - Vec3::new(0.12, 0.0, 0.12), p + Vec3::new(0.12, h, 0.12));
            }
            for k in 0..4 {
                let a = k as f32 * std::f32::consts::FRAC_PI_2;
                let p = c + Vec3::new(a.cos(), 0.0, -a.sin()) * (r + 1.0) + Vec3::Y * 3.0;
                m.aabox(p - Vec3::splat(0.6), p + Vec3::splat(0.6));
            }
            if fits(b, &m) {
                b.object("equipment", "boiler", BOILER, m);
            }
        }
        BayKind::Turbine => {
            let mut m = Mesh::default();
            m.aabox(
                lo + Vec3::new(1.0, 0.0, 6.0),
                lo + Vec3::new(BAY - 1.0, 1.5, 12.0),
            );
            let radii = [1.2f32, 1.8, 2.4, 2.4, 1.6];
            let mut x = lo.x + 1.5;
            for r in radii {
                let a = Vec3::new(x, 1.5 + 2.5, c.z);
                m.tube(a, a + Vec3::X * 2.6, r * 0.9, r, 40, 4, true);
                x += 2.6;
            }
            m.aabox(
                Vec3::new(x + 0.2, 1.5, c.z - 1.8),
                Vec3::new(lo.x + BAY - 1.0, 5.5, c.z + 1.8),
            );
            if fits(b, &m) {
                b.object("equipment", "turbine", STEEL, m);
            }
        }
        BayKind::Tanks => {
            mezzanine = true;
            let count = 2 + rng.below(2);
            for k in 0..count {
                let r = rng.rangef(1.4, 2.2);
                let x = lo.x + 3.0 + k as f32 * (BAY - 6.0) / (count - 1).max(1) as f32;
                let a = Vec3::new(x, r + 0.8, lo.z + 3.0);
                let e = Vec3::new(x, r + 0.8, lo.z + BAY - 3.0);
                let mut m = Mesh::default();
                m.tube(a, e, r, r, 32, 8, false);
                m.sphere(a, r, Vec3::new(1.0, 1.0, 1.0), 8, 32);
                m.sphere(e, r, Vec3::new(1.0, 1.0, 1.0), 8, 32);
                for z in [a.z + 2.0, e.z - 2.0] {
                    m.aabox(
                        Vec3::new(x - r * 0.8, 0.0, z - 0.3),
                        Vec3::new(x + r * 0.8, 0.9, z + 0.3),
                    );
                }
                if fits(b, &m) {
                    b.object("equipment", "tank", WHITE, m);
                }
            }
        }
        BayKind::Room => {
            mezzanine = true;
            // Full-height walls with one door facing the aisle: strong occluders.
            let mut m = Mesh::default();
            let (x0, x1, z0, z1) = (lo.x, lo.x + BAY, lo.z, lo.z + BAY);
            let t = 0.25;
            m.aabox(Vec3::new(x0, 0.0, z0), Vec3::new(x1, ROOF, z0 + t));
            m.aabox(Vec3::new(x0, 0.0, z1 - t), Vec3::new(x1, ROOF, z1));
            m.aabox(Vec3::new(x1 - t, 0.0, z0), Vec3::new(x1, ROOF, z1));
            let (d0, d1) = (c.z - 1.0, c.z + 1.0);
            m.aabox(Vec3::new(x0, 0.0, z0), Vec3::new(x0 + t, ROOF, d0));
            m.aabox(Vec3::new(x0, 0.0, d1), Vec3::new(x0 + t, ROOF, z1));
            m.aabox(Vec3::new(x0, 2.5, d0), Vec3::new(x0 + t, ROOF, d1));
            if fits(b, &m) {
                b.object("structure", "room_walls", CONCRETE, m);
            }
            for row in 0..4 {
                for k in 0..12 {
                    let p = Vec3::new(
                        lo.x + 3.0 + row as f32 * 3.5,
                        0.0,
                        lo.z + 1.0 + k as f32 * 1.3,
                    );
                    let mut m = Mesh::default();
                    m.aabox(p, p + Vec3::new(0.6, 2.2, 1.2));
                    m.aabox(
                        p + Vec3::new(-0.02, 0.1, 0.05),
                        p + Vec3::new(0.0, 2.1, 1.15),
                    );
                    m.aabox(
                        p + Vec3::new(-0.06, 1.0, 0.9),
                        p + Vec3::new(-0.02, 1.2, 0.94),
                    );
                    if !fits(b, &m) {
                        break;
                    }
                    b.object("equipment", "cabinet", DARK, m);
                }
            }
        }
        BayKind::Pumps => {}
    }
    if mezzanine {
        for y in [STOREY, 2.0 * STOREY] {
            let mut m = Mesh::default();
            m.aabox(
                lo + Vec3::new(0.0, y - 0.25, 0.0),
                lo + Vec3::new(BAY, y, BAY),
            );
            if fits(b, &m) {
                b.object("structure", "floor", CONCRETE, m);
            }
        }
    }
    // Auxiliary equipment on a 3 m grid until the bay's budget is spent:
    // pumps, small vessels, instrument stands, risers.
    let pump_tris = b.mesh_triangles(parts.pump[1]);
    for gz in 0..6 {
        for gx in 0..6 {
            let on_edge = gx == 0 || gz == 0 || gx == 5 || gz == 5;
            if kind != BayKind::Pumps && !on_edge {
                continue;
            }
            if kind == BayKind::Room && gx < 5 {
                continue;
            }
            let p = lo + Vec3::new(1.5 + gx as f32 * 3.0, 0.0, 1.5 + gz as f32 * 3.0);
            if b.triangles() + pump_tris > budget {
                return;
            }
            match rng.below(4) {
                0 | 1 => {
                    let which = rng.below(2);
                    let yaw = if rng.chance(0.5) {
                        0.0
                    } else {
                        std::f64::consts::FRAC_PI_2
                    };
                    b.instance(
                        "equipment",
                        "pump",
                        parts.pump[which],
                        p.as_dvec3(),
                        Some(DQuat::from_rotation_y(yaw)),
                        None,
                    );
                }
                2 => {
                    let r = rng.rangef(0.3, 0.8);
                    let h = rng.rangef(1.5, 4.0);
                    let mut m = Mesh::default();
                    m.tube(
                        p + Vec3::Y * 0.6,
                        p + Vec3::Y * (0.6 + h),
                        r,
                        r,
                        24,
                        4,
                        true,
                    );
                    m.sphere(p + Vec3::Y * (0.6 + h), r, Vec3::new(1.0, 0.5, 1.0), 6, 24);
                    for k in 0..3 {
                        let a = k as f32 * std::f32::consts::TAU / 3.0;
                        let q = p + Vec3::new(a.cos(), 0.0, a.sin()) * r * 0.8;
                        m.tube(q, q + Vec3::Y * 0.7, 0.04, 0.04, 6, 1, true);
                    }
                    for k in 0..3 {
                        let y = 0.9 + k as f32 * h / 3.0;
                        m.tube(
                            p + Vec3::new(0.0, y, 0.0),
                            p + Vec3::new(r + 0.3, y, 0.0),
                            0.05,
                            0.05,
                            10,
                            1,
                            true,
                        );
                    }
                    b.object("equipment", "vessel", WHITE, m);
                }
                _ => {
                    let mut m = Mesh::default();
                    m.tube(p, p + Vec3::Y * 1.3, 0.04, 0.04, 8, 1, true);
                    m.aabox(
                        p + Vec3::new(-0.25, 1.3, -0.1),
                        p + Vec3::new(0.25, 1.8, 0.1),
                    );
                    m.tube(
                        p + Vec3::new(0.0, 1.55, 0.1),
                        p + Vec3::new(0.0, 1.55, 0.16),
                        0.08,
                        0.08,
                        16,
                        1,
                        true,
                    );
                    m.tube(
                        p + Vec3::new(0.3, 0.0, 0.0),
                        p + Vec3::new(0.3, 6.5, 0.0),
                        0.12,
                        0.12,
                        12,
                        6,
                        true,
                    );
                    b.object("equipment", "instrument", STEEL, m);
                }
            }
        }
    }
}
