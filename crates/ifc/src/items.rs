//! Representation items to triangles: the dispatch by class, mapped items
//! (IfcRepresentationMap through a transformation operator), booleans
//! (half-space clipping, differences of convex solids, unions), simple
//! CSG primitives, and solids as convex pieces for subtraction.

use glam::{DMat4, DVec2, DVec3};

use crate::classes::camel;
use crate::clip::{convex_of_faces, cut, Convex, Plane};
use crate::geom::{transform, Ctx, GeomError, Tri, G};
use crate::placement::{axis2, opt_axis2, transform_operator};
use crate::profile::profile;
use crate::triangulate::triangulate_2d;

/// Triangles of representation item `id` in its representation's frame,
/// coloured by its style where it has one.
pub fn item(ctx: &Ctx, id: u32, depth: usize) -> G<Vec<Tri>> {
    if depth > 32 {
        return Err(ctx.get(id)?.error("items nest too deep (a cycle?)").into());
    }
    let e = ctx.get(id)?;
    let mut tris = match e.ty {
        "IFCEXTRUDEDAREASOLID" => crate::extrude::extruded_area_solid(ctx, id)?,
        "IFCREVOLVEDAREASOLID" => crate::revolve::revolved_area_solid(ctx, id)?,
        "IFCFACETEDBREP"
        | "IFCFACETEDBREPWITHVOIDS"
        | "IFCADVANCEDBREP"
        | "IFCADVANCEDBREPWITHVOIDS"
        | "IFCSHELLBASEDSURFACEMODEL"
        | "IFCFACEBASEDSURFACEMODEL" => crate::brep::brep(ctx, id)?,
        "IFCTRIANGULATEDFACESET" | "IFCPOLYGONALFACESET" => crate::face_set::face_set(ctx, id)?,
        "IFCSWEPTDISKSOLID" | "IFCSWEPTDISKSOLIDPOLYGONAL" => crate::swept::swept_disk(ctx, id)?,
        "IFCMAPPEDITEM" => mapped(ctx, id, depth)?,
        "IFCBOOLEANCLIPPINGRESULT" | "IFCBOOLEANRESULT" => boolean(ctx, id, depth)?,
        "IFCCSGSOLID" => item(ctx, e.reference(0)?, depth + 1)?,
        "IFCBLOCK" | "IFCRIGHTCIRCULARCYLINDER" => {
            let mut t = Vec::new();
            for faces in primitive_faces(ctx, id)? {
                for f in faces {
                    for [a, b, c] in crate::triangulate::triangulate_3d(&[f]) {
                        t.push(Tri::new(a, b, c));
                    }
                }
            }
            t
        }
        other => return Err(GeomError::Unsupported(camel(other))),
    };
    if let Some(&c) = ctx.styles.item.get(&id) {
        for t in &mut tris {
            if t.c[3] < 0.0 {
                t.c = c;
            }
        }
    }
    Ok(tris)
}

/// The items of IfcShapeRepresentation `rep`, each failure noted (its
/// kind counted, a malformed entity also warned about) rather than
/// failing the others.
pub fn representation(ctx: &Ctx, rep: u32, depth: usize, out: &mut Vec<Tri>) -> G<()> {
    let r = ctx.get(rep)?;
    for i in r.refs(3)? {
        match item(ctx, i, depth + 1) {
            Ok(t) => out.extend(t),
            Err(GeomError::Unsupported(k)) => ctx.notes.borrow_mut().push(k),
            Err(GeomError::Bad(e)) => {
                let class = ctx.step.type_of(i).map(camel).unwrap_or_default();
                ctx.notes.borrow_mut().push(format!("malformed {class}"));
                ctx.warnings.borrow_mut().push(e.to_string());
            }
        }
    }
    Ok(())
}

/// IfcMappedItem: the map's representation, placed by MappingOrigin then
/// MappingTarget. A map's triangles are made once and reused.
fn mapped(ctx: &Ctx, id: u32, depth: usize) -> G<Vec<Tri>> {
    let e = ctx.get(id)?;
    let map = ctx.expect(e.reference(0)?, &["IFCREPRESENTATIONMAP"])?;
    let target = transform_operator(ctx, e.reference(1)?)?;
    let origin = axis2(ctx, map.reference(0)?)?;
    let cached = ctx.mapped.borrow().get(&map.id).cloned();
    let (mut tris, notes) = match cached {
        Some(c) => c,
        None => {
            let before = ctx.notes.borrow().len();
            let mut tris = Vec::new();
            representation(ctx, map.reference(1)?, depth, &mut tris)?;
            let notes = ctx.notes.borrow_mut().split_off(before);
            ctx.mapped
                .borrow_mut()
                .insert(map.id, (tris.clone(), notes.clone()));
            (tris, notes)
        }
    };
    ctx.notes.borrow_mut().extend(notes);
    transform(&mut tris, &(target * origin));
    Ok(tris)
}

