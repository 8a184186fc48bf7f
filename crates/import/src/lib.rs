//! Model import: glTF 2.0 and Wavefront OBJ into a flat [`Model`] of
//! [`Object`]s in f64 world coordinates.

mod model;

pub use model::{ImportStats, Model, Object};
