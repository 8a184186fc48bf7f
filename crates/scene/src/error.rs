//! Errors of reading and writing scene files.

use std::io;

/// Why a scene file could not be read: every message names the file, and
/// where it applies the section, node or LOD and the byte offset.
#[derive(Debug, thiserror::Error)]
#[error("{file}: {kind}")]
pub struct ReadError {
    /// The file's path, or a description of an in-memory source.
    pub file: String,
    pub kind: ReadErrorKind,
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReadErrorKind {
    #[error("cannot read: {0}")]
    Io(#[from] io::Error),
    #[error("not a gigawalk scene file (bad magic number)")]
    NotAScene,
    #[error("file is format version {major}.{minor}; this gigawalk reads version {}.x only: use a newer gigawalk", crate::format::MAJOR)]
    NewerVersion { major: u16, minor: u16 },
    #[error("file is format version {major}.{minor}, which no gigawalk ever wrote")]
    OlderVersion { major: u16, minor: u16 },
    #[error("file is {actual} bytes but its header says {expected}: truncated or appended to")]
    LengthMismatch { expected: u64, actual: u64 },
    #[error("checksum mismatch in {section} (bytes {offset}..{end})")]
    Checksum {
        section: String,
        offset: u64,
        end: u64,
    },
    #[error("{section} at byte {offset}: {detail}")]
    Corrupt {
        section: String,
        offset: u64,
        detail: String,
    },
    #[error("NODE section, node {node} at byte {offset}: {detail}")]
    Node {
        node: u32,
        offset: u64,
        detail: String,
    },
    #[error("LODS section, LOD {lod} of node {node} at byte {offset}: {detail}")]
    Lod {
        lod: u32,
        node: u32,
        offset: u64,
        detail: String,
    },
    #[error("LOD index {lod} is out of range (the scene has {count} LODs)")]
    NoSuchLod { lod: u32, count: u32 },
}

/// Why a scene file could not be written. Nothing at the destination path
/// changes when writing fails.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WriteError {
    #[error("{path}: cannot write: {source}")]
    Io { path: String, source: io::Error },
    #[error("LOD {lod}: {detail}")]
    BadMesh { lod: u32, detail: String },
    #[error("the scene would not be valid: {0}")]
    Invalid(ReadErrorKind),
    #[error("{0} position bits is outside 8..=24")]
    PositionBits(u8),
    #[error("{0} normal bits is neither 16 nor 8")]
    NormalBits(u8),
    #[error("the scene would not be valid: {0}")]
    Skeleton(crate::SkeletonError),
}
