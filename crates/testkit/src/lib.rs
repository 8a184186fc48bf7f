//! Shared code for gigawalk's tests and benches, and nothing else: a
//! seeded random number generator whose sequence tests pin their figures
//! to, a runner for a built binary that collects its output, and small
//! scene builders.
//!
//! Only `[dev-dependencies]` name this crate. A library that depended on
//! it normally would ship test code, so none does; the crate is not
//! published.

#![forbid(unsafe_code)]

pub mod cli;
pub mod models;
pub mod rng;
pub mod scenes;

pub use rng::{XorShift, XorShift32};
pub use scenes::{box_mesh, write_leaf_scene};
