//! What the CLI's test files share: running the binary and checking a refusal.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the binary under test.
pub fn isoforge(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_isoforge")).args(args).output().expect("run isoforge")
}

/// A run's standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A path as an argument.
pub fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// The repository's `testdata/`.
pub fn testdata() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../testdata")
}

/// Exit 2 with a one-line error holding `needle`, no file at `out` and no temporary file beside
/// it.
pub fn fails(args: &[&str], needle: &str, out: &Path) {
    let o = isoforge(args);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert!(err.contains(needle), "{args:?}: expected {needle:?} in {err:?}");
    assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: error is not one line: {err}");
    assert!(!out.exists(), "{args:?}: left {} behind", out.display());
    let leftovers: Vec<_> = std::fs::read_dir(out.parent().unwrap())
        .map(|d| d.filter_map(|e| e.ok()).filter(|e| e.file_name().to_string_lossy().contains(".tmp")).collect())
        .unwrap_or_default();
    assert!(leftovers.is_empty(), "{args:?}: temporary files left: {leftovers:?}");
}
