//! gigawalk in a browser page: the scene streamed from a static HTTP
//! server with range requests, culled and drawn on the page's one thread
//! with WebGPU.
//!
//! A page has no threads to give the pipeline's stages: each animation
//! frame runs one step of gigawalk-runtime's stepped schedule (OR, STC
//! and RVG, the native stages, on the page's one device, OR's read-back
//! polled), then yields to the browser, which brings fetched bytes back
//! between frames. The runtime streams as natively (its pool, stand-ins
//! and order of requests); the page fetches what it asks for.
//!
//! - [`stream`]: the range requests that fetch the LODs the runtime asks
//!   for, nearby blobs sharing one.
//! - `page` (wasm32 only): the page's entry point, its loop, input and
//!   HUD. `crates/web/build.sh` builds the bundle `gigawalk web` and
//!   `gigawalk serve` put beside a scene.
//!
//! The scene file as the byte ranges fetched so far is the scene
//! crate's (`gigawalk_scene::sparse`): the page fetches what it names.
//! A view's link (`#view=`) and the key table are the reviewer state's
//! (`gigawalk_review::link`, `gigawalk_review::keys`), so the page and
//! the native viewer answer the same keys the same way.
//!
//! The parts that do not touch the browser build and are tested natively.

#![forbid(unsafe_code)]

pub mod stream;

#[cfg(target_arch = "wasm32")]
mod page;
