//! The one error type of an import: every variant names the file and, where
//! it applies, the object (mesh/primitive or OBJ group) and the index.

/// Why a model could not be imported. `object` reads like
/// `mesh "Pipe" (mesh 3) primitive 0` for glTF and `group "valve" (line 12)`
/// for OBJ.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ImportError {
    #[error("{file}: cannot read: {source}")]
    Io {
        file: String,
        source: std::io::Error,
    },
    /// A caller's sink could not keep an object (a preprocessor writing
    /// the model to disk as it is read, say).
    #[error("cannot write the model's objects to {dir}: {source}")]
    Spill { dir: String, source: std::io::Error },
    #[error("{file}: unsupported file type (expected .gltf, .glb, .obj or .ifc)")]
    UnsupportedFormat { file: String },
    #[error("{file}: malformed glTF: {message}")]
    MalformedGltf { file: String, message: String },
    #[error("{file}: buffer {buffer} ({uri}): {reason}")]
    MissingBuffer {
        file: String,
        buffer: usize,
        uri: String,
        reason: String,
    },
    #[error("{file}: buffer {buffer} holds {actual} bytes but declares {declared}")]
    BufferTooShort {
        file: String,
        buffer: usize,
        declared: usize,
        actual: usize,
    },
    /// The file requires an extension gigawalk cannot read; `advice` says
    /// what to do about it (starts with "; " or is empty).
    #[error("{file}: requires glTF extension {extension}, which gigawalk cannot read{advice}")]
    UnsupportedExtension {
        file: String,
        extension: String,
        advice: String,
    },
    /// A meshopt-compressed buffer view (`extension` is
    /// EXT_meshopt_compression or KHR_meshopt_compression) with bad
    /// parameters or data that does not decode.
    #[error("{file}: bufferView {view} ({extension}): {reason}")]
    BadCompressedView {
        file: String,
        view: usize,
        extension: &'static str,
        reason: String,
    },
    #[error("{file}: node {node}: {reason}")]
    BadNode {
        file: String,
        node: usize,
        reason: String,
    },
    #[error("{file}: {object}: accessor {accessor} ({semantic}): {reason}")]
    BadAccessor {
        file: String,
        object: String,
        accessor: usize,
        semantic: &'static str,
        reason: String,
    },
    #[error("{file}: {object}: index {value} at position {position} is out of range ({vertices} vertices)")]
    IndexOutOfRange {
        file: String,
        object: String,
        position: usize,
        value: i64,
        vertices: usize,
    },
    /// An OBJ face or line element whose texture-coordinate or normal index
    /// (`kind` is "texcoord" or "normal") points outside those defined so
    /// far; `count` is how many there are.
    #[error("{file}: {object}: {kind} index {value} at position {position} is out of range ({count} {kind}s)")]
    ObjIndexOutOfRange {
        file: String,
        object: String,
        kind: &'static str,
        position: usize,
        value: i64,
        count: usize,
    },
    #[error("{file}: {object}: vertex {vertex} has a non-finite position {position:?}")]
    NonFinitePosition {
        file: String,
        object: String,
        vertex: usize,
        position: [f64; 3],
    },
    #[error("{file}: {object}: empty mesh ({reason})")]
    EmptyMesh {
        file: String,
        object: String,
        reason: String,
    },
    #[error("{file}: malformed OBJ: {message}")]
    MalformedObj { file: String, message: String },
    #[error("{file}: no triangles to import")]
    NoGeometry { file: String },
    #[error("{dir}: no .gltf, .glb, .obj or .ifc files in this directory")]
    NoModelFiles { dir: String },
    /// An IFC file that does not parse, or has no geometry (the error
    /// names the file, and the line and entity where it applies).
    #[error(transparent)]
    Ifc(#[from] gigawalk_ifc::IfcError),
}
