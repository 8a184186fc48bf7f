//! Profiles (IfcProfileDef) as 2D loops: arbitrary closed and open
//! curves, with voids, rectangles (hollow too), circles (hollow too),
//! I, L, T, U, C shapes, derived profiles; each in its Position.

use glam::{DMat4, DVec2, DVec3};

use crate::classes::camel;
use crate::curve;
use crate::geom::{Ctx, GeomError, G};
use crate::placement::{opt_axis2, transform_operator};
use crate::triangulate::{newell, open_loop};

/// A profile: its outer loop counter-clockwise, its holes clockwise;
/// `open` for a curve that bounds no area (extruded to a strip).
#[derive(Clone, Debug, Default)]
pub struct Profile {
    pub outer: Vec<DVec2>,
    pub holes: Vec<Vec<DVec2>>,
    pub open: bool,
}

/// Profile `id`'s loops (several for an IfcCompositeProfileDef).
pub fn profile(ctx: &Ctx, id: u32) -> G<Vec<Profile>> {
    let e = ctx.get(id)?;
    let position = |i: usize| opt_axis2(ctx, &e, i);
    let mut p = match e.ty {
        "IFCARBITRARYCLOSEDPROFILEDEF" | "IFCARBITRARYPROFILEDEFWITHVOIDS" => {
            let outer = loop2(ctx, e.reference(2)?)?;
            let mut holes = Vec::new();
            if e.ty == "IFCARBITRARYPROFILEDEFWITHVOIDS" {
                for h in e.refs(3)? {
                    holes.push(loop2(ctx, h)?);
                }
            }
            Profile {
                outer,
                holes,
                open: false,
            }
        }
        "IFCARBITRARYOPENPROFILEDEF" => {
            let pts = curve::points(ctx, e.reference(2)?)?;
            Profile {
                outer: pts.iter().map(|p| p.truncate()).collect(),
                holes: Vec::new(),
                open: true,
            }
        }
        "IFCRECTANGLEPROFILEDEF" | "IFCROUNDEDRECTANGLEPROFILEDEF" => {
            let (x, y) = (e.real(3)? / 2.0, e.real(4)? / 2.0);
            placed(position(2)?, rect(x, y), vec![])
        }
        "IFCRECTANGLEHOLLOWPROFILEDEF" => {
            let (x, y, t) = (e.real(3)? / 2.0, e.real(4)? / 2.0, e.real(5)?);
            placed(position(2)?, rect(x, y), vec![rect(x - t, y - t)])
        }
        "IFCCIRCLEPROFILEDEF" => {
            let r = e.real(3)?;
            placed(position(2)?, circle(ctx, r), vec![])
        }
        "IFCCIRCLEHOLLOWPROFILEDEF" => {
            let (r, t) = (e.real(3)?, e.real(4)?);
            placed(position(2)?, circle(ctx, r), vec![circle(ctx, r - t)])
        }
        "IFCELLIPSEPROFILEDEF" => {
            let (a, b) = (e.real(3)?, e.real(4)?);
            let c = circle(ctx, a.max(b));
            let pts = c
                .iter()
                .map(|p| DVec2::new(p.x * a / a.max(b), p.y * b / a.max(b)));
            placed(position(2)?, pts.collect(), vec![])
        }
        "IFCISHAPEPROFILEDEF" | "IFCASYMMETRICISHAPEPROFILEDEF" => {
            let (w, d, tw, tf) = (e.real(3)?, e.real(4)?, e.real(5)?, e.real(6)?);
            let (w2, d2, tw2) = (w / 2.0, d / 2.0, tw / 2.0);
            let pts = [
                (-w2, -d2),
                (w2, -d2),
                (w2, -d2 + tf),
                (tw2, -d2 + tf),
                (tw2, d2 - tf),
                (w2, d2 - tf),
                (w2, d2),
                (-w2, d2),
                (-w2, d2 - tf),
                (-tw2, d2 - tf),
                (-tw2, -d2 + tf),
                (-w2, -d2 + tf),
            ];
            placed(position(2)?, v2(&pts), vec![])
        }
        "IFCLSHAPEPROFILEDEF" => {
            let (d, w, t) = (e.real(3)?, e.opt_real(4).unwrap_or(e.real(3)?), e.real(5)?);
            let (d2, w2) = (d / 2.0, w / 2.0);
            let pts = [
                (-w2, -d2),
                (w2, -d2),
                (w2, -d2 + t),
                (-w2 + t, -d2 + t),
                (-w2 + t, d2),
                (-w2, d2),
            ];
            placed(position(2)?, v2(&pts), vec![])
        }
        "IFCTSHAPEPROFILEDEF" => {
            let (d, fw, tw, tf) = (e.real(3)?, e.real(4)?, e.real(5)?, e.real(6)?);
            let (d2, fw2, tw2) = (d / 2.0, fw / 2.0, tw / 2.0);
            let pts = [
                (-tw2, -d2),
                (tw2, -d2),
                (tw2, d2 - tf),
                (fw2, d2 - tf),
                (fw2, d2),
                (-fw2, d2),
                (-fw2, d2 - tf),
                (-tw2, d2 - tf),
            ];
            placed(position(2)?, v2(&pts), vec![])
        }
        "IFCUSHAPEPROFILEDEF" => {
            let (d, fw, tw, tf) = (e.real(3)?, e.real(4)?, e.real(5)?, e.real(6)?);
            let (d2, fw2) = (d / 2.0, fw / 2.0);
            let pts = [
                (-fw2, -d2),
                (fw2, -d2),
                (fw2, -d2 + tf),
                (-fw2 + tw, -d2 + tf),
                (-fw2 + tw, d2 - tf),
                (fw2, d2 - tf),
                (fw2, d2),
                (-fw2, d2),
            ];
            placed(position(2)?, v2(&pts), vec![])
        }
        "IFCCSHAPEPROFILEDEF" => {
            let (d, w, t, g) = (e.real(3)?, e.real(4)?, e.real(5)?, e.real(6)?);
            let (d2, w2) = (d / 2.0, w / 2.0);
            let pts = [
                (-w2, -d2),
                (w2, -d2),
                (w2, -d2 + g),
                (w2 - t, -d2 + g),
                (w2 - t, -d2 + t),
                (-w2 + t, -d2 + t),
                (-w2 + t, d2 - t),
                (w2 - t, d2 - t),
                (w2 - t, d2 - g),
                (w2, d2 - g),
                (w2, d2),
                (-w2, d2),
            ];
            placed(position(2)?, v2(&pts), vec![])
        }
        "IFCDERIVEDPROFILEDEF" => {
            let parents = profile(ctx, e.reference(2)?)?;
            let m = transform_operator(ctx, e.reference(3)?)?;
            return Ok(parents
                .into_iter()
                .map(|p| {
                    let t = |l: Vec<DVec2>| l.iter().map(|q| apply(&m, *q)).collect();
                    let mut q = Profile {
                        outer: t(p.outer),
                        holes: p.holes.into_iter().map(t).collect(),
                        open: p.open,
                    };
                    orient(&mut q);
                    q
                })
                .collect());
        }
        "IFCCOMPOSITEPROFILEDEF" => {
            let mut all = Vec::new();
            for p in e.refs(2)? {
                all.extend(profile(ctx, p)?);
            }
            return Ok(all);
        }
        other => return Err(GeomError::Unsupported(camel(other))),
    };
    if !p.open && p.outer.len() < 3 {
        return Err(e.error("profile has fewer than 3 points").into());
    }
    orient(&mut p);
    Ok(vec![p])
}

