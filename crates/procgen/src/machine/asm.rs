//! An assembly under construction: its parts merged into one mesh per
//! (subassembly, material) within a triangle budget and the slot's
//! footprint, the flat faces detail can be mounted on, and the multi-part
//! fastenings and runs (bolted joints, bolt and rivet rows, screw circles,
//! hoses and cables, bearings) every design uses.

use std::f32::consts::TAU;

use glam::{Vec2, Vec3};

use super::parts::{bolt, nut, pipe, rivet, rod, screw, washer};
use super::{BLACK, GAP, HALF, STEEL, ZINC};
use crate::rng::Rng;
use crate::shapes::{Frame, Mesh};

/// A flat exterior face that detail (name plates, junction boxes, cables)
/// can be mounted on: centre `c`, outward normal `n`, in-plane axes `t` and
/// `b = n x t`, half extents along them.
#[derive(Clone, Copy, Debug)]
pub(super) struct Face {
    pub(super) c: Vec3,
    pub(super) n: Vec3,
    pub(super) t: Vec3,
    pub(super) b: Vec3,
    pub(super) half: Vec2,
}

impl Face {
    pub(super) fn new(c: Vec3, n: Vec3, t: Vec3, half: Vec2) -> Face {
        Face {
            c,
            n,
            t,
            b: n.cross(t),
            half,
        }
    }

    pub(super) fn at(&self, x: f32, y: f32) -> Vec3 {
        self.c + self.t * x + self.b * y
    }

    /// A random point at least `margin` inside the face's edges (the centre
    /// when the face is smaller than that).
    pub(super) fn random(&self, rng: &mut Rng, margin: f32) -> Vec3 {
        let mx = (self.half.x - margin).max(0.0);
        let my = (self.half.y - margin).max(0.0);
        self.at(rng.rangef(-mx, mx + 1e-6), rng.rangef(-my, my + 1e-6))
    }

    /// Box axes for something lying on the face: [t, b, n], right-handed.
    pub(super) fn axes(&self) -> [Vec3; 3] {
        [self.t, self.b, self.n]
    }
}

/// An assembly under construction: its parts merged into one mesh per
/// (subassembly, material), and the budget they must stay within.
pub(super) struct Asm {
    pub(super) budget: u64,
    pub(super) tris: u64,
    pub(super) parts: usize,
    pub(super) paint: usize,
    pub(super) trim: usize,
    pub(super) meshes: Vec<(&'static str, usize, Mesh)>,
    /// Each part's mesh and triangle count, in the order added.
    pub(super) log: Vec<(usize, u32)>,
    pub(super) faces: Vec<Face>,
    pub(super) scratch: Mesh,
}

impl Asm {
    pub(super) fn left(&self) -> u64 {
        self.budget - self.tris
    }

    /// Adds the part `build` makes, unless it would pass the budget or leave
    /// the slot's footprint; says whether it was added.
    pub(super) fn part(
        &mut self,
        sub: &'static str,
        material: usize,
        build: impl FnOnce(&mut Mesh),
    ) -> bool {
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
    pub(super) fn bolted(&mut self, sub: &'static str, at: Vec3, n: Vec3, d: f32, grip: f32) {
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
    pub(super) fn bolt_nut(&mut self, sub: &'static str, at: Vec3, n: Vec3, d: f32, grip: f32) {
        if self.part(sub, BLACK, |m| bolt(m, at + n * GAP, n, d, grip + 1.3 * d)) {
            self.part(sub, BLACK, |m| nut(m, at - n * (grip + GAP), -n, d));
        }
    }

    /// `count` bolts (heads only seen: tapped holes) from `p0` to `p1`.
    pub(super) fn bolt_row(
        &mut self,
        sub: &'static str,
        p0: Vec3,
        p1: Vec3,
        n: Vec3,
        d: f32,
        count: u32,
    ) {
        for k in 0..count {
            let t = (k as f32 + 0.5) / count as f32;
            let at = p0 + (p1 - p0) * t;
            if !self.part(sub, BLACK, |m| bolt(m, at + n * GAP, n, d, 2.0 * d)) {
                return;
            }
        }
    }

    pub(super) fn rivet_row(
        &mut self,
        sub: &'static str,
        p0: Vec3,
        p1: Vec3,
        n: Vec3,
        d: f32,
        count: u32,
    ) {
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
    pub(super) fn screw_circle(
        &mut self,
        sub: &'static str,
        f: &Frame,
        r: f32,
        z: f32,
        d: f32,
        count: u32,
    ) {
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
    pub(super) fn run(
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
    pub(super) fn bearing(&mut self, sub: &'static str, f: &Frame, r_in: f32, r_out: f32, z: f32) {
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
