//! Curves as point lists: IfcPolyline, IfcCompositeCurve (lines and arcs,
//! 2D or 3D), IfcTrimmedCurve of IfcCircle, IfcEllipse and IfcLine,
//! IfcIndexedPolyCurve (line and arc segments), full circles and ellipses.

use glam::{DMat4, DVec3};

use crate::classes::camel;
use crate::geom::{Ctx, GeomError, G};
use crate::placement::{axis2, direction, point};
use crate::step::Value;

/// The points of curve `id`, in its frame; closed curves repeat no point.
pub fn points(ctx: &Ctx, id: u32) -> G<Vec<DVec3>> {
    let e = ctx.get(id)?;
    let mut out = match e.ty {
        "IFCPOLYLINE" => e
            .refs(0)?
            .into_iter()
            .map(|p| point(ctx, p))
            .collect::<G<Vec<_>>>()?,
        "IFCCOMPOSITECURVE" | "IFC2DCOMPOSITECURVE" | "IFCCOMPOSITECURVEONSURFACE" => {
            let mut out: Vec<DVec3> = Vec::new();
            for s in e.refs(0)? {
                let seg = ctx.expect(
                    s,
                    &[
                        "IFCCOMPOSITECURVESEGMENT",
                        "IFCREPARAMETRISEDCOMPOSITECURVESEGMENT",
                    ],
                )?;
                let mut pts = points(ctx, seg.reference(2)?)?;
                if seg.flag(1) == Some(false) {
                    pts.reverse();
                }
                append(&mut out, pts);
            }
            out
        }
        "IFCTRIMMEDCURVE" => trimmed(ctx, id)?,
        "IFCCIRCLE" | "IFCELLIPSE" => {
            let (m, a, b) = conic(ctx, id)?;
            let n = ctx.circle_segments(a.max(b), std::f64::consts::TAU);
            let mut out: Vec<DVec3> = (0..n)
                .map(|i| {
                    let t = std::f64::consts::TAU * i as f64 / n as f64;
                    m.transform_point3(DVec3::new(a * t.cos(), b * t.sin(), 0.0))
                })
                .collect();
            // A full circle is closed: close it as polylines are.
            out.push(out[0]);
            out
        }
        "IFCINDEXEDPOLYCURVE" => indexed(ctx, id)?,
        "IFCBSPLINECURVEWITHKNOTS" | "IFCRATIONALBSPLINECURVEWITHKNOTS" => {
            crate::bspline::curve(ctx, &e)?
        }
        other => return Err(GeomError::Unsupported(camel(other))),
    };
    out.dedup_by(|a, b| a.distance_squared(*b) < 1e-18);
    Ok(out)
}

/// Appends `pts` to `out`, dropping the first when it repeats the last.
fn append(out: &mut Vec<DVec3>, pts: Vec<DVec3>) {
    let skip = match (out.last(), pts.first()) {
        (Some(a), Some(b)) => a.distance_squared(*b) < 1e-12,
        _ => false,
    };
    out.extend(pts.into_iter().skip(skip as usize));
}

/// An IfcCircle's or IfcEllipse's placement and semi-axes.
fn conic(ctx: &Ctx, id: u32) -> G<(DMat4, f64, f64)> {
    let e = ctx.get(id)?;
    let m = axis2(ctx, e.reference(0)?)?;
    let a = e.real(1)?;
    let b = if e.ty == "IFCELLIPSE" { e.real(2)? } else { a };
    if !(a > 0.0 && b > 0.0) {
        return Err(e.error("radius must be positive").into());
    }
    Ok((m, a, b))
}

/// A trim value: a parameter (IfcParameterValue) or a point.
fn trims(ctx: &Ctx, v: &Value) -> G<(Option<f64>, Option<DVec3>)> {
    let mut param = None;
    let mut pt = None;
    for t in v.as_list().unwrap_or(&[]) {
        match t {
            Value::Typed(name, inner) if name == "IFCPARAMETERVALUE" => param = inner.as_f64(),
            Value::Ref(r) => pt = Some(point(ctx, *r)?),
            _ => {}
        }
    }
    Ok((param, pt))
}

