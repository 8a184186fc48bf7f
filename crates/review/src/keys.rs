//! The key bindings of the native viewer and the browser page: one table
//! that both look keys up in, and that the viewer's on-screen help and
//! `gigawalk view --help` come from, so both answer the same keys the
//! same way.
//!
//! Keys are named by where they are on the keyboard, as the W3C's
//! `KeyboardEvent.code` names them ("KeyW", "ArrowUp", "Digit0",
//! "BracketRight", "NumpadAdd", "ShiftLeft", "F4"): what the page gets
//! from the browser, and the names of winit's `KeyCode` variants, which
//! the viewer looks up by. An action a frontend does not offer is one it
//! ignores.

/// Something a key does once when pressed (movement keys are held instead,
/// see [`Movement`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Action {
    ToggleWalk,
    ToggleOcclusion,
    CycleCuller,
    ToggleHlod,
    PixelErrorUp,
    PixelErrorDown,
    ToggleAsync,
    ToggleTarget,
    ToggleWireframe,
    ToggleEdges,
    ToggleAmbientOcclusion,
    ToggleAntialiasing,
    ToggleXray,
    ToggleBoxes,
    ToggleFreeze,
    /// Fly to see the selected object whole.
    FrameSelection,
    /// Open the search prompt.
    Search,
    /// The last search's next match.
    NextMatch,
    Hide,
    Isolate,
    ShowAll,
    /// Save the view: the viewer to the scene's views file, the page as
    /// a link in the address bar.
    SaveView,
    NextView,
    /// A section plane through the point under the cursor, facing the
    /// camera.
    SectionPlane,
    /// Move the active section plane along its normal (cutting more
    /// away) or back.
    SectionForward,
    SectionBack,
    FlipSection,
    /// A section box around the selection, or around what is in view.
    SectionBox,
    ToggleSections,
    ClearSections,
    /// Start a measurement, or clear it.
    Measure,
    ToggleRecord,
    Screenshot,
    ToggleHud,
    ToggleHelp,
    Quit,
}

/// Held movement keys (the controller's).
pub use crate::fly::Movement;

/// One line of the bindings table.
pub struct Binding {
    /// The keys, as `KeyboardEvent.code` names them.
    pub keys: &'static [&'static str],
    /// How the keys are written in help text.
    pub label: &'static str,
    pub what: &'static str,
    pub does: Does,
}

pub enum Does {
    Move(Movement),
    Act(Action),
    /// Restore the saved view the key's digit numbers ([`view_number`]).
    RestoreView,
}

use Does::{Act, Move};

