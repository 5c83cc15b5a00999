//! The one error of the mesh module: what is wrong, what to do, and which file.

use std::fmt;
use std::path::{Path, PathBuf};

/// A mesh file that could not be loaded, or a shape that could not be made.
///
/// Displays as `FILE: MESSAGE` (or `SHAPE: MESSAGE` for a built-in shape); the message says what
/// is wrong and, where it can, what to do about it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MeshError {
    source: Source,
    message: String,
}

#[derive(Debug, Clone, PartialEq, Eq)]
enum Source {
    File(PathBuf),
    Shape(&'static str),
}

impl MeshError {
    pub(crate) fn file(path: &Path, message: impl Into<String>) -> MeshError {
        MeshError { source: Source::File(path.to_path_buf()), message: message.into() }
    }

    pub(crate) fn shape(shape: &'static str, message: impl Into<String>) -> MeshError {
        MeshError { source: Source::Shape(shape), message: message.into() }
    }

    #[cfg(test)]
    /// The file concerned; `None` for a built-in shape.
    pub(crate) fn path(&self) -> Option<&Path> {
        match &self.source {
            Source::File(path) => Some(path),
            Source::Shape(_) => None,
        }
    }
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.source {
            Source::File(path) => write!(f, "{}: {}", path.display(), self.message),
            Source::Shape(shape) => write!(f, "{shape}: {}", self.message),
        }
    }
}

impl std::error::Error for MeshError {}

/// A byte count for messages: `1024 bytes`, `50 MB`, `2.1 GB` (decimal units).
pub(crate) fn bytes(n: u128) -> String {
    const UNITS: [(u128, &str); 3] = [(1_000_000_000, "GB"), (1_000_000, "MB"), (1_000, "kB")];
    for (unit, name) in UNITS {
        if n >= unit * 10 {
            return format!("{} {name}", n / unit);
        }
        if n >= unit {
            return format!("{:.1} {name}", n as f64 / unit as f64);
        }
    }
    format!("{n} bytes")
}
