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

use std::f32::consts::{PI, TAU};
use std::f64::consts::FRAC_PI_2;

use glam::{DQuat, DVec3, Quat, Vec2, Vec3};

use crate::glb::{GlbBuilder, Material};
use crate::plant::mat;
use crate::rng::Rng;
use crate::shapes::{at_radius, circle, gear_outline, hexagon, rounded_rect, Frame, Mesh, Ring};
use crate::walk::Grid;

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

/// A flat exterior face that detail (name plates, junction boxes, cables)
/// can be mounted on: centre `c`, outward normal `n`, in-plane axes `t` and
/// `b = n x t`, half extents along them.
#[derive(Clone, Copy, Debug)]
struct Face {
    c: Vec3,
    n: Vec3,
    t: Vec3,
    b: Vec3,
    half: Vec2,
}

impl Face {
    fn new(c: Vec3, n: Vec3, t: Vec3, half: Vec2) -> Face {
        Face {
            c,
            n,
            t,
            b: n.cross(t),
            half,
        }
    }

    fn at(&self, x: f32, y: f32) -> Vec3 {
        self.c + self.t * x + self.b * y
    }

    /// A random point at least `margin` inside the face's edges (the centre
    /// when the face is smaller than that).
    fn random(&self, rng: &mut Rng, margin: f32) -> Vec3 {
        let mx = (self.half.x - margin).max(0.0);
        let my = (self.half.y - margin).max(0.0);
        self.at(rng.rangef(-mx, mx + 1e-6), rng.rangef(-my, my + 1e-6))
    }

    /// Box axes for something lying on the face: [t, b, n], right-handed.
    fn axes(&self) -> [Vec3; 3] {
        [self.t, self.b, self.n]
    }
}

/// An assembly under construction: its parts merged into one mesh per
/// (subassembly, material), and the budget they must stay within.
struct Asm {
    budget: u64,
    tris: u64,
    parts: usize,
    paint: usize,
    trim: usize,
    meshes: Vec<(&'static str, usize, Mesh)>,
    /// Each part's mesh and triangle count, in the order added.
    log: Vec<(usize, u32)>,
    faces: Vec<Face>,
    scratch: Mesh,
}

impl Asm {
    fn left(&self) -> u64 {
        self.budget - self.tris
    }

    /// Adds the part `build` makes, unless it would pass the budget or leave
    /// the slot's footprint; says whether it was added.
    fn part(&mut self, sub: &'static str, material: usize, build: impl FnOnce(&mut Mesh)) -> bool {
        let mut m = std::mem::take(&mut self.scratch);
        m.clear();
        build(&mut m);
        let t = m.triangles() as u64;
        let inside = m
            .positions
            .iter()
            .all(|p| p.x.abs() <= HALF && p.z.abs() <= HALF && p.y >= 0.0);
        let ok = t > 0 && self.tris + t <= self.budget && inside;
        if ok {
            let i = match self
                .meshes
                .iter()
                .position(|(s, mt, _)| *s == sub && *mt == material)
            {
                Some(i) => i,
                None => {
                    self.meshes.push((sub, material, Mesh::default()));
                    self.meshes.len() - 1
                }
            };
            self.meshes[i].2.append(&m);
            self.log.push((i, t as u32));
            self.tris += t;
            self.parts += 1;
        }
        self.scratch = m;
        ok
    }

    /// A through-bolt with washers and a nut: head side on the surface at
    /// `at` facing `n`, `grip` of material, nut on the far side.
    fn bolted(&mut self, sub: &'static str, at: Vec3, n: Vec3, d: f32, grip: f32) {
        let tw = 0.16 * d;
        let len = grip + 2.0 * tw + 1.3 * d;
        if !self.part(sub, ZINC, |m| washer(m, at + n * GAP, n, d)) {
            return;
        }
        self.part(sub, BLACK, |m| {
            bolt(m, at + n * (tw + 2.0 * GAP), n, d, len)
        });
        let back = at - n * grip;
        self.part(sub, ZINC, |m| washer(m, back - n * GAP, -n, d));
        self.part(sub, BLACK, |m| nut(m, back - n * (tw + 2.0 * GAP), -n, d));
    }

    /// A bolt and nut without washers: head on the surface at `at` facing
    /// `n`, nut on the far side of `grip`.
    fn bolt_nut(&mut self, sub: &'static str, at: Vec3, n: Vec3, d: f32, grip: f32) {
        if self.part(sub, BLACK, |m| bolt(m, at + n * GAP, n, d, grip + 1.3 * d)) {
            self.part(sub, BLACK, |m| nut(m, at - n * (grip + GAP), -n, d));
        }
    }

    /// `count` bolts (heads only seen: tapped holes) from `p0` to `p1`.
    fn bolt_row(&mut self, sub: &'static str, p0: Vec3, p1: Vec3, n: Vec3, d: f32, count: u32) {
        for k in 0..count {
            let t = (k as f32 + 0.5) / count as f32;
            let at = p0 + (p1 - p0) * t;
            if !self.part(sub, BLACK, |m| bolt(m, at + n * GAP, n, d, 2.0 * d)) {
                return;
            }
        }
    }

    fn rivet_row(&mut self, sub: &'static str, p0: Vec3, p1: Vec3, n: Vec3, d: f32, count: u32) {
        for k in 0..count {
            let t = if count == 1 {
                0.5
            } else {
                k as f32 / (count - 1) as f32
            };
            let at = p0 + (p1 - p0) * t;
            if !self.part(sub, STEEL, |m| rivet(m, at + n * GAP, n, d)) {
                return;
            }
        }
    }

    /// Socket-head cap screws on a circle of radius `r` in the plane of
    /// `f` at height `z`, heads facing +w.
    fn screw_circle(&mut self, sub: &'static str, f: &Frame, r: f32, z: f32, d: f32, count: u32) {
        for k in 0..count {
            let a = TAU * (k as f32 + 0.5) / count as f32;
            let at = f.at(Vec2::new(a.cos(), a.sin()) * r, z + GAP);
            if !self.part(sub, BLACK, |m| screw(m, at, f.w, d, 2.0 * d)) {
                return;
            }
        }
    }

    /// A hose or cable along the cubic Bezier `c`: separate short segments
    /// `seg` long (hollow rings for a hose), a small gap between each.
    /// Returns how many segments fitted.
    #[allow(clippy::too_many_arguments)] // a run is its curve, section, material and where it goes
    fn run(
        &mut self,
        sub: &'static str,
        material: usize,
        c: [Vec3; 4],
        r: f32,
        seg: f32,
        sides: u32,
        hollow: bool,
    ) -> usize {
        let bez = |t: f32| {
            let u = 1.0 - t;
            c[0] * (u * u * u)
                + c[1] * (3.0 * u * u * t)
                + c[2] * (3.0 * u * t * t)
                + c[3] * (t * t * t)
        };
        let mut len = 0.0;
        for k in 0..16 {
            len += (bez((k + 1) as f32 / 16.0) - bez(k as f32 / 16.0)).length();
        }
        let count = ((len / seg).ceil() as usize).clamp(1, 200);
        for k in 0..count {
            let (p0, p1) = (
                bez(k as f32 / count as f32),
                bez((k + 1) as f32 / count as f32),
            );
            let axis = p1 - p0;
            let l = axis.length();
            if l < 4.0 * GAP {
                continue;
            }
            let f = Frame::along(p0, axis);
            let (z0, z1) = (0.04 * l, 0.96 * l);
            let ok = self.part(sub, material, |m| {
                if hollow {
                    pipe(m, &f, r, 0.75 * r, z0, z1, sides)
                } else {
                    rod(m, &f, r, z0, z1, sides)
                }
            });
            if !ok {
                return k;
            }
        }
        count
    }

