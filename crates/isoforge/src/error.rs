//! The library's error type.

/// What can go wrong in the library. Input errors name what to fix; `Internal` is a bug.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A size exceeds what the library (or the caller's limits) allows.
    #[error("{what}: {requested} exceeds the limit of {allowed}")]
    Limit {
        /// What was too large.
        what: &'static str,
        /// The size asked for.
        requested: u64,
        /// The largest size allowed.
        allowed: u64,
    },
    /// The input is well-formed but cannot be processed as asked.
    #[error("{0}")]
    InvalidInput(String),
    /// Reading the input or writing the output failed (out-of-core extraction).
    #[error("{0}")]
    External(Box<dyn std::error::Error + Send + Sync>),
    /// The caller cancelled the walk ([`Progress::cancelled`](crate::walk::Progress::cancelled)).
    #[error("cancelled")]
    Cancelled,
    /// An internal invariant failed: this is a bug, please report it.
    #[error("internal error (this is a bug, please report it): {0}")]
    Internal(String),
}

/// Shorthand for results of this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
