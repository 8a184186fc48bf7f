//! The pump skid design, with the bolted flange pairs and gate valves of
//! its pipework.

use std::f32::consts::TAU;

use glam::{Vec2, Vec3};

use super::asm::{Asm, Face};
use super::components::{ibeam, motor};
use super::parts::{cover, pipe, rod};
use super::{BLACK, BRASS, CABLES, GAP, HALF, LIGHT_GREY, SAFETY_YELLOW, SIGNAL_RED, STEEL, ZINC};
use crate::rng::Rng;
use crate::shapes::{circle, Frame, Ring};

/// A pump skid: base frame with chequer plates, two or three pump sets
/// (casing, nozzles with bolted flanges, motor), suction and discharge
/// headers of flanged pipe spools, valves with hand wheels, pipe supports.
pub(super) fn pump_skid(a: &mut Asm, rng: &mut Rng, s: f32) {
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
