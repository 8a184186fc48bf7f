//! The diesel genset design.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use super::asm::{Asm, Face};
use super::components::{ibeam, motor};
use super::parts::{bolt, cover, gear, nut, pipe, rod, round_cover, washer};
use super::{BLACK, BRASS, CABLES, GAP, RUBBER, SHEET, STEEL, ZINC};
use crate::rng::Rng;
use crate::shapes::{circle, Frame, Ring};

/// A diesel genset: skid, engine block, oil pan, head and valve cover with
/// their bolt rows, cylinders, pistons and crankshaft inside, manifolds,
/// turbocharger, radiator with fins, and the generator behind it.
pub(super) fn engine(a: &mut Asm, rng: &mut Rng, s: f32) {
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
