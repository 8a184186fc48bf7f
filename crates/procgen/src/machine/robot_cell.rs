//! The robot cell design.

use std::f32::consts::{PI, TAU};

use glam::{Quat, Vec2, Vec3};

use super::asm::{Asm, Face};
use super::components::motor;
use super::parts::{bolt, cover, nut, pipe, rod, round_cover, screw, washer};
use super::{BLACK, BRASS, CABLES, GAP, LIGHT_GREY, RUBBER, SHEET, STEEL, ZINC};
use crate::rng::Rng;
use crate::shapes::Frame;

/// A robot cell: a six-axis arm on a pedestal, posed by seed, its cable
/// harness, a controller cabinet and a roller conveyor.
pub(super) fn robot_cell(a: &mut Asm, rng: &mut Rng, s: f32) {
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