/// IfcTrimmedCurve over a circle, an ellipse or a line.
fn trimmed(ctx: &Ctx, id: u32) -> G<Vec<DVec3>> {
    let e = ctx.get(id)?;
    let basis = e.reference(0)?;
    let (p1, q1) = trims(ctx, e.arg(1))?;
    let (p2, q2) = trims(ctx, e.arg(2))?;
    let sense = e.flag(3).unwrap_or(true);
    let prefer_cartesian = e.arg(4).as_enum() == Some("CARTESIAN");
    let b = ctx.get(basis)?;
    match b.ty {
        "IFCLINE" => {
            let origin = point(ctx, b.reference(0)?)?;
            let v = ctx.expect(b.reference(1)?, &["IFCVECTOR"])?;
            let dir = direction(ctx, v.reference(0)?)? * v.real(1)?;
            let at = |p: Option<f64>, q: Option<DVec3>| match (p, q) {
                (_, Some(q)) if prefer_cartesian || p.is_none() => Some(q),
                (Some(p), _) => Some(origin + dir * p),
                (None, _) => None,
            };
            match (at(p1, q1), at(p2, q2)) {
                (Some(a), Some(b)) => Ok(vec![a, b]),
                _ => Err(e.error("trims give no point").into()),
            }
        }
        "IFCCIRCLE" | "IFCELLIPSE" => {
            let (m, a, r2) = conic(ctx, basis)?;
            let inv = m.inverse();
            let param = |p: Option<f64>, q: Option<DVec3>| -> Option<f64> {
                match (p, q) {
                    (_, Some(q)) if prefer_cartesian || p.is_none() => {
                        let l = inv.transform_point3(q);
                        Some((l.y / r2).atan2(l.x / a))
                    }
                    (Some(p), _) => Some(p * ctx.angle),
                    (None, _) => None,
                }
            };
            let (Some(t1), Some(mut t2)) = (param(p1, q1), param(p2, q2)) else {
                return Err(e.error("trims give no parameter").into());
            };
            if sense {
                while t2 <= t1 + 1e-12 {
                    t2 += std::f64::consts::TAU;
                }
            } else {
                while t2 >= t1 - 1e-12 {
                    t2 -= std::f64::consts::TAU;
                }
            }
            let n = ctx.circle_segments(a.max(r2), t2 - t1).max(1);
            Ok((0..=n)
                .map(|i| {
                    let t = t1 + (t2 - t1) * i as f64 / n as f64;
                    m.transform_point3(DVec3::new(a * t.cos(), r2 * t.sin(), 0.0))
                })
                .collect())
        }
        "IFCPOLYLINE" | "IFCCOMPOSITECURVE" | "IFCINDEXEDPOLYCURVE"
            if q1.is_none() && q2.is_none() && p1.is_none() && p2.is_none() =>
        {
            points(ctx, basis)
        }
        other => Err(GeomError::Unsupported(format!(
            "IfcTrimmedCurve of {}",
            camel(other)
        ))),
    }
}

/// IfcIndexedPolyCurve over an IfcCartesianPointList2D/3D.
fn indexed(ctx: &Ctx, id: u32) -> G<Vec<DVec3>> {
    let e = ctx.get(id)?;
    let list = ctx.expect(
        e.reference(0)?,
        &["IFCCARTESIANPOINTLIST2D", "IFCCARTESIANPOINTLIST3D"],
    )?;
    let pts = point_list(&list)?;
    let at = |i: i64| -> G<DVec3> {
        pts.get((i - 1) as usize)
            .copied()
            .ok_or_else(|| e.error(format!("point index {i} out of range")).into())
    };
    let Some(segments) = e.arg(1).as_list() else {
        return Ok(pts);
    };
    let mut out = Vec::new();
    for s in segments {
        let Value::Typed(kind, inner) = s else {
            return Err(e
                .error("a segment is not IfcLineIndex or IfcArcIndex")
                .into());
        };
        let idx: Vec<i64> = inner
            .as_list()
            .unwrap_or(&[])
            .iter()
            .filter_map(|v| match v {
                Value::Int(i) => Some(*i),
                _ => None,
            })
            .collect();
        let seg = match kind.as_str() {
            "IFCLINEINDEX" => idx.iter().map(|&i| at(i)).collect::<G<Vec<_>>>()?,
            "IFCARCINDEX" if idx.len() == 3 => arc3(ctx, at(idx[0])?, at(idx[1])?, at(idx[2])?),
            _ => return Err(e.error(format!("bad segment {kind}")).into()),
        };
        append(&mut out, seg);
    }
    Ok(out)
}

/// Points of an IfcCartesianPointList2D/3D.
pub fn point_list(list: &crate::step::Entity) -> G<Vec<DVec3>> {
    list.list(0)?
        .iter()
        .map(|c| {
            let c: Vec<f64> = c
                .as_list()
                .unwrap_or(&[])
                .iter()
                .filter_map(Value::as_f64)
                .collect();
            match c.as_slice() {
                [x, y] => Ok(DVec3::new(*x, *y, 0.0)),
                [x, y, z] => Ok(DVec3::new(*x, *y, *z)),
                _ => Err(list.error("a point has 2 or 3 coordinates").into()),
            }
        })
        .collect()
}

/// The arc through three points (a straight line when they are collinear).
pub fn arc3(ctx: &Ctx, a: DVec3, b: DVec3, c: DVec3) -> Vec<DVec3> {
    let ab = b - a;
    let ac = c - a;
    let n = ab.cross(ac);
    let n2 = n.length_squared();
    if n2 < 1e-24 {
        return vec![a, c];
    }
    // The circumcentre of a, b, c.
    let centre =
        a + (n.cross(ab) * ac.length_squared() + ac.cross(n) * ab.length_squared()) / (2.0 * n2);
    let r = (a - centre).length();
    let x = (a - centre) / r;
    let y = n.normalize().cross(x);
    let angle = |p: DVec3| {
        let v = p - centre;
        let t = v.dot(y).atan2(v.dot(x));
        if t < 0.0 {
            t + std::f64::consts::TAU
        } else {
            t
        }
    };
    let sweep = angle(c);
    let steps = ctx.circle_segments(r, sweep).max(1);
    (0..=steps)
        .map(|i| {
            let t = sweep * i as f64 / steps as f64;
            centre + (x * t.cos() + y * t.sin()) * r
        })
        .collect()
}