    /// A ball bearing in the plane of `f` at height `z`: outer and inner
    /// race and the balls between them.
    fn bearing(&mut self, sub: &'static str, f: &Frame, r_in: f32, r_out: f32, z: f32) {
        let gap = r_out - r_in;
        let w = 0.5 * gap;
        self.part(sub, STEEL, |m| {
            pipe(m, f, r_out, r_out - 0.25 * gap, z - w, z + w, 16)
        });
        self.part(sub, STEEL, |m| {
            pipe(m, f, r_in + 0.25 * gap, r_in, z - w, z + w, 16)
        });
        let rm = 0.5 * (r_in + r_out);
        let rb = 0.22 * gap;
        let balls = ((TAU * rm / (2.6 * rb)) as u32).clamp(6, 14);
        for k in 0..balls {
            let a = TAU * k as f32 / balls as f32;
            let c = f.at(Vec2::new(a.cos(), a.sin()) * rm, z);
            if !self.part(sub, STEEL, |m| m.sphere(c, rb, Vec3::ONE, 4, 6)) {
                return;
            }
        }
    }
}

// Parts. Each is one connected piece; `n` is a unit normal.

/// Hex bolt of nominal diameter `d`: head on the surface at `at` facing
/// `n`, shank `len` into it. 48 triangles, 96 from M14 up.
fn bolt(m: &mut Mesh, at: Vec3, n: Vec3, d: f32, len: f32) {
    let fine = d >= 0.014;
    let shank = circle(0.5 * d, if fine { 12 } else { 6 });
    headed_shank(m, at, n, shank, hexagon(1.6 * d, fine), len, 0.65 * d);
}

/// A shank `len` into the surface at `at` under a head `h` tall facing
/// `n`, both prisms of their outlines, capped: bolts and screws.
fn headed_shank(
    m: &mut Mesh,
    at: Vec3,
    n: Vec3,
    shank: Vec<Vec2>,
    head: Vec<Vec2>,
    len: f32,
    h: f32,
) {
    m.loft(
        &Frame::along(at, n),
        &[
            Ring::apex(-len),
            Ring::new(-len, shank.clone()),
            Ring::new(0.0, shank),
            Ring::new(0.0, head.clone()),
            Ring::new(h, head),
            Ring::apex(h),
        ],
        false,
    );
}

/// Hex nut for a `d` bolt on the surface at `at`, facing `n`: 48 triangles.
fn nut(m: &mut Mesh, at: Vec3, n: Vec3, d: f32) {
    let hex = hexagon(1.6 * d, false);
    annulus(m, &Frame::along(at, n), &hex, 0.55 * d, 0.0, 0.8 * d);
}

/// Flat washer for a `d` bolt: 64 triangles.
fn washer(m: &mut Mesh, at: Vec3, n: Vec3, d: f32) {
    annulus(
        m,
        &Frame::along(at, n),
        &circle(d, 8),
        0.55 * d,
        0.0,
        0.16 * d,
    );
}

/// Round-head rivet of shank diameter `d` on the surface at `at`: 36
/// triangles (the shank is inside the plate).
fn rivet(m: &mut Mesh, at: Vec3, n: Vec3, d: f32) {
    m.loft(
        &Frame::along(at, n),
        &[
            Ring::apex(0.0),
            Ring::new(0.0, circle(0.9 * d, 6)),
            Ring::new(0.3 * d, circle(0.75 * d, 6)),
            Ring::new(0.5 * d, circle(0.4 * d, 6)),
            Ring::apex(0.58 * d),
        ],
        false,
    );
}

/// Socket-head cap screw: round head on the surface at `at`, 64 triangles.
fn screw(m: &mut Mesh, at: Vec3, n: Vec3, d: f32, len: f32) {
    headed_shank(m, at, n, circle(0.5 * d, 8), circle(0.8 * d, 8), len, d);
}

/// Solid cylinder of radius `r` along `f.w` from `z0` to `z1`: `4 * sides`
/// triangles.
fn rod(m: &mut Mesh, f: &Frame, r: f32, z0: f32, z1: f32, sides: u32) {
    let c = circle(r, sides);
    m.loft(
        f,
        &[
            Ring::apex(z0),
            Ring::new(z0, c.clone()),
            Ring::new(z1, c),
            Ring::apex(z1),
        ],
        false,
    );
}

/// `outline` extruded along `f.w` from `z0` to `z1`, capped: `4n`
/// triangles for `n` points (the outline star-shaped about the axis).
fn prism(m: &mut Mesh, f: &Frame, outline: &[Vec2], z0: f32, z1: f32) {
    m.loft(
        f,
        &[
            Ring::apex(z0),
            Ring::new(z0, outline.to_vec()),
            Ring::new(z1, outline.to_vec()),
            Ring::apex(z1),
        ],
        false,
    );
}

/// Tube with a wall, `r_in` to `r_out`, from `z0` to `z1`: `8 * sides`
/// triangles.
fn pipe(m: &mut Mesh, f: &Frame, r_out: f32, r_in: f32, z0: f32, z1: f32, sides: u32) {
    annulus(m, f, &circle(r_out, sides), r_in, z0, z1);
}

/// `outer` extruded from `z0` to `z1` with a round bore of radius `bore`.
fn annulus(m: &mut Mesh, f: &Frame, outer: &[Vec2], bore: f32, z0: f32, z1: f32) {
    let inner = at_radius(outer, bore);
    m.loft(
        f,
        &[
            Ring::new(z0, inner.clone()),
            Ring::new(z0, outer.to_vec()),
            Ring::new(z1, outer.to_vec()),
            Ring::new(z1, inner),
        ],
        true,
    );
}

/// Spur gear: `teeth` teeth from `root` to `tip` radius, `width` thick
/// from `z` on, round bore: `32 * teeth` triangles.
#[allow(clippy::too_many_arguments)] // a gear is its frame and five numbers
fn gear(m: &mut Mesh, f: &Frame, root: f32, tip: f32, teeth: u32, width: f32, bore: f32, z: f32) {
    annulus(m, f, &gear_outline(root, tip, teeth), bore, z, z + width);
}

/// A sheet-metal cover open at `z = 0` and closed at `h`, walls `SHEET`
/// thick with both faces modelled, rounded-rectangle plan of half sizes
/// `hu`, `hv` along `f.u`, `f.v`, optionally with a mounting flange
/// `flange` wide around its open edge. 8 or 12 triangles a plan point.
fn cover(m: &mut Mesh, f: &Frame, hu: f32, hv: f32, h: f32, flange: f32) {
    let t = SHEET;
    let r = (0.15 * hu.min(hv)).max(2.5 * t);
    let per = if hu.max(hv) > 0.4 { 5 } else { 3 };
    let outer = rounded_rect(hu, hv, r, per);
    let inner = rounded_rect(hu - t, hv - t, r - t, per);
    let mut rings = vec![
        Ring::apex(h - t),
        Ring::new(h - t, inner.clone()),
        Ring::new(0.0, inner),
    ];
    if flange > 0.0 {
        let fl = rounded_rect(hu + flange, hv + flange, r + flange, per);
        rings.push(Ring::new(0.0, fl.clone()));
        rings.push(Ring::new(t, fl));
        rings.push(Ring::new(t, outer.clone()));
    } else {
        rings.push(Ring::new(0.0, outer.clone()));
    }
    rings.push(Ring::new(h, outer));
    rings.push(Ring::apex(h));
    m.loft(f, &rings, false);
}

/// The same cover with a round plan of radius `r` (`sides` points).
fn round_cover(m: &mut Mesh, f: &Frame, r: f32, h: f32, flange: f32, sides: u32) {
    let t = SHEET;
    let mut rings = vec![
        Ring::apex(h - t),
        Ring::new(h - t, circle(r - t, sides)),
        Ring::new(0.0, circle(r - t, sides)),
    ];
    if flange > 0.0 {
        rings.push(Ring::new(0.0, circle(r + flange, sides)));
        rings.push(Ring::new(t, circle(r + flange, sides)));
        rings.push(Ring::new(t, circle(r, sides)));
    } else {
        rings.push(Ring::new(0.0, circle(r, sides)));
    }
    rings.push(Ring::new(h, circle(r, sides)));
    rings.push(Ring::apex(h));
    m.loft(f, &rings, false);
}

/// An I-beam from `a` to `b` (horizontal) as three welded plates: flanges
/// and web, three parts. `h` high, `w` wide, standing on `a.y`.
fn ibeam(asm: &mut Asm, sub: &'static str, a: Vec3, b: Vec3, h: f32, w: f32) {
    let d = (b - a).normalize();
    let axes = [d, Vec3::Y, d.cross(Vec3::Y)];
    let mid = (a + b) * 0.5;
    let half = 0.5 * (b - a).length();
    let tf = 0.06 * h + 0.004;
    let material = asm.trim;
    for (y, hy, hz) in [
        (0.5 * tf, 0.5 * tf, 0.5 * w),
        (h - 0.5 * tf, 0.5 * tf, 0.5 * w),
        (0.5 * h, 0.5 * h - tf - GAP, 0.04 * h + 0.002),
    ] {
        let c = mid + Vec3::Y * y;
        asm.part(sub, material, |m| {
            m.oriented_box(c, axes, Vec3::new(half, hy, hz))
        });
    }
}

/// An electric motor (or generator): housing with cooling fins, end
/// shields, fan cover, shaft, feet and a terminal box. The shaft end of
/// the housing's axis is at `c`, the housing runs `len` back along
/// `-axis` (horizontal), radius `r`; the feet stand on `c.y - 1.25 r`.
fn motor(asm: &mut Asm, rng: &mut Rng, c: Vec3, axis: Vec3, r: f32, len: f32) {
    let sub = "motor";
    let paint = asm.paint;
    let back = Frame::along(c, -axis);
    asm.part(sub, paint, |m| pipe(m, &back, r, r - 0.008, 0.0, len, 24));
    // Fins over the upper three quarters; none under the terminal box.
    let side = axis.cross(Vec3::Y).normalize();
    let fins = 14 + rng.below(8) as u32;
    let fin_h = 0.12 * r;
    for k in 0..fins {
        let phi = -0.8 * PI + 1.6 * PI * k as f32 / (fins - 1) as f32;
        if phi.abs() < 0.3 {
            continue;
        }
        let radial = Vec3::Y * phi.cos() + side * phi.sin();
        let centre = c - axis * (0.5 * len) + radial * (r + 0.5 * fin_h + GAP);
        asm.part(sub, paint, |m| {
            m.oriented_box(
                centre,
                [axis, radial, axis.cross(radial)],
                Vec3::new(0.45 * len, 0.5 * fin_h, 0.003),
            )
        });
    }
    // Drive-end shield bolted to the housing, fan cover at the other end.
    let de = Frame::along(c + axis * GAP, axis);
    asm.part(sub, paint, |m| round_cover(m, &de, r, 0.12 * r, 0.02, 24));
    asm.screw_circle(sub, &de, r + 0.01, SHEET, 0.008, 6);
    let fan = Frame::along(c - axis * (len + GAP), -axis);
    asm.part(sub, asm.trim, |m| {
        round_cover(m, &fan, 1.02 * r, 0.4 * r, 0.0, 24)
    });
    // Grille bars across the fan cover's end.
    let fan_end = fan.at(Vec2::ZERO, 0.4 * r + GAP);
    for k in 0..7 {
        let y = (k as f32 - 3.0) * 0.22 * r;
        let p = fan_end + Vec3::Y * y - axis * 0.004;
        let half = ((0.85 * r) * (0.85 * r) - y * y).max(0.0).sqrt();
        if half < 0.02 {
            continue;
        }
        asm.part(sub, asm.trim, |m| {
            m.oriented_box(
                p,
                [side, Vec3::Y, side.cross(Vec3::Y)],
                Vec3::new(half, 0.008, 0.004),
            )
        });
    }
    // Shaft and key.
    let shaft_r = 0.16 * r;
    let sh = Frame::along(c, axis);
    asm.part(sub, STEEL, |m| {
        rod(m, &sh, shaft_r, 0.12 * r + 2.0 * GAP, 0.42 * r, 12)
    });
    let key = c + axis * (0.12 * r + 0.18 * r) + Vec3::Y * (shaft_r + 0.003);
    asm.part(sub, STEEL, |m| {
        m.oriented_box(
            key,
            [axis, Vec3::Y, axis.cross(Vec3::Y)],
            Vec3::new(0.08 * r, 0.004, 0.2 * shaft_r),
        )
    });
    // Feet, bolted down.
    let floor = c.y - 1.25 * r;
    for (t, s) in [(0.15, 1.0), (0.15, -1.0), (0.85, 1.0), (0.85, -1.0)] {
        let p = c - axis * (len * t) + side * (s * 0.75 * r);
        let (y0, y1) = (floor + GAP, c.y - 0.6 * r);
        let centre = Vec3::new(p.x, 0.5 * (y0 + y1), p.z);
        asm.part(sub, paint, |m| {
            m.oriented_box(
                centre,
                [axis, Vec3::Y, axis.cross(Vec3::Y)],
                Vec3::new(0.1 * r, 0.5 * (y1 - y0), 0.12 * r),
            )
        });
        let foot_top = Vec3::new(p.x, floor + 0.06 * r + GAP, p.z) + side * (s * 0.05 * r);
        let d = (0.05 * r).clamp(0.008, 0.02);
        asm.part(sub, ZINC, |m| {
            washer(m, foot_top + Vec3::Y * GAP, Vec3::Y, d)
        });
        asm.part(sub, BLACK, |m| {
            bolt(
                m,
                foot_top + Vec3::Y * (0.16 * d + 2.0 * GAP),
                Vec3::Y,
                d,
                0.05 * r,
            )
        });
    }
    // Terminal box on top, with a lid, screws and cable glands.
    let top = c - axis * (0.4 * len) + Vec3::Y * (r + GAP);
    let (bu, bv, bh) = (0.35 * r, 0.3 * r, 0.3 * r);
    let tb = Frame::new(top, axis, Vec3::Y.cross(axis));
    asm.part(sub, paint, |m| cover(m, &tb, bu, bv, bh, 0.0));
    let lid = top + Vec3::Y * (bh + GAP + 0.003);
    asm.part(sub, paint, |m| {
        m.oriented_box(
            lid,
            [axis, Vec3::Y, axis.cross(Vec3::Y)],
            Vec3::new(bu + 0.005, 0.003, bv + 0.005),
        )
    });
    for (x, z) in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)] {
        let at =
            lid + Vec3::Y * (0.003 + GAP) + axis * (x * (bu - 0.01)) + side * (z * (bv - 0.01));
        asm.part(sub, BLACK, |m| screw(m, at, Vec3::Y, 0.005, 0.01));
    }
    let wall = top + Vec3::Y * (0.5 * bh) + side * (bv + GAP);
    for k in 0..2 {
        let at = wall + axis * ((k as f32 - 0.5) * 0.8 * bu);
        asm.part(sub, BLACK, |m| nut(m, at, side, 0.02 * r.max(0.5)));
    }
    asm.faces.push(Face::new(
        top + Vec3::Y * (0.5 * bh) - side * (bv + GAP),
        -side,
        axis,
        Vec2::new(bu, 0.5 * bh),
    ));
}

// The five designs. Each builds its main parts in order of importance (so a
// small budget still gets a recognisable machine) and leaves the rest of its
// budget to `decorate`.