#[rustfmt::skip]
pub const BINDINGS: &[Binding] = &[
    Binding { keys: &["KeyW", "ArrowUp"], label: "W / Up", what: "fly forward", does: Move(Movement::Forward) },
    Binding { keys: &["KeyS", "ArrowDown"], label: "S / Down", what: "fly back", does: Move(Movement::Back) },
    Binding { keys: &["KeyA", "ArrowLeft"], label: "A / Left", what: "strafe left", does: Move(Movement::Left) },
    Binding { keys: &["KeyD", "ArrowRight"], label: "D / Right", what: "strafe right", does: Move(Movement::Right) },
    Binding { keys: &["KeyQ", "ControlLeft"], label: "Q / Ctrl", what: "down", does: Move(Movement::Down) },
    Binding { keys: &["Space"], label: "Space", what: "up", does: Move(Movement::Up) },
    Binding { keys: &["ShiftLeft", "ShiftRight"], label: "Shift", what: "hold: 5x faster", does: Move(Movement::Fast) },
    Binding { keys: &["KeyG"], label: "G", what: "walk mode (eye height, level) on/off", does: Act(Action::ToggleWalk) },
    Binding { keys: &["KeyO"], label: "O", what: "occlusion culling on/off", does: Act(Action::ToggleOcclusion) },
    Binding { keys: &["KeyK"], label: "K", what: "keep the target frame rate (--target-fps, default 30): pixel error chosen each frame", does: Act(Action::ToggleTarget) },
    Binding { keys: &["KeyC"], label: "C", what: "next occlusion culler: hzb (GigaWalk), grid (lazy occlusion grid), oq (occlusion queries), ct (large occluders)", does: Act(Action::CycleCuller) },
    Binding { keys: &["KeyL"], label: "L", what: "HLOD on/off", does: Act(Action::ToggleHlod) },
    Binding { keys: &["Equal", "NumpadAdd", "PageUp"], label: "+ / PgUp", what: "pixel error up", does: Act(Action::PixelErrorUp) },
    Binding { keys: &["Minus", "NumpadSubtract", "PageDown"], label: "- / PgDn", what: "pixel error down", does: Act(Action::PixelErrorDown) },
    Binding { keys: &["KeyY"], label: "Y", what: "async rendering on/off", does: Act(Action::ToggleAsync) },
    Binding { keys: &["KeyT"], label: "T", what: "wireframe", does: Act(Action::ToggleWireframe) },
    Binding { keys: &["KeyE"], label: "E", what: "edges on/off: creases and silhouettes", does: Act(Action::ToggleEdges) },
    Binding { keys: &["F2"], label: "F2", what: "ambient occlusion on/off", does: Act(Action::ToggleAmbientOcclusion) },
    Binding { keys: &["F3"], label: "F3", what: "anti-aliasing (FXAA) on/off", does: Act(Action::ToggleAntialiasing) },
    Binding { keys: &["F4"], label: "F4", what: "x-ray: hidden and isolated-away objects as faint ghosts", does: Act(Action::ToggleXray) },
    Binding { keys: &["KeyB"], label: "B", what: "bounding boxes on/off", does: Act(Action::ToggleBoxes) },
    Binding { keys: &["KeyZ"], label: "Z", what: "freeze culling: keep this view's visible set, fly around it", does: Act(Action::ToggleFreeze) },
    Binding { keys: &["KeyF"], label: "F", what: "frame the selected object: fly back along the view until it fits", does: Act(Action::FrameSelection) },
    Binding { keys: &["Slash", "NumpadDivide"], label: "/", what: "find objects by name or path (* ? wildcards): type, Enter flies to a match, Esc cancels", does: Act(Action::Search) },
    Binding { keys: &["Enter", "NumpadEnter"], label: "Enter", what: "fly to the search's next match (k of n)", does: Act(Action::NextMatch) },
    Binding { keys: &["KeyH"], label: "H", what: "hide the selection (after a search: all its matches)", does: Act(Action::Hide) },
    Binding { keys: &["KeyI"], label: "I", what: "isolate the selection (after a search: its matches): hide all else", does: Act(Action::Isolate) },
    Binding { keys: &["KeyU"], label: "U", what: "show every object again", does: Act(Action::ShowAll) },
    Binding { keys: &["KeyV"], label: "V", what: "save the view: camera, selection, hidden objects (SCENE.views.json)", does: Act(Action::SaveView) },
    Binding { keys: &["KeyN"], label: "N", what: "restore the next saved view", does: Act(Action::NextView) },
    Binding { keys: &["Digit1", "Digit2", "Digit3", "Digit4", "Digit5", "Digit6", "Digit7", "Digit8", "Digit9"], label: "1 - 9", what: "restore saved view 1 to 9", does: Does::RestoreView },
    Binding { keys: &["KeyX"], label: "X", what: "section plane at the cursor, facing you: cuts away what is in front (6 at most)", does: Act(Action::SectionPlane) },
    Binding { keys: &["BracketRight"], label: "]", what: "move the last section plane away along its normal (Shift+scroll up too)", does: Act(Action::SectionForward) },
    Binding { keys: &["BracketLeft"], label: "[", what: "move the last section plane back (Shift+scroll down too)", does: Act(Action::SectionBack) },
    Binding { keys: &["Backslash"], label: "\\", what: "flip the last section plane: keep the other side", does: Act(Action::FlipSection) },
    Binding { keys: &["KeyJ"], label: "J", what: "section box around the selection, or around what is in view", does: Act(Action::SectionBox) },
    Binding { keys: &["Digit0"], label: "0", what: "sections on/off", does: Act(Action::ToggleSections) },
    Binding { keys: &["Delete"], label: "Delete", what: "clear every section plane and the box", does: Act(Action::ClearSections) },
    Binding { keys: &["KeyM"], label: "M", what: "measure: click two points for their distance (M or Esc clears)", does: Act(Action::Measure) },
    Binding { keys: &["KeyR"], label: "R", what: "record camera path: start / stop and write", does: Act(Action::ToggleRecord) },
    Binding { keys: &["KeyP", "F12"], label: "P / F12", what: "screenshot to PNG", does: Act(Action::Screenshot) },
    Binding { keys: &["Tab"], label: "Tab", what: "HUD on/off", does: Act(Action::ToggleHud) },
    Binding { keys: &["F1"], label: "F1", what: "this help", does: Act(Action::ToggleHelp) },
    Binding { keys: &["Escape"], label: "Esc", what: "clear the measurement; with none, quit", does: Act(Action::Quit) },
];

