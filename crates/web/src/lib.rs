//! gigawalk in a browser page: the scene streamed from a static HTTP
//! server with range requests, culled and drawn on the page's one thread
//! with WebGPU.
//!
//! A page has no threads to give the pipeline's stages: each animation
//! frame runs traversal and LOD selection (gigawalk-cull, the same code as
//! native STC), plans fetches and draws the visible set with the native
//! RVG pass (gigawalk-gpu's `VisiblePass` on the page's one device), then
//! yields to the browser, which brings fetched bytes back between frames.
//!
//! - [`sparse`]: the scene file as the byte ranges fetched so far; the
//!   scene reader opens and reads LODs from it, every checksum checked.
//! - [`link`]: a saved view (camera, selection, hidden objects, section)
//!   as the page URL's `#view=` fragment, to share.
//! - [`stream`]: which LODs to fetch, keep and draw under a byte budget,
//!   with stand-ins while one is on its way.
//! - `page` (wasm32 only): the page's entry point, its loop, input and
//!   HUD. `crates/web/build.sh` builds the bundle `gigawalk web` and
//!   `gigawalk serve` put beside a scene.
//!
//! The parts that do not touch the browser build and are tested natively.

#![forbid(unsafe_code)]

pub mod link;
pub mod sparse;
pub mod stream;

#[cfg(target_arch = "wasm32")]
mod page;
