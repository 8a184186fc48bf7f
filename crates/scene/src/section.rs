//! Sections: up to six planes and a box that cut the model away, as a
//! design review cuts a plant open to look inside.
//!
//! A plane `nx ny nz d` keeps the points `p` with `n·p + d >= 0` (the
//! normal points into what is kept; it is normalised, `d` with it). A box
//! `x0 y0 z0 x1 y1 z1` keeps what lies inside it. What is kept is the
//! intersection of every plane's kept half-space and the box: a convex
//! region, so a ray meets it in one interval and a box is wholly removed
//! when one half-space alone removes it.
//!
//! Everything here is f64, in world coordinates. The GPU clips each
//! fragment by the same half-spaces made camera-relative
//! ([`Section::relative_to`]), so a scene far from the origin cuts as
//! precisely as one at it.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::Aabb;

/// One half-space: keeps `p` with `normal·p + d >= 0`; `normal` is a unit
/// vector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HalfSpace {
    pub normal: DVec3,
    pub d: f64,
}

impl HalfSpace {
    /// Signed distance of `p` from the plane, positive on the kept side.
    pub fn distance(&self, p: DVec3) -> f64 {
        self.normal.dot(p) + self.d
    }

    /// The same half-space for coordinates relative to `origin`.
    pub fn relative_to(&self, origin: DVec3) -> HalfSpace {
        HalfSpace {
            normal: self.normal,
            d: self.distance(origin),
        }
    }
}

/// Where a box lies against a section.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoxSide {
    /// Wholly on the removed side of one half-space: nothing of it shows.
    Removed,
    /// Wholly kept.
    Kept,
    /// Cut by at least one plane.
    Cut,
}

/// A section as given: planes as `[nx, ny, nz, d]` and a box as
/// `[x0, y0, z0, x1, y1, z1]`, the form saved views and the command line
/// use.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SectionSpec {
    #[serde(default)]
    pub planes: Vec<[f64; 4]>,
    #[serde(default, rename = "box")]
    pub bbox: Option<[f64; 6]>,
}

/// Why a section is not usable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SectionError {
    #[error("section plane {text:?}: {why} (expected four numbers \"nx ny nz d\", keeping n·p + d >= 0)")]
    BadPlane { text: String, why: String },
    #[error("section box {text:?}: {why} (expected six numbers \"x0 y0 z0 x1 y1 z1\", the box's min and max corners)")]
    BadBox { text: String, why: String },
    #[error("{count} section planes: at most {max} are allowed (a section box adds its own six)")]
    TooManyPlanes { count: usize, max: usize },
}

/// Planes and a box, validated.
#[derive(Clone, Debug, PartialEq)]
pub struct Section {
    spec: SectionSpec,
    /// The planes' half-spaces, then the box's six faces.
    half_spaces: Vec<HalfSpace>,
}

impl Section {
    /// The most planes a section takes besides its box.
    pub const MAX_PLANES: usize = 6;
    /// The most half-spaces a section has: its planes and a box's faces.
    pub const MAX_HALF_SPACES: usize = Self::MAX_PLANES + 6;

    /// Validates `spec`: at most [`Section::MAX_PLANES`] planes with
    /// finite, non-zero normals and finite offsets; a finite box with
    /// min <= max on every axis.
    pub fn new(spec: SectionSpec) -> Result<Section, SectionError> {
        if spec.planes.len() > Self::MAX_PLANES {
            return Err(SectionError::TooManyPlanes {
                count: spec.planes.len(),
                max: Self::MAX_PLANES,
            });
        }
        let mut half_spaces = Vec::with_capacity(spec.planes.len() + 6);
        for p in &spec.planes {
            half_spaces.push(plane_half_space(p)?);
        }
        if let Some(b) = &spec.bbox {
            half_spaces.extend(box_half_spaces(b)?);
        }
        Ok(Section { spec, half_spaces })
    }

    /// Planes and a box from their command-line text (see
    /// [`parse_plane`], [`parse_box`]).
    pub fn parse(planes: &[String], bbox: Option<&str>) -> Result<Section, SectionError> {
        let spec = SectionSpec {
            planes: planes
                .iter()
                .map(|p| parse_plane(p))
                .collect::<Result<_, _>>()?,
            bbox: bbox.map(parse_box).transpose()?,
        };
        Section::new(spec)
    }

    pub fn spec(&self) -> &SectionSpec {
        &self.spec
    }

