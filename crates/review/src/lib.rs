//! gigawalk's reviewer state: what a reviewer's viewer keeps about a
//! scene besides what it draws, shared by the native viewer
//! (`gigawalk view`) and the browser page so both answer the same keys
//! the same way, and by the command line's `pick`, `find` and
//! `replay --hide/--isolate/--view`.
//!
//! - [`actions`]: what the object and section keys do, for viewer and
//!   page alike;
//! - [`objects`]: the selection, the search (find), the hidden objects
//!   (hide, isolate) and saved views over the scene's object table, and
//!   the framing of an object's box;
//! - [`sections`]: the section planes and the section box;
//! - [`select`]: object selection against a scene: the hidden set a
//!   frame's `Visibility` is built from, find, and the pick under a pixel;
//! - [`link`]: a saved view as the browser page URL's `#view=` fragment,
//!   to share, checked on the way in;
//! - [`keys`]: the key bindings, one table the viewer and the page look
//!   keys up in (by their `KeyboardEvent.code` names) and the help text
//!   comes from;
//! - [`measure`]: a distance measured between two picked points (M,
//!   click, click), its label and its segment on screen;
//! - [`recorder`]: the camera recorded as a path that replay reads back;
//! - [`fly`]: the fly / walk camera controller, and [`gestures`] what
//!   pointers dragged and pinched on a touch screen ask of it;
//! - [`group`]: counts written in groups of thousands.
//!
//! Pure state and text: the frame loops (the viewer's and the page's) read
//! the scene, cast the pick ray and hand each frame's `Visibility` and
//! section to traversal, so all of this is unit-tested without a window.
//! It draws nothing, knows nothing about GPUs and starts no threads; the
//! culling it feeds is gigawalk-cull's.

#![forbid(unsafe_code)]

pub mod actions;
pub mod fly;
pub mod gestures;
pub mod keys;
pub mod link;
pub mod measure;
pub mod objects;
pub mod recorder;
pub mod sections;
pub mod select;

/// 1234567 -> "1,234,567": counts of millions read at a glance.
pub fn group(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::with_capacity(s.len() + s.len() / 3);
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn group_thousands() {
        assert_eq!(group(0), "0");
        assert_eq!(group(999), "999");
        assert_eq!(group(1000), "1,000");
        assert_eq!(group(1234567), "1,234,567");
    }
}