/// A diesel genset: skid, engine block, oil pan, head and valve cover with
/// their bolt rows, cylinders, pistons and crankshaft inside, manifolds,
/// turbocharger, radiator with fins, and the generator behind it.
fn engine(a: &mut Asm, rng: &mut Rng, s: f32) {
    let cyl = [4u32, 6, 6, 8][rng.below(4)];
    let pitch = 0.19 * s;
    let bore = 0.12 * s;
    let (hl, hw) = (0.5 * (cyl as f32 * pitch + 0.25 * s), 0.26 * s);
    let (gr, gen_len) = (0.33 * s, 0.6 * s);
    let rad_w = 0.25;
    // Radiator, fan space, block, flywheel housing, generator with its
    // end shield and fan cover.
    let total = rad_w + 0.3 + 2.0 * hl + 0.13 + 0.52 * gr + gen_len + 0.05;
    let x0 = -0.5 * total;
    let bx = x0 + rad_w + 0.3 + hl;
    let (paint, trim) = (a.paint, a.trim);
    let skid = 0.22;
    // Skid: two beams and cross members.
    for z in [-0.45 * s, 0.45 * s] {
        ibeam(
            a,
            "skid",
            Vec3::new(x0, 0.0, z),
            Vec3::new(-x0, 0.0, z),
            skid,
            0.12,
        );
    }
    for k in 0..4 {
        let x = x0 + 0.2 + k as f32 * (total - 0.4) / 3.0;
        a.part("skid", trim, |m| {
            m.aabox(
                Vec3::new(x - 0.04, 0.02, -0.45 * s + 0.06),
                Vec3::new(x + 0.04, skid - 0.03, 0.45 * s - 0.06),
            )
        });
    }
    let top = skid + GAP;
    let pan_y = top + 0.16;
    let split = pan_y + 0.2 * s;
    // Engine mounts: rubber pad on the beam, upright and arm to the block,
    // bolted through the beam's flange and into the block.
    let flange = 0.06 * skid + 0.004;
    for (x, side) in [
        (bx - hl + 0.12, 1.0f32),
        (bx - hl + 0.12, -1.0),
        (bx + hl - 0.12, 1.0),
        (bx + hl - 0.12, -1.0),
    ] {
        let z = side * 0.45 * s;
        a.part("mounts", RUBBER, |m| {
            m.aabox(
                Vec3::new(x - 0.06, top, z - 0.05),
                Vec3::new(x + 0.06, top + 0.05, z + 0.05),
            )
        });
        a.part("mounts", trim, |m| {
            m.aabox(
                Vec3::new(x - 0.05, top + 0.05 + GAP, z - 0.04),
                Vec3::new(x + 0.05, split + 0.1, z + 0.04),
            )
        });
        let (z0, z1) = if side > 0.0 {
            (hw + GAP, z - 0.04 - GAP)
        } else {
            (z + 0.04 + GAP, -hw - GAP)
        };
        a.part("mounts", trim, |m| {
            m.aabox(
                Vec3::new(x - 0.05, split + 0.06, z0),
                Vec3::new(x + 0.05, split + 0.1 - GAP, z1),
            )
        });
        for dx in [-0.09f32, 0.09] {
            a.bolted("mounts", Vec3::new(x + dx, skid, z), Vec3::Y, 0.012, flange);
        }
        let face = Vec3::new(x, split + 0.08, z + side * (0.04 + GAP));
        a.bolt_row(
            "mounts",
            face - Vec3::X * 0.04,
            face + Vec3::X * 0.04,
            Vec3::Z * side,
            0.01,
            2,
        );
    }
    // Oil pan (open upward) and block (open downward) meet at their flanges.
    let pan = Frame::new(Vec3::new(bx, split - GAP, 0.0), Vec3::X, Vec3::Z);
    a.part("block", paint, |m| {
        cover(m, &pan, hl - 0.04, hw - 0.04, split - GAP - pan_y, 0.03)
    });
    let block_h = 0.55 * s;
    let blk = Frame::new(Vec3::new(bx, split, 0.0), Vec3::Z, Vec3::X);
    a.part("block", paint, |m| cover(m, &blk, hw, hl, block_h, 0.03));
    for z in [-1.0f32, 1.0] {
        let zf = z * (hw + 0.015);
        let n = ((2.0 * hl) / (0.09 * s)) as u32;
        let (p0, p1) = (
            Vec3::new(bx - hl, split + SHEET, zf),
            Vec3::new(bx + hl, split + SHEET, zf),
        );
        a.bolt_row("block_bolts", p0, p1, Vec3::Y, 0.008, n);
    }
    for x in [-1.0f32, 1.0] {
        let xf = bx + x * (hl + 0.015);
        let (p0, p1) = (
            Vec3::new(xf, split + SHEET, -hw),
            Vec3::new(xf, split + SHEET, hw),
        );
        a.bolt_row("block_bolts", p0, p1, Vec3::Y, 0.008, 5);
    }
    let deck = split + block_h;
    for side in [-1.0f32, 1.0] {
        a.faces.push(Face::new(
            Vec3::new(bx, split + 0.55 * block_h, side * (hw + GAP)),
            Vec3::Z * side,
            Vec3::X * side,
            Vec2::new(hl - 0.2, 0.4 * block_h),
        ));
    }
    // Inside: liners, pistons, connecting rods, crankshaft.
    let xs: Vec<f32> = (0..cyl)
        .map(|k| bx - hl + 0.125 * s + (k as f32 + 0.5) * pitch)
        .collect();
    let crank_y = split + 0.05 * s;
    for (k, &x) in xs.iter().enumerate() {
        let up = Frame::along(Vec3::new(x, 0.0, 0.0), Vec3::Y);
        a.part("internals", STEEL, |m| {
            pipe(
                m,
                &up,
                0.5 * bore + 0.008,
                0.5 * bore,
                deck - 0.3 * s,
                deck - 0.01,
                16,
            )
        });
        let throw = 0.05 * s * (k as f32 * 2.1).cos();
        let py = deck - 0.2 * s + throw;
        a.part("internals", STEEL, |m| {
            rod(m, &up, 0.5 * bore - 0.002, py, py + 0.09 * s, 12)
        });
        let pin = Vec3::new(x, crank_y + throw, 0.0);
        let mid = (pin + Vec3::new(x, py, 0.0)) * 0.5;
        let half = 0.5 * (py - pin.y) - 0.01;
        a.part("internals", STEEL, |m| {
            m.aabox(
                mid - Vec3::new(0.012, half, 0.02),
                mid + Vec3::new(0.012, half, 0.02),
            )
        });
        let along = Frame::along(Vec3::new(x - 0.5 * pitch, crank_y, 0.0), Vec3::X);
        a.part("internals", STEEL, |m| {
            rod(m, &along, 0.03 * s, 0.01, 0.5 * pitch - 0.04, 10)
        });
        for dx in [-0.03f32, 0.03] {
            a.part("internals", STEEL, |m| {
                m.aabox(
                    Vec3::new(x + dx - 0.008, crank_y - 0.04 * s, -0.04 * s),
                    Vec3::new(x + dx + 0.008, crank_y + 0.08 * s, 0.04 * s),
                )
            });
        }
    }
    // Head and valve cover with their bolts.
    let head_h = 0.12 * s;
    let head = Frame::new(Vec3::new(bx, deck + GAP, 0.0), Vec3::Z, Vec3::X);
    a.part("head", paint, |m| {
        cover(m, &head, hw - 0.02, hl - 0.02, head_h, 0.015)
    });
    for &x in &xs {
        for dz in [-1.0f32, 1.0] {
            let at = Vec3::new(x + 0.4 * pitch, deck + GAP + head_h + GAP, dz * (hw - 0.07));
            a.part("head", ZINC, |m| washer(m, at, Vec3::Y, 0.012));
            a.part("head", BLACK, |m| {
                bolt(m, at + Vec3::Y * (0.002 + GAP), Vec3::Y, 0.012, 0.05)
            });
        }
    }
    let vc_y = deck + 2.0 * GAP + head_h;
    let vc = Frame::new(Vec3::new(bx, vc_y, 0.0), Vec3::Z, Vec3::X);
    a.part("head", trim, |m| {
        cover(m, &vc, hw - 0.11, hl - 0.1, 0.08 * s, 0.012)
    });
    for dz in [-1.0f32, 1.0] {
        let z = dz * (hw - 0.11 + 0.006);
        let n = (2.0 * hl / 0.12) as u32;
        let (p0, p1) = (
            Vec3::new(bx - hl + 0.1, vc_y + SHEET, z),
            Vec3::new(bx + hl - 0.1, vc_y + SHEET, z),
        );
        a.bolt_row("head", p0, p1, Vec3::Y, 0.006, n);
    }
    // Exhaust side (-z): a bent pipe of ring segments from each port to a
    // collector, studs at the ports, turbocharger at the end.
    let port_y = deck + 0.5 * head_h;
    let coll = Vec3::new(0.0, port_y + 0.12, -hw - 0.18);
    for &x in &xs {
        let p = Vec3::new(x, port_y, -hw);
        for dx in [-0.025f32, 0.025] {
            a.part("exhaust", BRASS, |m| {
                nut(m, p + Vec3::new(dx, 0.03, -0.04), -Vec3::Z, 0.008)
            });
        }
        let e = Vec3::new(x, coll.y, coll.z);
        let c = [
            p - Vec3::Z * 0.04,
            p - Vec3::Z * 0.15,
            e - Vec3::Y * 0.08,
            e,
        ];
        a.run("exhaust", STEEL, c, 0.025 * s, 0.06, 8, true);
    }
    let (cx0, cx1) = (xs[0] - 0.05, xs[xs.len() - 1] + 0.05);
    let (c0, c1) = (
        Vec3::new(cx0, coll.y, coll.z),
        Vec3::new(cx1, coll.y, coll.z),
    );
    a.run(
        "exhaust",
        STEEL,
        [c0, c0 + Vec3::X * 0.3, c1 - Vec3::X * 0.3, c1],
        0.04 * s,
        0.1,
        10,
        true,
    );
    let turbo = Vec3::new(cx1 + 0.12, coll.y + 0.05, coll.z);
    let tf = Frame::along(turbo, Vec3::Z);
    a.part("exhaust", STEEL, |m| {
        m.loft(
            &tf,
            &[
                Ring::apex(-0.1),
                Ring::new(-0.1, circle(0.06 * s, 16)),
                Ring::new(-0.06, circle(0.11 * s, 16)),
                Ring::new(0.0, circle(0.12 * s, 16)),
                Ring::new(0.05, circle(0.1 * s, 16)),
                Ring::new(0.08, circle(0.05 * s, 16)),
                Ring::apex(0.1),
            ],
            false,
        )
    });
    let t0 = turbo + Vec3::Y * (0.12 * s + 0.01);
    let c = [
        t0,
        t0 + Vec3::Y * 0.2,
        t0 + Vec3::new(0.0, 0.35, 0.1),
        t0 + Vec3::new(0.0, 0.5, 0.12),
    ];
    a.run("exhaust", STEEL, c, 0.05 * s, 0.08, 10, true);
    // Intake side (+z): plenum and runners.
    let plen = Frame::along(Vec3::new(cx0, port_y + 0.1, hw + 0.12), Vec3::X);
    a.part("intake", trim, |m| {
        rod(m, &plen, 0.06 * s, 0.0, cx1 - cx0, 16)
    });
    for &x in &xs {
        let p = Vec3::new(x, port_y, hw + 0.01);
        let e = Vec3::new(x, port_y + 0.1, hw + 0.12 - 0.06 * s - 0.01);
        a.run(
            "intake",
            trim,
            [p, p + Vec3::Z * 0.03, e - Vec3::Z * 0.03, e],
            0.022 * s,
            0.04,
            8,
            true,
        );
    }
    // Fuel rail and a steel line to each injector.
    let rail_y = vc_y + 0.04;
    let rail = Frame::along(Vec3::new(cx0, rail_y, hw - 0.06), Vec3::X);
    a.part("fuel", STEEL, |m| rod(m, &rail, 0.012, 0.0, cx1 - cx0, 8));
    for &x in &xs {
        let inj = Vec3::new(x, vc_y + 0.08 * s + 0.005, 0.0);
        a.part("fuel", STEEL, |m| {
            rod(m, &Frame::along(inj, Vec3::Y), 0.012, 0.0, 0.05, 8)
        });
        let r0 = Vec3::new(x, rail_y + 0.013, hw - 0.06);
        let e = inj + Vec3::Y * 0.055;
        let c = [r0, r0 + Vec3::Y * 0.1, e + Vec3::new(0.0, 0.07, 0.05), e];
        a.run("fuel", STEEL, c, 0.004, 0.04, 6, false);
    }
    // Timing gear and accessory gear at the front (-x), a belt of separate
    // blocks around them.
    let front = bx - hl - GAP;
    let (p1, p2) = (
        Vec3::new(front, split + 0.2 * s, 0.0),
        Vec3::new(front, deck - 0.05, 0.12 * s),
    );
    let r1 = 0.09 * s;
    let ff = Frame::along(p1, -Vec3::X);
    a.part("front", STEEL, |m| {
        gear(m, &ff, r1 - 0.01, r1, 14, 0.03, 0.02, 0.01)
    });
    let ff2 = Frame::along(p2, -Vec3::X);
    a.part("front", STEEL, |m| {
        gear(m, &ff2, r1 - 0.01, r1, 14, 0.03, 0.015, 0.01)
    });
    let rb = r1 + 0.008;
    let e2 = (p2 - p1).normalize();
    let e1 = Vec3::X.cross(e2);
    let l = (p2 - p1).length();
    let belt_len = 2.0 * PI * rb + 2.0 * l;
    // A stadium around both gears: far half of the first, straight, near
    // half of the second, straight back.
    let belt = |u: f32| {
        let u = u.rem_euclid(belt_len);
        let c = p1 - Vec3::X * 0.025;
        if u < PI * rb {
            let f = u / rb;
            c + (e1 * f.cos() - e2 * f.sin()) * rb
        } else if u < PI * rb + l {
            c - e1 * rb + e2 * (u - PI * rb)
        } else if u < 2.0 * PI * rb + l {
            let f = (u - PI * rb - l) / rb;
            c + e2 * l + (-e1 * f.cos() + e2 * f.sin()) * rb
        } else {
            c + e1 * rb + e2 * (l - (u - 2.0 * PI * rb - l))
        }
    };
    let links = (belt_len / 0.02) as u32;
    for k in 0..links {
        let u = belt_len * k as f32 / links as f32;
        let c = belt(u);
        let tangent = (belt(u + 0.001) - belt(u - 0.001)).normalize();
        let radial = Vec3::X.cross(tangent);
        let ok = a.part("front", RUBBER, |m| {
            m.oriented_box(
                c,
                [tangent, radial, Vec3::X],
                Vec3::new(0.008, 0.004, 0.012),
            )
        });
        if !ok {
            break;
        }
    }
    // Radiator at the front: core, tanks, fins, hoses to the engine.
    let rx = x0 + 0.5 * rad_w;
    let (rh, rz) = (0.9 * s, hw + 0.15);
    let ry0 = top + 0.05;
    a.part("radiator", trim, |m| {
        m.aabox(
            Vec3::new(rx - 0.04, ry0 + 0.12, -rz),
            Vec3::new(rx + 0.04, ry0 + rh - 0.12, rz),
        )
    });
    for y in [ry0, ry0 + rh - 0.1] {
        let f = Frame::new(Vec3::new(rx, y, 0.0), Vec3::Z, Vec3::X);
        a.part("radiator", trim, |m| cover(m, &f, rz, 0.06, 0.1, 0.0));
    }
    let fins = (2.0 * rz / 0.03) as u32;
    for k in 0..fins {
        let z = -rz + (k as f32 + 0.5) * 2.0 * rz / fins as f32;
        let ok = a.part("radiator", STEEL, |m| {
            m.aabox(
                Vec3::new(rx + 0.04 + GAP, ry0 + 0.13, z - 0.001),
                Vec3::new(rx + 0.09, ry0 + rh - 0.13, z + 0.001),
            )
        });
        if !ok {
            break;
        }
    }
    for (y0, y1) in [(ry0 + rh - 0.05, deck - 0.05), (ry0 + 0.05, split + 0.05)] {
        let p = Vec3::new(rx + 0.1, y0, -0.15 * s);
        let e = Vec3::new(front - 0.01, y1, -0.15 * s);
        let c = [p, p + Vec3::X * 0.15, e - Vec3::X * 0.15, e];
        a.run("radiator", RUBBER, c, 0.03, 0.06, 8, true);
    }
    a.faces.push(Face::new(
        Vec3::new(rx - 0.04 - GAP, ry0 + 0.5 * rh, 0.0),
        -Vec3::X,
        Vec3::Z,
        Vec2::new(rz - 0.05, 0.5 * rh - 0.15),
    ));
    // Flywheel housing and the generator behind the block.
    let rear = bx + hl + GAP;
    let axis_y = split + 0.2 * s;
    let fw = Frame::along(Vec3::new(rear, axis_y, 0.0), Vec3::X);
    a.part("generator", paint, |m| {
        round_cover(m, &fw, 0.3 * s, 0.12, 0.02, 24)
    });
    a.screw_circle("generator", &fw, 0.3 * s + 0.01, SHEET, 0.01, 10);
    let gx = rear + 0.12 + 4.0 * GAP + 0.12 * gr;
    motor(a, rng, Vec3::new(gx, axis_y, 0.0), -Vec3::X, gr, gen_len);
    // A wiring harness along the intake side, clipped at each cylinder.
    let hz = hw + GAP + 0.015;
    let hy = split + 0.75 * block_h;
    let c = [
        Vec3::new(cx0, hy, hz),
        Vec3::new(cx0 + 0.4, hy + 0.02, hz),
        Vec3::new(cx1 - 0.4, hy - 0.02, hz),
        Vec3::new(cx1 + 0.3, hy - 0.2, hz),
    ];
    a.run("harness", CABLES[0], c, 0.01, 0.05, 6, false);
    for &x in &xs {
        let p = Vec3::new(x, hy, hz);
        a.part("harness", BLACK, |m| {
            m.aabox(
                p - Vec3::new(0.008, 0.016, 0.016),
                p + Vec3::new(0.008, 0.016, 0.016),
            )
        });
    }
}

