//! Shared steps of the volume readers: size checks before allocation, decompression to an exact
//! size, byte decoding in the sample's own type, and the non-finite check.

use std::path::Path;

use isoforge::grid::{AnyGrid, DType, DenseGrid, Lattice, Sample};

use crate::error::{Ctx, Result};
use crate::limits::Limits;

/// Bytes the samples of `dims` × `dtype` take, checked for overflow and against `limits`.
pub(crate) fn sample_bytes(ctx: Ctx, dims: [u32; 3], dtype: DType, limits: &Limits) -> Result<usize> {
    let n = (dims[0] as u64)
        .checked_mul(dims[1] as u64)
        .and_then(|n| n.checked_mul(dims[2] as u64))
        .and_then(|n| n.checked_mul(dtype.size() as u64));
    let Some(bytes) = n else {
        return Err(ctx.bad(format!("dims {}x{}x{} of {dtype}: the size overflows 64 bits", dims[0], dims[1], dims[2])));
    };
    if bytes > limits.max_bytes {
        return Err(ctx.limit(format!("dims {}x{}x{} of {dtype}", dims[0], dims[1], dims[2]), bytes, limits.max_bytes));
    }
    usize::try_from(bytes).map_err(|_| ctx.limit("samples", bytes, usize::MAX as u64))
}

/// Reads a whole file whose size must not exceed `max` bytes.
pub(crate) fn read_file(ctx: Ctx, path: &Path, max: u64) -> Result<Vec<u8>> {
    let len = std::fs::metadata(path).map_err(|e| ctx.io(e))?.len();
    if len > max {
        return Err(ctx.limit("the file", len, max));
    }
    std::fs::read(path).map_err(|e| ctx.io(e))
}

/// Decodes exactly `lattice.num_points()` samples of `dtype` and rejects non-finite values.
pub(crate) fn decode(ctx: Ctx, lattice: Lattice, dtype: DType, big_endian: bool, bytes: &[u8]) -> Result<AnyGrid> {
    fn go<S: Sample>(ctx: Ctx, lattice: Lattice, big_endian: bool, bytes: &[u8]) -> Result<AnyGrid>
    where
        AnyGrid: From<DenseGrid<S>>,
    {
        let size = S::DTYPE.size();
        let data: Vec<S> = bytes.chunks_exact(size).map(|c| S::from_bytes(c, big_endian)).collect();
        let grid = DenseGrid::new(lattice, data).map_err(|e| ctx.lib(e))?;
        if let Some(nf) = grid.first_non_finite() {
            let [i, j, k] = nf.ijk;
            return Err(ctx.bad(format!(
                "sample ({i}, {j}, {k}) is {}: volumes must be finite (replace or mask such samples before meshing)",
                nf.value
            )));
        }
        Ok(grid.into())
    }
    isoforge::with_dtype!(dtype, S => go::<S>(ctx, lattice, big_endian, bytes))
}

/// Splits `text` into trimmed lines numbered from 1.
pub(crate) fn numbered_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines().enumerate().map(|(i, l)| (i + 1, l.trim_end_matches('\r')))
}

/// Parses whitespace- or comma-separated numbers.
pub(crate) fn parse_numbers<T: std::str::FromStr>(s: &str) -> Option<Vec<T>> {
    s.split(|c: char| c.is_whitespace() || c == ',').filter(|t| !t.is_empty()).map(|t| t.parse().ok()).collect()
}

/// A positive whole number that fits `u32`, as a lattice dimension.
pub(crate) fn parse_dim(s: &str) -> Option<u32> {
    s.parse::<u64>().ok().filter(|&d| d >= 1 && d <= u32::MAX as u64).map(|d| d as u32)
}

/// Finds `needle` as a whole line ending; returns the offset just past it.
pub(crate) fn find_header_end(bytes: &[u8], max_header: usize) -> Option<usize> {
    let limit = bytes.len().min(max_header);
    (0..limit).find_map(|i| {
        if bytes[i] == b'\n' && i + 1 < bytes.len() && bytes[i + 1] == b'\n' {
            Some(i + 2)
        } else if bytes[i] == b'\n' && i + 2 < bytes.len() && bytes[i + 1] == b'\r' && bytes[i + 2] == b'\n' {
            Some(i + 3)
        } else {
            None
        }
    })
}

/// Builds a lattice from file geometry, naming the file in errors.
pub(crate) fn lattice(
    ctx: Ctx,
    dims: [u32; 3],
    spacing: [f64; 3],
    origin: [f64; 3],
    direction: Option<[[f64; 3]; 3]>,
) -> Result<Lattice> {
    let l = Lattice::with_geometry(dims, spacing, origin).map_err(|e| ctx.lib(e))?;
    match direction {
        Some(d) => l.with_direction(d).map_err(|e| ctx.unsupported(e)),
        None => Ok(l),
    }
}

/// Splits a 3×3 matrix given as three axis vectors into spacings (lengths) and unit directions.
pub(crate) fn split_axes(axes: [[f64; 3]; 3]) -> Option<([f64; 3], [[f64; 3]; 3])> {
    let mut spacing = [0.0; 3];
    let mut dir = [[0.0; 3]; 3];
    for a in 0..3 {
        let len = (axes[a][0] * axes[a][0] + axes[a][1] * axes[a][1] + axes[a][2] * axes[a][2]).sqrt();
        if !(len.is_finite() && len > 0.0) {
            return None;
        }
        spacing[a] = len;
        dir[a] = axes[a].map(|x| x / len);
    }
    Some((spacing, dir))
}

/// Parses whitespace- or comma-separated ASCII samples into little-endian bytes of `dtype`.
pub(crate) fn ascii_to_bytes(ctx: Ctx, data: &[u8], dims: [u32; 3], dtype: DType) -> Result<Vec<u8>> {
    let text =
        std::str::from_utf8(data).map_err(|e| ctx.bad(format!("ASCII data: byte {} is not text", e.valid_up_to())))?;
    let n = dims.iter().map(|&d| d as usize).product::<usize>();
    let mut out = Vec::with_capacity(n * dtype.size());
    let mut count = 0usize;
    for tok in text.split(|c: char| c.is_whitespace() || c == ',').filter(|t| !t.is_empty()) {
        if count == n {
            break;
        }
        let bad = || ctx.bad(format!("ASCII data: value {} {tok:?} is not a {dtype}", count + 1));
        macro_rules! put {
            ($t:ty) => {{
                let v: $t = tok.parse().map_err(|_| bad())?;
                out.extend_from_slice(&v.to_le_bytes());
            }};
        }
        match dtype {
            DType::U8 => put!(u8),
            DType::I8 => put!(i8),
            DType::U16 => put!(u16),
            DType::I16 => put!(i16),
            DType::U32 => put!(u32),
            DType::I32 => put!(i32),
            DType::F32 => put!(f32),
            _ => put!(f64),
        }
        count += 1;
    }
    if count < n {
        return Err(ctx.bad(format!("ASCII data has {count} values, the header declares {n}")));
    }
    Ok(out)
}