/// The plane bounding an IfcHalfSpaceSolid (or the half space of an
/// IfcBoxedHalfSpace / IfcPolygonalBoundedHalfSpace), oriented so the
/// half space's material is behind it.
fn half_space_plane(ctx: &Ctx, e: &crate::step::Entity) -> G<Plane> {
    let surface = ctx.expect(e.reference(0)?, &["IFCPLANE"])?;
    let m = axis2(ctx, surface.reference(0)?)?;
    let n = m.z_axis.truncate();
    let o = m.w_axis.truncate();
    // AgreementFlag: the normal points away from the material.
    let p = Plane::new(n, o);
    Ok(if e.flag(1) == Some(false) {
        p.flipped()
    } else {
        p
    })
}

/// A size for tolerances: the triangles' box diagonal.
fn extent(tris: &[Tri]) -> f64 {
    let (lo, hi) = tris.iter().flat_map(|t| t.p).fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(p), hi.max(p)),
    );
    if tris.is_empty() {
        0.0
    } else {
        (hi - lo).length()
    }
}

/// IfcBooleanResult / IfcBooleanClippingResult.
fn boolean(ctx: &Ctx, id: u32, depth: usize) -> G<Vec<Tri>> {
    let e = ctx.get(id)?;
    let op = e.arg(0).as_enum().unwrap_or_default().to_string();
    let first = item(ctx, e.reference(1)?, depth + 1)?;
    let second = ctx.get(e.reference(2)?)?;
    match op.as_str() {
        "DIFFERENCE" => {}
        "UNION" => {
            let mut all = first;
            match item(ctx, second.id, depth + 1) {
                Ok(t) => all.extend(t),
                Err(GeomError::Unsupported(k)) => ctx.notes.borrow_mut().push(k),
                Err(e) => return Err(e),
            }
            return Ok(all);
        }
        "INTERSECTION" => return intersection(ctx, first, &second, depth),
        _ => {
            ctx.notes
                .borrow_mut()
                .push(format!("IfcBooleanResult {op} (first operand kept)"));
            return Ok(first);
        }
    }
    let scale = extent(&first);
    match second.ty {
        "IFCHALFSPACESOLID" | "IFCBOXEDHALFSPACE" => {
            let plane = half_space_plane(ctx, &second)?;
            let half = Convex {
                planes: vec![plane],
                bounds: None,
                faces: Vec::new(),
            };
            Ok(cut(first, &half, scale))
        }
        "IFCPOLYGONALBOUNDEDHALFSPACE" => {
            let plane = half_space_plane(ctx, &second)?;
            let m = axis2(ctx, second.reference(2)?)?;
            let boundary =
                crate::triangulate::open_loop(crate::curve::points(ctx, second.reference(3)?)?);
            let mut out = first;
            for piece in prisms(&boundary, &m) {
                let mut c = piece;
                c.planes.push(plane);
                out = cut(out, &c, scale);
            }
            Ok(out)
        }
        _ => match convex_pieces(ctx, second.id, &DMat4::IDENTITY, depth + 1) {
            Ok(pieces) => {
                let mut out = first;
                for c in &pieces {
                    out = cut(out, c, scale);
                }
                Ok(out)
            }
            Err(GeomError::Unsupported(k)) => {
                ctx.notes
                    .borrow_mut()
                    .push(format!("IfcBooleanResult DIFFERENCE with {k} (not cut)"));
                Ok(first)
            }
            Err(e) => Err(e),
        },
    }
}

