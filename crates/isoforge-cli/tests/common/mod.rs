//! What the CLI's test files share: running the binary and checking a refusal.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// Runs the binary under test.
pub fn isoforge(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_isoforge")).args(args).output().expect("run isoforge")
}

/// A path as an argument.
pub fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// Exit 2 with a one-line error holding `needle`, and no file at `out`.
pub fn fails(args: &[&str], needle: &str, out: &Path) {
    let o = isoforge(args);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert!(err.contains(needle), "{args:?}: expected {needle:?} in {err:?}");
    assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
    assert!(!out.exists(), "{args:?}: left {}", out.display());
}
