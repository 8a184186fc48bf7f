//! gigawalk's scene-graph data model and file formats.
//!
//! Main types: [`Skeleton`] (the AABB hierarchy with per-node LODs),
//! [`LodMesh`] (one LOD's geometry), [`SceneWriter`] and [`SceneReader`]
//! (the `.gwk` scene file, spec in docs/scene-format.md), and
//! [`path::CameraPath`] (camera path files, docs/path-format.md).
//!
//! This crate knows nothing about GPUs or threads.

mod aabb;
mod mesh;
pub mod path;
mod skeleton;

pub use aabb::Aabb;
pub use mesh::{Colours, LodMesh};
pub use skeleton::{IndexFormat, LodInfo, Node, Provenance, Skeleton, NO_NODE};