/// `first` within a half space or a convex solid `second`: cut by each
/// of its planes in turn, keeping what is behind (and closing each cut).
/// Anything else (several convex pieces) keeps `first`, noted.
fn intersection(
    ctx: &Ctx,
    first: Vec<Tri>,
    second: &crate::step::Entity,
    depth: usize,
) -> G<Vec<Tri>> {
    let planes = match second.ty {
        "IFCHALFSPACESOLID" | "IFCBOXEDHALFSPACE" => vec![half_space_plane(ctx, second)?],
        _ => match convex_pieces(ctx, second.id, &DMat4::IDENTITY, depth + 1) {
            Ok(pieces) if pieces.len() == 1 => pieces[0].planes.clone(),
            Ok(_) | Err(GeomError::Unsupported(_)) => {
                ctx.notes.borrow_mut().push(format!(
                    "IfcBooleanResult INTERSECTION with {} (first operand kept)",
                    camel(second.ty)
                ));
                return Ok(first);
            }
            Err(e) => return Err(e),
        },
    };
    let scale = extent(&first);
    let mut out = first;
    for p in planes {
        // Removing what lies in front of the plane keeps what is behind.
        let outside = Convex {
            planes: vec![p.flipped()],
            bounds: None,
            faces: Vec::new(),
        };
        out = cut(out, &outside, scale);
    }
    Ok(out)
}

/// Infinite prisms over a 2D polygon (in `m`'s XY plane, along its Z):
/// one convex piece, or one per triangle when the polygon is not convex.
fn prisms(boundary: &[DVec3], m: &DMat4) -> Vec<Convex> {
    let mut poly: Vec<DVec2> = boundary.iter().map(|p| p.truncate()).collect();
    if poly.len() < 3 {
        return Vec::new();
    }
    let area: f64 = (0..poly.len())
        .map(|i| poly[i].perp_dot(poly[(i + 1) % poly.len()]))
        .sum();
    if area < 0.0 {
        poly.reverse();
    }
    let side_planes = |loop_: &[DVec2]| -> Convex {
        let planes = (0..loop_.len())
            .filter_map(|i| {
                let (a, b) = (loop_[i], loop_[(i + 1) % loop_.len()]);
                let d = b - a;
                // Outward of a counter-clockwise loop: the edge's right.
                let n2 = DVec2::new(d.y, -d.x);
                let n = m.transform_vector3(n2.extend(0.0)).try_normalize()?;
                Some(Plane::new(n, m.transform_point3(a.extend(0.0))))
            })
            .collect();
        Convex {
            planes,
            bounds: None,
            faces: Vec::new(),
        }
    };
    if is_convex(&poly) {
        return vec![side_planes(&poly)];
    }
    triangulate_2d(&poly, &[])
        .into_iter()
        .map(|[a, b, c]| {
            let mut t = [poly[a], poly[b], poly[c]];
            if (t[1] - t[0]).perp_dot(t[2] - t[0]) < 0.0 {
                t.swap(1, 2);
            }
            side_planes(&t)
        })
        .collect()
}

fn is_convex(poly: &[DVec2]) -> bool {
    let n = poly.len();
    (0..n).all(|i| {
        let (a, b, c) = (poly[i], poly[(i + 1) % n], poly[(i + 2) % n]);
        (b - a).perp_dot(c - b) >= -1e-12 * (b - a).length() * (c - b).length()
    })
}

