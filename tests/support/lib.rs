//! Support code shared by the cross-crate integration tests (tests/) and
//! benches (benches/): scene builders and reference computations.

pub mod raster;
pub mod scenes;