/// A gear drive on a base frame: motor, coupling under a guard, and a
/// split gearbox housing with gears, shafts and bearings inside and a bolt
/// row along its split.
fn gear_drive(a: &mut Asm, rng: &mut Rng, s: f32) {
    let len = 3.4 * s;
    let x0 = -0.5 * len;
    let base_h = 0.2;
    for z in [-0.5 * s, 0.5 * s] {
        ibeam(
            a,
            "frame",
            Vec3::new(x0, 0.0, z),
            Vec3::new(-x0, 0.0, z),
            base_h,
            0.12,
        );
    }
    let trim = a.trim;
    for k in 0..5 {
        let x = x0 + 0.1 + k as f32 * (len - 0.2) / 4.0;
        a.part("frame", trim, |m| {
            m.aabox(
                Vec3::new(x - 0.05, 0.02, -0.5 * s + 0.06),
                Vec3::new(x + 0.05, base_h - 0.02, 0.5 * s - 0.06),
            )
        });
    }
    let deck = base_h + GAP;
    a.part("frame", STEEL, |m| {
        m.aabox(
            Vec3::new(x0, deck, -0.55 * s),
            Vec3::new(-x0, deck + 0.02, 0.55 * s),
        )
    });
    let deck = deck + 0.02;
    for z in [-0.55 * s + 0.04, 0.55 * s - 0.04] {
        a.rivet_row(
            "frame",
            Vec3::new(x0 + 0.05, deck, z),
            Vec3::new(-x0 - 0.05, deck, z),
            Vec3::Y,
            0.008,
            (len / 0.15) as u32,
        );
    }
    // Motor on the left half, shaft towards +x.
    let r = 0.28 * s;
    let axis_y = deck + 1.25 * r + GAP;
    let mlen = 0.9 * s;
    let mx = -0.15 * s;
    motor(a, rng, Vec3::new(mx, axis_y, 0.0), Vec3::X, r, mlen);
    // Coupling: two hubs and the rubber spider between them, under a guard.
    let cf = Frame::along(Vec3::new(mx + 0.12 * r + 0.3 * r, axis_y, 0.0), Vec3::X);
    a.part("coupling", STEEL, |m| {
        pipe(m, &cf, 0.1 * s, 0.16 * r + 0.002, 0.0, 0.06, 16)
    });
    a.part("coupling", RUBBER, |m| {
        gear(m, &cf, 0.06 * s, 0.09 * s, 6, 0.02, 0.03, 0.06 + GAP)
    });
    a.part("coupling", STEEL, |m| {
        pipe(m, &cf, 0.1 * s, 0.03, 0.08 + 2.0 * GAP, 0.14, 16)
    });
    let gf = Frame::new(
        Vec3::new(cf.origin.x + 0.1, deck + GAP, 0.0),
        Vec3::Z,
        Vec3::X,
    );
    a.part("coupling", a.paint, |m| {
        cover(m, &gf, 0.18 * s, 0.13, axis_y + 0.15 * s - deck, 0.02)
    });
    for z in [-1.0f32, 1.0] {
        let at = gf.origin + Vec3::new(0.0, SHEET, z * (0.18 * s + 0.01));
        a.bolt_row(
            "coupling",
            at - Vec3::X * 0.1,
            at + Vec3::X * 0.1,
            Vec3::Y,
            0.006,
            3,
        );
    }
    // Gearbox: lower and upper housing meeting at the shaft plane.
    let gx0 = cf.origin.x + 0.25;
    let (hu, hv) = (0.45 * s, 0.42 * s);
    let gc = Vec3::new(gx0 + hu, axis_y, 0.1 * s);
    let paint = a.paint;
    let low = Frame::new(gc - Vec3::Y * GAP, Vec3::X, Vec3::Z);
    a.part("gearbox", paint, |m| {
        cover(m, &low, hu, hv, axis_y - deck - 2.0 * GAP, 0.04)
    });
    let up = Frame::new(gc, Vec3::Z, Vec3::X);
    a.part("gearbox", paint, |m| cover(m, &up, hv, hu, 0.38 * s, 0.04));
    // Split bolts along the flange, through both flanges.
    let grip = 2.0 * SHEET + GAP;
    let d = 0.012;
    for side in [-1.0f32, 1.0] {
        let z = gc.z + side * (hv + 0.02);
        let n = (2.0 * hu / 0.1) as u32;
        for k in 0..n {
            let x = gc.x - hu + (k as f32 + 0.5) * 2.0 * hu / n as f32;
            a.bolted(
                "gearbox_bolts",
                Vec3::new(x, axis_y + SHEET, z),
                Vec3::Y,
                d,
                grip,
            );
        }
        let x = gc.x + side * (hu + 0.02);
        for k in 0..6 {
            let z = gc.z - hv + (k as f32 + 0.5) * 2.0 * hv / 6.0;
            a.bolted(
                "gearbox_bolts",
                Vec3::new(x, axis_y + SHEET, z),
                Vec3::Y,
                d,
                grip,
            );
        }
    }
    // Inside: three shafts along x, two gear stages, a bearing at each wall.
    let stages = [(0.0f32, 0.05f32), (-0.16, 0.11), (0.17, 0.14)];
    for (k, &(dz, rw)) in stages.iter().enumerate() {
        let z = gc.z - 0.1 * s + dz * s;
        let f = Frame::along(Vec3::new(gc.x - hu, axis_y, z), Vec3::X);
        let shaft = 0.025 * s + 0.006 * k as f32;
        a.part("gears", STEEL, |m| {
            rod(m, &f, shaft, 0.01, 2.0 * hu - 0.01, 12)
        });
        a.bearing("gears", &f, shaft + 0.002, shaft + 0.04, 0.04);
        a.bearing("gears", &f, shaft + 0.002, shaft + 0.04, 2.0 * hu - 0.04);
        let teeth = 9 + (rw * 40.0) as u32;
        let root = rw * s;
        a.part("gears", STEEL, |m| {
            gear(
                m,
                &f,
                root,
                root + 0.012,
                teeth.min(15),
                0.05,
                shaft + 0.001,
                0.3 * hu + k as f32 * 0.25 * hu,
            )
        });
        let pin = (0.035 * s).max(shaft + 0.012);
        a.part("gears", STEEL, |m| {
            gear(
                m,
                &f,
                pin,
                pin + 0.01,
                9,
                0.06,
                shaft + 0.001,
                0.4 * hu + k as f32 * 0.3 * hu,
            )
        });
    }
    // Output shaft and its flange with a bolt circle.
    let out = Frame::along(Vec3::new(gc.x + hu, axis_y, gc.z + 0.07 * s), Vec3::X);
    a.part("gearbox", STEEL, |m| rod(m, &out, 0.04 * s, 0.06, 0.25, 12));
    a.part("gearbox", STEEL, |m| {
        pipe(m, &out, 0.12 * s, 0.04 * s + 0.002, 0.25 + GAP, 0.28, 20)
    });
    a.screw_circle(
        "gearbox",
        &Frame::along(out.origin, Vec3::X),
        0.09 * s,
        0.28,
        0.01,
        6,
    );
    // On top: inspection cover, breather, lifting eyes.
    let top_y = axis_y + 0.38 * s + GAP;
    let ic = Vec3::new(gc.x, top_y + 0.004, gc.z);
    a.part("gearbox", paint, |m| {
        m.aabox(
            ic - Vec3::new(0.2 * s, 0.004, 0.15 * s),
            ic + Vec3::new(0.2 * s, 0.004, 0.15 * s),
        )
    });
    for (x, z) in [
        (1.0, 1.0),
        (0.0, 1.0),
        (-1.0, 1.0),
        (-1.0, -1.0),
        (0.0, -1.0),
        (1.0, -1.0),
    ] {
        let at = ic + Vec3::new(x * (0.2 * s - 0.02), 0.004 + GAP, z * (0.15 * s - 0.02));
        a.part("gearbox", BLACK, |m| screw(m, at, Vec3::Y, 0.008, 0.012));
    }
    let br = Vec3::new(gc.x + 0.3 * hu, top_y + 0.008 + GAP, gc.z - 0.1);
    a.part("gearbox", BRASS, |m| {
        rod(m, &Frame::along(br, Vec3::Y), 0.015, 0.0, 0.06, 8)
    });
    for x in [-0.7f32, 0.7] {
        let p = Vec3::new(gc.x + x * hu, top_y + 0.05, gc.z);
        a.part("gearbox", STEEL, |m| {
            m.torus(p, Vec3::Z, 0.035, 0.01, 12, 6)
        });
    }
    for side in [-1.0f32, 1.0] {
        a.faces.push(Face::new(
            Vec3::new(gc.x, axis_y + 0.19 * s, gc.z + side * (hv + GAP)),
            Vec3::Z * side,
            Vec3::X,
            Vec2::new(hu - 0.05, 0.17 * s),
        ));
    }
    a.faces.push(Face::new(
        Vec3::new(gc.x + hu + GAP, axis_y + 0.2 * s, gc.z - 0.1),
        Vec3::X,
        -Vec3::Z,
        Vec2::new(0.2, 0.12 * s),
    ));
    // Oil lines from the gearbox to a small cooler on the frame.
    let cooler = Vec3::new(x0 + 0.3, deck + GAP, -0.3 * s);
    let cf = Frame::new(cooler, Vec3::Z, Vec3::X);
    a.part("cooler", trim, |m| cover(m, &cf, 0.15, 0.2, 0.35, 0.015));
    for k in 0..10 {
        let z = cooler.z - 0.12 + k as f32 * 0.025;
        a.part("cooler", STEEL, |m| {
            m.aabox(
                Vec3::new(cooler.x - 0.22, deck + 0.05, z),
                Vec3::new(cooler.x - 0.205, deck + 0.33, z + 0.004),
            )
        });
    }
    for dy in [0.1f32, 0.25] {
        // Out of the cooler's side and round the motor's flank.
        let p = Vec3::new(cooler.x, deck + dy, cooler.z - 0.15 - GAP);
        let e = Vec3::new(gc.x - hu - GAP, axis_y - 0.1 - dy * 0.3, gc.z - hv + 0.1);
        let c = [
            p,
            p + Vec3::new(0.3, 0.2, -0.15),
            e + Vec3::new(-0.3, 0.0, -0.25),
            e,
        ];
        a.run("cooler", RUBBER, c, 0.012, 0.035, 8, true);
    }
}

