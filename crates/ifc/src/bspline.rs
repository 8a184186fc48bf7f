//! B-splines: IfcBSplineCurveWithKnots and IfcBSplineSurfaceWithKnots,
//! rational ones too, evaluated by de Boor's algorithm on homogeneous
//! points; curves as polylines, surfaces as grids over their whole
//! parameter range.

use glam::{DVec3, DVec4};

use crate::geom::{Ctx, Tri, G};
use crate::placement::point;
use crate::step::{Entity, Value};

/// Samples per knot span of a curve, and per direction of the coarse
/// grid a surface's sag is measured on.
const SAMPLES_PER_SPAN: usize = 8;

/// How far a surface's triangles may stray from it (metres), as
/// IfcOpenShell's default deflection.
const DEFLECTION: f64 = 0.001;

/// A B-spline of degree `degree` over the expanded knot vector `knots`.
struct Basis {
    degree: usize,
    knots: Vec<f64>,
}

impl Basis {
    /// From multiplicities and distinct knots, checked against the number
    /// of control points.
    fn new(e: &Entity, degree: usize, mult: &[Value], knots: &[Value], n: usize) -> G<Basis> {
        let mut k = Vec::new();
        for (m, v) in mult.iter().zip(knots) {
            let (Some(m), Some(v)) = (m.as_f64(), v.as_f64()) else {
                return Err(e.error("knots and multiplicities must be numbers").into());
            };
            for _ in 0..(m as usize).min(64) {
                k.push(v);
            }
        }
        if degree == 0 || n <= degree || k.len() != n + degree + 1 {
            return Err(e
                .error(format!(
                    "{} knots for {n} control points of degree {degree}",
                    k.len()
                ))
                .into());
        }
        if k.windows(2).any(|w| w[1] < w[0]) || k.iter().any(|v| !v.is_finite()) {
            return Err(e.error("knots must not decrease").into());
        }
        Ok(Basis { degree, knots: k })
    }

    fn range(&self) -> (f64, f64) {
        let n = self.knots.len() - self.degree - 1;
        (self.knots[self.degree], self.knots[n])
    }

    fn spans(&self) -> usize {
        let (a, b) = self.range();
        let mut inner: Vec<f64> = self
            .knots
            .iter()
            .copied()
            .filter(|&k| k > a && k < b)
            .collect();
        inner.dedup();
        inner.len() + 1
    }

    /// The curve through homogeneous `ctrl` at `t` (de Boor).
    fn eval(&self, ctrl: &[DVec4], t: f64) -> DVec4 {
        let p = self.degree;
        let n = ctrl.len();
        let u = &self.knots;
        let mut k = p;
        while k + 1 < n && t >= u[k + 1] {
            k += 1;
        }
        let mut d: Vec<DVec4> = (0..=p).map(|j| ctrl[j + k - p]).collect();
        for r in 1..=p {
            for j in (r..=p).rev() {
                let i = j + k - p;
                let den = u[i + p + 1 - r] - u[i];
                let a = if den.abs() < 1e-300 {
                    0.0
                } else {
                    (t - u[i]) / den
                };
                d[j] = d[j - 1] * (1.0 - a) + d[j] * a;
            }
        }
        d[p]
    }
}

fn project(h: DVec4) -> DVec3 {
    if h.w.abs() < 1e-300 {
        h.truncate()
    } else {
        h.truncate() / h.w
    }
}

fn homogeneous(p: DVec3, w: f64) -> DVec4 {
    (p * w).extend(w)
}

/// An IfcBSplineCurveWithKnots (or rational) as a polyline.
pub fn curve(ctx: &Ctx, e: &Entity) -> G<Vec<DVec3>> {
    let degree = e.real(0)? as usize;
    let pts: Vec<DVec3> = e
        .refs(1)?
        .into_iter()
        .map(|p| point(ctx, p))
        .collect::<G<_>>()?;
    let weights = if e.ty == "IFCRATIONALBSPLINECURVEWITHKNOTS" {
        e.reals(8)?
    } else {
        vec![1.0; pts.len()]
    };
    if weights.len() != pts.len() {
        return Err(e.error("one weight per control point").into());
    }
    let basis = Basis::new(e, degree, e.list(5)?, e.list(6)?, pts.len())?;
    let ctrl: Vec<DVec4> = pts
        .iter()
        .zip(&weights)
        .map(|(p, w)| homogeneous(*p, *w))
        .collect();
    let (a, b) = basis.range();
    let n = (basis.spans() * SAMPLES_PER_SPAN).clamp(2, 512);
    Ok((0..=n)
        .map(|i| project(basis.eval(&ctrl, a + (b - a) * i as f64 / n as f64)))
        .collect())
}