/// Mouse controls, not in the key table.
pub const MOUSE_HELP: &[(&str, &str)] = &[
    ("drag (any button)", "look around"),
    (
        "click",
        "select the object under the cursor (on nothing: deselect)",
    ),
    ("double click", "select it and frame it"),
    ("scroll", "move speed up / down"),
    ("Shift+scroll", "move the last section plane away / back"),
];

/// What the key `code` (a `KeyboardEvent.code` name) does, if anything.
pub fn lookup(code: &str) -> Option<&'static Does> {
    BINDINGS
        .iter()
        .find(|b| b.keys.contains(&code))
        .map(|b| &b.does)
}

/// The saved view a digit key restores: 1 for `Digit1`, ... 9 for
/// `Digit9`.
pub fn view_number(code: &str) -> Option<usize> {
    const DIGITS: [&str; 9] = [
        "Digit1", "Digit2", "Digit3", "Digit4", "Digit5", "Digit6", "Digit7", "Digit8", "Digit9",
    ];
    DIGITS.iter().position(|&k| k == code).map(|i| i + 1)
}

/// The controls as aligned text lines: the on-screen help and `--help`.
pub fn help_lines() -> Vec<String> {
    let rows: Vec<(&str, &str)> = MOUSE_HELP
        .iter()
        .copied()
        .chain(BINDINGS.iter().map(|b| (b.label, b.what)))
        .collect();
    let width = rows.iter().map(|r| r.0.len()).max().unwrap_or(0);
    rows.iter()
        .map(|(k, w)| format!("{k:<width$}  {w}"))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_key_is_bound_twice() {
        let mut seen = std::collections::HashSet::new();
        for b in BINDINGS {
            for k in b.keys {
                assert!(seen.insert(*k), "{k} is bound twice");
            }
        }
    }

    #[test]
    fn wasd_moves_z_freezes_f_frames_e_draws_edges_and_f1_helps() {
        assert!(matches!(
            lookup("KeyW"),
            Some(Does::Move(Movement::Forward))
        ));
        assert!(matches!(
            lookup("KeyZ"),
            Some(Does::Act(Action::ToggleFreeze))
        ));
        assert!(matches!(
            lookup("KeyF"),
            Some(Does::Act(Action::FrameSelection))
        ));
        assert!(matches!(lookup("KeyH"), Some(Does::Act(Action::Hide))));
        assert!(matches!(lookup("F1"), Some(Does::Act(Action::ToggleHelp))));
        assert!(matches!(
            lookup("KeyX"),
            Some(Does::Act(Action::SectionPlane))
        ));
        assert!(matches!(lookup("KeyM"), Some(Does::Act(Action::Measure))));
        assert!(matches!(
            lookup("KeyE"),
            Some(Does::Act(Action::ToggleEdges))
        ));
        assert!(matches!(lookup("F4"), Some(Does::Act(Action::ToggleXray))));
        assert!(matches!(lookup("Space"), Some(Does::Move(Movement::Up))));
        assert!(lookup("F5").is_none());
    }

    #[test]
    fn digits_restore_views_one_to_nine() {
        assert!(matches!(lookup("Digit5"), Some(Does::RestoreView)));
        assert_eq!(view_number("Digit1"), Some(1));
        assert_eq!(view_number("Digit9"), Some(9));
        assert_eq!(view_number("Digit0"), None);
        assert_eq!(view_number("KeyV"), None);
        // Every key bound to RestoreView has a number.
        for b in BINDINGS {
            if matches!(b.does, Does::RestoreView) {
                assert!(b.keys.iter().all(|&k| view_number(k).is_some()));
            }
        }
    }

    #[test]
    fn help_lists_every_binding_and_the_mouse() {
        let help = help_lines();
        assert_eq!(help.len(), BINDINGS.len() + MOUSE_HELP.len());
        assert!(help
            .iter()
            .any(|l| l.contains("scroll") && l.contains("speed")));
        assert!(help.iter().all(|l| l.is_ascii()), "the HUD font is ASCII");
    }
}
