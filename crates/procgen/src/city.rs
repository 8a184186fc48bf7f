//! The city: a grid of blocks between streets; each block holds several
//! buildings whose walls are large occluders (the case Coorg and Teller's
//! object-space culling targets), and street furniture fills the sidewalks.
//!
//! Units are metres. The camera walks the street centre lines; parked cars
//! and furniture stay at least 2.5 m to the side.

use glam::{DQuat, DVec3, Vec3};

use crate::glb::{GlbBuilder, Material, MeshId};
use crate::plant::mat;
use crate::rng::Rng;
use crate::shapes::Mesh;
use crate::walk::Grid;

/// Block and street widths: an 84 m block, a 16 m street (10 m road and two
/// 3 m sidewalks), typical of a North American downtown grid.
const BLOCK: f32 = 84.0;
const STREET: f32 = 16.0;
const PITCH: f32 = BLOCK + STREET;
const ROAD_HALF: f32 = 5.0;
/// Triangles per block: a 1M-triangle city has 16 blocks, 20M has 334.
const TRIANGLES_PER_BLOCK: u64 = 60_000;
const BUILDING_SHARE: f64 = 0.7;
/// Storey height and window spacing along a facade.
const FLOOR: f32 = 3.5;
const WINDOW_SPACING: f32 = 3.0;

const ASPHALT: usize = 0;
const PAVEMENT: usize = 1;
const FACADES: [usize; 4] = [2, 3, 4, 5];
const GLASS: usize = 6;
const METAL: usize = 7;
const CAR_COLOURS: [usize; 3] = [8, 9, 10];
const GREEN: usize = 11;
const BARK: usize = 12;

const MATERIALS: [Material; 13] = [
    mat("asphalt", [0.12, 0.12, 0.13], 0.0, 0.9),
    mat("pavement", [0.55, 0.54, 0.50], 0.0, 0.9),
    mat("facade_brick", [0.55, 0.30, 0.22], 0.0, 0.8),
    mat("facade_stone", [0.70, 0.66, 0.58], 0.0, 0.8),
    mat("facade_concrete", [0.52, 0.53, 0.55], 0.0, 0.85),
    mat("facade_glass_tower", [0.25, 0.35, 0.42], 0.6, 0.2),
    mat("glass", [0.15, 0.20, 0.25], 0.8, 0.1),
    mat("metal", [0.30, 0.31, 0.33], 0.8, 0.4),
    mat("car_red", [0.55, 0.05, 0.05], 0.5, 0.3),
    mat("car_white", [0.85, 0.85, 0.85], 0.5, 0.3),
    mat("car_blue", [0.08, 0.15, 0.45], 0.5, 0.3),
    mat("foliage", [0.15, 0.40, 0.12], 0.0, 0.9),
    mat("bark", [0.30, 0.20, 0.12], 0.0, 0.9),
];

struct Furniture {
    lamp: MeshId,
    bench: MeshId,
    bin: MeshId,
    car: MeshId,
    tree: MeshId,
    bollard: MeshId,
    can: MeshId,
}