/// A robot cell: a six-axis arm on a pedestal, posed by seed, its cable
/// harness, a controller cabinet and a roller conveyor.
fn robot_cell(a: &mut Asm, rng: &mut Rng, s: f32) {
    let paint = a.paint;
    let trim = a.trim;
    // Pedestal plate with anchor bolts, riser, base.
    a.part("base", trim, |m| {
        m.aabox(
            Vec3::new(-0.45 * s, 0.0, -0.45 * s),
            Vec3::new(0.45 * s, 0.04, 0.45 * s),
        )
    });
    for k in 0..8 {
        let ang = TAU * (k as f32 + 0.5) / 8.0;
        let at = Vec3::new(0.38 * s * ang.cos(), 0.04 + GAP, 0.38 * s * ang.sin());
        a.part("base", ZINC, |m| washer(m, at, Vec3::Y, 0.016));
        a.part("base", BLACK, |m| {
            bolt(m, at + Vec3::Y * (0.003 + GAP), Vec3::Y, 0.016, 0.025)
        });
    }
    let riser_h = 0.45 * s;
    let rf = Frame::new(Vec3::new(0.0, 0.04 + GAP, 0.0), Vec3::Z, Vec3::X);
    a.part("base", trim, |m| {
        cover(m, &rf, 0.25 * s, 0.25 * s, riser_h, 0.04)
    });
    // Screws along the square flange's sides.
    for k in 0..12 {
        let (along, across) = ((k % 3) as f32 - 1.0, 0.27 * s);
        let p = match k / 3 {
            0 => Vec3::new(across, 0.0, along * 0.15 * s),
            1 => Vec3::new(-across, 0.0, along * 0.15 * s),
            2 => Vec3::new(along * 0.15 * s, 0.0, across),
            _ => Vec3::new(along * 0.15 * s, 0.0, -across),
        };
        let at = p + Vec3::Y * (0.04 + 2.0 * GAP + SHEET);
        a.part("base", BLACK, |m| screw(m, at, Vec3::Y, 0.01, 0.02));
    }
    let j1y = 0.04 + 2.0 * GAP + riser_h;
    let j1 = Frame::along(Vec3::new(0.0, j1y, 0.0), Vec3::Y);
    a.part("arm", paint, |m| rod(m, &j1, 0.26 * s, 0.0, 0.1 * s, 24));
    a.screw_circle("arm", &j1, 0.22 * s, 0.1 * s, 0.01, 12);
    // Pose: turn, shoulder and elbow angles, lowered no further than the
    // conveyor's height.
    let th1 = rng.rangef(-PI, PI);
    let th2 = rng.rangef(-0.5, 0.7);
    let mut th3 = rng.rangef(0.6, 1.8);
    let q1 = Quat::from_rotation_y(th1);
    let turn_y = j1y + 0.1 * s + GAP;
    let tt = Frame::new(Vec3::new(0.0, turn_y, 0.0), q1 * Vec3::Z, q1 * Vec3::X);
    a.part("arm", paint, |m| {
        round_cover(m, &tt, 0.24 * s, 0.28 * s, 0.0, 24)
    });
    let j2_axis = q1 * Vec3::Z;
    let shoulder = Vec3::new(0.0, turn_y + 0.46 * s, 0.0) + q1 * Vec3::X * (0.12 * s);
    let dir = |th: f32| q1 * Vec3::new(th.sin(), th.cos(), 0.0);
    let (l2, l3) = (0.95 * s, 0.8 * s);
    let elbow = shoulder + dir(th2) * l2;
    while th3 > 0.0 && (elbow + dir(th2 + th3) * (l3 + 0.3)).y < 1.2 {
        th3 -= 0.1;
    }
    let wrist = elbow + dir(th2 + th3) * l3;
    // Shoulder and elbow joints with screw circles on both faces.
    for (p, r) in [(shoulder, 0.17 * s), (elbow, 0.13 * s)] {
        let f = Frame::along(p - j2_axis * (0.16 * s), j2_axis);
        a.part("arm", paint, |m| rod(m, &f, r, 0.0, 0.32 * s, 24));
        a.screw_circle("arm", &f, 0.75 * r, 0.32 * s, 0.008, 8);
        let g = Frame::along(p + j2_axis * (0.16 * s), -j2_axis);
        a.screw_circle("arm", &g, 0.75 * r, 0.32 * s, 0.008, 8);
        // Servo motor on the joint's side.
        let mf = Frame::along(p + j2_axis * (0.16 * s + GAP), j2_axis);
        a.part("arm", BLACK, |m| {
            round_cover(m, &mf, 0.07 * s, 0.16 * s, 0.015, 16)
        });
        a.screw_circle("arm", &mf, 0.07 * s + 0.008, SHEET, 0.005, 4);
        let conn = mf.at(Vec2::ZERO, 0.16 * s + GAP);
        a.part("arm", BLACK, |m| {
            m.aabox(conn - Vec3::splat(0.02), conn + Vec3::splat(0.02))
        });
    }
    // Links: sheet-metal housings along the arm.
    for (p0, p1, hu, hv) in [
        (shoulder, elbow, 0.11 * s, 0.09 * s),
        (elbow, wrist, 0.08 * s, 0.07 * s),
    ] {
        let d = (p1 - p0).normalize();
        let v = d.cross(j2_axis).normalize();
        let f = Frame::new(p0 + d * (0.14 * s), j2_axis, v);
        a.part("arm", paint, |m| {
            cover(m, &f, hu, hv, (p1 - p0).length() - 0.26 * s, 0.0)
        });
        // Cable clamps and the harness on the link's side.
        let side = j2_axis * (hu + 0.02);
        for k in 0..4 {
            let c = p0 + (p1 - p0) * (0.25 + 0.17 * k as f32) + side;
            a.part("harness", BLACK, |m| {
                m.oriented_box(c, [d, v, d.cross(v)], Vec3::new(0.012, 0.025, 0.02))
            });
        }
        let c0 = p0 + side * 1.3;
        let c1 = p1 + side * 1.3;
        for (k, cable) in CABLES.iter().enumerate() {
            let off = v * ((k as f32 - 1.0) * 0.022);
            a.run(
                "harness",
                *cable,
                [c0 + off, c0 + off + d * 0.2, c1 + off - d * 0.2, c1 + off],
                0.009,
                0.05,
                6,
                false,
            );
        }
    }
    // Wrist, tool flange and gripper.
    let d3 = dir(th2 + th3);
    let wf = Frame::along(wrist, d3);
    a.part("arm", paint, |m| rod(m, &wf, 0.065 * s, 0.0, 0.12 * s, 16));
    a.part("tool", STEEL, |m| {
        pipe(
            m,
            &wf,
            0.06 * s,
            0.015,
            0.12 * s + GAP,
            0.12 * s + 0.015,
            16,
        )
    });
    a.screw_circle("tool", &wf, 0.045 * s, 0.12 * s + 0.015, 0.005, 6);
    let g0 = wrist + d3 * (0.12 * s + 0.015 + 2.0 * GAP);
    let gv = d3.cross(j2_axis).normalize();
    let axes = [j2_axis, gv, d3];
    a.part("tool", trim, |m| {
        m.oriented_box(g0 + d3 * 0.04, axes, Vec3::new(0.05, 0.07, 0.04))
    });
    for side in [-1.0f32, 1.0] {
        let fc = g0 + d3 * (0.08 + GAP + 0.06) + gv * (side * 0.04);
        a.part("tool", STEEL, |m| {
            m.oriented_box(fc, axes, Vec3::new(0.02, 0.008, 0.06))
        });
        let pad = fc + d3 * 0.03 - gv * (side * 0.011);
        a.part("tool", RUBBER, |m| {
            m.oriented_box(pad, axes, Vec3::new(0.018, 0.002, 0.025))
        });
    }
    for k in 0..2 {
        let at = g0 + d3 * 0.04 + j2_axis * (0.05 + GAP) + gv * ((k as f32 - 0.5) * 0.05);
        a.part("tool", BRASS, |m| nut(m, at, j2_axis, 0.008));
        let e = elbow + j2_axis * (0.2 * s) + gv * 0.05;
        a.run(
            "tool",
            CABLES[1],
            [at + j2_axis * 0.01, at + j2_axis * 0.1, e + d3 * 0.2, e],
            0.005,
            0.04,
            6,
            true,
        );
    }
    a.faces.push(Face::new(
        Vec3::new(0.25 * s + GAP, 0.04 + 0.5 * riser_h, 0.0),
        Vec3::X,
        -Vec3::Z,
        Vec2::new(0.2 * s, 0.18 * s),
    ));
    a.faces.push(Face::new(
        Vec3::new(-0.25 * s - GAP, 0.04 + 0.5 * riser_h, 0.0),
        -Vec3::X,
        Vec3::Z,
        Vec2::new(0.2 * s, 0.18 * s),
    ));
    // Controller cabinet in a corner, cabled to the base along the floor.
    // Y x X = -Z: the body opens to the front (+z), the door closes it.
    let cc = Vec3::new(-2.4, 0.6 + GAP, -2.4);
    let cab = Frame::new(cc + Vec3::Z * 0.25, Vec3::Y, Vec3::X);
    a.part("controller", LIGHT_GREY, |m| {
        cover(m, &cab, 0.6, 0.3, 0.5, 0.0)
    });
    let door = cc + Vec3::new(0.0, 0.0, 0.25 + GAP + 0.01);
    a.part("controller", LIGHT_GREY, |m| {
        m.aabox(
            door - Vec3::new(0.29, 0.59, 0.01),
            door + Vec3::new(0.29, 0.59, 0.01),
        )
    });
    let handle = door + Vec3::new(0.22, 0.0, 0.01 + GAP);
    a.part("controller", BLACK, |m| {
        rod(
            m,
            &Frame::along(handle - Vec3::Y * 0.06, Vec3::Y),
            0.008,
            0.0,
            0.12,
            8,
        )
    });
    for k in 0..8 {
        let p = door + Vec3::new(0.0, -0.45 + 0.02 * k as f32, 0.01 + GAP);
        a.part("controller", BLACK, |m| {
            m.aabox(
                p - Vec3::new(0.15, 0.004, 0.0),
                p + Vec3::new(0.15, 0.004, 0.004),
            )
        });
    }
    a.faces.push(Face::new(
        door + Vec3::new(0.0, 0.25, 0.01 + GAP),
        Vec3::Z,
        Vec3::X,
        Vec2::new(0.25, 0.25),
    ));
    a.faces.push(Face::new(
        cc + Vec3::new(0.3 + GAP, 0.0, 0.0),
        Vec3::X,
        -Vec3::Z,
        Vec2::new(0.2, 0.5),
    ));
    let plug = Vec3::new(cc.x + 0.3 + GAP, 0.1, cc.z);
    a.run(
        "controller",
        CABLES[0],
        [
            plug,
            plug + Vec3::new(0.5, -0.07, 0.0),
            Vec3::new(-0.6, 0.03, -0.3),
            Vec3::new(-0.25 * s - 0.01, 0.15, 0.0),
        ],
        0.014,
        0.06,
        6,
        false,
    );
    // Conveyor along one side: rails, legs, rollers, drive motor.
    let (cz, cy, cl) = (2.35, 0.75, 2.6);
    for z in [cz - 0.27, cz + 0.27] {
        a.part("conveyor", trim, |m| {
            m.aabox(
                Vec3::new(-cl, cy - 0.1, z - 0.02),
                Vec3::new(cl, cy, z + 0.02),
            )
        });
        for k in 0..4 {
            let x = -cl + 0.15 + k as f32 * (2.0 * cl - 0.3) / 3.0;
            a.part("conveyor", trim, |m| {
                m.aabox(
                    Vec3::new(x - 0.03, 0.0, z - 0.03),
                    Vec3::new(x + 0.03, cy - 0.1 - GAP, z + 0.03),
                )
            });
            let out = (z - cz).signum();
            a.bolted(
                "conveyor",
                Vec3::new(x, cy - 0.05, z + 0.02 * out),
                Vec3::Z * out,
                0.008,
                0.04,
            );
        }
    }
    let rollers = (2.0 * cl / 0.09) as u32;
    for k in 0..rollers {
        let x = -cl + (k as f32 + 0.5) * 2.0 * cl / rollers as f32;
        let f = Frame::along(Vec3::new(x, cy - 0.03, cz - 0.25 + GAP), Vec3::Z);
        if !a.part("conveyor", ZINC, |m| {
            rod(m, &f, 0.03, 0.0, 0.5 - 2.0 * GAP, 12)
        }) {
            break;
        }
    }
    for k in 0..3 {
        let x = -1.5 + k as f32 * 1.1 + rng.rangef(-0.2, 0.2);
        let h = rng.rangef(0.08, 0.2);
        a.part("conveyor", CABLES[1], |m| {
            m.aabox(
                Vec3::new(x - 0.15, cy + GAP, cz - 0.15),
                Vec3::new(x + 0.15, cy + h, cz + 0.15),
            )
        });
    }
    let mr = 0.08;
    motor(
        a,
        rng,
        Vec3::new(cl - 0.3, cy - 0.1 - mr - GAP, cz - 0.27 - 0.05 - mr),
        Vec3::X,
        mr,
        0.25,
    );
}

