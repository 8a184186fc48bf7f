//! Detail that fills what is left of an assembly's budget once its design
//! is built: small parts on the design's faces, then the smallest parts to
//! top it up.

use glam::Vec3;

use super::asm::{Asm, Face};
use super::parts::{cover, nut, rivet, rod, screw};
use super::{BLACK, CABLES, GAP, LIGHT_GREY, RUBBER, STEEL, ZINC};
use crate::rng::Rng;
use crate::shapes::Frame;

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
pub(super) fn decorate(a: &mut Asm, rng: &mut Rng) {
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
