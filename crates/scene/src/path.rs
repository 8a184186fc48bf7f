//! Camera path files (docs/path-format.md): one pose per line.
