//! IFC4 tessellated items: IfcTriangulatedFaceSet and IfcPolygonalFaceSet
//! (faces with voids too), with their IfcIndexedColourMap's per-face
//! colours.

use glam::DVec3;

use crate::colour::linear;
use crate::curve::point_list;
use crate::geom::{Ctx, Tri, G, UNSET};
use crate::step::{Entity, Value};
use crate::triangulate::triangulate_3d;

/// 1-based indices of a list of integers.
fn ints(e: &Entity, v: &Value) -> G<Vec<i64>> {
    v.as_list()
        .ok_or_else(|| e.error("expected a list of indices"))?
        .iter()
        .map(|i| match i {
            Value::Int(i) => Ok(*i),
            Value::Typed(_, b) => match **b {
                Value::Int(i) => Ok(i),
                _ => Err(e.error("expected an integer index").into()),
            },
            _ => Err(e.error("expected an integer index").into()),
        })
        .collect()
}

/// Triangles of an IfcTriangulatedFaceSet or IfcPolygonalFaceSet.
pub fn face_set(ctx: &Ctx, id: u32) -> G<Vec<Tri>> {
    let e = ctx.get(id)?;
    let coords = ctx.expect(e.reference(0)?, &["IFCCARTESIANPOINTLIST3D"])?;
    let pts = point_list(&coords)?;
    // Optional PnIndex maps face indices to the point list.
    let pn_index = if e.ty == "IFCTRIANGULATEDFACESET" {
        4
    } else {
        3
    };
    let pn = match e.arg(pn_index) {
        v @ Value::List(_) => Some(ints(&e, v)?),
        _ => None,
    };
    let at = |i: i64| -> G<DVec3> {
        let i = match &pn {
            Some(pn) => *pn
                .get((i - 1) as usize)
                .ok_or_else(|| e.error(format!("index {i} outside PnIndex")))?,
            None => i,
        };
        pts.get((i - 1) as usize)
            .copied()
            .ok_or_else(|| e.error(format!("point index {i} out of range")).into())
    };
    let mut out = Vec::new();
    // The colour map's faces index the face list: record each face's
    // first triangle.
    let mut face_start = Vec::new();
    if e.ty == "IFCTRIANGULATEDFACESET" {
        for f in e.list(3)? {
            let idx = ints(&e, f)?;
            face_start.push(out.len());
            if idx.len() == 3 {
                out.push(Tri::new(at(idx[0])?, at(idx[1])?, at(idx[2])?));
            }
        }
    } else {
        for f in e.refs(2)? {
            let face = ctx.expect(
                f,
                &[
                    "IFCINDEXEDPOLYGONALFACE",
                    "IFCINDEXEDPOLYGONALFACEWITHVOIDS",
                ],
            )?;
            let mut loops = vec![ints(&face, face.arg(0))?
                .into_iter()
                .map(at)
                .collect::<G<Vec<_>>>()?];
            if face.ty == "IFCINDEXEDPOLYGONALFACEWITHVOIDS" {
                for inner in face.list(1)? {
                    loops.push(ints(&face, inner)?.into_iter().map(at).collect::<G<_>>()?);
                }
            }
            face_start.push(out.len());
            out.extend(
                triangulate_3d(&loops)
                    .into_iter()
                    .map(|[a, b, c]| Tri::new(a, b, c)),
            );
        }
    }
    face_start.push(out.len());
    if let Some(&map) = ctx.colour_maps.get(&id) {
        colour_faces(ctx, map, &face_start, &mut out)?;
    }
    Ok(out)
}

/// Colours each face's triangles from IfcIndexedColourMap `map`
/// (MappedTo, Opacity, Colours, ColourIndex).
fn colour_faces(ctx: &Ctx, map: u32, face_start: &[usize], out: &mut [Tri]) -> G<()> {
    let m = ctx.get(map)?;
    // Opacity: 1 is opaque.
    let alpha = m.opt_real(1).map_or(1.0, |o| o.clamp(0.0, 1.0) as f32);
    let list = ctx.expect(m.reference(2)?, &["IFCCOLOURRGBLIST"])?;
    let colours: Vec<[f32; 4]> = list
        .list(0)?
        .iter()
        .map(|c| {
            let v: Vec<f64> = c
                .as_list()
                .unwrap_or(&[])
                .iter()
                .filter_map(Value::as_f64)
                .collect();
            match v.as_slice() {
                [r, g, b] => {
                    let [r, g, b] = linear([*r, *g, *b]);
                    [r, g, b, alpha]
                }
                _ => UNSET,
            }
        })
        .collect();
    let index = ints(&m, m.arg(3))?;
    for (f, &ci) in index.iter().enumerate() {
        let Some(&c) = colours.get((ci - 1) as usize) else {
            continue;
        };
        let (Some(&s), Some(&t)) = (face_start.get(f), face_start.get(f + 1)) else {
            break;
        };
        for tri in &mut out[s..t] {
            tri.c = c;
        }
    }
    Ok(())
}
