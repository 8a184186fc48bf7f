//! Cutting triangles by planes: half-space clipping (IfcHalfSpaceSolid,
//! IfcPolygonalBoundedHalfSpace in IfcBooleanClippingResult) and the
//! subtraction of convex solids (openings, boolean differences), exact for
//! a convex solid: a triangle is split by each of its planes in turn and
//! only what ends up behind all of them is dropped.

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

/// Keeps the parts of `tris` in front of `plane`.
pub fn clip(tris: Vec<Tri>, plane: &Plane, scale: f64) -> Vec<Tri> {
    let mut front = Vec::with_capacity(tris.len());
    let mut back = Vec::new();
    for t in &tris {
        split(t, plane, scale, &mut front, &mut back);
        back.clear();
    }
    front
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
            if tlo.cmpgt(hi).any() || thi.cmplt(lo).any() {
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

/// The sides of the hole convex `opening` cuts in convex `element`: the
/// opening's faces clipped to inside the element, facing into the hole.
pub fn reveals(opening: &Convex, element: &Convex, scale: f64) -> Vec<Tri> {
    let mut out = Vec::new();
    for f in &opening.faces {
        let mut tris: Vec<Tri> = (1..f.len().saturating_sub(1))
            .map(|i| Tri::new(f[0], f[i + 1], f[i]))
            .collect();
        for p in &element.planes {
            tris = clip(tris, &p.flipped(), scale);
        }
        // What lies on the element's own faces is its surface, not a
        // reveal.
        tris.retain(|t| {
            element
                .planes
                .iter()
                .all(|p| t.p.iter().any(|&q| p.distance(q) < -EPS.max(scale * 1e-9)))
        });
        out.extend(tris);
    }
    out
}
