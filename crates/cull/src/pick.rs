//! What is under a pixel: a ray cast through the hierarchy against every
//! leaf's full-detail LOD, whatever LOD a frame drew, so the answer is
//! the object the full-detail image shows there.
//!
//! Boxes are visited nearest entry first and a leaf's finest LOD is read
//! only when its box could hold a nearer hit than the best so far, so a
//! pick reads the few leaves along the ray in front of the hit.

use std::collections::BinaryHeap;

use gigawalk_scene::objects::ObjectTable;
use gigawalk_scene::{LodMesh, Skeleton};
use glam::DVec3;

use crate::nearest::Nearest;
use crate::{Camera, Section, Viewport};

/// A ray in world coordinates: points `origin + t dir` for `t_min <= t
/// <= t_max`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: DVec3,
    /// Unit length.
    pub dir: DVec3,
    pub t_min: f64,
    /// Infinite unless a section cuts the ray ([`Ray::clipped`]).
    pub t_max: f64,
}

impl Ray {
    /// The part of the ray `section` keeps (one interval: the kept region
    /// is convex), so a pick finds the nearest surface the cut image
    /// shows; `None` when it keeps none of it.
    pub fn clipped(&self, section: Option<&Section>) -> Option<Ray> {
        let Some(s) = section else {
            return Some(*self);
        };
        let (t_min, t_max) = s.clip_ray(self.origin, self.dir, self.t_min, self.t_max)?;
        Some(Ray {
            t_min,
            t_max,
            ..*self
        })
    }
}

impl Camera {
    /// The ray through image point `(x, y)` of `viewport`, in pixels from
    /// the top-left corner (a pixel's centre is at `+0.5`), starting at
    /// the near plane (nothing nearer is drawn). `None` outside the image.
    pub fn pixel_ray(&self, viewport: Viewport, x: f64, y: f64) -> Option<Ray> {
        let (w, h) = (viewport.width as f64, viewport.height as f64);
        if !(x >= 0.0 && y >= 0.0 && x <= w && y <= h) {
            return None;
        }
        let ndc_x = 2.0 * x / w - 1.0;
        let ndc_y = 1.0 - 2.0 * y / h;
        let ty = self.tan_half_fovy();
        let tx = ty * self.aspect;
        let forward = self.forward();
        let dir = (forward + self.right() * (ndc_x * tx) + self.up() * (ndc_y * ty)).normalize();
        Some(Ray {
            origin: self.position,
            dir,
            t_min: self.near / dir.dot(forward),
            t_max: f64::INFINITY,
        })
    }
}

/// Where a ray first meets the full-detail surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PickHit {
    /// The leaf, its finest LOD and the triangle within it.
    pub node: u32,
    pub lod: u32,
    pub triangle: u32,
    /// The object the triangle belongs to (`None` without an object table).
    pub object: Option<u32>,
    /// The hit point, world coordinates.
    pub point: DVec3,
    /// Along the ray from its origin.
    pub distance: f64,
    /// The triangle's unit normal, facing the ray's origin.
    pub normal: DVec3,
}

/// What a pick did: the hit, and how many leaves it read.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PickStats {
    pub leaves_read: u32,
    pub triangles_tested: u64,
}

type Entry = Nearest<()>;

/// The nearest hit of `ray` on the full detail of the leaves of
/// `skeleton`, skipping nodes `skip_node` says hold nothing to hit and
/// triangles of objects `skip_object` says are hidden (both only asked
/// where an object table is given for the objects). `read` gives a LOD's
/// geometry (as stored: the image is drawn from it).
pub fn pick<E>(
    skeleton: &Skeleton,
    objects: Option<&ObjectTable>,
    ray: &Ray,
    skip_node: &dyn Fn(u32) -> bool,
    skip_object: &dyn Fn(u32) -> bool,
    read: &mut dyn FnMut(u32) -> Result<LodMesh, E>,
) -> Result<(Option<PickHit>, PickStats), E> {
    let mut stats = PickStats::default();
    let mut best: Option<PickHit> = None;
    let mut heap = BinaryHeap::new();
    let inv = DVec3::ONE / ray.dir;
    let enter = |node: u32| -> Option<f64> {
        let b = skeleton.node(node).bounds;
        let t0 = (b.min - ray.origin) * inv;
        let t1 = (b.max - ray.origin) * inv;
        // NaN (0 * inf on a box face) takes the other slab's bound.
        let lo = t0.min(t1);
        let hi = t0.max(t1);
        let near = lo.max_element().max(ray.t_min);
        let far = hi.min_element().min(ray.t_max);
        (near <= far).then_some(near)
    };
    if let Some(t) = enter(0) {
        heap.push(Entry::new(t, 0, ()));
    }
    while let Some(e) = heap.pop() {
        let (t, node) = (e.distance(), e.node);
        if best.is_some_and(|b| b.distance < t) {
            break;
        }
        if skip_node(node) {
            continue;
        }
        let n = skeleton.node(node);
        if !n.is_leaf() {
            for c in n.children() {
                if let Some(t) = enter(c) {
                    heap.push(Entry::new(t, c, ()));
                }
            }
            continue;
        }
        let lod = n.first_lod;
        let mesh = read(lod)?;
        stats.leaves_read += 1;
        let runs = objects.and_then(|o| o.runs(lod));
        let mut run = 0usize;
        let mut run_end = runs
            .and_then(|r| r.first())
            .map_or(u32::MAX, |r| r.triangles);
        for (ti, tri) in mesh.indices.chunks_exact(3).enumerate() {
            let ti = ti as u32;
            let object = match runs {
                Some(r) => {
                    while ti >= run_end && run + 1 < r.len() {
                        run += 1;
                        run_end += r[run].triangles;
                    }
                    Some(r[run].object)
                }
                None => None,
            };
            if object.is_some_and(skip_object) {
                continue;
            }
            stats.triangles_tested += 1;
            let p = |i: u32| mesh.origin + glam::Vec3::from(mesh.positions[i as usize]).as_dvec3();
            let (a, b, c) = (p(tri[0]), p(tri[1]), p(tri[2]));
            if let Some((t, normal)) = intersect(ray, a, b, c) {
                if best.is_none_or(|h| t < h.distance) {
                    best = Some(PickHit {
                        node,
                        lod,
                        triangle: ti,
                        object,
                        point: ray.origin + ray.dir * t,
                        distance: t,
                        normal,
                    });
                }
            }
        }
    }
    Ok((best, stats))
}

