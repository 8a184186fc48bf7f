//! Subassemblies several designs share, each many parts added to an
//! assembly: the welded I-beam of base frames and the electric motor (or
//! generator) with its fins, fan cover, feet and terminal box.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use super::asm::{Asm, Face};
use super::parts::{bolt, cover, nut, pipe, rod, round_cover, screw, washer};
use super::{BLACK, GAP, SHEET, STEEL, ZINC};
use crate::rng::Rng;
use crate::shapes::Frame;

/// An I-beam from `a` to `b` (horizontal) as three welded plates: flanges
/// and web, three parts. `h` high, `w` wide, standing on `a.y`.
pub(super) fn ibeam(asm: &mut Asm, sub: &'static str, a: Vec3, b: Vec3, h: f32, w: f32) {
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
pub(super) fn motor(asm: &mut Asm, rng: &mut Rng, c: Vec3, axis: Vec3, r: f32, len: f32) {
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
