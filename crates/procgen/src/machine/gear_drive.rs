//! The gear drive design.

use glam::{Vec2, Vec3};

use super::asm::{Asm, Face};
use super::components::{ibeam, motor};
use super::parts::{cover, gear, pipe, rod, screw};
use super::{BLACK, BRASS, GAP, RUBBER, SHEET, STEEL};
use crate::rng::Rng;
use crate::shapes::Frame;

/// A gear drive on a base frame: motor, coupling under a guard, and a
/// split gearbox housing with gears, shafts and bearings inside and a bolt
/// row along its split.
pub(super) fn gear_drive(a: &mut Asm, rng: &mut Rng, s: f32) {
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
