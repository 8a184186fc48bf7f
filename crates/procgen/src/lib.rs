//! Deterministic procedural test scenes as glTF 2.0 binaries.
