//! The I/O error type: every variant names the file.

use std::fmt;
use std::path::{Path, PathBuf};

/// What went wrong reading or writing a file. Messages start with the path and say what to fix.
///
/// The message is complete on its own: [`Error::Io`] includes the operating system's reason in
/// its `Display` and does not repeat it through [`std::error::Error::source`], so a printed chain
/// (`anyhow`'s `{:#}`) says it once.
#[derive(Debug)]
#[non_exhaustive]
pub enum Error {
    /// The file's content is malformed: `detail` names the line or byte offset, field and value.
    Read {
        /// The file.
        path: PathBuf,
        /// The format being read.
        format: &'static str,
        /// What is wrong, where.
        detail: String,
    },
    /// A header-declared size exceeds the limits (checked before allocating).
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
    Unsupported {
        /// The file.
        path: PathBuf,
        /// What is not supported.
        detail: String,
    },
    /// The operating system refused (missing file, permissions, disk full).
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The request itself is inconsistent (e.g. raw dims missing).
    InvalidInput(String),
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Read { path, detail, .. } | Error::Unsupported { path, detail } => {
                write!(f, "{}: {detail}", path.display())
            }
            Error::Limit { path, what, requested, allowed } => write!(
                f,
                "{}: {what} needs {requested} bytes, over the limit of {allowed} bytes (raise it with --max-bytes)",
                path.display()
            ),
            Error::Io { path, source } => write!(f, "{}: {}", path.display(), os_reason(source)),
            Error::InvalidInput(msg) => f.write_str(msg),
        }
    }
}

/// No `source()`: every variant's message already says everything (see the type's doc).
impl std::error::Error for Error {}

/// The reason of an I/O error without Rust's " (os error N)" suffix, e.g. "No such file or directory".
pub(crate) fn os_reason(e: &std::io::Error) -> String {
    let text = e.to_string();
    match text.rfind(" (os error ") {
        Some(i) if text.ends_with(')') => text[..i].to_string(),
        _ => text,
    }
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
