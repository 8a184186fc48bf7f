//! Measuring a distance, as xeokit's distance measurements do: `M`, then
//! two clicks on the full-detail surface; the distance shows in model
//! units and metres, drawn as a line between the points with a label at
//! its middle, until `M` again or Esc clears it.
//!
//! Pure state, text and projection: the frame loop picks the points and
//! the presenter draws what [`screen_segment`] gives, so all of it is
//! unit-tested without a window.

use gigawalk_cull::Camera;
use gigawalk_scene::units::Units;
use glam::DVec3;

/// Where a measurement is.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Measure {
    /// No measurement: clicks select.
    #[default]
    Off,
    /// `M` pressed: the next click picks the first point.
    First,
    /// The first point picked: the next click picks the second.
    Second(DVec3),
    /// Both picked: the distance shows until `M` or Esc.
    Done(DVec3, DVec3),
}

impl Measure {
    /// `M`: starts a measurement, or clears the one there is. What to
    /// show.
    pub fn toggle(&mut self) -> String {
        if *self == Measure::Off {
            *self = Measure::First;
            "measure: click the first point (M or Esc cancels)".into()
        } else {
            *self = Measure::Off;
            "measurement cleared".into()
        }
    }

    /// Whether anything is shown or awaited (Esc clears it rather than
    /// quitting).
    pub fn is_active(&self) -> bool {
        *self != Measure::Off
    }

    /// Whether the next click is a measuring one (not a selection).
    pub fn wants_click(&self) -> bool {
        matches!(self, Measure::First | Measure::Second(_))
    }

    /// A measuring click that hit `point` (`None`: nothing there, which
    /// leaves the measurement waiting). What to show.
    pub fn click(&mut self, point: Option<DVec3>, units: &Units) -> String {
        let Some(p) = point else {
            return "measure: nothing there (cut away, hidden or empty); click a surface".into();
        };
        match *self {
            Measure::First => {
                *self = Measure::Second(p);
                "measure: click the second point".into()
            }
            Measure::Second(a) => {
                *self = Measure::Done(a, p);
                format!(
                    "measured {} between {} and {}",
                    units.format(a.distance(p)),
                    crate::objects::point_text(a),
                    crate::objects::point_text(p)
                )
            }
            Measure::Off | Measure::Done(..) => String::new(),
        }
    }

    /// The distance measured (model units), once both points are picked.
    pub fn distance(&self) -> Option<f64> {
        match self {
            Measure::Done(a, b) => Some(a.distance(*b)),
            _ => None,
        }
    }

    /// The label at the line's middle, once both points are picked.
    pub fn label(&self, units: &Units) -> Option<String> {
        self.distance().map(|d| units.format(d))
    }

    /// The points picked so far.
    pub fn points(&self) -> Vec<DVec3> {
        match *self {
            Measure::Off | Measure::First => Vec::new(),
            Measure::Second(a) => vec![a],
            Measure::Done(a, b) => vec![a, b],
        }
    }

    /// Where the measurement shows on a `size` image of `camera`: a
    /// marker at each point picked in front of the near plane, and the
    /// segment between the two once both are ([`screen_segment`]).
    pub fn on_screen(&self, camera: &Camera, size: (u32, u32)) -> OnScreen {
        let points = self.points();
        let markers = points
            .iter()
            .filter_map(|&p| screen_segment(camera, size, p, p).map(|(a, _)| a))
            .collect();
        let segment = match points.as_slice() {
            [a, b] => screen_segment(camera, size, *a, *b),
            _ => None,
        };
        OnScreen { markers, segment }
    }

    /// The HUD's line while measuring.
    pub fn hud_line(&self, units: &Units) -> Option<String> {
        match self {
            Measure::Off => None,
            Measure::First => Some("measure: click the first point".into()),
            Measure::Second(_) => Some("measure: click the second point".into()),
            Measure::Done(..) => self
                .label(units)
                .map(|l| format!("measured {l} (M or Esc clears)")),
        }
    }
}

