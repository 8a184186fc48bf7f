//! What the keys that change only the objects' and the sections' state
//! do, answered alike by the viewer and the page: hide, isolate and show
//! all; move, flip, toggle and clear section planes.

use glam::DVec3;

use crate::keys::Action;
use crate::objects::Objects;
use crate::sections::Sections;

/// Said when a key acts on the last section plane and there is none.
pub const NO_PLANE: &str = "no section plane yet: X places one at the cursor";

/// Applies `action` to `objects` and `sections` (`eye`: the camera's
/// position, `diagonal`: the scene box's, which set how far a plane
/// moves): `None` when `action` is not one of theirs, else what to show,
/// if anything (a refusal says why).
pub fn act(
    action: Action,
    objects: &mut Objects,
    sections: &mut Sections,
    eye: DVec3,
    diagonal: f64,
) -> Option<Option<String>> {
    let plane = |done: bool, said: Option<&str>| match done {
        true => said.map(str::to_string),
        false => Some(NO_PLANE.to_string()),
    };
    let either = |r: Result<String, String>| match r {
        Ok(m) | Err(m) => Some(m),
    };
    Some(match action {
        Action::Hide => either(objects.hide()),
        Action::Isolate => either(objects.isolate()),
        Action::ShowAll => either(objects.show_all()),
        Action::SectionForward => plane(sections.move_active(1.0, eye, diagonal), None),
        Action::SectionBack => plane(sections.move_active(-1.0, eye, diagonal), None),
        Action::FlipSection => plane(sections.flip_active(), Some("section plane flipped")),
        Action::ToggleSections => Some(sections.toggle()),
        Action::ClearSections => Some(sections.clear()),
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn section_keys_without_a_plane_say_so_and_other_keys_are_not_theirs() {
        let mut objects = Objects::new(Err("no table".into()));
        let mut sections = Sections::default();
        let mut run = |a| act(a, &mut objects, &mut sections, DVec3::ZERO, 10.0);
        for a in [
            Action::SectionForward,
            Action::SectionBack,
            Action::FlipSection,
        ] {
            assert_eq!(run(a), Some(Some(NO_PLANE.to_string())), "{a:?}");
        }
        assert_eq!(run(Action::Hide), Some(Some("no table".to_string())));
        assert!(matches!(run(Action::ClearSections), Some(Some(_))));
        assert_eq!(run(Action::ToggleHud), None);
    }
}
