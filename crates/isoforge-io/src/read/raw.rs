//! Raw sample files: no header, geometry from the caller (`--dims`, `--dtype`, …).

use std::path::Path;

use isoforge::grid::{AnyGrid, DType};

use super::decode;
use super::stream::{open_data, Compression, VolumeReader};
use crate::error::{Ctx, Result};
use crate::limits::Limits;

/// How to interpret a raw file.
#[derive(Debug, Clone, PartialEq)]
pub struct RawSpec {
    /// Points per axis, x fastest.
    pub dims: [u32; 3],
    /// Sample type.
    pub dtype: DType,
    /// Byte order of multi-byte samples.
    pub big_endian: bool,
    /// Bytes to skip before the samples.
    pub header_bytes: u64,
    /// Spacing (default 1: index units).
    pub spacing: [f64; 3],
    /// Origin (default 0).
    pub origin: [f64; 3],
}

impl RawSpec {
    /// Little-endian, no header, unit spacing at the origin.
    pub fn new(dims: [u32; 3], dtype: DType) -> Self {
        RawSpec { dims, dtype, big_endian: false, header_bytes: 0, spacing: [1.0; 3], origin: [0.0; 3] }
    }
}

/// Opens a raw file; its size must be exactly `header_bytes` + the samples.
///
/// # Errors
/// [`Error::Read`](crate::Error::Read) when the size does not match.
pub fn open_raw(path: &Path, spec: &RawSpec, limits: &Limits) -> Result<VolumeReader> {
    let ctx = Ctx::new(path, "raw");
    let need = decode::sample_bytes(ctx, spec.dims, spec.dtype, limits)? as u64;
    let spacing = decode::spacings(ctx, "spacing", spec.dims, spec.spacing)?;
    let lattice = decode::lattice(ctx, "spacing, origin", spec.dims, spacing, spec.origin, None)?;
    let len = crate::file::open(ctx, path)?.len;
    let expected = spec.header_bytes.saturating_add(need);
    if len != expected {
        let [x, y, z] = spec.dims;
        return Err(ctx.bad(format!(
            "file has {len} bytes, but {x}x{y}x{z} {} samples after a {}-byte header need {expected} (check --dims, --dtype and --header-bytes)",
            spec.dtype, spec.header_bytes
        )));
    }
    let data = open_data(ctx, path, spec.header_bytes, Compression::None, need, "sample data")?;
    Ok(VolumeReader::stream(ctx, lattice, spec.dtype, spec.big_endian, data))
}

/// Reads a raw file into a grid.
///
/// # Errors
/// As [`open_raw`], [`VolumeReader::read_grid`].
pub fn read_raw(path: &Path, spec: &RawSpec, limits: &Limits) -> Result<AnyGrid> {
    open_raw(path, spec, limits)?.read_grid(limits)
}