/// A measurement in pixels of one image ([`Measure::on_screen`]), row 0
/// at the top.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OnScreen {
    pub markers: Vec<[f32; 2]>,
    pub segment: Option<([f32; 2], [f32; 2])>,
}

/// The part of the segment `a`-`b` in front of `camera`'s near plane, in
/// pixels of a `size` image (row 0 at the top), projected through
/// camera-relative f64 coordinates so a model far from the origin draws
/// as steadily as one at it. `None` when all of it is behind the near
/// plane.
pub fn screen_segment(
    camera: &Camera,
    size: (u32, u32),
    a: DVec3,
    b: DVec3,
) -> Option<([f32; 2], [f32; 2])> {
    let (f, r, u) = (camera.forward(), camera.right(), camera.up());
    let rel = |p: DVec3| {
        let d = p - camera.position;
        DVec3::new(d.dot(r), d.dot(u), d.dot(f))
    };
    let (mut p, mut q) = (rel(a), rel(b));
    let near = camera.near;
    if p.z < near && q.z < near {
        return None;
    }
    // Cut at the near plane the end that lies behind it.
    let cut = |from: DVec3, to: DVec3| from + (to - from) * ((near - from.z) / (to.z - from.z));
    if p.z < near {
        p = cut(p, q);
    } else if q.z < near {
        q = cut(q, p);
    }
    let ty = camera.tan_half_fovy();
    let tx = ty * camera.aspect;
    let (w, h) = (size.0 as f64, size.1 as f64);
    let pixel = |v: DVec3| {
        let (nx, ny) = (v.x / (v.z * tx), v.y / (v.z * ty));
        [((nx + 1.0) * 0.5 * w) as f32, ((1.0 - ny) * 0.5 * h) as f32]
    };
    Some((pixel(p), pixel(q)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mm() -> Units {
        "mm".parse().unwrap()
    }

    #[test]
    fn m_then_two_clicks_measures_and_m_clears() {
        let mut m = Measure::default();
        assert!(!m.is_active() && !m.wants_click());
        assert!(m.toggle().contains("first point"));
        assert!(m.wants_click());
        let a = DVec3::new(0.0, 0.0, 0.0);
        let b = DVec3::new(300.0, 400.0, 0.0);
        assert!(m.click(Some(a), &mm()).contains("second point"));
        assert_eq!(m.points(), vec![a]);
        assert_eq!(m.label(&mm()), None);
        let said = m.click(Some(b), &mm());
        assert_eq!(
            said,
            "measured 500 mm (0.5 m) between 0.000000, 0.000000, 0.000000 and \
             300.000000, 400.000000, 0.000000"
        );
        assert_eq!(m, Measure::Done(a, b));
        assert!(!m.wants_click(), "clicks select again");
        assert!(m.is_active());
        assert_eq!(m.label(&mm()).as_deref(), Some("500 mm (0.5 m)"));
        assert_eq!(
            m.hud_line(&mm()).as_deref(),
            Some("measured 500 mm (0.5 m) (M or Esc clears)")
        );
        assert_eq!(m.toggle(), "measurement cleared");
        assert_eq!(m, Measure::Off);
        assert!(m.points().is_empty() && m.hud_line(&mm()).is_none());
    }

    #[test]
    fn a_click_on_nothing_keeps_waiting_and_m_cancels() {
        let mut m = Measure::default();
        m.toggle();
        assert!(m.click(None, &Units::default()).contains("nothing there"));
        assert_eq!(m, Measure::First);
        m.click(Some(DVec3::ONE), &Units::default());
        m.click(None, &Units::default());
        assert_eq!(m, Measure::Second(DVec3::ONE));
        m.toggle();
        assert_eq!(m, Measure::Off);
    }

    #[test]
    fn metres_alone_when_the_model_is_in_metres() {
        let mut m = Measure::First;
        m.click(Some(DVec3::ZERO), &Units::default());
        m.click(Some(DVec3::new(0.0, 2.5, 0.0)), &Units::default());
        assert_eq!(m.label(&Units::default()).as_deref(), Some("2.5 m"));
    }

    fn camera_at(position: DVec3) -> Camera {
        // Looking down -z, 90 degrees vertical, square image.
        Camera::look_at(position, position - DVec3::Z, 90f64.to_radians(), 1.0, 0.1)
    }

    #[test]
    fn a_segment_in_front_projects_to_pixels() {
        let cam = camera_at(DVec3::ZERO);
        let (p, q) = screen_segment(
            &cam,
            (200, 100),
            DVec3::new(0.0, 0.0, -5.0),
            DVec3::new(5.0, 5.0, -5.0),
        )
        .unwrap();
        let near =
            |a: [f32; 2], b: [f32; 2]| (a[0] - b[0]).abs() < 1e-3 && (a[1] - b[1]).abs() < 1e-3;
        assert!(near(p, [100.0, 50.0]), "the centre: {p:?}");
        assert!(
            near(q, [200.0, 0.0]),
            "45 degrees right and up, the corner: {q:?}"
        );
    }

    #[test]
    fn on_screen_marks_each_point_picked_and_the_segment_once_both_are() {
        let cam = camera_at(DVec3::ZERO);
        let mut m = Measure::default();
        assert_eq!(m.on_screen(&cam, (200, 100)), OnScreen::default());
        m.toggle();
        m.click(Some(DVec3::new(0.0, 0.0, -5.0)), &Units::default());
        let one = m.on_screen(&cam, (200, 100));
        assert_eq!((one.markers.len(), one.segment), (1, None));
        // The second point behind the eye: no marker for it, and the
        // segment cut at the near plane.
        m.click(Some(DVec3::new(0.0, 0.0, 5.0)), &Units::default());
        let both = m.on_screen(&cam, (200, 100));
        assert_eq!(both.markers, one.markers);
        assert!(both.segment.is_some());
    }

    #[test]
    fn a_segment_through_the_near_plane_is_cut_there_and_one_behind_is_gone() {
        let cam = camera_at(DVec3::ZERO);
        let (p, q) = screen_segment(
            &cam,
            (100, 100),
            DVec3::new(0.0, 0.0, 5.0),
            DVec3::new(1.0, 0.0, -1.0),
        )
        .unwrap();
        assert!(
            (q[0] - 100.0).abs() < 1e-3 && (q[1] - 50.0).abs() < 1e-3,
            "{q:?}"
        );
        // Cut at the near plane, 0.85 to the right at depth 0.1: far off
        // the image's right edge.
        assert!(p[0] > 100.0 && (p[1] - 50.0).abs() < 1e-3, "{p:?}");
        assert!(screen_segment(
            &cam,
            (100, 100),
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0, 0.0, 2.0)
        )
        .is_none());
    }

    #[test]
    fn projection_is_camera_relative_far_from_the_origin() {
        let far = DVec3::new(4e6, -3e6, 2e5);
        let cam = camera_at(far);
        let near_origin = screen_segment(
            &camera_at(DVec3::ZERO),
            (640, 480),
            DVec3::new(0.25, 0.125, -3.0),
            DVec3::new(-1.0, 0.5, -7.0),
        )
        .unwrap();
        let moved = screen_segment(
            &cam,
            (640, 480),
            far + DVec3::new(0.25, 0.125, -3.0),
            far + DVec3::new(-1.0, 0.5, -7.0),
        )
        .unwrap();
        for (x, y) in [(near_origin.0, moved.0), (near_origin.1, moved.1)] {
            assert!((x[0] - y[0]).abs() < 1e-3 && (x[1] - y[1]).abs() < 1e-3);
        }
    }
}