/// Möller and Trumbore's ray-triangle test in f64, both faces, edges
/// inclusive: the distance and the normal facing the ray.
pub fn intersect(ray: &Ray, a: DVec3, b: DVec3, c: DVec3) -> Option<(f64, DVec3)> {
    let e1 = b - a;
    let e2 = c - a;
    let p = ray.dir.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = ray.origin - a;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = ray.dir.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    if t < ray.t_min || t > ray.t_max || !t.is_finite() {
        return None;
    }
    let n = e1.cross(e2).normalize_or_zero();
    let n = if n.dot(ray.dir) > 0.0 { -n } else { n };
    Some((t, n))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;

    #[test]
    fn a_pixel_centre_ray_passes_through_the_pixel() {
        let cam = Camera::from_pose(
            DVec3::new(1e7, 5.0, 0.0),
            DQuat::from_rotation_y(0.3),
            1.0,
            Viewport::new(64, 48),
            0.01,
        );
        let vp = Viewport::new(64, 48);
        let r = cam.pixel_ray(vp, 32.0, 24.0).unwrap();
        assert!((r.dir - cam.forward()).length() < 1e-12);
        assert!((r.t_min - 0.01).abs() < 1e-12);
        // The top-left corner is up and to the left.
        let r = cam.pixel_ray(vp, 0.0, 0.0).unwrap();
        assert!(r.dir.dot(cam.up()) > 0.0 && r.dir.dot(cam.right()) < 0.0);
        // Projected back, a point on the ray lands on the pixel.
        let p = r.origin + r.dir * 10.0;
        let clip = cam.view_projection_rel_f64() * (p - cam.position).extend(1.0);
        assert!((clip.x / clip.w + 1.0).abs() < 1e-9 && (clip.y / clip.w - 1.0).abs() < 1e-9);
        assert!(cam.pixel_ray(vp, 64.5, 1.0).is_none());
        assert!(cam.pixel_ray(vp, -0.1, 1.0).is_none());
    }

    #[test]
    fn a_ray_hits_a_triangle_inside_and_misses_outside_and_behind() {
        let ray = Ray {
            origin: DVec3::new(0.2, 0.2, 5.0),
            dir: DVec3::NEG_Z,
            t_min: 0.0,
            t_max: f64::INFINITY,
        };
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        let (t, n) = intersect(&ray, a, b, c).unwrap();
        assert!((t - 5.0).abs() < 1e-12 && n == DVec3::Z);
        let miss = Ray {
            origin: DVec3::new(0.8, 0.8, 5.0),
            ..ray
        };
        assert!(intersect(&miss, a, b, c).is_none());
        let near = Ray { t_min: 6.0, ..ray };
        assert!(intersect(&near, a, b, c).is_none());
        let short = Ray { t_max: 4.0, ..ray };
        assert!(intersect(&short, a, b, c).is_none());
        // A section keeping z <= 2 leaves the ray from t = 3 on.
        let cut = Section::parse(&["0 0 -1 2".into()], None).unwrap();
        let kept = ray.clipped(Some(&cut)).unwrap();
        assert_eq!((kept.t_min, kept.t_max), (3.0, f64::INFINITY));
        let (t, _) = intersect(&kept, a, b, c).unwrap();
        assert!((t - 5.0).abs() < 1e-12);
        // Keeping z >= 1 removes the triangle at z = 0.
        let above = Section::parse(&["0 0 1 -1".into()], None).unwrap();
        assert!(intersect(&ray.clipped(Some(&above)).unwrap(), a, b, c).is_none());
    }
}
