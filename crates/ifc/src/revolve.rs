//! IfcRevolvedAreaSolid: a profile turned about an axis in its plane by
//! an angle; caps at both ends unless it turns all the way round.

use glam::{DMat3, DVec3};

use crate::geom::{Ctx, Tri, G};
use crate::placement::{direction, opt_axis2, point};
use crate::profile::profile;
use crate::triangulate::triangulate_2d;

/// The triangles of IfcRevolvedAreaSolid `id` (SweptArea, Position,
/// Axis, Angle) in its parent's frame.
pub fn revolved_area_solid(ctx: &Ctx, id: u32) -> G<Vec<Tri>> {
    let e = ctx.get(id)?;
    let profiles = profile(ctx, e.reference(0)?)?;
    let m = opt_axis2(ctx, &e, 1)?;
    let axis = ctx.expect(e.reference(2)?, &["IFCAXIS1PLACEMENT"])?;
    let origin = point(ctx, axis.reference(0)?)?;
    let dir = match axis.opt_ref(1) {
        Some(d) => direction(ctx, d)?,
        None => DVec3::Z,
    };
    let angle = e.real(3)? * ctx.angle;
    if !angle.is_finite() || angle.abs() < 1e-12 {
        return Err(e.error("the angle must be finite and not zero").into());
    }
    let full = angle.abs() >= std::f64::consts::TAU - 1e-9;
    let angle = angle.clamp(-std::f64::consts::TAU, std::f64::consts::TAU);
    let radius = profiles
        .iter()
        .flat_map(|p| p.outer.iter())
        .map(|q| {
            let v = q.extend(0.0) - origin;
            (v - dir * v.dot(dir)).length()
        })
        .fold(0.0, f64::max);
    let steps = ctx.circle_segments(radius, angle);
    let turn = |q: DVec3, k: usize| -> DVec3 {
        let r = DMat3::from_axis_angle(dir, angle * k as f64 / steps as f64);
        origin + r * (q - origin)
    };
    let mut tris = Vec::new();
    for p in &profiles {
        let mut ring = |l: &[glam::DVec2], closed: bool| {
            let n = l.len();
            let edges = if closed { n } else { n.saturating_sub(1) };
            for i in 0..edges {
                let (a, b) = (l[i].extend(0.0), l[(i + 1) % n].extend(0.0));
                for k in 0..steps {
                    let (a0, b0, a1, b1) = (turn(a, k), turn(b, k), turn(a, k + 1), turn(b, k + 1));
                    tris.push(Tri::new(a0, b0, b1));
                    tris.push(Tri::new(a0, b1, a1));
                }
            }
        };
        ring(&p.outer, !p.open);
        if p.open {
            continue;
        }
        for h in &p.holes {
            ring(h, true);
        }
        if !full {
            let all: Vec<glam::DVec2> = p
                .outer
                .iter()
                .chain(p.holes.iter().flatten())
                .copied()
                .collect();
            for [a, b, c] in triangulate_2d(&p.outer, &p.holes) {
                let [a, b, c] = [all[a], all[b], all[c]].map(|q| q.extend(0.0));
                tris.push(Tri::new(a, c, b));
                tris.push(Tri::new(turn(a, steps), turn(b, steps), turn(c, steps)));
            }
        }
    }
    // Which way the profile and the turn wind the faces depends on the
    // sense of both: settle it by the enclosed volume's sign.
    let volume: f64 = tris.iter().map(|t| t.p[0].dot(t.p[1].cross(t.p[2]))).sum();
    if volume < 0.0 {
        for t in &mut tris {
            t.p.swap(1, 2);
        }
    }
    crate::geom::transform(&mut tris, &m);
    Ok(tris)
}
