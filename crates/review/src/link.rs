//! A saved view as a link: the camera, the selection, the hidden and
//! isolated objects and the section of a [`SavedView`]
//! (docs/views-format.md) in the browser page's URL fragment,
//! `#view=TEXT`, so a reviewer shares what they see by sharing the
//! address. TEXT is the
//! view's JSON (a views file's entry) in URL-safe base64 without
//! padding: the fragment never reaches the server, and nothing in it
//! needs escaping.
//!
//! A link is untrusted input: [`decode`] says what is wrong with one
//! that is cut short, edited or from elsewhere, and checks its camera as
//! a views file's is checked.

use base64::engine::general_purpose::URL_SAFE_NO_PAD;
use base64::Engine;
use gigawalk_scene::views::SavedView;

/// The fragment's key: `#view=TEXT`.
pub const KEY: &str = "view";

/// `view` as the text after `#view=`.
pub fn encode(view: &SavedView) -> String {
    let json = serde_json::to_vec(view).expect("a saved view always serializes");
    URL_SAFE_NO_PAD.encode(json)
}

/// The view in a URL fragment (with or without its `#`), `None` when it
/// has no `view=` part; an error says what is wrong with one it has.
pub fn from_fragment(fragment: &str) -> Option<Result<SavedView, String>> {
    let f = fragment.strip_prefix('#').unwrap_or(fragment);
    f.split('&')
        .find_map(|kv| kv.strip_prefix(KEY).and_then(|r| r.strip_prefix('=')))
        .map(decode)
}

/// The view `text` encodes, checked.
pub fn decode(text: &str) -> Result<SavedView, String> {
    let bytes = URL_SAFE_NO_PAD
        .decode(text.trim().trim_end_matches('='))
        .map_err(|e| format!("the link's view is not URL-safe base64 ({e}): was it cut short?"))?;
    let view: SavedView = serde_json::from_slice(&bytes)
        .map_err(|e| format!("the link's view is not a saved view (docs/views-format.md): {e}"))?;
    view.pose()
        .map_err(|e| format!("the link's view {:?}: {e}", view.name))?;
    if let Some(s) = &view.section {
        gigawalk_scene::section::Section::new(s.clone())
            .map_err(|e| format!("the link's view {:?}: its section: {e}", view.name))?;
    }
    Ok(view)
}

#[cfg(test)]
mod tests {
    use super::*;
    use gigawalk_scene::path::Pose;
    use gigawalk_scene::section::SectionSpec;
    use gigawalk_scene::views::ObjectRef;
    use glam::{DQuat, DVec3};

    fn view() -> SavedView {
        let pose = Pose {
            time: 0.0,
            position: DVec3::new(1e7 + 0.125, -3.5, 2.0 / 3.0),
            orientation: DQuat::from_rotation_y(0.3) * DQuat::from_rotation_x(-0.1),
            fovy: 1.0,
        };
        let mut v = SavedView::new("link", &pose);
        v.selected = vec![ObjectRef {
            id: 7,
            path: "plant.glb/pipes/p7".into(),
        }];
        v.hidden = vec![ObjectRef {
            id: 3,
            path: "plant.glb/walls/w3".into(),
        }];
        v.isolated = Some(vec![ObjectRef {
            id: 9,
            path: "plant.glb/pumps/ü 9".into(),
        }]);
        v.section = Some(SectionSpec {
            planes: vec![[0.0, 0.0, -1.0, 5.0]],
            bbox: None,
        });
        v
    }

    #[test]
    fn a_view_comes_back_from_its_link_exactly() {
        let v = view();
        let text = encode(&v);
        assert!(
            text.bytes()
                .all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_'),
            "{text}"
        );
        assert_eq!(decode(&text).unwrap(), v);
        let fragment = format!("#other=1&{KEY}={text}");
        assert_eq!(from_fragment(&fragment).unwrap().unwrap(), v);
        assert!(from_fragment("#x=1").is_none());
        assert!(from_fragment("").is_none());
    }

    #[test]
    fn a_bad_link_says_what_is_wrong() {
        let text = encode(&view());
        let cut = decode(&text[..text.len() / 2]).unwrap_err();
        assert!(
            cut.contains("not a saved view") || cut.contains("base64"),
            "{cut}"
        );
        let e = decode("not base64!").unwrap_err();
        assert!(e.contains("base64"), "{e}");
        let e = decode(&URL_SAFE_NO_PAD.encode(b"{\"name\":1}")).unwrap_err();
        assert!(e.contains("not a saved view"), "{e}");
        let mut v = view();
        v.fovy_deg = 400.0;
        let e = decode(&encode(&v)).unwrap_err();
        assert!(e.contains("fovy"), "{e}");
        let mut v = view();
        v.orientation = [0.0; 4];
        let e = decode(&encode(&v)).unwrap_err();
        assert!(e.contains("orientation"), "{e}");
        let mut v = view();
        v.section = Some(SectionSpec {
            planes: vec![[0.0, 0.0, 0.0, 5.0]],
            bbox: None,
        });
        let e = decode(&encode(&v)).unwrap_err();
        assert!(e.contains("section"), "{e}");
    }
}