/// A pump skid: base frame with chequer plates, two or three pump sets
/// (casing, nozzles with bolted flanges, motor), suction and discharge
/// headers of flanged pipe spools, valves with hand wheels, pipe supports.
fn pump_skid(a: &mut Asm, rng: &mut Rng, s: f32) {
    let pumps = 2 + rng.below(2);
    let len = (1.5 * pumps as f32 * s + 0.6).min(2.0 * HALF - 0.2);
    let x0 = -0.5 * len;
    let (zw, base_h) = (1.1, 0.18);
    for z in [-zw, zw] {
        ibeam(
            a,
            "skid",
            Vec3::new(x0, 0.0, z),
            Vec3::new(-x0, 0.0, z),
            base_h,
            0.1,
        );
    }
    let trim = a.trim;
    let cross = pumps as u32 + 2;
    for k in 0..cross {
        let x = x0 + 0.05 + k as f32 * (len - 0.1) / (cross - 1) as f32;
        a.part("skid", trim, |m| {
            m.aabox(
                Vec3::new(x - 0.04, 0.02, -zw + 0.05),
                Vec3::new(x + 0.04, base_h - 0.02, zw - 0.05),
            )
        });
    }
    let deck = base_h + GAP;
    let plates = pumps as u32;
    for k in 0..plates {
        let (p0, p1) = (
            x0 + k as f32 * len / plates as f32 + GAP,
            x0 + (k + 1) as f32 * len / plates as f32 - GAP,
        );
        a.part("skid", STEEL, |m| {
            m.aabox(
                Vec3::new(p0, deck, -zw - 0.05),
                Vec3::new(p1, deck + 0.008, zw + 0.05),
            )
        });
        for z in [-zw, zw] {
            a.rivet_row(
                "skid",
                Vec3::new(p0 + 0.05, deck + 0.008, z),
                Vec3::new(p1 - 0.05, deck + 0.008, z),
                Vec3::Y,
                0.008,
                ((p1 - p0) / 0.12) as u32,
            );
        }
    }
    let deck = deck + 0.008;
    let paint = a.paint;
    let head_y = 1.7 * s.min(1.05);
    let suction_z = -0.85;
    for k in 0..pumps {
        let x = x0 + (k as f32 + 0.5) * len / pumps as f32;
        // Pump casing: a volute-like body of revolution across the skid.
        let r = 0.22 * s;
        let cy = deck + 0.1 + r;
        let cz = -0.35;
        let cf = Frame::along(Vec3::new(x, cy, cz), Vec3::Z);
        a.part("pumps", paint, |m| {
            m.loft(
                &cf,
                &[
                    Ring::apex(-0.06),
                    Ring::new(-0.06, circle(0.5 * r, 20)),
                    Ring::new(-0.03, circle(0.95 * r, 20)),
                    Ring::new(0.05, circle(r, 20)),
                    Ring::new(0.13, circle(0.9 * r, 20)),
                    Ring::new(0.16, circle(0.45 * r, 20)),
                    Ring::apex(0.16),
                ],
                false,
            )
        });
        // Pedestal under the casing.
        a.part("pumps", paint, |m| {
            m.aabox(
                Vec3::new(x - 0.12, deck + GAP, cz - 0.02),
                Vec3::new(x + 0.12, cy - 0.6 * r, cz + 0.14),
            )
        });
        // Suction nozzle towards -z, discharge nozzle upward; flanges.
        let nr = 0.07 * s;
        let sf = Frame::along(Vec3::new(x, cy, cz - 0.06 - GAP), -Vec3::Z);
        a.part("pumps", paint, |m| {
            pipe(m, &sf, nr, nr - 0.008, 0.0, 0.12, 16)
        });
        flange_pair(a, &sf, nr, 0.12 + GAP);
        let df = Frame::along(Vec3::new(x, cy + r + GAP, cz + 0.05), Vec3::Y);
        a.part("pumps", paint, |m| {
            pipe(m, &df, 0.8 * nr, 0.8 * nr - 0.008, 0.0, 0.1, 16)
        });
        flange_pair(a, &df, 0.8 * nr, 0.1 + GAP);
        // Bearing frame, coupling guard and motor behind.
        let bf = Frame::along(Vec3::new(x, cy, cz + 0.16 + GAP), Vec3::Z);
        a.part("pumps", paint, |m| rod(m, &bf, 0.09 * s, 0.0, 0.22, 16));
        let guard = Frame::new(Vec3::new(x, deck + GAP, cz + 0.5), Vec3::Z, Vec3::X);
        a.part("pumps", SAFETY_YELLOW, |m| {
            cover(m, &guard, 0.1, 0.12, cy + 0.1 - deck, 0.02)
        });
        let mr = 0.17 * s;
        // The motor's feet stand on a base plate raising its shaft to the
        // pump's.
        let feet = cy - 1.25 * mr;
        a.part("pumps", trim, |m| {
            m.aabox(
                Vec3::new(x - 1.0 * mr, deck + GAP, cz + 0.62),
                Vec3::new(x + 1.0 * mr, feet, cz + 0.62 + 0.5 * s),
            )
        });
        motor(a, rng, Vec3::new(x, cy, cz + 0.62), -Vec3::Z, mr, 0.5 * s);
        // Suction branch: a spool from the header to the nozzle's flange.
        let p = Vec3::new(x, cy, cz - 0.06 - 0.12 - 0.045);
        let e = Vec3::new(x, cy, suction_z + 0.08);
        a.run(
            "piping",
            STEEL,
            [p, p - Vec3::Z * 0.05, e + Vec3::Z * 0.05, e],
            nr,
            0.1,
            12,
            true,
        );
        // Discharge: up to the header, a valve with a hand wheel on the way.
        let d0 = Vec3::new(x, cy + r + 0.15, cz + 0.05);
        let vy = 0.5 * (d0.y + head_y);
        let v0 = Vec3::new(x, vy - 0.08, cz + 0.05);
        a.run(
            "piping",
            STEEL,
            [d0, d0 + Vec3::Y * 0.05, v0 - Vec3::Y * 0.05, v0],
            0.8 * nr,
            0.1,
            12,
            true,
        );
        valve(a, Vec3::new(x, vy, cz + 0.05), Vec3::Y, 0.8 * nr);
        let v1 = Vec3::new(x, vy + 0.08, cz + 0.05);
        let hd = Vec3::new(x, head_y - 0.08 * s, 0.3);
        a.run(
            "piping",
            STEEL,
            [v1, v1 + Vec3::Y * 0.2, hd - Vec3::new(0.0, 0.2, 0.0), hd],
            0.8 * nr,
            0.1,
            12,
            true,
        );
        // Gauge on the discharge line.
        let g = Vec3::new(x + 0.8 * nr + GAP, 0.5 * (d0.y + vy), cz + 0.05);
        a.part("piping", BRASS, |m| {
            rod(m, &Frame::along(g, Vec3::X), 0.008, 0.0, 0.06, 8)
        });
        let gf = Frame::along(g + Vec3::X * (0.06 + GAP), Vec3::X);
        a.part("piping", BLACK, |m| rod(m, &gf, 0.05, 0.0, 0.03, 20));
        a.part("piping", STEEL, |m| {
            pipe(m, &gf, 0.052, 0.045, 0.03 + GAP, 0.04, 20)
        });
    }
    // Headers: spools along the skid joined by flange pairs, on supports.
    for (y, z, r) in [
        (deck + 0.1 + 0.22 * s, suction_z, 0.1 * s),
        (head_y, 0.3, 0.08 * s),
    ] {
        let spools = 2;
        let (h0, h1) = (x0 + 0.1, -x0 - 0.1);
        for k in 0..spools {
            let (a0, a1) = (
                h0 + k as f32 * (h1 - h0) / spools as f32,
                h0 + (k + 1) as f32 * (h1 - h0) / spools as f32,
            );
            let f = Frame::along(Vec3::new(a0, y, z), Vec3::X);
            a.part("piping", STEEL, |m| {
                pipe(m, &f, r, r - 0.008, 0.02, a1 - a0 - 0.02, 20)
            });
            if k + 1 < spools {
                flange_pair(
                    a,
                    &Frame::along(Vec3::new(a1 - 0.02, y, z), Vec3::X),
                    r,
                    GAP,
                );
            }
        }
        for k in 0..=spools {
            let x = h0 + (k as f32 + 0.25) * (h1 - h0) / (spools + 1) as f32;
            a.part("supports", trim, |m| {
                m.aabox(
                    Vec3::new(x - 0.03, deck + GAP, z - 0.03),
                    Vec3::new(x + 0.03, y - r - 0.005, z + 0.03),
                )
            });
            a.part("supports", ZINC, |m| {
                m.torus(Vec3::new(x, y, z), Vec3::X, r + 0.006, 0.005, 16, 4)
            });
        }
    }
    // The beams' outer webs.
    let web = 0.04 * base_h + 0.002 + GAP;
    for side in [-1.0f32, 1.0] {
        a.faces.push(Face::new(
            Vec3::new(0.0, 0.5 * base_h, side * (zw + web)),
            Vec3::Z * side,
            Vec3::X * side,
            Vec2::new(0.5 * len - 0.2, 0.25 * base_h),
        ));
    }
    // Local control station with cables to the motors.
    let jb = Vec3::new(-x0 - 0.15, deck + GAP, zw - 0.15);
    a.part("controls", trim, |m| {
        m.aabox(
            jb - Vec3::new(0.03, 0.0, 0.03),
            jb + Vec3::new(0.03, 1.2, 0.03),
        )
    });
    let bf = Frame::new(jb + Vec3::new(0.0, 1.0, 0.03 + GAP), Vec3::X, Vec3::Y);
    a.part("controls", LIGHT_GREY, |m| {
        cover(m, &bf, 0.15, 0.2, 0.12, 0.0)
    });
    let face = jb + Vec3::new(0.0, 1.0, 0.15 + 2.0 * GAP);
    for (k, c) in [BLACK, CABLES[1], SIGNAL_RED].into_iter().enumerate() {
        let at = face + Vec3::new(0.0, 0.1 - k as f32 * 0.08, 0.0);
        a.part("controls", c, |m| {
            rod(m, &Frame::along(at, Vec3::Z), 0.015, 0.0, 0.02, 12)
        });
    }
    a.faces.push(Face::new(
        face + Vec3::Y * 0.05,
        Vec3::Z,
        Vec3::X,
        Vec2::new(0.12, 0.15),
    ));
    for k in 0..pumps {
        let x = x0 + (k as f32 + 0.5) * len / pumps as f32;
        let e = Vec3::new(x + 0.2, deck + 0.5, 0.45);
        let p = jb + Vec3::new(0.0, 0.9, 0.04);
        a.run(
            "controls",
            CABLES[0],
            [p, p - Vec3::Y * 0.8, e + Vec3::new(0.3, -0.4, 0.2), e],
            0.01,
            0.05,
            6,
            false,
        );
    }
}

