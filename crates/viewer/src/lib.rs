//! gigawalk's interactive viewer: fly or walk through a scene and watch
//! what culling and LODs do.
//!
//! Main types: [`FlyController`] (the camera: mouse look, WASD/QE, walk
//! mode), [`Settings`] (the toggles, and which need the pipeline
//! restarted), [`controls::BINDINGS`] (the key table that input, the
//! on-screen help and `--help` share, the browser page's too:
//! `gigawalk_review::keys`, looked up here by winit's key codes), [`PathRecorder`] (camera paths),
//! [`hud_lines`] (the HUD text), [`overlay_boxes`] (node boxes coloured by
//! what culling did), [`Objects`] (the selection, search, hidden objects
//! and saved views), [`Sections`] (section planes and box), [`Measure`]
//! (a distance between two picked points), [`write_png`] (screenshots),
//! and [`run`], the winit
//! app that feeds live input to the runtime and presents its frames.
//!
//! Everything but [`run`] works without a window, so it is unit-tested.

#![forbid(unsafe_code)]

mod app;
mod boxes;
pub mod controls;
mod hud;
mod image;
mod settings;

use gigawalk_review::{objects, sections};

pub use app::{run, DisplayError, ViewArgs, ViewError};
pub use boxes::{overlay_boxes, CullSets};
pub use gigawalk_review::fly::{FlyController, EYE_HEIGHT};
pub use gigawalk_review::measure::{screen_segment, Measure};
pub use gigawalk_review::recorder::{next_free_name, PathRecorder};
pub use hud::{hud_lines, FrameClock, FrameNumbers, ViewerState};
pub use image::{image_stats, read_png, write_png, ImageStats, ScreenshotError};
pub use objects::{frame_box, Objects, NO_IDENTITY};
pub use sections::{view_box, Sections};
pub use settings::{Settings, PIXEL_ERROR_STEPS};
