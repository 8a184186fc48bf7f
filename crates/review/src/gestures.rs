//! Pointer gestures on a view, as touch-screen viewers read them: one
//! pointer dragged looks around, two pinched apart or together fly
//! forward or back, and a press released where it went down (within
//! [`CLICK_SLOP`]) with no other pointer down is a click. Pure state: the
//! page feeds it pointer events and acts on what it says, so the
//! gestures are tested natively.

/// A press and release closer than this (CSS pixels) is a click, not a
/// drag.
pub const CLICK_SLOP: f64 = 4.0;

/// Spreading two fingers this many CSS pixels apart flies one second
/// forward at the fly controller's speed (pinching in flies back).
pub const PINCH_PIXELS_PER_SECOND: f64 = 100.0;

/// What a pointer's move means.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Gesture {
    /// Look around by this many pixels (right, down).
    Look(f64, f64),
    /// Fly along the view by this many seconds at the controller's speed
    /// (negative: back).
    Fly(f64),
    /// Nothing (a pointer not pressed, or three at once).
    None,
}

/// A point in CSS pixels.
type Point = (f64, f64);

/// The pointers down now: each one's id, where it is and where it went
/// down.
#[derive(Debug, Default)]
pub struct Pointers {
    down: Vec<(i32, Point, Point)>,
}

impl Pointers {
    pub fn press(&mut self, id: i32, at: (f64, f64)) {
        self.down.retain(|q| q.0 != id);
        self.down.push((id, at, at));
    }

    /// Pointer `id` moved to `at`.
    pub fn moved(&mut self, id: i32, at: (f64, f64)) -> Gesture {
        let Some(i) = self.down.iter().position(|q| q.0 == id) else {
            return Gesture::None;
        };
        let before = std::mem::replace(&mut self.down[i].1, at);
        match self.down.len() {
            1 => Gesture::Look(at.0 - before.0, at.1 - before.1),
            2 => {
                let other = self.down[1 - i].1;
                let gap = |q: (f64, f64)| (q.0 - other.0).hypot(q.1 - other.1);
                Gesture::Fly((gap(at) - gap(before)) / PINCH_PIXELS_PER_SECOND)
            }
            _ => Gesture::None,
        }
    }

    /// Pointer `id` went up (`released`: let go with the primary button,
    /// not cancelled); whether that was a click.
    pub fn release(&mut self, id: i32, released: bool) -> bool {
        let Some(i) = self.down.iter().position(|q| q.0 == id) else {
            return false;
        };
        let (_, now, pressed) = self.down.remove(i);
        let still = (now.0 - pressed.0).hypot(now.1 - pressed.1) < CLICK_SLOP;
        released && still && self.down.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_drag_looks_a_pinch_flies_and_a_still_press_clicks() {
        let mut p = Pointers::default();
        assert_eq!(p.moved(1, (5.0, 5.0)), Gesture::None);
        p.press(1, (10.0, 10.0));
        assert_eq!(p.moved(1, (13.0, 6.0)), Gesture::Look(3.0, -4.0));
        // Dragged far: not a click.
        assert!(!p.release(1, true));
        p.press(1, (10.0, 10.0));
        assert_eq!(p.moved(1, (11.0, 10.0)), Gesture::Look(1.0, 0.0));
        assert!(p.release(1, true));
        // Cancelled, or another button: no click.
        p.press(1, (10.0, 10.0));
        assert!(!p.release(1, false));
        // Two fingers 100 px apart spread to 150: half a second forward;
        // the first lifted is no click while the other is down.
        p.press(1, (0.0, 0.0));
        p.press(2, (100.0, 0.0));
        assert_eq!(p.moved(2, (150.0, 0.0)), Gesture::Fly(0.5));
        assert_eq!(p.moved(1, (100.0, 0.0)), Gesture::Fly(-1.0));
        assert!(!p.release(1, true));
        assert!(!p.release(2, true));
        assert!(!p.release(3, true));
    }
}
