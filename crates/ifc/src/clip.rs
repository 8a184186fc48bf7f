//! Cutting closed meshes by convex solids: half spaces (IfcHalfSpaceSolid,
//! IfcPolygonalBoundedHalfSpace in IfcBooleanClippingResult), openings and
//! boolean differences. Exact for a convex solid: a triangle is split by
//! each of its planes in turn and only what ends up behind all of them is
//! dropped; the solid's faces inside the mesh close the cut.

use glam::DVec3;

use crate::geom::Tri;

/// A plane `n · p = d`; "behind" (inside a solid) is `n · p < d`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    pub n: DVec3,
    pub d: f64,
}

impl Plane {
    pub fn new(n: DVec3, at: DVec3) -> Plane {
        Plane { n, d: n.dot(at) }
    }

    pub fn distance(&self, p: DVec3) -> f64 {
        self.n.dot(p) - self.d
    }

    pub fn flipped(&self) -> Plane {
        Plane {
            n: -self.n,
            d: -self.d,
        }
    }
}

/// A convex solid: the intersection of its planes' back sides.
#[derive(Clone, Debug, Default)]
pub struct Convex {
    pub planes: Vec<Plane>,
    /// Its box (None: unbounded, e.g. a bounded half space).
    pub bounds: Option<(DVec3, DVec3)>,
    /// Its faces wound outward, when bounded: what an opening's reveals
    /// are made of.
    pub faces: Vec<Vec<DVec3>>,
}

/// Distances this close to a plane count as on it (file units; IFC
/// coordinates are millimetres or metres, so well below any feature).
const EPS: f64 = 1e-9;

/// Splits `t` by `plane` into the parts in front of it and behind it.
/// A triangle in the plane goes behind when it faces as the plane does
/// (a face that a subtracted solid shares goes with it), else in front.
pub fn split(t: &Tri, plane: &Plane, scale: f64, front: &mut Vec<Tri>, back: &mut Vec<Tri>) {
    let eps = EPS.max(scale * 1e-9);
    let d = t.p.map(|p| plane.distance(p));
    let pos = d.iter().filter(|&&x| x > eps).count();
    let neg = d.iter().filter(|&&x| x < -eps).count();
    if neg == 0 && pos == 0 {
        if t.cross().dot(plane.n) > 0.0 {
            back.push(*t);
        } else {
            front.push(*t);
        }
        return;
    }
    if neg == 0 {
        front.push(*t);
        return;
    }
    if pos == 0 {
        back.push(*t);
        return;
    }
    // Walk the polygon, emitting each side's vertices with the crossing
    // points; each side's polygon (at most 4 corners) is fanned.
    let mut f: Vec<DVec3> = Vec::with_capacity(4);
    let mut b: Vec<DVec3> = Vec::with_capacity(4);
    for i in 0..3 {
        let (p, q) = (t.p[i], t.p[(i + 1) % 3]);
        let (dp, dq) = (d[i], d[(i + 1) % 3]);
        if dp >= -eps {
            f.push(p);
        }
        if dp <= eps {
            b.push(p);
        }
        if (dp > eps && dq < -eps) || (dp < -eps && dq > eps) {
            let x = p + (q - p) * (dp / (dp - dq));
            f.push(x);
            b.push(x);
        }
    }
    for (poly, out) in [(f, front), (b, back)] {
        for i in 1..poly.len().saturating_sub(1) {
            out.push(Tri {
                p: [poly[0], poly[i], poly[i + 1]],
                c: t.c,
            });
        }
    }
}

/// The closed mesh `solid` minus the convex solid `c`, closed again: its
/// triangles outside `c` and `c`'s surface inside it (an opening's
/// reveals, a clipping plane's cap), in the solid's first colour.
pub fn cut(solid: Vec<Tri>, c: &Convex, scale: f64) -> Vec<Tri> {
    let mut closing = surface_inside(c, &solid, scale);
    if let Some(first) = solid.first() {
        for t in &mut closing {
            t.c = first.c;
        }
    }
    let mut out = subtract(solid, c, scale);
    out.append(&mut closing);
    out
}