/// A solid as convex pieces (each the faces of a convex polytope), placed
/// by `m`: extrusions (per triangle of a non-convex profile), blocks,
/// cylinders, convex breps, mapped items of those. Anything else is
/// unsupported as a subtracted solid.
pub fn convex_pieces(ctx: &Ctx, id: u32, m: &DMat4, depth: usize) -> G<Vec<Convex>> {
    if depth > 32 {
        return Err(ctx.get(id)?.error("items nest too deep (a cycle?)").into());
    }
    let e = ctx.get(id)?;
    let faces_to_convex = |faces: Vec<Vec<DVec3>>, what: &str| -> G<Convex> {
        let placed: Vec<Vec<DVec3>> = faces
            .into_iter()
            .map(|f| f.into_iter().map(|p| m.transform_point3(p)).collect())
            .collect();
        convex_of_faces(&placed).ok_or_else(|| GeomError::Unsupported(format!("non-convex {what}")))
    };
    match e.ty {
        "IFCEXTRUDEDAREASOLID" => {
            let position = opt_axis2(ctx, &e, 1)?;
            let dir = crate::placement::direction(ctx, e.reference(2)?)? * e.real(3)?;
            let mut out = Vec::new();
            for p in profile(ctx, e.reference(0)?)? {
                if p.open {
                    return Err(GeomError::Unsupported("open profile".into()));
                }
                let loops: Vec<Vec<DVec2>> = if p.holes.is_empty() && is_convex(&p.outer) {
                    vec![p.outer.clone()]
                } else {
                    let all: Vec<DVec2> = p
                        .outer
                        .iter()
                        .chain(p.holes.iter().flatten())
                        .copied()
                        .collect();
                    triangulate_2d(&p.outer, &p.holes)
                        .into_iter()
                        .map(|[a, b, c]| vec![all[a], all[b], all[c]])
                        .collect()
                };
                for l in loops {
                    let bottom: Vec<DVec3> = l
                        .iter()
                        .map(|q| position.transform_point3(q.extend(0.0)))
                        .collect();
                    let top: Vec<DVec3> = l
                        .iter()
                        .map(|q| position.transform_point3(q.extend(0.0) + dir))
                        .collect();
                    let mut faces = vec![bottom.clone(), top.clone()];
                    for i in 0..l.len() {
                        let j = (i + 1) % l.len();
                        faces.push(vec![bottom[i], bottom[j], top[j], top[i]]);
                    }
                    out.push(faces_to_convex(faces, "extrusion")?);
                }
            }
            Ok(out)
        }
        "IFCBLOCK" | "IFCRIGHTCIRCULARCYLINDER" => primitive_faces(ctx, id)?
            .into_iter()
            .map(|f| faces_to_convex(f, "primitive"))
            .collect(),
        "IFCFACETEDBREP" | "IFCFACETEDBREPWITHVOIDS" | "IFCADVANCEDBREP" => {
            let tris = crate::brep::brep(ctx, id)?;
            let faces = tris.into_iter().map(|t| t.p.to_vec()).collect();
            Ok(vec![faces_to_convex(faces, "brep")?])
        }
        "IFCMAPPEDITEM" => {
            let map = ctx.expect(e.reference(0)?, &["IFCREPRESENTATIONMAP"])?;
            let target = transform_operator(ctx, e.reference(1)?)?;
            let origin = axis2(ctx, map.reference(0)?)?;
            let rep = ctx.get(map.reference(1)?)?;
            let inner = *m * target * origin;
            let mut out = Vec::new();
            for i in rep.refs(3)? {
                out.extend(convex_pieces(ctx, i, &inner, depth + 1)?);
            }
            Ok(out)
        }
        other => Err(GeomError::Unsupported(camel(other))),
    }
}

/// IfcBlock (Position, XLength, YLength, ZLength) and
/// IfcRightCircularCylinder (Position, Height, Radius) as one convex
/// polytope's faces.
fn primitive_faces(ctx: &Ctx, id: u32) -> G<Vec<Vec<Vec<DVec3>>>> {
    let e = ctx.get(id)?;
    let m = opt_axis2(ctx, &e, 0)?;
    let (base, h): (Vec<DVec2>, f64) = if e.ty == "IFCBLOCK" {
        let (x, y) = (e.real(1)?, e.real(2)?);
        (
            vec![
                DVec2::ZERO,
                DVec2::new(x, 0.0),
                DVec2::new(x, y),
                DVec2::new(0.0, y),
            ],
            e.real(3)?,
        )
    } else {
        let r = e.real(2)?;
        let n = ctx.circle_segments(r, std::f64::consts::TAU);
        (
            (0..n)
                .map(|i| {
                    let t = std::f64::consts::TAU * i as f64 / n as f64;
                    DVec2::new(r * t.cos(), r * t.sin())
                })
                .collect(),
            e.real(1)?,
        )
    };
    if h.is_nan() || h <= 0.0 {
        return Err(e.error("height must be positive").into());
    }
    let bottom: Vec<DVec3> = base
        .iter()
        .rev()
        .map(|q| m.transform_point3(q.extend(0.0)))
        .collect();
    let top: Vec<DVec3> = base
        .iter()
        .map(|q| m.transform_point3(q.extend(h)))
        .collect();
    let n = base.len();
    let mut faces = vec![bottom, top];
    for i in 0..n {
        let j = (i + 1) % n;
        faces.push(vec![
            m.transform_point3(base[i].extend(0.0)),
            m.transform_point3(base[j].extend(0.0)),
            m.transform_point3(base[j].extend(h)),
            m.transform_point3(base[i].extend(h)),
        ]);
    }
    Ok(vec![faces])
}