/// Two flanges bolted face to face at height `z` of `f` (pipe radius `r`):
/// flanges, bolts with washers, nuts.
fn flange_pair(a: &mut Asm, f: &Frame, r: f32, z: f32) {
    let (fr, t) = (1.9 * r + 0.02, 0.02);
    a.part("flanges", STEEL, |m| {
        pipe(m, f, fr, r - 0.009, z, z + t, 20)
    });
    a.part("flanges", STEEL, |m| {
        pipe(m, f, fr, r - 0.009, z + t + GAP, z + 2.0 * t + GAP, 20)
    });
    let bolts = if r > 0.08 { 8 } else { 4 };
    let d = (0.12 * r).clamp(0.008, 0.016);
    for k in 0..bolts {
        let ang = TAU * (k as f32 + 0.5) / bolts as f32;
        let at = f.at(
            Vec2::new(ang.cos(), ang.sin()) * (fr - 1.4 * d),
            z + 2.0 * t + GAP,
        );
        a.bolt_nut("flanges", at, f.w, d, 2.0 * t + GAP);
    }
}

/// A gate valve in a vertical line: body, bonnet, stem and hand wheel.
fn valve(a: &mut Asm, c: Vec3, up: Vec3, r: f32) {
    let bf = Frame::along(c - up * 0.08, up);
    a.part("valves", BLACK, |m| {
        m.loft(
            &bf,
            &[
                Ring::apex(0.0),
                Ring::new(0.0, circle(r, 16)),
                Ring::new(0.04, circle(1.4 * r, 16)),
                Ring::new(0.12, circle(1.4 * r, 16)),
                Ring::new(0.16, circle(r, 16)),
                Ring::apex(0.16),
            ],
            false,
        )
    });
    let side = up.cross(Vec3::X).normalize_or(Vec3::Z);
    let bon = Frame::along(c + side * (1.4 * r + GAP), side);
    a.part("valves", BLACK, |m| rod(m, &bon, 0.5 * r, 0.0, 0.12, 12));
    a.part("valves", STEEL, |m| rod(m, &bon, 0.01, 0.12 + GAP, 0.24, 8));
    let hw = bon.at(Vec2::ZERO, 0.22);
    a.part("valves", SIGNAL_RED, |m| {
        m.torus(hw, side, 1.2 * r, 0.008, 20, 6)
    });
    for k in 0..3 {
        let ang = TAU * k as f32 / 3.0;
        let dir = bon.u * ang.cos() + bon.v * ang.sin();
        let c = hw + dir * (0.6 * r);
        a.part("valves", SIGNAL_RED, |m| {
            m.oriented_box(
                c,
                [dir, side, dir.cross(side)],
                Vec3::new(0.5 * r - 0.012, 0.004, 0.004),
            )
        });
    }
}

/// A row of switchgear cabinets on plinths: sheet-metal bodies and doors
/// (some open), mounting plates with DIN rails full of terminal blocks,
/// breakers and contactors, circuit boards, wire ducts and wires, and a
/// cable tray over the top.
fn switchgear(a: &mut Asm, rng: &mut Rng, s: f32) {
    let count = 2 + rng.below(4);
    let w = 0.6 + 0.2 * rng.below(2) as f32;
    let (depth, h) = (0.6, 2.0 * s.min(1.1));
    let x0 = -0.5 * count as f32 * w;
    let body_col = a.paint;
    let mut plates = Vec::new();
    for k in 0..count {
        let cx = x0 + (k as f32 + 0.5) * w;
        let z0 = -0.5 * depth;
        a.part("plinth", BLACK, |m| {
            m.aabox(
                Vec3::new(cx - 0.5 * w + 0.005, 0.0, z0),
                Vec3::new(cx + 0.5 * w - 0.005, 0.1, -z0),
            )
        });
        let y0 = 0.1 + GAP;
        // Body: a cover open at the front (+z).
        let bf = Frame::new(Vec3::new(cx, y0 + 0.5 * h, -z0), Vec3::Y, Vec3::X);
        a.part("cabinets", body_col, |m| {
            cover(m, &bf, 0.5 * h, 0.5 * w - 0.003, depth, 0.0)
        });
        // Door, open on some cabinets, hinged on its left edge.
        // Below a right angle an open door stays clear of its neighbour's.
        let open = if rng.chance(0.5) {
            rng.rangef(1.0, 1.5)
        } else {
            0.0
        };
        let hinge = Vec3::new(cx - 0.5 * w + 0.01, y0, -z0 + 0.012);
        let q = Quat::from_rotation_y(-open);
        let (du, dv) = (q * Vec3::X, q * Vec3::Z);
        let dc = hinge + du * (0.5 * w - 0.01) + Vec3::Y * (0.5 * h) + dv * 0.01;
        let df = Frame::new(dc - dv * 0.012, du, Vec3::Y);
        a.part("doors", body_col, |m| {
            cover(m, &df, 0.5 * w - 0.015, 0.5 * h - 0.01, 0.025, 0.0)
        });
        let front = dc + dv * (0.013 + GAP);
        let handle = front + du * (0.5 * w - 0.08) + dv * 0.012;
        a.part("doors", BLACK, |m| {
            rod(
                m,
                &Frame::along(handle - Vec3::Y * 0.08, Vec3::Y),
                0.01,
                0.0,
                0.16,
                8,
            )
        });
        a.part("doors", BLACK, |m| {
            rod(
                m,
                &Frame::along(handle + Vec3::Y * 0.15, dv),
                0.015,
                0.0,
                0.015,
                12,
            )
        });
        for y in [0.2f32, 0.5 * h, h - 0.2] {
            let p = hinge + Vec3::Y * y - Vec3::X * 0.006;
            a.part("doors", BLACK, |m| {
                rod(
                    m,
                    &Frame::along(p - Vec3::Y * 0.04, Vec3::Y),
                    0.008,
                    0.0,
                    0.08,
                    8,
                )
            });
        }
        // Louvres at the bottom and top of the door.
        for y in [0.15f32, h - 0.3] {
            for r in 0..6 {
                let p = front + du * 0.0 + Vec3::Y * (y - 0.5 * h + r as f32 * 0.025);
                a.part("doors", body_col, |m| {
                    m.oriented_box(p, [du, Vec3::Y, dv], Vec3::new(0.5 * w - 0.1, 0.004, 0.004))
                });
            }
        }
        a.faces.push(Face::new(
            front + Vec3::Y * 0.3,
            dv,
            du,
            Vec2::new(0.5 * w - 0.1, 0.25),
        ));
        // Mounting plate inside.
        let pz = z0 + 0.05;
        let pc = Vec3::new(cx, y0 + 0.5 * h, pz);
        a.part("panel", ZINC, |m| {
            m.aabox(
                pc - Vec3::new(0.5 * w - 0.05, 0.5 * h - 0.08, 0.0),
                pc + Vec3::new(0.5 * w - 0.05, 0.5 * h - 0.08, 0.003),
            )
        });
        plates.push((pc + Vec3::Z * (0.003 + GAP), 0.5 * w - 0.05, 0.5 * h - 0.08));
    }
    if count >= 2 {
        let (side_x, n) = (x0 - GAP, -Vec3::X);
        a.faces.push(Face::new(
            Vec3::new(side_x, 0.1 + 0.5 * h, 0.0),
            n,
            Vec3::Z,
            Vec2::new(0.25, 0.5 * h - 0.1),
        ));
        a.faces.push(Face::new(
            Vec3::new(-side_x, 0.1 + 0.5 * h, 0.0),
            -n,
            -Vec3::Z,
            Vec2::new(0.25, 0.5 * h - 0.1),
        ));
    }
    // Cable tray over the row.
    let ty = 0.1 + 2.0 * GAP + h + 0.25;
    let tf = Frame::new(Vec3::new(0.0, ty, -0.1), Vec3::X, Vec3::Z);
    let tl = -x0 + 0.1;
    a.part("tray", ZINC, |m| cover(m, &tf, tl, 0.15, 0.08, 0.0));
    for k in 0..count {
        let x = x0 + (k as f32 + 0.5) * w;
        a.part("tray", ZINC, |m| {
            m.aabox(
                Vec3::new(x - 0.015, 0.1 + 2.0 * GAP + h, -0.12),
                Vec3::new(x + 0.015, ty - 0.08 - GAP, -0.08),
            )
        });
    }
    // Electrics on each plate: rails with terminals, breakers, contactors,
    // a PLC with boards, wire ducts, wires.
    // Each plate gets an even share of most of what is left, so a small
    // budget fills every cabinet a little rather than the first one fully.
    let share = a.left() * 7 / 10 / plates.len() as u64;
    let budget = a.budget;
    for (k, &(pc, hx, hy)) in plates.iter().enumerate() {
        a.budget = a.tris + share;
        let n = Vec3::Z;
        // Copper bus bars across the top, bolted to their supports.
        for i in 0..3 {
            let bc = Vec3::new(pc.x, pc.y + hy - 0.03 - 0.03 * i as f32, pc.z + 0.03);
            a.part("busbars", COPPER, |m| {
                m.aabox(
                    bc - Vec3::new(hx - 0.07, 0.01, 0.003),
                    bc + Vec3::new(hx - 0.07, 0.01, 0.003),
                )
            });
            let at = bc + n * (0.003 + GAP);
            a.bolt_row(
                "busbars",
                at - Vec3::X * (hx - 0.1),
                at + Vec3::X * (hx - 0.1),
                n,
                0.006,
                3,
            );
            for sx in [-1.0f32, 1.0] {
                let sc = Vec3::new(pc.x + sx * (hx - 0.1), bc.y, pc.z + 0.0135 - 0.5 * GAP);
                a.part("busbars", BLACK, |m| {
                    m.aabox(
                        sc - Vec3::new(0.01, 0.012, 0.0135 - GAP),
                        sc + Vec3::new(0.01, 0.012, 0.0135 - GAP),
                    )
                });
            }
        }
        // Vertical duct on each side, horizontal ducts between the rails.
        let rails = 4;
        for side in [-1.0f32, 1.0] {
            let dc = pc + Vec3::X * side * (hx - 0.03);
            let f = Frame::new(dc + n * 0.06, Vec3::Y, Vec3::X);
            a.part("ducts", LIGHT_GREY, |m| {
                cover(m, &f, hy - 0.02, 0.025, 0.06, 0.0)
            });
        }
        // A PLC board low on the plate: board, chips, capacitors, connectors.
        let bc = Vec3::new(pc.x, pc.y - hy + 0.12, pc.z + 0.02);
        a.part("boards", PCB, |m| {
            m.aabox(
                bc - Vec3::new(0.12, 0.07, 0.0008),
                bc + Vec3::new(0.12, 0.07, 0.0008),
            )
        });
        for i in 0..8 {
            for j in 0..3 {
                let c = bc
                    + Vec3::new(
                        -0.1 + i as f32 * 0.028,
                        -0.045 + j as f32 * 0.045,
                        0.0008 + GAP,
                    );
                if (i + j) % 3 == 0 {
                    a.part("boards", BLACK, |m| {
                        m.aabox(
                            c - Vec3::new(0.008, 0.008, 0.0),
                            c + Vec3::new(0.008, 0.008, 0.002),
                        )
                    });
                } else {
                    a.part("boards", CABLES[2], |m| {
                        rod(m, &Frame::along(c, Vec3::Z), 0.004, 0.0, 0.01, 8)
                    });
                }
            }
        }
        for (x, y) in [
            (-0.11f32, -0.06f32),
            (0.11, -0.06),
            (-0.11, 0.06),
            (0.11, 0.06),
        ] {
            let at = bc + Vec3::new(x, y, 0.0008 + GAP);
            a.part("boards", ZINC, |m| screw(m, at, n, 0.003, 0.005));
        }
        let plate_cap = a.budget;
        for r in 0..rails {
            // Each rail an even share of the plate's, filled from the left.
            a.budget = a.tris + (plate_cap - a.tris) / (rails - r) as u64;
            let y = pc.y + hy - 0.25 - r as f32 * (2.0 * hy - 0.35) / rails as f32;
            // DIN rail.
            let rc = Vec3::new(pc.x, y, pc.z + 0.004);
            a.part("rails", ZINC, |m| {
                m.aabox(
                    rc - Vec3::new(hx - 0.08, 0.0175, 0.0),
                    rc + Vec3::new(hx - 0.08, 0.0175, 0.0075),
                )
            });
            // The wire duct above the rail.
            let dy = y + 0.1;
            let f = Frame::new(Vec3::new(pc.x, dy, pc.z + 0.05), Vec3::Y, Vec3::X);
            a.part("ducts", LIGHT_GREY, |m| {
                cover(m, &f, 0.02, hx - 0.065, 0.05, 0.0)
            });
            let mut x = pc.x - hx + 0.1;
            let end = pc.x + hx - 0.1;
            let kind = (k + r) % 3;
            while x < end {
                let (wd, col) = match kind {
                    0 => (
                        0.006,
                        if rng.chance(0.2) {
                            CABLES[2]
                        } else {
                            CABLES[0]
                        },
                    ),
                    1 => (0.018, LIGHT_GREY),
                    _ => (0.045, LIGHT_GREY),
                };
                if x + wd > end {
                    break;
                }
                let c = Vec3::new(x + 0.5 * wd, y, pc.z + 0.0075 + GAP + 0.035);
                // A chamfered body clipped on the rail.
                let f = Frame::new(c, Vec3::Y, Vec3::Z);
                let body = rounded_rect(0.04, 0.035, 0.006, 2);
                let hw = 0.5 * wd - 0.0003;
                if !a.part("devices", col, |m| prism(m, &f, &body, -hw, hw)) {
                    break;
                }
                if kind == 1 {
                    let t = c + Vec3::new(0.0, 0.005, 0.035 + GAP + 0.004);
                    a.part("devices", BLACK, |m| {
                        m.aabox(
                            t - Vec3::new(0.003, 0.008, 0.004),
                            t + Vec3::new(0.003, 0.008, 0.004),
                        )
                    });
                }
                if kind == 2 {
                    let t = c + Vec3::new(0.0, 0.0, 0.035 + GAP + 0.006);
                    a.part("devices", BLACK, |m| {
                        m.aabox(
                            t - Vec3::new(0.015, 0.02, 0.006),
                            t + Vec3::new(0.015, 0.02, 0.006),
                        )
                    });
                }
                // A wire from the device's top into the duct above.
                let p = c + Vec3::new(0.0, 0.04 + GAP, 0.0);
                let e = Vec3::new(p.x + 0.01, y + 0.085, pc.z + 0.03);
                a.run(
                    "wires",
                    CABLES[(k + r) % 3],
                    [p, p + Vec3::Y * 0.02, e - Vec3::Y * 0.02, e],
                    0.0015,
                    0.035,
                    6,
                    false,
                );
                x += wd + 0.001;
            }
        }
    }
    a.budget = budget;
}

