//! A reviewer's section planes and section box, as design-review tools
//! cut a model open (xeokit's section planes, Navisworks' sectioning):
//! a plane placed through the point under the cursor facing the camera,
//! moved along its normal, flipped; a box around the selection or around
//! what is in view; all of it on or off at once.
//!
//! Pure state and text: the frame loop picks the point and publishes
//! [`Sections::current`] with every camera, so this is unit-tested
//! without a window. A plane is kept as `[nx, ny, nz, d]` with a unit
//! normal (`gigawalk_scene::section`): it keeps `n·p + d >= 0`, the side
//! its normal points to.

use std::sync::Arc;

use gigawalk_cull::{Camera, Section, SectionSpec};
use gigawalk_scene::Aabb;
use glam::DVec3;

/// A section box around a selected object is this fraction of the
/// object's diagonal larger on every side, so the object's own faces are
/// not cut and a little of its surroundings shows.
pub const BOX_PAD: f64 = 0.05;
/// A section box around what is in view reaches this many times the
/// distance of the surface under the screen's centre: what is near that
/// surface stays, the far background goes.
pub const VIEW_BOX_DEPTH: f64 = 3.0;
/// A plane moves this fraction of the eye's distance to it per wheel
/// notch or key press: fine steps close up, big ones from afar.
pub const STEP_OF_DISTANCE: f64 = 0.05;
/// The smallest step, as a fraction of the scene's diagonal (an eye on
/// the plane still moves it).
pub const MIN_STEP_OF_SCENE: f64 = 1e-4;

/// The viewer's sections: planes (the last placed is the active one), a
/// box, and whether they cut.
#[derive(Debug)]
pub struct Sections {
    planes: Vec<[f64; 4]>,
    bbox: Option<[f64; 6]>,
    enabled: bool,
    /// What the passes cut by (`None`: nothing cut), rebuilt only when
    /// the planes, the box or `enabled` change.
    current: Option<Arc<Section>>,
}

impl Default for Sections {
    fn default() -> Self {
        Sections {
            planes: Vec::new(),
            bbox: None,
            enabled: true,
            current: None,
        }
    }
}

impl Sections {
    /// Starts from `section` (the command line's or a saved view's).
    pub fn new(section: Option<&Section>) -> Sections {
        let mut s = Sections::default();
        if let Some(section) = section {
            s.set_spec(section.spec());
        }
        s
    }

    /// What every camera request carries: `None` when off or empty.
    pub fn current(&self) -> Option<Arc<Section>> {
        self.current.clone()
    }

    /// The planes and the box, whether on or off; `None` when there are
    /// none.
    pub fn spec(&self) -> Option<SectionSpec> {
        (!self.planes.is_empty() || self.bbox.is_some()).then(|| SectionSpec {
            planes: self.planes.clone(),
            bbox: self.bbox,
        })
    }

    /// What `V` saves: the section that cuts now (none while off: a view
    /// keeps what was seen).
    pub fn saved(&self) -> Option<SectionSpec> {
        self.current.as_ref().map(|s| s.spec().clone())
    }

    /// A saved view's section, or none when it has none (a view is the
    /// whole state); what to add to the restore message: its section, or
    /// why it was left out.
    pub fn restore(&mut self, spec: Option<&SectionSpec>) -> String {
        let Some(spec) = spec else {
            self.planes.clear();
            self.bbox = None;
            self.enabled = true;
            self.rebuild();
            return String::new();
        };
        match Section::new(spec.clone()) {
            Ok(s) => {
                self.set_spec(s.spec());
                format!(", section {}", s.describe())
            }
            Err(e) => format!("; its section is left out: {e}"),
        }
    }

    pub fn enabled(&self) -> bool {
        self.enabled
    }

    pub fn planes(&self) -> &[[f64; 4]] {
        &self.planes
    }

    pub fn bbox(&self) -> Option<[f64; 6]> {
        self.bbox
    }

    /// Replaces the planes and the box with `spec`'s (already validated:
    /// it came from a [`Section`]) and turns sections on; a view without
    /// a section clears them.
    pub fn set_spec(&mut self, spec: &SectionSpec) {
        // Normalised here as `Section` does, so moving a plane steps in
        // model units.
        self.planes = spec
            .planes
            .iter()
            .take(Section::MAX_PLANES)
            .filter_map(|p| normalised(*p))
            .collect();
        self.bbox = spec.bbox;
        self.enabled = true;
        self.rebuild();
    }

