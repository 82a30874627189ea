//! What every target shares: the input's first byte picks a variant of the format (attached or
//! detached header, compressed or not, …), the rest is the file; a second file (a detached data
//! file, another DICOM slice) follows the marker [`SPLIT`]. Files live in a per-process folder
//! on a RAM disk when there is one. Any outcome but a panic, a timeout or memory past libFuzzer's
//! limit is fine; what is read must also hold the readers' promises (finite samples, indices in
//! range, finite coordinates).
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use isoforge_io::Limits;

/// Separates the main file from its companion (e.g. `data file: d.raw` of a `.nhdr`).
pub const SPLIT: &[u8] = b"\n--ISOFORGE-FUZZ-SPLIT--\n";

/// The limit every read gets: large enough for the seeds, small enough that anything
/// allocated past it shows up under `-rss_limit_mb`.
pub fn limits() -> Limits {
    Limits::new(16 << 20)
}

/// This process's scratch folder (created once).
pub fn scratch(kind: &str) -> PathBuf {
    let base = if Path::new("/dev/shm").is_dir() { PathBuf::from("/dev/shm") } else { std::env::temp_dir() };
    let dir = base.join(format!("isoforge-fuzz-{kind}-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    dir
}

/// The variant chosen by the first byte, and the rest split into the file and its companion.
pub fn split(data: &[u8], variants: usize) -> Option<(usize, &[u8], &[u8])> {
    let (&pick, body) = data.split_first()?;
    let (main, companion) = match body.windows(SPLIT.len()).position(|w| w == SPLIT) {
        Some(at) => (&body[..at], &body[at + SPLIT.len()..]),
        None => (body, &[][..]),
    };
    Some((pick as usize % variants, main, companion))
}

/// Reads a volume and checks what a reader promises of it.
pub fn check_volume(path: &Path) {
    if let Ok(grid) = isoforge_io::read_volume(path, &limits()) {
        let l = grid.lattice();
        assert!(l.num_points() as usize * grid.dtype().size() <= 16 << 20);
        assert!(grid.first_non_finite().is_none(), "a non-finite sample was accepted");
        let (lo, hi) = l.world_bounds();
        assert!(
            lo.iter().chain(&hi).all(|x| x.is_finite() && x.abs() <= f32::MAX as f64),
            "world bounds {lo:?} {hi:?}"
        );
    }
}

/// Reads a mesh and checks what a reader promises of it.
pub fn check_mesh(path: &Path) {
    if let Ok(mesh) = isoforge_io::read_mesh(path, &limits()) {
        let n = mesh.positions.len();
        assert!(mesh.triangles.iter().flatten().all(|&v| (v as usize) < n), "index out of range");
        assert!(mesh.positions.iter().flatten().all(|c| c.is_finite()), "non-finite coordinate");
        assert!((n + mesh.triangles.len()) * 12 <= 16 << 20, "mesh past the limit");
    }
}

/// Writes `main` as `f.EXT` (and `companion`, when given, as `companion_name`), then reads it.
pub fn volume_file(kind: &str, ext: &str, main: &[u8], companion: Option<(&str, &[u8])>) {
    let dir = scratch(kind);
    let path = dir.join(format!("f.{ext}"));
    if let Some((name, bytes)) = companion {
        if std::fs::write(dir.join(name), bytes).is_err() {
            return;
        }
    }
    if std::fs::write(&path, main).is_ok() {
        check_volume(&path);
    }
}

/// Writes `main` as `f.EXT` and reads it as a mesh.
pub fn mesh_file(kind: &str, ext: &str, main: &[u8]) {
    let path = scratch(kind).join(format!("f.{ext}"));
    if std::fs::write(&path, main).is_ok() {
        check_mesh(&path);
    }
}