fn v2(pts: &[(f64, f64)]) -> Vec<DVec2> {
    pts.iter().map(|&(x, y)| DVec2::new(x, y)).collect()
}

fn rect(x: f64, y: f64) -> Vec<DVec2> {
    v2(&[(-x, -y), (x, -y), (x, y), (-x, y)])
}

fn circle(ctx: &Ctx, r: f64) -> Vec<DVec2> {
    let n = ctx.circle_segments(r, std::f64::consts::TAU);
    (0..n)
        .map(|i| {
            let t = std::f64::consts::TAU * i as f64 / n as f64;
            DVec2::new(r * t.cos(), r * t.sin())
        })
        .collect()
}

fn apply(m: &DMat4, p: DVec2) -> DVec2 {
    m.transform_point3(p.extend(0.0)).truncate()
}

fn placed(m: DMat4, outer: Vec<DVec2>, holes: Vec<Vec<DVec2>>) -> Profile {
    Profile {
        outer: outer.iter().map(|p| apply(&m, *p)).collect(),
        holes: holes
            .into_iter()
            .map(|h| h.iter().map(|p| apply(&m, *p)).collect())
            .collect(),
        open: false,
    }
}

/// A closed curve as a 2D loop, without its repeated closing point.
fn loop2(ctx: &Ctx, id: u32) -> G<Vec<DVec2>> {
    let pts = open_loop(curve::points(ctx, id)?);
    Ok(pts.iter().map(|p| p.truncate()).collect())
}

/// Signed area (positive counter-clockwise).
fn area(l: &[DVec2]) -> f64 {
    let p: Vec<DVec3> = l.iter().map(|q| q.extend(0.0)).collect();
    newell(&p).z / 2.0
}

/// Outer loop counter-clockwise, holes clockwise.
fn orient(p: &mut Profile) {
    if p.open {
        return;
    }
    if area(&p.outer) < 0.0 {
        p.outer.reverse();
    }
    for h in &mut p.holes {
        if area(h) > 0.0 {
            h.reverse();
        }
    }
}
