//! Boundary representations: IfcFacetedBrep (with voids), shells
//! (IfcClosedShell, IfcOpenShell, IfcConnectedFaceSet) in
//! IfcShellBasedSurfaceModel and IfcFaceBasedSurfaceModel, IfcPolyLoop
//! faces with inner bounds, and IfcAdvancedBrep's planar faces.

use glam::DVec3;

use crate::classes::camel;
use crate::curve;
use crate::geom::{Ctx, GeomError, Tri, G};
use crate::placement::point;
use crate::triangulate::{open_loop, triangulate_3d};

/// Triangles of a brep or surface model item.
pub fn brep(ctx: &Ctx, id: u32) -> G<Vec<Tri>> {
    let e = ctx.get(id)?;
    let mut out = Vec::new();
    match e.ty {
        "IFCFACETEDBREP" | "IFCADVANCEDBREP" => shell(ctx, e.reference(0)?, &mut out)?,
        "IFCFACETEDBREPWITHVOIDS" | "IFCADVANCEDBREPWITHVOIDS" => {
            shell(ctx, e.reference(0)?, &mut out)?;
            for v in e.refs(1)? {
                shell(ctx, v, &mut out)?;
            }
        }
        "IFCSHELLBASEDSURFACEMODEL" | "IFCFACEBASEDSURFACEMODEL" => {
            for s in e.refs(0)? {
                shell(ctx, s, &mut out)?;
            }
        }
        other => return Err(GeomError::Unsupported(camel(other))),
    }
    Ok(out)
}

/// A shell's faces (IfcClosedShell, IfcOpenShell, IfcConnectedFaceSet).
fn shell(ctx: &Ctx, id: u32, out: &mut Vec<Tri>) -> G<()> {
    let e = ctx.expect(
        id,
        &["IFCCLOSEDSHELL", "IFCOPENSHELL", "IFCCONNECTEDFACESET"],
    )?;
    let start = out.len();
    let mut unsupported = Vec::new();
    for f in e.refs(0)? {
        match face(ctx, f, out) {
            Ok(()) => {}
            // A face of a kind not read leaves the others; each is
            // counted.
            Err(GeomError::Unsupported(k)) => unsupported.push(k),
            Err(e) => return Err(e),
        }
    }
    match unsupported.pop() {
        Some(k) if out.len() == start => Err(GeomError::Unsupported(k)),
        Some(k) => {
            ctx.notes.borrow_mut().extend(unsupported);
            ctx.notes.borrow_mut().push(k);
            Ok(())
        }
        None => Ok(()),
    }
}

/// One face: IfcFace / IfcFaceSurface with poly loops, or IfcAdvancedFace
/// on an IfcPlane with edge loops.
fn face(ctx: &Ctx, id: u32, out: &mut Vec<Tri>) -> G<()> {
    let e = ctx.get(id)?;
    match e.ty {
        "IFCFACE" | "IFCFACESURFACE" => {}
        "IFCADVANCEDFACE" => {
            let s = ctx.get(e.reference(1)?)?;
            if matches!(
                s.ty,
                "IFCBSPLINESURFACEWITHKNOTS" | "IFCRATIONALBSPLINESURFACEWITHKNOTS"
            ) {
                // The whole patch: its bounds are taken to be its edges
                // (trimmed B-spline faces are drawn untrimmed).
                let flip = e.flag(2) == Some(false);
                out.extend(crate::bspline::surface(ctx, &s, flip)?);
                return Ok(());
            }
            if s.ty != "IFCPLANE" {
                return Err(GeomError::Unsupported(format!(
                    "IfcAdvancedFace on {}",
                    camel(s.ty)
                )));
            }
        }
        other => return Err(GeomError::Unsupported(camel(other))),
    }
    let mut outer: Option<Vec<DVec3>> = None;
    let mut loops = Vec::new();
    for b in e.refs(0)? {
        let bound = ctx.expect(b, &["IFCFACEOUTERBOUND", "IFCFACEBOUND"])?;
        let mut pts = bound_points(ctx, bound.reference(0)?)?;
        if bound.flag(1) == Some(false) {
            pts.reverse();
        }
        if pts.len() < 3 {
            continue;
        }
        if bound.ty == "IFCFACEOUTERBOUND" && outer.is_none() {
            outer = Some(pts);
        } else {
            loops.push(pts);
        }
    }
    let outer = match outer {
        Some(o) => o,
        None if !loops.is_empty() => loops.remove(0),
        None => return Ok(()),
    };
    loops.insert(0, outer);
    let flip = e.ty == "IFCADVANCEDFACE" && e.flag(2) == Some(false);
    for [a, b, c] in triangulate_3d(&loops) {
        out.push(if flip {
            Tri::new(a, c, b)
        } else {
            Tri::new(a, b, c)
        });
    }
    Ok(())
}

/// A loop's points: IfcPolyLoop, or IfcEdgeLoop of oriented edges whose
/// curves are lines or polylines.
fn bound_points(ctx: &Ctx, id: u32) -> G<Vec<DVec3>> {
    let e = ctx.get(id)?;
    match e.ty {
        "IFCPOLYLOOP" => Ok(open_loop(
            e.refs(0)?
                .into_iter()
                .map(|p| point(ctx, p))
                .collect::<G<Vec<_>>>()?,
        )),
        "IFCEDGELOOP" => {
            let mut out: Vec<DVec3> = Vec::new();
            for oe in e.refs(0)? {
                let o = ctx.expect(oe, &["IFCORIENTEDEDGE"])?;
                let mut pts = edge_points(ctx, o.reference(2)?)?;
                if o.flag(3) == Some(false) {
                    pts.reverse();
                }
                // Each edge's last point is the next one's first.
                pts.pop();
                out.extend(pts);
            }
            Ok(open_loop(out))
        }
        other => Err(GeomError::Unsupported(camel(other))),
    }
}

/// An IfcEdgeCurve's points from its start to its end.
fn edge_points(ctx: &Ctx, id: u32) -> G<Vec<DVec3>> {
    let e = ctx.expect(id, &["IFCEDGECURVE", "IFCEDGE"])?;
    let vertex = |i: usize| -> G<DVec3> {
        let v = ctx.expect(e.reference(i)?, &["IFCVERTEXPOINT"])?;
        point(ctx, v.reference(0)?)
    };
    let (a, b) = (vertex(0)?, vertex(1)?);
    if e.ty == "IFCEDGE" {
        return Ok(vec![a, b]);
    }
    let c = ctx.get(e.reference(2)?)?;
    let mut pts = match c.ty {
        "IFCLINE" => vec![a, b],
        "IFCPOLYLINE"
        | "IFCINDEXEDPOLYCURVE"
        | "IFCTRIMMEDCURVE"
        | "IFCCOMPOSITECURVE"
        | "IFCBSPLINECURVEWITHKNOTS"
        | "IFCRATIONALBSPLINECURVEWITHKNOTS" => curve::points(ctx, c.id)?,
        other => {
            return Err(GeomError::Unsupported(format!(
                "IfcEdgeCurve on {}",
                camel(other)
            )))
        }
    };
    if e.flag(3) == Some(false) {
        pts.reverse();
    }
    if pts.len() < 2 {
        return Ok(vec![a, b]);
    }
    Ok(pts)
}