/// `tris` minus the convex solid `c`. Each triangle is cut as a convex
/// polygon: what lies in front of a plane is done (fanned into
/// triangles), what lies behind goes on to the next plane, and what is
/// behind all of them is inside the solid and dropped.
pub fn subtract(tris: Vec<Tri>, c: &Convex, scale: f64) -> Vec<Tri> {
    if c.planes.is_empty() {
        return tris;
    }
    let eps = EPS.max(scale * 1e-9);
    let mut out = Vec::with_capacity(tris.len());
    let mut front = Vec::new();
    let mut back = Vec::new();
    'tris: for t in tris {
        if let Some((lo, hi)) = c.bounds {
            let (tlo, thi) = (
                t.p[0].min(t.p[1]).min(t.p[2]),
                t.p[0].max(t.p[1]).max(t.p[2]),
            );
            // Touching counts: a face flush with the solid's may go with it.
            if tlo.cmpgt(hi + eps).any() || thi.cmplt(lo - eps).any() {
                out.push(t);
                continue;
            }
        }
        // A triangle wholly in front of any plane is outside: kept whole.
        if c.planes.iter().any(|p| in_front(&t, p, scale)) {
            out.push(t);
            continue;
        }
        let normal = t.cross();
        let mut inside: Vec<DVec3> = t.p.to_vec();
        for plane in &c.planes {
            let d: Vec<f64> = inside.iter().map(|&q| plane.distance(q)).collect();
            let pos = d.iter().any(|&x| x > eps);
            let neg = d.iter().any(|&x| x < -eps);
            match (pos, neg) {
                // In the plane: behind when it faces as the plane does (a
                // face the solid shares goes with it).
                (false, false) if normal.dot(plane.n) <= 0.0 => {
                    fan(&inside, t.c, &mut out);
                    continue 'tris;
                }
                (false, _) => continue,
                (true, false) => {
                    fan(&inside, t.c, &mut out);
                    continue 'tris;
                }
                (true, true) => {}
            }
            front.clear();
            back.clear();
            for i in 0..inside.len() {
                let j = (i + 1) % inside.len();
                let (p, q, dp, dq) = (inside[i], inside[j], d[i], d[j]);
                if dp >= -eps {
                    front.push(p);
                }
                if dp <= eps {
                    back.push(p);
                }
                if (dp > eps && dq < -eps) || (dp < -eps && dq > eps) {
                    let x = p + (q - p) * (dp / (dp - dq));
                    front.push(x);
                    back.push(x);
                }
            }
            fan(&front, t.c, &mut out);
            std::mem::swap(&mut inside, &mut back);
        }
    }
    out
}

/// A convex polygon's triangles, fanned from its first corner.
fn fan(poly: &[DVec3], c: [f32; 4], out: &mut Vec<Tri>) {
    for i in 1..poly.len().saturating_sub(1) {
        out.push(Tri {
            p: [poly[0], poly[i], poly[i + 1]],
            c,
        });
    }
}

/// Whether all of `t` is in front of `plane` (touching it counts).
fn in_front(t: &Tri, plane: &Plane, scale: f64) -> bool {
    let eps = EPS.max(scale * 1e-9);
    t.p.iter().all(|&p| plane.distance(p) >= -eps)
        && !t.p.iter().all(|&p| plane.distance(p).abs() <= eps)
}

/// The convex hull's planes of a convex point set given as faces
/// (polygons), oriented outward by the centroid; None when the faces do
/// not bound a convex solid.
pub fn convex_of_faces(faces: &[Vec<DVec3>]) -> Option<Convex> {
    let all: Vec<DVec3> = faces.iter().flatten().copied().collect();
    if all.len() < 4 {
        return None;
    }
    let centre = all.iter().copied().sum::<DVec3>() / all.len() as f64;
    let (lo, hi) = all.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let size = (hi - lo).length();
    let mut planes: Vec<Plane> = Vec::new();
    let mut outward = Vec::with_capacity(faces.len());
    for f in faces {
        let Some(n) = crate::triangulate::newell(f).try_normalize() else {
            continue;
        };
        let mut p = Plane::new(n, f[0]);
        if p.distance(centre) > 0.0 {
            p = p.flipped();
            outward.push(f.iter().rev().copied().collect());
        } else {
            outward.push(f.clone());
        }
        if all.iter().any(|&q| p.distance(q) > size * 1e-6) {
            return None;
        }
        if !planes
            .iter()
            .any(|o| o.n.dot(p.n) > 1.0 - 1e-9 && (o.d - p.d).abs() < size * 1e-9)
        {
            planes.push(p);
        }
    }
    (planes.len() >= 4).then_some(Convex {
        planes,
        bounds: Some((lo, hi)),
        faces: outward,
    })
}