fn furniture(b: &mut GlbBuilder) -> Furniture {
    let mut m = Mesh::default();
    m.tube(Vec3::ZERO, Vec3::Y * 6.0, 0.09, 0.06, 12, 3, true);
    m.tube(
        Vec3::Y * 5.9,
        Vec3::new(1.2, 6.1, 0.0),
        0.04,
        0.04,
        8,
        1,
        true,
    );
    m.sphere(
        Vec3::new(1.3, 6.0, 0.0),
        0.25,
        Vec3::new(1.0, 0.5, 1.0),
        6,
        12,
    );
    let lamp = b.add_mesh("lamp_post", METAL, &m);
    let mut m = Mesh::default();
    m.aabox(Vec3::new(-0.9, 0.42, -0.22), Vec3::new(0.9, 0.47, 0.22));
    m.aabox(Vec3::new(-0.9, 0.5, 0.2), Vec3::new(0.9, 0.9, 0.25));
    for x in [-0.8f32, 0.8] {
        m.aabox(
            Vec3::new(x - 0.03, 0.0, -0.2),
            Vec3::new(x + 0.03, 0.42, 0.2),
        );
    }
    let bench = b.add_mesh("bench", METAL, &m);
    let mut m = Mesh::default();
    m.tube(Vec3::ZERO, Vec3::Y * 0.9, 0.25, 0.28, 16, 2, true);
    let bin = b.add_mesh("bin", METAL, &m);
    let mut m = Mesh::default();
    m.aabox(Vec3::new(-0.9, 0.3, -2.2), Vec3::new(0.9, 1.0, 2.2));
    m.aabox(Vec3::new(-0.8, 1.0, -1.1), Vec3::new(0.8, 1.5, 1.0));
    for (x, z) in [(-0.9f32, -1.4f32), (0.9, -1.4), (-0.9, 1.4), (0.9, 1.4)] {
        let s = x.signum() * 0.12;
        m.tube(
            Vec3::new(x - s, 0.33, z),
            Vec3::new(x + s, 0.33, z),
            0.33,
            0.33,
            16,
            1,
            true,
        );
    }
    let car = b.add_mesh("car", CAR_COLOURS[0], &m);
    let mut m = Mesh::default();
    m.tube(Vec3::ZERO, Vec3::Y * 2.5, 0.15, 0.1, 8, 2, false);
    m.sphere(Vec3::Y * 3.6, 1.6, Vec3::new(1.0, 0.85, 1.0), 7, 12);
    let tree = b.add_mesh("street_tree", GREEN, &m);
    let mut m = Mesh::default();
    m.tube(Vec3::ZERO, Vec3::Y * 0.9, 0.1, 0.1, 8, 1, true);
    let bollard = b.add_mesh("bollard", METAL, &m);
    let mut m = Mesh::default();
    m.tube(
        Vec3::ZERO,
        Vec3::new(0.0, 0.0, 0.12),
        0.033,
        0.033,
        8,
        1,
        true,
    );
    let can = b.add_mesh("litter_can", METAL, &m);
    let _ = BARK;
    Furniture {
        lamp,
        bench,
        bin,
        car,
        tree,
        bollard,
        can,
    }
}

