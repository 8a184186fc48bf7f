//! IfcSweptDiskSolid (pipes, cables, reinforcement): a circle (a ring
//! with an inner radius) swept along a directrix polyline or composite
//! curve, its frames carried along without twist.

use glam::DVec3;

use crate::curve;
use crate::geom::{Ctx, Tri, G};

/// Triangles of IfcSweptDiskSolid `id` (Directrix, Radius, InnerRadius,
/// StartParam, EndParam; the parameters are not read: the whole
/// directrix is swept).
pub fn swept_disk(ctx: &Ctx, id: u32) -> G<Vec<Tri>> {
    let e = ctx.get(id)?;
    let mut path = curve::points(ctx, e.reference(0)?)?;
    path.dedup_by(|a, b| a.distance_squared(*b) < 1e-18);
    let r = e.real(1)?;
    if r.is_nan() || r <= 0.0 || path.len() < 2 {
        return Err(e
            .error("needs a positive radius and a directrix of 2 points or more")
            .into());
    }
    let inner = e.opt_real(2).filter(|&ri| ri > 0.0 && ri < r);
    let n = ctx.circle_segments(r, std::f64::consts::TAU).clamp(6, 32);
    let mut out = Vec::new();
    let rings_outer = rings(&path, r, n);
    tube(&rings_outer, false, &mut out);
    let last = rings_outer.len() - 1;
    match inner {
        Some(ri) => {
            let rings_inner = rings(&path, ri, n);
            tube(&rings_inner, true, &mut out);
            for (k, flip) in [(0, true), (last, false)] {
                for i in 0..n {
                    let j = (i + 1) % n;
                    let (a, b, c, d) = (
                        rings_outer[k][i],
                        rings_outer[k][j],
                        rings_inner[k][j],
                        rings_inner[k][i],
                    );
                    push_quad(&mut out, [a, b, c, d], flip);
                }
            }
        }
        None => {
            for (k, flip) in [(0, true), (last, false)] {
                let c = path[if k == 0 { 0 } else { path.len() - 1 }];
                for i in 0..n {
                    let (a, b) = (rings_outer[k][i], rings_outer[k][(i + 1) % n]);
                    out.push(if flip {
                        Tri::new(c, b, a)
                    } else {
                        Tri::new(c, a, b)
                    });
                }
            }
        }
    }
    Ok(out)
}

fn push_quad(out: &mut Vec<Tri>, [a, b, c, d]: [DVec3; 4], flip: bool) {
    if flip {
        out.push(Tri::new(a, c, b));
        out.push(Tri::new(a, d, c));
    } else {
        out.push(Tri::new(a, b, c));
        out.push(Tri::new(a, c, d));
    }
}

/// A ring of `n` points of radius `r` around each path point, in the
/// plane bisecting the path's turn there.
fn rings(path: &[DVec3], r: f64, n: usize) -> Vec<Vec<DVec3>> {
    let tangent = |i: usize| -> DVec3 {
        let a = if i > 0 {
            (path[i] - path[i - 1]).normalize_or_zero()
        } else {
            DVec3::ZERO
        };
        let b = if i + 1 < path.len() {
            (path[i + 1] - path[i]).normalize_or_zero()
        } else {
            DVec3::ZERO
        };
        (a + b).normalize_or(b.normalize_or(a))
    };
    let mut u = tangent(0).any_orthonormal_vector();
    let mut out = Vec::with_capacity(path.len());
    for (i, &p) in path.iter().enumerate() {
        let t = tangent(i);
        // Parallel transport: the previous frame's u, made normal to t.
        u = (u - t * u.dot(t)).normalize_or(t.any_orthonormal_vector());
        let v = t.cross(u);
        // At a bend the ring lies in the bisecting plane: stretch it along
        // the bend so the tube keeps its radius on both segments.
        let stretch = if i > 0 && i + 1 < path.len() {
            let d = (path[i] - path[i - 1]).normalize_or_zero();
            1.0 / d.dot(t).abs().max(0.2)
        } else {
            1.0
        };
        let bend = if i > 0 && i + 1 < path.len() {
            let d = (path[i + 1] - path[i]).normalize_or_zero()
                - (path[i] - path[i - 1]).normalize_or_zero();
            (d - t * d.dot(t)).normalize_or_zero()
        } else {
            DVec3::ZERO
        };
        out.push(
            (0..n)
                .map(|k| {
                    let a = std::f64::consts::TAU * k as f64 / n as f64;
                    let off = (u * a.cos() + v * a.sin()) * r;
                    let along = bend * off.dot(bend) * (stretch - 1.0);
                    p + off + along
                })
                .collect(),
        );
    }
    out
}

/// The tube between consecutive rings, facing out (or in, for a bore).
fn tube(rings: &[Vec<DVec3>], inward: bool, out: &mut Vec<Tri>) {
    for w in rings.windows(2) {
        let n = w[0].len();
        for i in 0..n {
            let j = (i + 1) % n;
            push_quad(out, [w[0][i], w[0][j], w[1][j], w[1][i]], inward);
        }
    }
}