/// The surface subtracting convex `c` from the closed mesh `solid` makes:
/// the parts of `c`'s faces inside `solid`, facing into `c` (an opening's
/// reveals, a clipping plane's cap). Each face is cut by the planes of
/// the solid's triangles near it, so every piece lies wholly inside or
/// outside, and a piece is kept when rays from its centre cross the
/// solid an odd number of times (two of three rays agreeing).
pub fn surface_inside(c: &Convex, solid: &[Tri], scale: f64) -> Vec<Tri> {
    let eps = EPS.max(scale * 1e-9);
    let Some((lo, hi)) = bounds_of(solid) else {
        return Vec::new();
    };
    let faces = if c.faces.is_empty() {
        faces_within(c, lo, hi)
    } else {
        c.faces.clone()
    };
    let mut out = Vec::new();
    for f in &faces {
        // Facing into the solid `c`: the face's winding reversed.
        let mut pieces: Vec<Tri> = (1..f.len().saturating_sub(1))
            .map(|i| Tri::new(f[0], f[i + 1], f[i]))
            .collect();
        let Some((flo, fhi)) = bounds_of(&pieces) else {
            continue;
        };
        let near: Vec<&Tri> = solid
            .iter()
            .filter(|t| {
                let (tlo, thi) = (
                    t.p[0].min(t.p[1]).min(t.p[2]),
                    t.p[0].max(t.p[1]).max(t.p[2]),
                );
                !(tlo.cmpgt(fhi + eps).any() || thi.cmplt(flo - eps).any())
            })
            .collect();
        let mut planes: Vec<Plane> = Vec::new();
        for t in &near {
            let Some(n) = t.cross().try_normalize() else {
                continue;
            };
            let p = Plane::new(n, t.p[0]);
            if !planes
                .iter()
                .any(|o| (o.n.dot(p.n).abs() > 1.0 - 1e-12) && (o.distance(t.p[0])).abs() < eps)
            {
                planes.push(p);
            }
        }
        for plane in &planes {
            let mut front = Vec::with_capacity(pieces.len());
            let mut back = Vec::new();
            for t in &pieces {
                split(t, plane, scale, &mut front, &mut back);
            }
            front.append(&mut back);
            pieces = front;
        }
        for t in pieces {
            let centre = (t.p[0] + t.p[1] + t.p[2]) / 3.0;
            if near.iter().any(|s| on_triangle(s, centre, eps)) {
                continue;
            }
            if inside(solid, centre) {
                out.push(t);
            }
        }
    }
    out
}

/// The box around triangles, if any.
fn bounds_of(tris: &[Tri]) -> Option<(DVec3, DVec3)> {
    let first = tris.first()?.p[0];
    Some(
        tris.iter()
            .flat_map(|t| t.p)
            .fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p))),
    )
}

/// The faces of `c` cut to the box `lo`..`hi` grown by its diagonal: an
/// unbounded solid's (a half space's) faces where a solid in the box
/// can meet them.
fn faces_within(c: &Convex, lo: DVec3, hi: DVec3) -> Vec<Vec<DVec3>> {
    let centre = (lo + hi) / 2.0;
    let h = (hi - lo).length().max(1e-6) * 2.0;
    let mut out = Vec::new();
    for (i, p) in c.planes.iter().enumerate() {
        let o = centre - p.n * p.distance(centre);
        let u = p.n.any_orthonormal_vector();
        let v = p.n.cross(u);
        let mut poly = vec![
            o - u * h - v * h,
            o + u * h - v * h,
            o + u * h + v * h,
            o - u * h + v * h,
        ];
        for (j, q) in c.planes.iter().enumerate() {
            if i != j {
                poly = keep_behind(&poly, q);
            }
        }
        if poly.len() >= 3 {
            out.push(poly);
        }
    }
    out
}

/// The part of convex polygon `poly` behind `plane`.
fn keep_behind(poly: &[DVec3], plane: &Plane) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for i in 0..poly.len() {
        let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
        let (dp, dq) = (plane.distance(p), plane.distance(q));
        if dp <= 0.0 {
            out.push(p);
        }
        if (dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0) {
            out.push(p + (q - p) * (dp / (dp - dq)));
        }
    }
    out
}

/// Whether `p` lies on triangle `t` (in its plane, within its edges).
fn on_triangle(t: &Tri, p: DVec3, eps: f64) -> bool {
    let n = t.cross();
    let len = n.length();
    if len < 1e-300 || (p - t.p[0]).dot(n / len).abs() > eps {
        return false;
    }
    (0..3).all(|i| {
        let (a, b) = (t.p[i], t.p[(i + 1) % 3]);
        (b - a).cross(p - a).dot(n) >= -eps * len
    })
}

/// Whether `p` is inside the closed mesh `solid`, by the parity of three
/// skewed rays' crossings (the majority, so a ray through an edge does
/// not decide alone).
fn inside(solid: &[Tri], p: DVec3) -> bool {
    const RAYS: [DVec3; 3] = [
        DVec3::new(0.5773, 0.5774, 0.5771),
        DVec3::new(-0.6123, 0.3217, 0.7222),
        DVec3::new(0.2311, -0.8867, 0.4003),
    ];
    let odd = RAYS
        .iter()
        .filter(|d| solid.iter().filter(|t| crosses(t, p, **d)).count() % 2 == 1)
        .count();
    odd >= 2
}

/// Whether the ray from `o` along `d` crosses triangle `t`
/// (Möller-Trumbore).
fn crosses(t: &Tri, o: DVec3, d: DVec3) -> bool {
    let (e1, e2) = (t.p[1] - t.p[0], t.p[2] - t.p[0]);
    let h = d.cross(e2);
    let a = e1.dot(h);
    if a.abs() < 1e-300 {
        return false;
    }
    let f = 1.0 / a;
    let s = o - t.p[0];
    let u = f * s.dot(h);
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let q = s.cross(e1);
    let v = f * d.dot(q);
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    f * e2.dot(q) > 0.0
}