/// An IfcBSplineSurfaceWithKnots (or rational) over its whole parameter
/// range, wound so its normal is du x dv (`flip` reverses it).
pub fn surface(ctx: &Ctx, e: &Entity, flip: bool) -> G<Vec<Tri>> {
    let (du, dv) = (e.real(0)? as usize, e.real(1)? as usize);
    let rows: Vec<Vec<DVec3>> = e
        .list(2)?
        .iter()
        .map(|row| {
            row.as_list()
                .unwrap_or(&[])
                .iter()
                .map(|p| match p {
                    Value::Ref(r) => point(ctx, *r),
                    _ => Err(e.error("control points must be references").into()),
                })
                .collect::<G<Vec<_>>>()
        })
        .collect::<G<_>>()?;
    let nu = rows.len();
    let nv = rows.first().map_or(0, Vec::len);
    if nu == 0 || rows.iter().any(|r| r.len() != nv) {
        return Err(e.error("control points must form a grid").into());
    }
    let weights: Vec<Vec<f64>> = if e.ty == "IFCRATIONALBSPLINESURFACEWITHKNOTS" {
        e.list(12)?
            .iter()
            .map(|r| {
                r.as_list()
                    .unwrap_or(&[])
                    .iter()
                    .filter_map(Value::as_f64)
                    .collect()
            })
            .collect()
    } else {
        vec![vec![1.0; nv]; nu]
    };
    if weights.len() != nu || weights.iter().any(|r| r.len() != nv) {
        return Err(e.error("one weight per control point").into());
    }
    let bu = Basis::new(e, du, e.list(7)?, e.list(9)?, nu)?;
    let bv = Basis::new(e, dv, e.list(8)?, e.list(10)?, nv)?;
    let ctrl: Vec<Vec<DVec4>> = rows
        .iter()
        .zip(&weights)
        .map(|(r, w)| r.iter().zip(w).map(|(p, w)| homogeneous(*p, *w)).collect())
        .collect();
    let ((u0, u1), (v0, v1)) = (bu.range(), bv.range());
    let eval = |u: f64, v: f64| -> DVec3 {
        let col: Vec<DVec4> = ctrl.iter().map(|row| bv.eval(row, v)).collect();
        project(bu.eval(&col, u))
    };
    // Samples per direction for chords within the deflection: measured
    // on a coarse grid (a chord's sag falls with the square of the
    // samples).
    let tolerance = DEFLECTION / ctx.length;
    let coarse = |spans: usize| (spans * SAMPLES_PER_SPAN).clamp(2, 32);
    let (cu, cv) = (coarse(bu.spans()), coarse(bv.spans()));
    let mut sag_u: f64 = 0.0;
    let mut sag_v: f64 = 0.0;
    for i in 0..cu {
        for j in 0..=cv {
            let (ua, ub) = (
                u0 + (u1 - u0) * i as f64 / cu as f64,
                u0 + (u1 - u0) * (i + 1) as f64 / cu as f64,
            );
            let v = v0 + (v1 - v0) * j as f64 / cv as f64;
            let mid = eval((ua + ub) / 2.0, v);
            sag_u = sag_u.max((mid - (eval(ua, v) + eval(ub, v)) / 2.0).length());
        }
    }
    for j in 0..cv {
        for i in 0..=cu {
            let (va, vb) = (
                v0 + (v1 - v0) * j as f64 / cv as f64,
                v0 + (v1 - v0) * (j + 1) as f64 / cv as f64,
            );
            let u = u0 + (u1 - u0) * i as f64 / cu as f64;
            let mid = eval(u, (va + vb) / 2.0);
            sag_v = sag_v.max((mid - (eval(u, va) + eval(u, vb)) / 2.0).length());
        }
    }
    // A twisted patch has straight isolines but bulges off the diagonal
    // its cells are split along: the centre's distance from the
    // diagonal's midpoint counts in both directions.
    for i in 0..cu {
        for j in 0..cv {
            let u = |k: usize| u0 + (u1 - u0) * k as f64 / cu as f64;
            let v = |k: usize| v0 + (v1 - v0) * k as f64 / cv as f64;
            let corners = (eval(u(i), v(j)) + eval(u(i + 1), v(j + 1))) / 2.0;
            let centre = eval((u(i) + u(i + 1)) / 2.0, (v(j) + v(j + 1)) / 2.0);
            let twist = (centre - corners).length();
            sag_u = sag_u.max(twist);
            sag_v = sag_v.max(twist);
        }
    }
    let samples = |coarse: usize, spans: usize, sag: f64| -> usize {
        let n = (coarse as f64 * (sag / tolerance).sqrt()).ceil();
        (n as usize).clamp(spans.max(1), 128)
    };
    let su = samples(cu, bu.spans(), sag_u);
    let sv = samples(cv, bv.spans(), sag_v);
    // Each row of control points as a curve in v, sampled once; then the
    // surface along u through those samples.
    let along_v: Vec<Vec<DVec4>> = (0..=sv)
        .map(|j| {
            let v = v0 + (v1 - v0) * j as f64 / sv as f64;
            ctrl.iter().map(|row| bv.eval(row, v)).collect()
        })
        .collect();
    let mut grid = Vec::with_capacity((su + 1) * (sv + 1));
    for i in 0..=su {
        let u = u0 + (u1 - u0) * i as f64 / su as f64;
        for col in &along_v {
            grid.push(project(bu.eval(col, u)));
        }
    }
    let at = |i: usize, j: usize| grid[i * (sv + 1) + j];
    let mut out = Vec::with_capacity(su * sv * 2);
    for i in 0..su {
        for j in 0..sv {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            for t in [[a, b, c], [a, c, d]] {
                out.push(if flip {
                    Tri::new(t[0], t[2], t[1])
                } else {
                    Tri::new(t[0], t[1], t[2])
                });
            }
        }
    }
    Ok(out)
}
