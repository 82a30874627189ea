//! Limits checked against header-declared sizes before anything is allocated.

/// The most a reader may allocate for one file's samples or mesh.
///
/// Checked before anything is allocated or decoded: header dims × sample size, decoded image
/// sizes (all pages of a TIFF), DICOM element lengths (against the bytes left), mesh counts and
/// the triangles polygons fan into. File content a reader holds in memory is capped too: mesh
/// files and DICOM slices at `max_bytes` (+ 1 MiB of header), `.vti` files at twice it (text
/// encodings are longer than their samples); ASCII samples are parsed as a stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Largest decoded sample (or mesh) buffer, in bytes.
    pub max_bytes: u64,
}

impl Limits {
    /// 4 GiB: a 1024 × 1024 × 2048 u16 CT fits; a corrupt header asking for terabytes does not.
    pub const DEFAULT_MAX_BYTES: u64 = 4 << 30;

    /// Limits with `max_bytes`.
    pub fn new(max_bytes: u64) -> Self {
        Limits { max_bytes }
    }
}

impl Default for Limits {
    fn default() -> Self {
        Limits { max_bytes: Self::DEFAULT_MAX_BYTES }
    }
}
