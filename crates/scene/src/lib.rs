//! gigawalk's scene-graph data model and file formats.
//!
//! Main types: [`Skeleton`] (the AABB hierarchy with per-node LODs),
//! [`LodMesh`] (one LOD's geometry), [`SceneWriter`] and [`SceneReader`]
//! (the `.gwk` scene file, spec in docs/scene-format.md), and
//! [`path::CameraPath`] (camera path files, docs/path-format.md).
//!
//! Writing a scene: [`SceneWriter::create`], then [`SceneWriter::add_lod`]
//! for every LOD (a node's LODs consecutively, finest first), then
//! [`SceneWriter::finish`] with the nodes and provenance. Reading:
//! [`SceneReader::open`] loads and validates the skeleton only;
//! [`SceneReader::read_lod`] reads one LOD's geometry on demand.
//! [`sparse`] reads a scene through the byte ranges fetched so far (the
//! browser page's range requests): a read of bytes not there yet names
//! the range to fetch, and [`sparse::open_step`] opens a scene in a few
//! such rounds.
//!
//! This crate knows nothing about GPUs or threads. Its wasm32 build (the
//! browser viewer) reads scenes and writes none: see `unpack`.

#![forbid(unsafe_code)]
// The browser build only reads: the writer's helpers go unused there.
#![cfg_attr(target_arch = "wasm32", allow(dead_code, unused_imports))]

mod aabb;
#[cfg(not(target_arch = "wasm32"))]
mod atomic;
pub mod codec;
mod error;
mod format;
mod mesh;
pub mod objects;
pub mod occluder_cells;
pub mod occluders;
pub mod path;
mod read;
pub mod section;
mod skeleton;
pub mod sparse;
mod squeeze;
mod stats;
pub mod units;
mod unpack;
mod validate;
pub mod views;
#[cfg(not(target_arch = "wasm32"))]
mod write;

pub use aabb::Aabb;
#[cfg(not(target_arch = "wasm32"))]
pub use atomic::{
    remove_temp_files, stale_temp_files_removed, temp_file_for, work_dir_prefix, write_atomic,
    TempFile,
};
pub use error::{ReadError, ReadErrorKind, WriteError};
pub use format::{MAJOR as FORMAT_MAJOR, MINOR as FORMAT_MINOR};
pub use mesh::{decode_normal, encode_normal, Colours, LodMesh};
pub use read::{opening_reads, GridLod, ReadAt, SceneReader, SectionInfo, StoredLod};
pub use skeleton::{
    GridBits, IndexFormat, LodInfo, Node, Provenance, Skeleton, SkeletonError, NO_NODE,
};
pub use stats::{DepthLevels, NodeSwitch, PositionStats, SceneStats, SwitchFactors};
#[cfg(not(target_arch = "wasm32"))]
pub use write::{EncodedLod, LodEncoder, SceneWriter, WriteSummary, DEFAULT_POSITION_BITS};
