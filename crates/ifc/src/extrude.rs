//! IfcExtrudedAreaSolid: a profile swept along a direction (any, not only
//! the profile's normal) by a depth; caps triangulated with their holes.

use glam::{DVec2, DVec3};

use crate::geom::{Ctx, Tri, G};
use crate::placement::{direction, opt_axis2};
use crate::profile::{profile, Profile};
use crate::triangulate::triangulate_2d;

/// The triangles of IfcExtrudedAreaSolid `id` in its parent's frame.
pub fn extruded_area_solid(ctx: &Ctx, id: u32) -> G<Vec<Tri>> {
    let e = ctx.get(id)?;
    let profiles = profile(ctx, e.reference(0)?)?;
    let m = opt_axis2(ctx, &e, 1)?;
    let dir = direction(ctx, e.reference(2)?)?;
    let depth = e.real(3)?;
    if !(depth.is_finite() && depth > 0.0) || dir.z.abs() < 1e-9 {
        return Err(e
            .error("depth must be positive and the direction leave the profile's plane")
            .into());
    }
    let mut tris = Vec::new();
    for p in &profiles {
        extrude(p, dir * depth, &mut tris);
    }
    crate::geom::transform(&mut tris, &m);
    Ok(tris)
}

/// Extrudes `p` (in the XY plane) by the vector `d`.
pub fn extrude(p: &Profile, d: DVec3, out: &mut Vec<Tri>) {
    // With d below the plane the loops' orientation turns the solid
    // inside out; mirroring the sides' winding keeps faces outward.
    let up = d.z > 0.0;
    let at = |q: DVec2, top: bool| {
        let b = q.extend(0.0);
        if top {
            b + d
        } else {
            b
        }
    };
    let mut side = |l: &[DVec2], closed: bool| {
        let n = l.len();
        let edges = if closed { n } else { n.saturating_sub(1) };
        for i in 0..edges {
            let (a, b) = (l[i], l[(i + 1) % n]);
            let (a0, b0, b1, a1) = (at(a, false), at(b, false), at(b, true), at(a, true));
            if up {
                out.push(Tri::new(a0, b0, b1));
                out.push(Tri::new(a0, b1, a1));
            } else {
                out.push(Tri::new(a0, b1, b0));
                out.push(Tri::new(a0, a1, b1));
            }
        }
    };
    side(&p.outer, !p.open);
    if p.open {
        return;
    }
    for h in &p.holes {
        side(h, true);
    }
    let all: Vec<DVec2> = p
        .outer
        .iter()
        .chain(p.holes.iter().flatten())
        .copied()
        .collect();
    for [a, b, c] in triangulate_2d(&p.outer, &p.holes) {
        let (pa, pb, pc) = (all[a], all[b], all[c]);
        // Earcut's winding follows no rule: orient each cap by its normal.
        let ccw = (pb - pa).perp_dot(pc - pa) > 0.0;
        let (pb, pc) = if ccw == up { (pb, pc) } else { (pc, pb) };
        out.push(Tri::new(at(pa, true), at(pb, true), at(pc, true)));
        out.push(Tri::new(at(pa, false), at(pc, false), at(pb, false)));
    }
}
