//! The I/O error type: every variant names the file.

use std::fmt;
use std::path::{Path, PathBuf};

/// What went wrong reading or writing a file. Messages start with the path and say what to fix.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The file's content is malformed: `detail` names the line or byte offset, field and value.
    #[error("{}: {detail}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The format being read.
        format: &'static str,
        /// What is wrong, where.
        detail: String,
    },
    /// A header-declared size exceeds the limits (checked before allocating).
    #[error("{}: {what} needs {requested} bytes, over the limit of {allowed} bytes (raise it with --max-bytes)", path.display())]
    Limit {
        /// The file.
        path: PathBuf,
        /// What was too large.
        what: String,
        /// Bytes asked for.
        requested: u64,
        /// Bytes allowed.
        allowed: u64,
    },
    /// Well-formed but not supported (a data type, an encoding, a layout).
    #[error("{}: {detail}", path.display())]
    Unsupported {
        /// The file.
        path: PathBuf,
        /// What is not supported.
        detail: String,
    },
    /// The operating system refused (missing file, permissions, disk full).
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The request itself is inconsistent (e.g. raw dims missing).
    #[error("{0}")]
    InvalidInput(String),
}

/// Shorthand for results of this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Builds errors for one file and format.
#[derive(Clone, Copy)]
pub(crate) struct Ctx<'a> {
    pub path: &'a Path,
    pub format: &'static str,
}

impl<'a> Ctx<'a> {
    pub fn new(path: &'a Path, format: &'static str) -> Self {
        Ctx { path, format }
    }
    pub fn bad(&self, detail: impl fmt::Display) -> Error {
        Error::Read { path: self.path.to_path_buf(), format: self.format, detail: detail.to_string() }
    }
    pub fn unsupported(&self, detail: impl fmt::Display) -> Error {
        Error::Unsupported { path: self.path.to_path_buf(), detail: detail.to_string() }
    }
    pub fn io(&self, source: std::io::Error) -> Error {
        Error::Io { path: self.path.to_path_buf(), source }
    }
    pub fn limit(&self, what: impl fmt::Display, requested: u64, allowed: u64) -> Error {
        Error::Limit { path: self.path.to_path_buf(), what: what.to_string(), requested, allowed }
    }
    /// Converts a library error about this file's content.
    pub fn lib(&self, e: isoforge::Error) -> Error {
        self.bad(e)
    }
}