    /// `X`: a plane through `point` whose normal is the camera's
    /// `forward`, so what lies between the eye and the point is cut away
    /// and what lies beyond it is kept. Turns sections on.
    pub fn place_plane(&mut self, point: DVec3, forward: DVec3) -> Result<String, String> {
        if self.planes.len() >= Section::MAX_PLANES {
            return Err(format!(
                "section planes: all {} in use (Delete clears them)",
                Section::MAX_PLANES
            ));
        }
        let n = forward
            .try_normalize()
            .ok_or("section plane: the camera has no direction")?;
        if !point.is_finite() {
            return Err("section plane: the point is not finite".into());
        }
        self.planes.push([n.x, n.y, n.z, -n.dot(point)]);
        self.enabled = true;
        self.rebuild();
        Ok(format!(
            "section plane {} of {} through {} (] [ or Shift+wheel move it, \\ flips it)",
            self.planes.len(),
            Section::MAX_PLANES,
            crate::objects::point_text(point)
        ))
    }

    /// Moves the active plane `steps` steps along its normal (positive:
    /// cuts more away); a step is [`STEP_OF_DISTANCE`] of the eye's
    /// distance to the plane, at least [`MIN_STEP_OF_SCENE`] of
    /// `scene_diagonal`. False when there is no plane to move.
    pub fn move_active(&mut self, steps: f64, eye: DVec3, scene_diagonal: f64) -> bool {
        let Some(p) = self.planes.last_mut() else {
            return false;
        };
        if steps == 0.0 || !steps.is_finite() {
            return true;
        }
        let n = DVec3::new(p[0], p[1], p[2]);
        let distance = (n.dot(eye) + p[3]).abs();
        let step = (STEP_OF_DISTANCE * distance).max(MIN_STEP_OF_SCENE * scene_diagonal);
        // The plane through q + s n has d = -n·(q + s n) = d - s.
        p[3] -= steps * step;
        self.enabled = true;
        self.rebuild();
        true
    }

    /// `\`: the active plane keeps the other side. False when there is
    /// none.
    pub fn flip_active(&mut self) -> bool {
        let Some(p) = self.planes.last_mut() else {
            return false;
        };
        *p = p.map(|v| -v);
        self.enabled = true;
        self.rebuild();
        true
    }

    /// `J`: the section box is `bounds` padded by [`BOX_PAD`] of its
    /// diagonal (a flat or point-like box by a little of
    /// `scene_diagonal`). Replaces any box; turns sections on.
    pub fn box_around(&mut self, bounds: &Aabb, scene_diagonal: f64) -> Result<String, String> {
        if !bounds.is_valid() {
            return Err("section box: nothing to put a box around".into());
        }
        let pad = (BOX_PAD * bounds.diagonal()).max(MIN_STEP_OF_SCENE * scene_diagonal);
        let (min, max) = (bounds.min - pad, bounds.max + pad);
        self.bbox = Some([min.x, min.y, min.z, max.x, max.y, max.z]);
        self.enabled = true;
        self.rebuild();
        Ok(format!(
            "section box {} .. {}",
            crate::objects::point_text(min),
            crate::objects::point_text(max)
        ))
    }

    /// `0`: sections off or on again (they are kept meanwhile).
    pub fn toggle(&mut self) -> String {
        self.enabled ^= true;
        self.rebuild();
        format!(
            "sections {}",
            if self.enabled {
                "on"
            } else {
                "off (0 turns them on)"
            }
        )
    }

    /// `Delete`: no plane and no box.
    pub fn clear(&mut self) -> String {
        self.planes.clear();
        self.bbox = None;
        self.enabled = true;
        self.rebuild();
        "sections cleared".into()
    }

    /// The HUD's line, when there is a section.
    pub fn hud_line(&self) -> Option<String> {
        if self.planes.is_empty() && self.bbox.is_none() {
            return None;
        }
        let mut parts = Vec::new();
        if !self.planes.is_empty() {
            parts.push(format!(
                "{} of {} planes{}",
                self.planes.len(),
                Section::MAX_PLANES,
                if self.planes.len() == Section::MAX_PLANES {
                    " (full)"
                } else {
                    ""
                }
            ));
        }
        if self.bbox.is_some() {
            parts.push("box".into());
        }
        Some(format!(
            "section: {}, {} (0: on/off, Delete: clear)",
            parts.join(" + "),
            if self.enabled { "on" } else { "OFF" }
        ))
    }

