//! Points, directions and placements: IfcAxis2Placement2D/3D with their
//! defaulted axes, IfcLocalPlacement chains composed to world matrices,
//! and IfcCartesianTransformationOperator (uniform and non-uniform scale).

use glam::{DMat4, DVec3, DVec4};

use crate::geom::{Ctx, GeomError, G};
use crate::step::Entity;

/// IfcCartesianPoint (2D points get z = 0).
pub fn point(ctx: &Ctx, id: u32) -> G<DVec3> {
    let e = ctx.expect(id, &["IFCCARTESIANPOINT"])?;
    let c = e.reals(0)?;
    let p = match c.as_slice() {
        [x, y] => DVec3::new(*x, *y, 0.0),
        [x, y, z] => DVec3::new(*x, *y, *z),
        _ => return Err(e.error("a point has 2 or 3 coordinates").into()),
    };
    finite(&e, p)
}

fn finite(e: &Entity, p: DVec3) -> G<DVec3> {
    if p.is_finite() {
        Ok(p)
    } else {
        Err(e.error("non-finite coordinates").into())
    }
}

/// IfcDirection, normalized (2D directions get z = 0).
pub fn direction(ctx: &Ctx, id: u32) -> G<DVec3> {
    let e = ctx.expect(id, &["IFCDIRECTION"])?;
    let c = e.reals(0)?;
    let d = match c.as_slice() {
        [x, y] => DVec3::new(*x, *y, 0.0),
        [x, y, z] => DVec3::new(*x, *y, *z),
        _ => return Err(e.error("a direction has 2 or 3 ratios").into()),
    };
    let d = finite(&e, d)?;
    d.try_normalize()
        .ok_or_else(|| e.error("zero-length direction").into())
}

/// An optional direction argument, else `default`.
fn opt_direction(ctx: &Ctx, e: &Entity, i: usize, default: DVec3) -> G<DVec3> {
    match e.opt_ref(i) {
        Some(d) => direction(ctx, d),
        None => Ok(default),
    }
}

/// An orthonormal frame from a Z axis and an approximate X axis (the
/// schema's "first direction projected perpendicular to the axis").
fn frame(z: DVec3, x_hint: DVec3, origin: DVec3) -> DMat4 {
    let mut x = x_hint - z * x_hint.dot(z);
    if x.length_squared() < 1e-20 {
        x = z.any_orthonormal_vector();
    }
    let x = x.normalize();
    let y = z.cross(x);
    DMat4::from_cols(
        x.extend(0.0),
        y.extend(0.0),
        z.extend(0.0),
        origin.extend(1.0),
    )
}

/// IfcAxis2Placement3D or IfcAxis2Placement2D as a matrix.
pub fn axis2(ctx: &Ctx, id: u32) -> G<DMat4> {
    let e = ctx.expect(id, &["IFCAXIS2PLACEMENT3D", "IFCAXIS2PLACEMENT2D"])?;
    let origin = point(ctx, e.reference(0)?)?;
    if e.ty == "IFCAXIS2PLACEMENT2D" {
        let x = opt_direction(ctx, &e, 1, DVec3::X)?;
        return Ok(frame(DVec3::Z, x, origin));
    }
    let z = opt_direction(ctx, &e, 1, DVec3::Z)?;
    let x = opt_direction(ctx, &e, 2, DVec3::X)?;
    Ok(frame(z, x, origin))
}

/// An optional placement argument, else the identity.
pub fn opt_axis2(ctx: &Ctx, e: &Entity, i: usize) -> G<DMat4> {
    match e.opt_ref(i) {
        Some(p) => axis2(ctx, p),
        None => Ok(DMat4::IDENTITY),
    }
}

/// An IfcLocalPlacement's world matrix (file units), following
/// PlacementRelTo up; cached per placement.
pub fn local_placement(ctx: &Ctx, id: u32) -> G<DMat4> {
    let mut chain = Vec::new();
    let mut at = Some(id);
    let mut base = DMat4::IDENTITY;
    while let Some(p) = at {
        if let Some(m) = ctx.placements.borrow().get(&p) {
            base = *m;
            break;
        }
        if chain.len() > 1000 {
            return Err(ctx.get(id)?.error("placement chain loops").into());
        }
        let e = ctx.get(p)?;
        if e.ty != "IFCLOCALPLACEMENT" {
            // IfcGridPlacement and IfcLinearPlacement are not read.
            return Err(GeomError::Unsupported(crate::classes::camel(e.ty)));
        }
        let rel = axis2(ctx, e.reference(1)?)?;
        chain.push((p, rel));
        at = e.opt_ref(0);
    }
    for (p, rel) in chain.into_iter().rev() {
        base *= rel;
        ctx.placements.borrow_mut().insert(p, base);
    }
    Ok(base)
}

/// IfcCartesianTransformationOperator3D (or 2D), uniform or non-uniform,
/// as a matrix: axes as the schema derives them, scaled.
pub fn transform_operator(ctx: &Ctx, id: u32) -> G<DMat4> {
    let e = ctx.expect(
        id,
        &[
            "IFCCARTESIANTRANSFORMATIONOPERATOR3D",
            "IFCCARTESIANTRANSFORMATIONOPERATOR3DNONUNIFORM",
            "IFCCARTESIANTRANSFORMATIONOPERATOR2D",
            "IFCCARTESIANTRANSFORMATIONOPERATOR2DNONUNIFORM",
        ],
    )?;
    let origin = point(ctx, e.reference(2)?)?;
    let s = e.opt_real(3).unwrap_or(1.0);
    let three_d = e.ty.contains("3D");
    let non_uniform = e.ty.ends_with("NONUNIFORM");
    let x1 = opt_direction(ctx, &e, 0, DVec3::X)?;
    let (x, y, z) = if three_d {
        let z_hint = opt_direction(ctx, &e, 4, DVec3::Z)?;
        // The schema's BaseAxis: U3 = axis3, U1 = axis1 orthogonal to it,
        // U2 = axis2 orthogonal to both.
        let z = z_hint;
        let mut x = x1 - z * x1.dot(z);
        if x.length_squared() < 1e-20 {
            x = z.any_orthonormal_vector();
        }
        let x = x.normalize();
        let y_hint = opt_direction(ctx, &e, 1, z.cross(x))?;
        let mut y = y_hint - z * y_hint.dot(z) - x * y_hint.dot(x);
        if y.length_squared() < 1e-20 {
            y = z.cross(x);
        }
        (x, y.normalize(), z)
    } else {
        let x = DVec3::new(x1.x, x1.y, 0.0).normalize_or(DVec3::X);
        let y_default = DVec3::new(-x.y, x.x, 0.0);
        let y_hint = opt_direction(ctx, &e, 1, y_default)?;
        let y = (y_hint - x * y_hint.dot(x)).normalize_or(y_default);
        (x, y, DVec3::Z)
    };
    let (s2, s3) = if non_uniform {
        let i2 = if three_d { 5 } else { 4 };
        (
            e.opt_real(i2).unwrap_or(s),
            if three_d {
                e.opt_real(6).unwrap_or(s)
            } else {
                1.0
            },
        )
    } else {
        (s, if three_d { s } else { 1.0 })
    };
    if !(s.is_finite() && s2.is_finite() && s3.is_finite()) || s * s2 * s3 == 0.0 {
        return Err(e.error("zero or non-finite scale").into());
    }
    Ok(DMat4::from_cols(
        (x * s).extend(0.0),
        (y * s2).extend(0.0),
        (z * s3).extend(0.0),
        DVec4::new(origin.x, origin.y, origin.z, 1.0),
    ))
}
