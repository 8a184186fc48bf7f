//! Part primitives: each builds one connected piece into a mesh (bolts,
//! nuts, washers, rivets, screws, rods, prisms, pipes, gears, sheet-metal
//! covers), with its triangle count fixed by its arguments so the designs
//! can budget for it.

use glam::{Vec2, Vec3};

use super::SHEET;
use crate::shapes::{at_radius, circle, gear_outline, hexagon, rounded_rect, Frame, Mesh, Ring};

// Parts. Each is one connected piece; `n` is a unit normal.

/// Hex bolt of nominal diameter `d`: head on the surface at `at` facing
/// `n`, shank `len` into it. 48 triangles, 96 from M14 up.
pub(super) fn bolt(m: &mut Mesh, at: Vec3, n: Vec3, d: f32, len: f32) {
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
pub(super) fn nut(m: &mut Mesh, at: Vec3, n: Vec3, d: f32) {
    let hex = hexagon(1.6 * d, false);
    annulus(m, &Frame::along(at, n), &hex, 0.55 * d, 0.0, 0.8 * d);
}

/// Flat washer for a `d` bolt: 64 triangles.
pub(super) fn washer(m: &mut Mesh, at: Vec3, n: Vec3, d: f32) {
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
pub(super) fn rivet(m: &mut Mesh, at: Vec3, n: Vec3, d: f32) {
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
pub(super) fn screw(m: &mut Mesh, at: Vec3, n: Vec3, d: f32, len: f32) {
    headed_shank(m, at, n, circle(0.5 * d, 8), circle(0.8 * d, 8), len, d);
}

/// Solid cylinder of radius `r` along `f.w` from `z0` to `z1`: `4 * sides`
/// triangles.
pub(super) fn rod(m: &mut Mesh, f: &Frame, r: f32, z0: f32, z1: f32, sides: u32) {
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
pub(super) fn prism(m: &mut Mesh, f: &Frame, outline: &[Vec2], z0: f32, z1: f32) {
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
pub(super) fn pipe(m: &mut Mesh, f: &Frame, r_out: f32, r_in: f32, z0: f32, z1: f32, sides: u32) {
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
pub(super) fn gear(
    m: &mut Mesh,
    f: &Frame,
    root: f32,
    tip: f32,
    teeth: u32,
    width: f32,
    bore: f32,
    z: f32,
) {
    annulus(m, f, &gear_outline(root, tip, teeth), bore, z, z + width);
}

/// A sheet-metal cover open at `z = 0` and closed at `h`, walls `SHEET`
/// thick with both faces modelled, rounded-rectangle plan of half sizes
/// `hu`, `hv` along `f.u`, `f.v`, optionally with a mounting flange
/// `flange` wide around its open edge. 8 or 12 triangles a plan point.
pub(super) fn cover(m: &mut Mesh, f: &Frame, hu: f32, hv: f32, h: f32, flange: f32) {
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
pub(super) fn round_cover(m: &mut Mesh, f: &Frame, r: f32, h: f32, flange: f32, sides: u32) {
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