    fn rebuild(&mut self) {
        self.current = if self.enabled {
            self.spec().and_then(|spec| match Section::new(spec) {
                Ok(s) if !s.is_empty() => Some(Arc::new(s)),
                // Every plane and box was validated on the way in; a
                // degenerate one cuts nothing rather than everything.
                _ => None,
            })
        } else {
            None
        };
    }
}

/// `p` with a unit normal (its offset scaled alike); `None` for a zero or
/// non-finite normal.
fn normalised(p: [f64; 4]) -> Option<[f64; 4]> {
    let n = DVec3::new(p[0], p[1], p[2]);
    let len = n.length();
    (len.is_finite() && len > 0.0 && p[3].is_finite()).then(|| {
        let u = n / len;
        [u.x, u.y, u.z, p[3] / len]
    })
}

/// What is in view, for a section box with nothing selected: the box
/// around the frustum from the near plane to [`VIEW_BOX_DEPTH`] times
/// `depth` (the distance of the surface under the screen's centre), met
/// with the scene's `bounds`. `None` when they do not meet.
pub fn view_box(camera: &Camera, depth: f64, bounds: &Aabb) -> Option<Aabb> {
    let usable = depth.is_finite() && depth > 0.0 && bounds.is_valid();
    if !usable {
        return None;
    }
    let far = (depth * VIEW_BOX_DEPTH).max(camera.near * 2.0);
    let (f, r, u) = (camera.forward(), camera.right(), camera.up());
    let ty = camera.tan_half_fovy();
    let tx = ty * camera.aspect;
    let corners = [camera.near, far].into_iter().flat_map(|z| {
        [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)]
            .map(|(sx, sy)| camera.position + (f + r * (sx * tx) + u * (sy * ty)) * z)
    });
    let frustum = Aabb::from_points(corners);
    let met = Aabb::new(frustum.min.max(bounds.min), frustum.max.min(bounds.max));
    met.is_valid().then_some(met)
}

