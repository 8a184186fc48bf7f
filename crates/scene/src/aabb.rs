//! Axis-aligned bounding boxes in f64 world coordinates.

use glam::DVec3;

/// An axis-aligned box. `min <= max` on every axis for a non-empty box; the
/// [`Aabb::EMPTY`] box has `min = +inf, max = -inf` so that growing it by any
/// point gives that point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: DVec3,
    pub max: DVec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: DVec3::splat(f64::INFINITY),
        max: DVec3::splat(f64::NEG_INFINITY),
    };

    pub fn new(min: DVec3, max: DVec3) -> Self {
        Aabb { min, max }
    }

    /// The smallest box holding every point; [`Aabb::EMPTY`] for no points.
    pub fn from_points(points: impl IntoIterator<Item = DVec3>) -> Self {
        let mut b = Aabb::EMPTY;
        for p in points {
            b.grow(p);
        }
        b
    }

    pub fn is_empty(&self) -> bool {
        !(self.min.cmple(self.max).all())
    }

    /// True when every coordinate is finite and `min <= max`.
    pub fn is_valid(&self) -> bool {
        self.min.is_finite() && self.max.is_finite() && !self.is_empty()
    }

    pub fn grow(&mut self, p: DVec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    pub fn contains_box(&self, o: &Aabb) -> bool {
        self.min.cmple(o.min).all() && o.max.cmple(self.max).all()
    }

    pub fn contains_point(&self, p: DVec3) -> bool {
        self.min.cmple(p).all() && p.cmple(self.max).all()
    }

    pub fn center(&self) -> DVec3 {
        (self.min + self.max) * 0.5
    }

    pub fn extent(&self) -> DVec3 {
        self.max - self.min
    }

    pub fn diagonal(&self) -> f64 {
        self.extent().length()
    }

    pub fn volume(&self) -> f64 {
        let e = self.extent().max(DVec3::ZERO);
        e.x * e.y * e.z
    }

    /// Distance between two boxes: 0 when they touch or overlap.
    pub fn gap(&self, o: &Aabb) -> f64 {
        let d = (o.min - self.max).max(self.min - o.max).max(DVec3::ZERO);
        d.length()
    }

    /// Distance from a point to the nearest point of the box: 0 inside.
    pub fn distance_to_point(&self, p: DVec3) -> f64 {
        let d = (self.min - p).max(p - self.max).max(DVec3::ZERO);
        d.length()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_grows_to_point() {
        let mut b = Aabb::EMPTY;
        assert!(b.is_empty());
        b.grow(DVec3::new(1.0, 2.0, 3.0));
        assert!(!b.is_empty());
        assert_eq!(b.min, b.max);
        assert_eq!(b.volume(), 0.0);
    }

    #[test]
    fn gap_and_distance() {
        let a = Aabb::new(DVec3::ZERO, DVec3::ONE);
        let b = Aabb::new(DVec3::new(3.0, 0.0, 0.0), DVec3::new(4.0, 1.0, 1.0));
        assert_eq!(a.gap(&b), 2.0);
        assert_eq!(b.gap(&a), 2.0);
        assert_eq!(a.gap(&a), 0.0);
        assert_eq!(a.distance_to_point(DVec3::splat(0.5)), 0.0);
        assert_eq!(a.distance_to_point(DVec3::new(1.0, 1.0, 4.0)), 3.0);
    }
}