pub(crate) fn build(generator: String, target: u64, rng: &mut Rng) -> (GlbBuilder, Grid) {
    let mut b = GlbBuilder::new(generator, &MATERIALS);
    let blocks = (target / TRIANGLES_PER_BLOCK).max(1);
    let nx = (blocks as f64).sqrt().ceil() as usize;
    let nz = (blocks as usize).div_ceil(nx);
    let w = nx as f32 * PITCH + STREET;
    let d = nz as f32 * PITCH + STREET;
    let f = furniture(&mut b);

    // Streets: one asphalt slab, raised sidewalks around each block.
    let mut m = Mesh::default();
    m.aabox(Vec3::new(0.0, -0.3, 0.0), Vec3::new(w, 0.0, d));
    b.object("streets", "road", ASPHALT, m);
    for j in 0..nz {
        let mut m = Mesh::default();
        for i in 0..nx {
            let lo = Vec3::new(i as f32 * PITCH + STREET, 0.0, j as f32 * PITCH + STREET);
            let sw = STREET * 0.5 - ROAD_HALF;
            m.aabox(
                lo - Vec3::new(sw, 0.0, sw),
                lo + Vec3::new(BLOCK + sw, 0.15, BLOCK + sw),
            );
        }
        b.object("streets", "sidewalks", PAVEMENT, m);
    }
    // Sidewalks along the city's outer edge.
    let mut m = Mesh::default();
    let sw = STREET * 0.5 - ROAD_HALF;
    m.aabox(Vec3::ZERO, Vec3::new(w, 0.15, sw));
    m.aabox(Vec3::new(0.0, 0.0, d - sw), Vec3::new(w, 0.15, d));
    m.aabox(Vec3::new(0.0, 0.0, sw), Vec3::new(sw, 0.15, d - sw));
    m.aabox(Vec3::new(w - sw, 0.0, sw), Vec3::new(w, 0.15, d - sw));
    b.object("streets", "sidewalks", PAVEMENT, m);

    // Buildings: each block cut into 2-3 x 2-3 lots; heights grow toward
    // the city centre so the skyline varies and tall walls occlude far.
    let lots_per_block = 6.0;
    let per_building = (target as f64 * BUILDING_SHARE / (nx * nz) as f64 / lots_per_block) as u64;
    let centre = Vec3::new(w * 0.5, 0.0, d * 0.5);
    for j in 0..nz {
        for i in 0..nx {
            let lo = Vec3::new(i as f32 * PITCH + STREET, 0.0, j as f32 * PITCH + STREET);
            let n = 2 + rng.below(2);
            let cx = cuts(rng, n);
            let n = 2 + rng.below(2);
            let cz = cuts(rng, n);
            for a in 0..cx.len() - 1 {
                for c in 0..cz.len() - 1 {
                    let min = lo + Vec3::new(cx[a] * BLOCK + 0.5, 0.15, cz[c] * BLOCK + 0.5);
                    let max =
                        lo + Vec3::new(cx[a + 1] * BLOCK - 0.5, 0.15, cz[c + 1] * BLOCK - 0.5);
                    let dist = ((min + max) * 0.5 - centre).length() / (w.max(d) * 0.5);
                    let tall = (1.0 - dist).clamp(0.1, 1.0);
                    let h = FLOOR * (3.0 + rng.rangef(0.0, 25.0) * tall).floor();
                    let budget = b.triangles() + per_building;
                    building(&mut b, rng, min, max, h, budget);
                }
            }
        }
    }

    // Street furniture: along every sidewalk until the budget is spent.
    // Object sizes span city (kilometre) to litter (centimetres).
    let smallest = b.mesh_triangles(f.can);
    let kinds: [(MeshId, f32, u32); 7] = [
        (f.lamp, 5.5, 3),
        (f.bench, 7.2, 2),
        (f.bin, 6.0, 2),
        (f.car, 3.9, 4),
        (f.tree, 6.6, 3),
        (f.bollard, 5.3, 3),
        (f.can, 6.3, 1),
    ];
    let total_weight: u32 = kinds.iter().map(|k| k.2).sum();
    while b.triangles() + smallest <= target {
        let left = target - b.triangles();
        let mut pick = rng.below(total_weight as usize) as u32;
        let mut choice = kinds[6];
        for k in kinds {
            if pick < k.2 {
                choice = k;
                break;
            }
            pick -= k.2;
        }
        if b.mesh_triangles(choice.0) > left {
            choice = kinds[6];
        }
        let (mesh, lateral, _) = choice;
        // A random street segment, a random side, a random spot along it.
        let along_z = rng.chance(0.5);
        let line = if along_z {
            rng.below(nx + 1)
        } else {
            rng.below(nz + 1)
        };
        // Along a block, never in an intersection another walk crosses.
        let blocks_along = if along_z { nz } else { nx };
        let s = rng.below(blocks_along) as f32 * PITCH + STREET + rng.rangef(1.0, BLOCK - 1.0);
        let side = if rng.chance(0.5) { 1.0 } else { -1.0 };
        let lat = line as f32 * PITCH + STREET * 0.5 + side * lateral;
        let y = if mesh == f.car { 0.0 } else { 0.15 };
        let p = if along_z {
            Vec3::new(lat, y, s)
        } else {
            Vec3::new(s, y, lat)
        };
        // Furniture faces the street; cars park along it.
        let mut yaw = if along_z {
            0.0
        } else {
            std::f64::consts::FRAC_PI_2
        };
        if mesh != f.car {
            yaw += if side > 0.0 {
                std::f64::consts::FRAC_PI_2
            } else {
                -std::f64::consts::FRAC_PI_2
            };
        }
        if mesh == f.can {
            yaw += rng.range(0.0, std::f64::consts::TAU);
        }
        let name = if mesh == f.car { "car" } else { "furniture" };
        b.instance(
            "furniture",
            name,
            mesh,
            p.as_dvec3(),
            Some(DQuat::from_rotation_y(yaw)),
            None,
        );
    }
    let _ = DVec3::ZERO;
    let grid = Grid {
        xs: (0..=nx)
            .map(|i| (i as f32 * PITCH + STREET * 0.5) as f64)
            .collect(),
        zs: (0..=nz)
            .map(|j| (j as f32 * PITCH + STREET * 0.5) as f64)
            .collect(),
        floor: 0.0,
    };
    (b, grid)
}