    /// No plane and no box: nothing is cut.
    pub fn is_empty(&self) -> bool {
        self.half_spaces.is_empty()
    }

    /// The planes' half-spaces, then the box's faces.
    pub fn half_spaces(&self) -> &[HalfSpace] {
        &self.half_spaces
    }

    /// Whether `p` is kept.
    pub fn keeps(&self, p: DVec3) -> bool {
        self.half_spaces.iter().all(|h| h.distance(p) >= 0.0)
    }

    /// Where `b` lies; `slack` (>= 0) widens the kept side, so a box that
    /// only rounding puts on the removed side counts as cut.
    pub fn classify(&self, b: &Aabb, slack: f64) -> BoxSide {
        classify(&self.half_spaces, b.min, b.max, slack)
    }

    /// The part `[t0, t1]` of the ray `origin + t dir` that lies in the
    /// kept region, within `[t_min, t_max]`; `None` when none does.
    pub fn clip_ray(
        &self,
        origin: DVec3,
        dir: DVec3,
        t_min: f64,
        t_max: f64,
    ) -> Option<(f64, f64)> {
        let (mut t0, mut t1) = (t_min, t_max);
        for h in &self.half_spaces {
            let s = h.distance(origin);
            let v = h.normal.dot(dir);
            if v == 0.0 {
                if s < 0.0 {
                    return None;
                }
                continue;
            }
            let t = -s / v;
            if v > 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
        (t0 <= t1).then_some((t0, t1))
    }

    /// Whether anything of `b` is kept: the kept region meets the box.
    /// Exact up to rounding: the intersection of the half-spaces and the
    /// box is a bounded convex polytope, non-empty exactly when one of its
    /// vertices (where three of the planes meet) satisfies them all.
    pub fn keeps_any_of(&self, b: &Aabb) -> bool {
        let mut all = self.half_spaces.clone();
        let (min, max) = (b.min, b.max);
        all.extend(box_faces(min, max));
        let scale = (max - min)
            .length()
            .max(min.abs().max(max.abs()).max_element());
        let tol = 1e-9 * scale.max(1e-300);
        let n = all.len();
        for i in 0..n {
            for j in i + 1..n {
                for k in j + 1..n {
                    let Some(p) = meet(&all[i], &all[j], &all[k]) else {
                        continue;
                    };
                    if all.iter().all(|h| h.distance(p) >= -tol) {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// The half-spaces relative to `eye`, as the GPU clips by them: x, y,
    /// z the unit normal and w the offset, each rounded once to f32.
    pub fn relative_to(&self, eye: DVec3) -> Vec<[f32; 4]> {
        self.half_spaces
            .iter()
            .map(|h| {
                let r = h.relative_to(eye);
                [
                    r.normal.x as f32,
                    r.normal.y as f32,
                    r.normal.z as f32,
                    r.d as f32,
                ]
            })
            .collect()
    }

    /// One line naming the planes and the box, for reports.
    pub fn describe(&self) -> String {
        let mut parts: Vec<String> = self
            .spec
            .planes
            .iter()
            .map(|p| format!("plane {} {} {} {}", p[0], p[1], p[2], p[3]))
            .collect();
        if let Some(b) = &self.spec.bbox {
            parts.push(format!(
                "box {} {} {} .. {} {} {}",
                b[0], b[1], b[2], b[3], b[4], b[5]
            ));
        }
        if parts.is_empty() {
            "none".into()
        } else {
            parts.join(", ")
        }
    }
}

/// Where the box `min..max` lies against `half_spaces` (see
/// [`Section::classify`]); the coordinates may be relative to any origin
/// the half-spaces are.
pub fn classify(half_spaces: &[HalfSpace], min: DVec3, max: DVec3, slack: f64) -> BoxSide {
    let mut side = BoxSide::Kept;
    for h in half_spaces {
        let n = h.normal;
        // The corners farthest along and against the normal.
        let far = DVec3::select(n.cmpge(DVec3::ZERO), max, min);
        let near = DVec3::select(n.cmpge(DVec3::ZERO), min, max);
        if h.distance(far) < -slack {
            return BoxSide::Removed;
        }
        if h.distance(near) < slack {
            side = BoxSide::Cut;
        }
    }
    side
}

/// `"nx ny nz d"` (spaces or commas between the numbers).
pub fn parse_plane(text: &str) -> Result<[f64; 4], SectionError> {
    let bad = |why: String| SectionError::BadPlane {
        text: text.to_string(),
        why,
    };
    let v = numbers(text).map_err(bad)?;
    let v: [f64; 4] = v
        .try_into()
        .map_err(|v: Vec<f64>| bad(format!("{} numbers", v.len())))?;
    plane_half_space(&v)?;
    Ok(v)
}

/// `"x0 y0 z0 x1 y1 z1"` (spaces or commas between the numbers).
pub fn parse_box(text: &str) -> Result<[f64; 6], SectionError> {
    let bad = |why: String| SectionError::BadBox {
        text: text.to_string(),
        why,
    };
    let v = numbers(text).map_err(bad)?;
    let v: [f64; 6] = v
        .try_into()
        .map_err(|v: Vec<f64>| bad(format!("{} numbers", v.len())))?;
    box_half_spaces(&v)?;
    Ok(v)
}

fn numbers(text: &str) -> Result<Vec<f64>, String> {
    text.split(|c: char| c.is_whitespace() || c == ',')
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<f64>()
                .map_err(|_| format!("{s:?} is not a number"))
        })
        .collect()
}

fn plane_half_space(p: &[f64; 4]) -> Result<HalfSpace, SectionError> {
    let bad = |why: &str| SectionError::BadPlane {
        text: format!("{} {} {} {}", p[0], p[1], p[2], p[3]),
        why: why.into(),
    };
    if !p.iter().all(|v| v.is_finite()) {
        return Err(bad("a number is not finite"));
    }
    let n = DVec3::new(p[0], p[1], p[2]);
    let len = n.length();
    if !(len.is_finite() && len > 0.0) {
        return Err(bad("its normal is zero, so it names no plane"));
    }
    Ok(HalfSpace {
        normal: n / len,
        d: p[3] / len,
    })
}

fn box_half_spaces(b: &[f64; 6]) -> Result<[HalfSpace; 6], SectionError> {
    let bad = |why: String| SectionError::BadBox {
        text: format!("{} {} {} {} {} {}", b[0], b[1], b[2], b[3], b[4], b[5]),
        why,
    };
    if !b.iter().all(|v| v.is_finite()) {
        return Err(bad("a number is not finite".into()));
    }
    for (axis, name) in ["x", "y", "z"].iter().enumerate() {
        if b[axis] > b[axis + 3] {
            return Err(bad(format!(
                "it is inverted: min {name} {} is greater than max {name} {}",
                b[axis],
                b[axis + 3]
            )));
        }
    }
    Ok(box_faces(
        DVec3::new(b[0], b[1], b[2]),
        DVec3::new(b[3], b[4], b[5]),
    ))
}

/// The six half-spaces whose intersection is the box `min..max`.
fn box_faces(min: DVec3, max: DVec3) -> [HalfSpace; 6] {
    let h = |normal: DVec3, d: f64| HalfSpace { normal, d };
    [
        h(DVec3::X, -min.x),
        h(DVec3::Y, -min.y),
        h(DVec3::Z, -min.z),
        h(DVec3::NEG_X, max.x),
        h(DVec3::NEG_Y, max.y),
        h(DVec3::NEG_Z, max.z),
    ]
}

/// Where three planes meet, when they meet in one point.
fn meet(a: &HalfSpace, b: &HalfSpace, c: &HalfSpace) -> Option<DVec3> {
    let (n1, n2, n3) = (a.normal, b.normal, c.normal);
    let det = n1.dot(n2.cross(n3));
    if det.abs() < 1e-12 {
        return None;
    }
    // n_i·p = -d_i.
    let p = (n2.cross(n3) * -a.d + n3.cross(n1) * -b.d + n1.cross(n2) * -c.d) / det;
    p.is_finite().then_some(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn aabb(min: [f64; 3], max: [f64; 3]) -> Aabb {
        Aabb {
            min: DVec3::from_array(min),
            max: DVec3::from_array(max),
        }
    }

    #[test]
    fn plane_keeps_the_side_its_normal_points_to() {
        let s = Section::parse(&["0 0 2 -10".into()], None).unwrap();
        assert!(s.keeps(DVec3::new(0.0, 0.0, 6.0)));
        assert!(!s.keeps(DVec3::new(0.0, 0.0, 4.0)));
        let h = s.half_spaces()[0];
        assert_eq!((h.normal, h.d), (DVec3::Z, -5.0));
        assert_eq!(
            s.classify(&aabb([0.0; 3], [1.0, 1.0, 4.0]), 0.0),
            BoxSide::Removed
        );
        assert_eq!(
            s.classify(&aabb([0.0, 0.0, 6.0], [1.0, 1.0, 7.0]), 0.0),
            BoxSide::Kept
        );
        assert_eq!(
            s.classify(&aabb([0.0; 3], [1.0, 1.0, 7.0]), 0.0),
            BoxSide::Cut
        );
        // Slack turns a box just past the plane into a cut one.
        assert_eq!(
            s.classify(&aabb([0.0; 3], [1.0, 1.0, 4.999]), 0.01),
            BoxSide::Cut
        );
    }

    #[test]
    fn box_keeps_its_inside() {
        let s = Section::parse(&[], Some("0,0,0, 10,10,10")).unwrap();
        assert!(s.keeps(DVec3::splat(5.0)));
        assert!(!s.keeps(DVec3::new(5.0, 11.0, 5.0)));
        assert_eq!(
            s.classify(&aabb([11.0; 3], [12.0; 3]), 0.0),
            BoxSide::Removed
        );
        assert_eq!(s.classify(&aabb([1.0; 3], [2.0; 3]), 0.0), BoxSide::Kept);
        assert_eq!(s.classify(&aabb([9.0; 3], [12.0; 3]), 0.0), BoxSide::Cut);
    }

    #[test]
    fn ray_clipping_is_one_interval() {
        let s = Section::parse(&[], Some("0 0 0 10 10 10")).unwrap();
        let (t0, t1) = s
            .clip_ray(DVec3::new(-5.0, 5.0, 5.0), DVec3::X, 0.0, 100.0)
            .unwrap();
        assert_eq!((t0, t1), (5.0, 15.0));
        assert!(s
            .clip_ray(DVec3::new(-5.0, 20.0, 5.0), DVec3::X, 0.0, 100.0)
            .is_none());
        assert!(s
            .clip_ray(DVec3::new(-5.0, 5.0, 5.0), DVec3::X, 0.0, 4.0)
            .is_none());
    }

    #[test]
    fn opposite_planes_can_remove_everything() {
        let scene = aabb([0.0; 3], [10.0; 3]);
        let both = Section::parse(&["1 0 0 -6".into(), "-1 0 0 4".into()], None).unwrap();
        assert!(!both.keeps_any_of(&scene));
        let slab = Section::parse(&["1 0 0 -4".into(), "-1 0 0 6".into()], None).unwrap();
        assert!(slab.keeps_any_of(&scene));
        let outside = Section::parse(&[], Some("20 20 20 30 30 30")).unwrap();
        assert!(!outside.keeps_any_of(&scene));
        let tilted = Section::parse(&["1 1 1 -29".into()], None).unwrap();
        assert!(tilted.keeps_any_of(&scene));
        let beyond = Section::parse(&["1 1 1 -31".into()], None).unwrap();
        assert!(!beyond.keeps_any_of(&scene));
    }

    #[test]
    fn bad_input_is_named() {
        let e = |r: Result<Section, SectionError>| r.unwrap_err().to_string();
        assert!(e(Section::parse(&["0 0 0 1".into()], None)).contains("normal is zero"));
        assert!(e(Section::parse(&["1 0 0".into()], None)).contains("3 numbers"));
        assert!(e(Section::parse(&["1 0 x 0".into()], None)).contains("\"x\" is not a number"));
        assert!(e(Section::parse(&["1 0 0 inf".into()], None)).contains("not finite"));
        assert!(e(Section::parse(&[], Some("0 0 0 -1 1 1"))).contains("inverted: min x 0"));
        let seven = vec!["1 0 0 0".to_string(); 7];
        assert!(e(Section::parse(&seven, None)).contains("at most 6"));
    }

    #[test]
    fn relative_planes_agree_far_from_the_origin() {
        let s = Section::parse(&["0.6 0.8 0 -1e7".into()], None).unwrap();
        let eye = DVec3::new(6e6, 8e6, 3.0);
        let r = s.relative_to(eye)[0];
        // w is the eye's signed distance, computed in f64.
        assert!((r[3] as f64 - s.half_spaces()[0].distance(eye)).abs() < 1.0);
        let p = DVec3::new(6e6 + 0.6, 8e6 + 0.8, 0.0);
        let rel = p - eye;
        let d = r[0] as f64 * rel.x + r[1] as f64 * rel.y + r[3] as f64;
        assert!((d - s.half_spaces()[0].distance(p)).abs() < 1e-3);
    }
}