/// A face near `f` (within a metre, looking the same way), or `f` itself:
/// cables and hoses run between nearby faces, not through the air across
/// the machine.
fn near_face(a: &Asm, rng: &mut Rng, f: &Face) -> Face {
    for _ in 0..4 {
        let g = a.faces[rng.below(a.faces.len())];
        if (g.c - f.c).length() < 1.0 && g.n.dot(f.n) > 0.5 {
            return g;
        }
    }
    *f
}

/// Fills what is left of the budget with small detail on the design's
/// faces (name plates, rivet rows, brackets, junction boxes, sensors, hose
/// runs, bolt rows), then tops it up with the smallest parts.
fn decorate(a: &mut Asm, rng: &mut Rng) {
    if a.faces.is_empty() {
        return;
    }
    let mut misses = 0;
    while a.left() >= 64 && misses < 40 {
        let f = a.faces[rng.below(a.faces.len())];
        let before = a.parts;
        match rng.below(8) {
            0 => {
                // Name plate with four rivets.
                let c = f.random(rng, 0.08);
                let (hx, hy) = (rng.rangef(0.04, 0.08), rng.rangef(0.025, 0.05));
                let pc = c + f.n * (0.001 + GAP);
                if a.part("detail", ZINC, |m| {
                    m.oriented_box(pc, f.axes(), Vec3::new(hx, hy, 0.001))
                }) {
                    for (sx, sy) in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)] {
                        let at = pc
                            + f.t * (sx * (hx - 0.008))
                            + f.b * (sy * (hy - 0.008))
                            + f.n * (0.001 + GAP);
                        a.part("detail", STEEL, |m| rivet(m, at, f.n, 0.004));
                    }
                }
            }
            1 => {
                // Rivet row along the face.
                let y = rng.rangef(-f.half.y, f.half.y);
                let (x0, x1) = (
                    -f.half.x * rng.rangef(0.3, 0.95),
                    f.half.x * rng.rangef(0.3, 0.95),
                );
                let count = (((x1 - x0) / rng.rangef(0.025, 0.05)) as u32).clamp(3, 24);
                a.rivet_row("detail", f.at(x0, y), f.at(x1, y), f.n, 0.005, count);
            }
            2 => {
                // Angle bracket with two screws.
                let c = f.random(rng, 0.06) + f.n * GAP;
                let (w, l) = (rng.rangef(0.02, 0.04), rng.rangef(0.04, 0.08));
                let trim = a.trim;
                if a.part("detail", trim, |m| {
                    m.oriented_box(c + f.n * 0.002, f.axes(), Vec3::new(w, l, 0.002))
                }) {
                    let top = c + f.b * (l - 0.002) + f.n * (0.004 + GAP + l * 0.5);
                    a.part("detail", trim, |m| {
                        m.oriented_box(top, f.axes(), Vec3::new(w, 0.002, 0.5 * l))
                    });
                    for s in [-0.5f32, 0.5] {
                        let at = c + f.b * (s * l) + f.n * (0.004 + GAP);
                        a.part("detail", BLACK, |m| screw(m, at, f.n, 0.005, 0.008));
                    }
                }
            }
            3 | 4 => {
                // Junction box with lid screws, a gland and a cable to
                // another face.
                let c = f.random(rng, 0.1) + f.n * GAP;
                let (hx, hy, d) = (
                    rng.rangef(0.04, 0.08),
                    rng.rangef(0.04, 0.07),
                    rng.rangef(0.04, 0.07),
                );
                let bf = Frame::new(c, f.t, f.b);
                if a.part("detail", LIGHT_GREY, |m| cover(m, &bf, hx, hy, d, 0.0)) {
                    for (sx, sy) in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)] {
                        let at = c
                            + f.t * (sx * (hx - 0.008))
                            + f.b * (sy * (hy - 0.008))
                            + f.n * (d + GAP);
                        a.part("detail", BLACK, |m| screw(m, at, f.n, 0.004, 0.006));
                    }
                    let gland = c - f.b * (hy + GAP) + f.n * (0.5 * d);
                    a.part("detail", BLACK, |m| nut(m, gland, -f.b, 0.012));
                    let g = near_face(a, rng, &f);
                    let e = g.random(rng, 0.05) + g.n * 0.012;
                    let p = gland - f.b * 0.012;
                    let reach = ((e - p).length() * 0.35).clamp(0.05, 0.5);
                    a.run(
                        "detail",
                        CABLES[rng.below(3)],
                        [p, p - f.b * reach, e + g.n * reach, e],
                        0.005,
                        0.04,
                        6,
                        false,
                    );
                }
            }
            5 => {
                // Sensor: body, lock nut and cable.
                let c = f.random(rng, 0.05) + f.n * GAP;
                if a.part("detail", ZINC, |m| {
                    rod(m, &Frame::along(c, f.n), 0.006, 0.0, 0.05, 8)
                }) {
                    a.part("detail", ZINC, |m| {
                        nut(m, c + f.n * (0.01 + GAP), f.n, 0.012)
                    });
                    let p = c + f.n * (0.05 + GAP);
                    let e = f.random(rng, 0.02) + f.n * 0.01;
                    a.run(
                        "detail",
                        CABLES[rng.below(3)],
                        [p, p + f.n * 0.1, e + f.n * 0.15, e],
                        0.003,
                        0.03,
                        6,
                        false,
                    );
                }
            }
            6 => {
                // Hose between two faces, clamped at both ends.
                let g = near_face(a, rng, &f);
                let p = f.random(rng, 0.05) + f.n * 0.015;
                let e = g.random(rng, 0.05) + g.n * 0.015;
                let reach = ((e - p).length() * 0.35).clamp(0.05, 0.4);
                let r = rng.rangef(0.006, 0.012);
                if a.run(
                    "detail",
                    RUBBER,
                    [p, p + f.n * reach, e + g.n * reach, e],
                    r,
                    0.035,
                    8,
                    true,
                ) > 0
                {
                    for (q, n) in [(p, f.n), (e, g.n)] {
                        a.part("detail", ZINC, |m| {
                            m.torus(q + n * 0.01, n, r + 0.002, 0.0015, 8, 4)
                        });
                    }
                }
            }
            _ => {
                // Row of bolts.
                let y = rng.rangef(-f.half.y, f.half.y);
                let (x0, x1) = (
                    -f.half.x * rng.rangef(0.3, 0.9),
                    f.half.x * rng.rangef(0.3, 0.9),
                );
                let count = (((x1 - x0) / 0.06) as u32).clamp(2, 12);
                a.bolt_row("detail", f.at(x0, y), f.at(x1, y), f.n, 0.008, count);
            }
        }
        if a.parts == before {
            misses += 1;
        } else {
            misses = 0;
        }
    }
    // Top up: rivets, then 12-triangle shims.
    let mut misses = 0;
    while a.left() >= 12 && misses < 20 {
        let f = a.faces[rng.below(a.faces.len())];
        let at = f.random(rng, 0.01) + f.n * GAP;
        let ok = if a.left() >= 36 {
            a.part("detail", STEEL, |m| rivet(m, at, f.n, 0.004))
        } else {
            a.part("detail", ZINC, |m| {
                m.oriented_box(at + f.n * 0.0005, f.axes(), Vec3::new(0.006, 0.006, 0.0005))
            })
        };
        misses = if ok { 0 } else { misses + 1 };
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
