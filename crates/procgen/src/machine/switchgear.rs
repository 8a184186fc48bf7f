//! The switchgear row design.

use glam::{Quat, Vec2, Vec3};

use super::asm::{Asm, Face};
use super::parts::{cover, prism, rod, screw};
use super::{BLACK, CABLES, COPPER, GAP, LIGHT_GREY, PCB, ZINC};
use crate::rng::Rng;
use crate::shapes::{rounded_rect, Frame};

/// A row of switchgear cabinets on plinths: sheet-metal bodies and doors
/// (some open), mounting plates with DIN rails full of terminal blocks,
/// breakers and contactors, circuit boards, wire ducts and wires, and a
/// cable tray over the top.
pub(super) fn switchgear(a: &mut Asm, rng: &mut Rng, s: f32) {
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