/// [`view_box`] for `J` with nothing selected, `hit` the distance of the
/// surface under the screen's centre (`None`: nothing there, and the box
/// reaches as deep as the scene goes); the message when the view shows
/// none of the scene.
pub fn box_in_view(camera: &Camera, hit: Option<f64>, bounds: &Aabb) -> Result<Aabb, String> {
    let depth = hit.unwrap_or_else(|| {
        ((bounds.center() - camera.position).length() + 0.5 * bounds.diagonal()) / VIEW_BOX_DEPTH
    });
    view_box(camera, depth, bounds)
        .ok_or_else(|| "section box: the view shows none of the scene".to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eye_looking_along_x() -> Camera {
        Camera::look_at(DVec3::ZERO, DVec3::X, 60f64.to_radians(), 1.5, 0.01)
    }

    #[test]
    fn a_placed_plane_cuts_between_the_eye_and_the_point() {
        let mut s = Sections::default();
        assert!(s.current().is_none());
        let cam = eye_looking_along_x();
        let hit = DVec3::new(10.0, 1.0, -2.0);
        let said = s.place_plane(hit, cam.forward() * 3.0).unwrap();
        assert!(said.contains("section plane 1 of 6"), "{said}");
        let c = s.current().unwrap();
        assert!(!c.keeps(DVec3::new(5.0, 0.0, 0.0)), "between eye and point");
        assert!(!c.keeps(cam.position));
        assert!(c.keeps(DVec3::new(12.0, 1.0, -2.0)), "beyond the point");
        assert!(c.half_spaces()[0].distance(hit).abs() < 1e-12);
        assert_eq!(s.planes()[0], [1.0, 0.0, 0.0, -10.0]);
    }

    #[test]
    fn moving_steps_along_the_normal_by_a_fraction_of_the_distance() {
        let mut s = Sections::default();
        assert!(!s.move_active(1.0, DVec3::ZERO, 100.0), "no plane yet");
        s.place_plane(DVec3::new(10.0, 0.0, 0.0), DVec3::X).unwrap();
        // The eye is 10 away: a step is 0.5, along +x (cuts more).
        assert!(s.move_active(2.0, DVec3::ZERO, 100.0));
        assert_eq!(s.planes()[0][3], -11.0);
        let c = s.current().unwrap();
        assert!(!c.keeps(DVec3::new(10.9, 0.0, 0.0)));
        assert!(c.keeps(DVec3::new(11.1, 0.0, 0.0)));
        // Back towards the eye; the new distance (11) sets the step.
        s.move_active(-1.0, DVec3::ZERO, 100.0);
        assert!((s.planes()[0][3] + 10.45).abs() < 1e-12);
        // An eye on the plane still moves it, by the scene's fraction.
        let mut on = Sections::default();
        on.place_plane(DVec3::ZERO, DVec3::Y).unwrap();
        on.move_active(1.0, DVec3::ZERO, 1000.0);
        assert!((on.planes()[0][3] + 0.1).abs() < 1e-12);
    }

    #[test]
    fn flipping_keeps_the_other_side_and_moves_only_the_active_plane() {
        let mut s = Sections::default();
        assert!(!s.flip_active());
        s.place_plane(DVec3::new(0.0, 5.0, 0.0), DVec3::Y).unwrap();
        s.place_plane(DVec3::new(10.0, 0.0, 0.0), DVec3::X).unwrap();
        let before = s.current().unwrap();
        assert!(before.keeps(DVec3::new(11.0, 6.0, 0.0)));
        assert!(s.flip_active());
        let after = s.current().unwrap();
        assert!(!after.keeps(DVec3::new(11.0, 6.0, 0.0)));
        assert!(after.keeps(DVec3::new(9.0, 6.0, 0.0)));
        assert_eq!(
            s.planes()[0],
            [0.0, 1.0, 0.0, -5.0],
            "the first is as placed"
        );
        assert_eq!(s.planes()[1], [-1.0, 0.0, 0.0, 10.0]);
    }

    #[test]
    fn at_most_six_planes_and_the_hud_says_full() {
        let mut s = Sections::default();
        for i in 0..6 {
            s.place_plane(DVec3::new(i as f64, 0.0, 0.0), DVec3::X)
                .unwrap();
        }
        let full = s.place_plane(DVec3::ZERO, DVec3::X).unwrap_err();
        assert!(full.contains("all 6 in use"), "{full}");
        assert_eq!(s.planes().len(), 6);
        let hud = s.hud_line().unwrap();
        assert!(hud.contains("6 of 6 planes (full), on"), "{hud}");
        assert!(s.place_plane(DVec3::ZERO, DVec3::ZERO).is_err());
    }

    #[test]
    fn toggling_and_clearing() {
        let mut s = Sections::default();
        assert_eq!(s.hud_line(), None);
        s.place_plane(DVec3::ZERO, DVec3::Z).unwrap();
        let on = s.current().unwrap();
        assert!(s.toggle().contains("off"));
        assert!(s.current().is_none(), "off: nothing is cut");
        assert!(s.hud_line().unwrap().contains("1 of 6 planes, OFF"));
        assert!(
            s.spec().is_some(),
            "off keeps the planes (a view saves them)"
        );
        assert!(s.toggle().contains("on"));
        assert_eq!(*s.current().unwrap(), *on);
        // Moving a plane while off turns sections on: the move shows.
        s.toggle();
        s.move_active(1.0, DVec3::new(0.0, 0.0, -4.0), 10.0);
        assert!(s.enabled() && s.current().is_some());
        s.clear();
        assert!(s.current().is_none() && s.spec().is_none() && s.hud_line().is_none());
    }

    #[test]
    fn the_arc_is_rebuilt_only_when_the_section_changes() {
        let mut s = Sections::default();
        s.place_plane(DVec3::ZERO, DVec3::Z).unwrap();
        let (a, b) = (s.current().unwrap(), s.current().unwrap());
        assert!(Arc::ptr_eq(&a, &b));
        s.flip_active();
        assert!(!Arc::ptr_eq(&a, &s.current().unwrap()));
    }

    #[test]
    fn a_box_around_a_selection_is_padded_and_keeps_it() {
        let mut s = Sections::default();
        let object = Aabb::new(DVec3::new(1.0, 2.0, 3.0), DVec3::new(3.0, 4.0, 4.0));
        let said = s.box_around(&object, 100.0).unwrap();
        assert!(said.starts_with("section box"), "{said}");
        let pad = BOX_PAD * object.diagonal();
        let b = s.bbox().unwrap();
        assert!((b[0] - (1.0 - pad)).abs() < 1e-12 && (b[5] - (4.0 + pad)).abs() < 1e-12);
        let c = s.current().unwrap();
        assert!(c.keeps(object.min) && c.keeps(object.max));
        assert!(!c.keeps(DVec3::new(5.0, 3.0, 3.5)));
        assert!(s.hud_line().unwrap().contains("section: box, on"));
        // A flat object still gets a box with thickness.
        let flat = Aabb::new(DVec3::ZERO, DVec3::new(0.0, 0.0, 0.0));
        s.box_around(&flat, 100.0).unwrap();
        let b = s.bbox().unwrap();
        assert!(b[3] - b[0] > 0.0);
        assert!(s.box_around(&Aabb::EMPTY, 100.0).is_err());
    }

    #[test]
    fn a_view_box_reaches_past_the_centre_surface_within_the_scene() {
        let cam = eye_looking_along_x();
        let scene = Aabb::new(DVec3::splat(-100.0), DVec3::splat(100.0));
        let b = view_box(&cam, 10.0, &scene).unwrap();
        assert!((b.max.x - 30.0).abs() < 1e-9, "{b:?}");
        assert!(b.min.x >= 0.0 && b.min.x < 0.02);
        // The frustum's half height at x = 30 is 30 tan 30 degrees.
        assert!((b.max.y - 30.0 * 30f64.to_radians().tan()).abs() < 1e-9);
        assert!(b.contains_point(DVec3::new(10.0, 0.0, 0.0)));
        // Clamped to the scene; nothing when the view misses it.
        let small = Aabb::new(DVec3::new(5.0, -1.0, -1.0), DVec3::new(8.0, 1.0, 1.0));
        assert_eq!(view_box(&cam, 10.0, &small), Some(small));
        let behind = Aabb::new(DVec3::splat(-9.0), DVec3::splat(-5.0));
        assert_eq!(view_box(&cam, 10.0, &behind), None);
        assert_eq!(view_box(&cam, f64::NAN, &scene), None);
        // Nothing under the centre: as deep as the scene goes.
        let deep = box_in_view(&cam, None, &scene).unwrap();
        assert!(deep.max.x >= 100.0 - 1e-9, "{deep:?}");
        assert!(box_in_view(&cam, Some(10.0), &behind).is_err());
    }

    #[test]
    fn a_view_saves_what_cuts_and_restores_it() {
        let mut s = Sections::default();
        assert_eq!(s.saved(), None);
        s.place_plane(DVec3::new(0.0, 0.0, 2.0), DVec3::Z).unwrap();
        let saved = s.saved().unwrap();
        assert_eq!(saved.planes, vec![[0.0, 0.0, 1.0, -2.0]]);
        s.toggle();
        assert_eq!(s.saved(), None, "off: the view shows no section");
        let mut other = Sections::default();
        other
            .box_around(&Aabb::new(DVec3::ZERO, DVec3::ONE), 10.0)
            .unwrap();
        let said = other.restore(Some(&saved));
        assert!(said.contains("section plane 0 0 1 -2"), "{said}");
        assert_eq!(other.spec(), Some(saved), "the box is replaced");
        assert_eq!(other.restore(None), "");
        assert!(other.spec().is_none());
        // A hand-edited view with a bad plane keeps the sections as they were.
        other.place_plane(DVec3::ZERO, DVec3::X).unwrap();
        let bad = SectionSpec {
            planes: vec![[0.0; 4]],
            bbox: None,
        };
        let said = other.restore(Some(&bad));
        assert!(
            said.contains("left out") && said.contains("normal is zero"),
            "{said}"
        );
        assert_eq!(other.planes().len(), 1);
    }

    #[test]
    fn a_restored_spec_is_normalised_and_turns_sections_on() {
        let spec = SectionSpec {
            planes: vec![[0.0, 0.0, 2.0, -10.0]],
            bbox: Some([0.0, 0.0, 0.0, 1.0, 1.0, 1.0]),
        };
        let section = Section::new(spec).unwrap();
        let mut s = Sections::new(Some(&section));
        assert_eq!(s.planes()[0], [0.0, 0.0, 1.0, -5.0]);
        // z >= 5 and the unit box: nothing is kept.
        assert!(!s.current().unwrap().keeps(DVec3::new(0.5, 0.5, 0.5)));
        s.toggle();
        s.set_spec(&SectionSpec::default());
        assert!(s.enabled() && s.current().is_none());
    }
}
