//! The viewer's key bindings: the table shared with the browser page
//! ([`gigawalk_review::keys`]), looked up by winit's `KeyCode`, whose
//! variants are named as the table names keys (`KeyboardEvent.code`).

use winit::keyboard::KeyCode;

pub use gigawalk_review::keys::{
    help_lines, Action, Binding, Does, Movement, BINDINGS, MOUSE_HELP,
};

/// The `KeyboardEvent.code` name of `key`: its variant's name ("KeyW",
/// "ArrowUp", "Digit0", ...).
pub fn code_name(key: KeyCode) -> String {
    format!("{key:?}")
}

/// What a key does, if anything.
pub fn lookup(key: KeyCode) -> Option<&'static Does> {
    gigawalk_review::keys::lookup(&code_name(key))
}

/// The saved view a digit key restores: 1 for `1`, ... 9 for `9`.
pub fn view_number(key: KeyCode) -> Option<usize> {
    gigawalk_review::keys::view_number(&code_name(key))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every key the table names, as winit names it.
    #[rustfmt::skip]
    const TABLE_KEYS: &[KeyCode] = &[
        KeyCode::KeyW, KeyCode::ArrowUp, KeyCode::KeyS, KeyCode::ArrowDown, KeyCode::KeyA,
        KeyCode::ArrowLeft, KeyCode::KeyD, KeyCode::ArrowRight, KeyCode::KeyQ,
        KeyCode::ControlLeft, KeyCode::Space, KeyCode::ShiftLeft, KeyCode::ShiftRight,
        KeyCode::KeyG, KeyCode::KeyO, KeyCode::KeyK, KeyCode::KeyC, KeyCode::KeyL, KeyCode::Equal,
        KeyCode::NumpadAdd, KeyCode::PageUp, KeyCode::Minus, KeyCode::NumpadSubtract,
        KeyCode::PageDown, KeyCode::KeyY, KeyCode::KeyT, KeyCode::KeyE, KeyCode::F2, KeyCode::F3,
        KeyCode::F4, KeyCode::KeyB, KeyCode::KeyZ, KeyCode::KeyF, KeyCode::Slash,
        KeyCode::NumpadDivide, KeyCode::Enter, KeyCode::NumpadEnter, KeyCode::KeyH,
        KeyCode::KeyI, KeyCode::KeyU, KeyCode::KeyV, KeyCode::KeyN, KeyCode::Digit1,
        KeyCode::Digit2, KeyCode::Digit3, KeyCode::Digit4, KeyCode::Digit5, KeyCode::Digit6,
        KeyCode::Digit7, KeyCode::Digit8, KeyCode::Digit9, KeyCode::KeyX, KeyCode::BracketRight,
        KeyCode::BracketLeft, KeyCode::Backslash, KeyCode::KeyJ, KeyCode::Digit0,
        KeyCode::Delete, KeyCode::KeyM, KeyCode::KeyR, KeyCode::KeyP, KeyCode::F12, KeyCode::Tab,
        KeyCode::F1, KeyCode::Escape,
    ];

    #[test]
    fn every_key_in_the_table_is_a_winit_key_code() {
        let names: Vec<String> = TABLE_KEYS.iter().map(|&k| code_name(k)).collect();
        for b in BINDINGS {
            for k in b.keys {
                assert!(
                    names.iter().any(|n| n == k),
                    "{k:?} ({}) is no winit KeyCode's name",
                    b.label
                );
            }
        }
        // And every one of those is a key the table binds.
        for &k in TABLE_KEYS {
            assert!(lookup(k).is_some(), "{k:?} is bound to nothing");
        }
    }

    #[test]
    fn winit_keys_find_their_bindings() {
        assert!(matches!(
            lookup(KeyCode::KeyW),
            Some(Does::Move(Movement::Forward))
        ));
        assert!(matches!(
            lookup(KeyCode::BracketRight),
            Some(Does::Act(Action::SectionForward))
        ));
        assert!(matches!(
            lookup(KeyCode::NumpadAdd),
            Some(Does::Act(Action::PixelErrorUp))
        ));
        assert!(matches!(
            lookup(KeyCode::F4),
            Some(Does::Act(Action::ToggleXray))
        ));
        assert!(lookup(KeyCode::F5).is_none());
        assert_eq!(view_number(KeyCode::Digit1), Some(1));
        assert_eq!(view_number(KeyCode::Digit9), Some(9));
        assert_eq!(view_number(KeyCode::Digit0), None);
    }
}