/// Sorted cut positions in [0, 1] splitting a block edge into `n` lots.
fn cuts(rng: &mut Rng, n: usize) -> Vec<f32> {
    let mut v = vec![0.0f32];
    for k in 1..n {
        v.push((k as f32 + rng.rangef(-0.2, 0.2)) / n as f32);
    }
    v.push(1.0);
    v
}

/// One building: four walls and a roof as a closed shell, window frames on
/// every facade floor by floor while the budget lasts, rooftop units.
fn building(b: &mut GlbBuilder, rng: &mut Rng, min: Vec3, max: Vec3, h: f32, budget: u64) {
    let mut m = Mesh::default();
    let top = Vec3::new(max.x, min.y + h, max.z);
    m.aabox(min, top);
    // Window frames protrude 15 cm; ground floor gets shop windows.
    let mut frames = Mesh::default();
    let floors = (h / FLOOR) as u32;
    let facades = [
        (
            Vec3::new(min.x, 0.0, min.z),
            Vec3::X,
            -Vec3::Z,
            max.x - min.x,
        ),
        (
            Vec3::new(max.x, 0.0, max.z),
            -Vec3::X,
            Vec3::Z,
            max.x - min.x,
        ),
        (
            Vec3::new(max.x, 0.0, min.z),
            Vec3::Z,
            Vec3::X,
            max.z - min.z,
        ),
        (
            Vec3::new(min.x, 0.0, max.z),
            -Vec3::Z,
            -Vec3::X,
            max.z - min.z,
        ),
    ];
    'floors: for fl in 0..floors {
        for (origin, along, out, len) in facades {
            let n = (len / WINDOW_SPACING) as u32;
            let y = min.y + fl as f32 * FLOOR + 1.0;
            let (ww, wh) = if fl == 0 { (2.6, 2.4) } else { (1.4, 1.8) };
            let before = frames.triangles();
            for k in 0..n {
                let c = origin
                    + along
                        * (WINDOW_SPACING * (k as f32 + 0.5)
                            + (len - n as f32 * WINDOW_SPACING) * 0.5);
                let c = Vec3::new(c.x, y + wh * 0.5, c.z) + out * 0.075;
                let half = along.abs() * (ww * 0.5) + Vec3::Y * (wh * 0.5) + out.abs() * 0.075;
                frames.aabox(c - half, c + half);
            }
            if b.triangles() + (m.triangles() + frames.triangles()) as u64 > budget {
                frames.positions.truncate(before * 2);
                frames.normals.truncate(before * 2);
                frames.indices.truncate(before * 3);
                break 'floors;
            }
        }
    }
    let base = m.positions.len() as u32;
    m.positions.extend_from_slice(&frames.positions);
    m.normals.extend_from_slice(&frames.normals);
    m.indices.extend(frames.indices.iter().map(|i| i + base));
    if b.triangles() + m.triangles() as u64 > budget {
        // Too small a budget for even a plain shell: still place the shell,
        // the furniture phase gives way.
        let mut shell = Mesh::default();
        shell.aabox(min, top);
        m = shell;
    }
    let facade = FACADES[rng.below(4)];
    b.object(
        "buildings",
        "building",
        if h > 60.0 { FACADES[3] } else { facade },
        m,
    );
    let mut roof = Mesh::default();
    for _ in 0..rng.below(4) {
        let p = Vec3::new(
            rng.rangef(min.x + 2.0, max.x - 4.0),
            top.y,
            rng.rangef(min.z + 2.0, max.z - 4.0),
        );
        roof.aabox(p, p + Vec3::new(2.0, 1.5, 1.5));
    }
    if rng.chance(0.3) {
        let p = Vec3::new((min.x + max.x) * 0.5, top.y, (min.z + max.z) * 0.5);
        roof.tube(p, p + Vec3::Y * 4.0, 1.5, 1.5, 16, 2, true);
    }
    if !roof.indices.is_empty() && b.triangles() + roof.triangles() as u64 <= budget {
        b.object("buildings", "rooftop", GLASS, roof);
    }
}
