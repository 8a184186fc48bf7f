//! The one error type of an IFC read: every variant names the file and,
//! where it applies, the line and the entity (`#id`).

/// Why an IFC file could not be read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum IfcError {
    #[error("{file}: cannot read: {source}")]
    Io {
        file: String,
        source: std::io::Error,
    },
    #[error("{file}: empty file")]
    Empty { file: String },
    #[error("{file}: not a STEP physical file (no ISO-10303-21 header)")]
    NotStep { file: String },
    #[error("{file}: line {line}: truncated file: {what}")]
    Truncated {
        file: String,
        line: usize,
        what: String,
    },
    #[error("{file}: line {line}: {entity}: broken record: {reason}")]
    BrokenRecord {
        file: String,
        line: usize,
        /// `#id`, or `record` when the id itself is unreadable.
        entity: String,
        reason: String,
    },
    #[error("{file}: line {line}: #{entity} refers to #{target}, which the file does not define")]
    DanglingReference {
        file: String,
        line: usize,
        entity: u32,
        target: u32,
    },
    #[error("{file}: line {line}: #{entity} is defined twice")]
    DuplicateEntity {
        file: String,
        line: usize,
        entity: u32,
    },
    #[error("{file}: unsupported schema {schema} (expected IFC2X3, IFC4 or IFC4X3)")]
    UnsupportedSchema { file: String, schema: String },
    #[error("{file}: no IFCPROJECT entity")]
    NoProject { file: String },
    #[error("{file}: line {line}: #{entity} ({class}): {reason}")]
    BadEntity {
        file: String,
        line: usize,
        entity: u32,
        class: String,
        reason: String,
    },
    #[error("{file}: no product with geometry ({reason})")]
    NoGeometry { file: String, reason: String },
}
