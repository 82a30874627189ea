//! Shared steps of the volume readers: size checks before allocation, decompression to an exact
//! size, byte decoding in the sample's own type, and the non-finite check.

use std::io::{BufRead, Read};
use std::path::Path;

use isoforge::grid::{AnyGrid, DType, DenseGrid, Lattice, NonFinite, Sample};

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

/// Reads a whole regular file whose size must not exceed `max` bytes.
pub(crate) fn read_file(ctx: Ctx, path: &Path, max: u64) -> Result<Vec<u8>> {
    crate::file::read_all(ctx, path, max)
}

/// Rejects a volume with a NaN or infinite sample (`first`: the first one, if any), naming it.
pub(crate) fn ensure_finite(ctx: Ctx, first: Option<NonFinite>) -> Result<()> {
    match first {
        None => Ok(()),
        Some(nf) => {
            let [i, j, k] = nf.ijk;
            Err(ctx.bad(format!(
                "sample ({i}, {j}, {k}) is {}: volumes must be finite (replace or mask such samples before meshing)",
                nf.value
            )))
        }
    }
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
        ensure_finite(ctx, grid.first_non_finite())?;
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

/// Builds a lattice from file geometry; errors name the file and the header `fields` the
/// geometry came from (e.g. "space directions, space origin").
pub(crate) fn lattice(
    ctx: Ctx,
    fields: &str,
    dims: [u32; 3],
    spacing: [f64; 3],
    origin: [f64; 3],
    direction: Option<[[f64; 3]; 3]>,
) -> Result<Lattice> {
    let l = Lattice::with_geometry(dims, spacing, origin).map_err(|e| match e {
        // The point count depends on the dims alone: name them, not the geometry fields.
        e @ isoforge::Error::Limit { .. } => ctx.bad(format!("dims {}x{}x{}: {e}", dims[0], dims[1], dims[2])),
        e => ctx.bad(format!("{fields}: {e}")),
    })?;
    match direction {
        Some(d) => l.with_direction(d).map_err(|e| ctx.unsupported(format!("{fields}: {e}"))),
        None => Ok(l),
    }
}

/// Checks spacings read from header `field`: finite and positive. An axis with a single point
/// has no spacing to speak of (no coordinate depends on it): any value there becomes 1.
pub(crate) fn spacings(ctx: Ctx, field: &str, dims: [u32; 3], values: [f64; 3]) -> Result<[f64; 3]> {
    let mut out = values;
    for a in 0..3 {
        if dims[a] == 1 && !(values[a].is_finite() && values[a] > 0.0) {
            out[a] = 1.0;
        } else if !(values[a].is_finite() && values[a] > 0.0) {
            return Err(ctx.bad(format!(
                "{field} {values:?}: the spacing of axis {a} is {}; spacings must be finite and positive",
                values[a]
            )));
        }
    }
    Ok(out)
}

/// Splits a 3×3 matrix given as three axis vectors into spacings (lengths) and unit directions.
pub(crate) fn split_axes(axes: [[f64; 3]; 3]) -> Option<([f64; 3], [[f64; 3]; 3])> {
    let mut spacing = [0.0; 3];
    let mut dir = [[0.0; 3]; 3];
    for a in 0..3 {
        // Scaled so huge (1e308) or tiny components do not overflow or vanish when squared.
        let scale = axes[a].iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let unit = axes[a].map(|x| x / scale);
        let len = scale * (unit[0] * unit[0] + unit[1] * unit[1] + unit[2] * unit[2]).sqrt();
        if !(len.is_finite() && len > 0.0) {
            return None;
        }
        spacing[a] = len;
        dir[a] = axes[a].map(|x| x / len);
    }
    Some((spacing, dir))
}

/// The longest ASCII sample accepted (digits, sign, exponent): longer tokens are not numbers.
const MAX_TOKEN: usize = 512;

/// Parses whitespace- or comma-separated ASCII samples from `r` straight into a grid on
/// `lattice` (read as a stream: memory is the grid, not the text), then rejects non-finite ones.
/// After the samples the lattice needs, one more token is looked at: a number there means the
/// data holds more values than the header declares (refused); anything else (a VTK keyword
/// starting the next array, a closing tag) ends the data.
pub(crate) fn ascii_grid(ctx: Ctx, r: impl Read, lattice: Lattice, dtype: DType) -> Result<AnyGrid> {
    fn go<S: Sample + std::str::FromStr>(ctx: Ctx, r: impl Read, lattice: Lattice) -> Result<AnyGrid>
    where
        AnyGrid: From<DenseGrid<S>>,
    {
        let n = lattice.num_points() as usize;
        let mut data: Vec<S> = Vec::with_capacity(n);
        let mut tok: Vec<u8> = Vec::with_capacity(64);
        let mut r = std::io::BufReader::with_capacity(1 << 16, r);
        let bad = |count: usize, tok: &[u8]| {
            ctx.bad(format!("ASCII data: value {} {:?} is not a {}", count + 1, String::from_utf8_lossy(tok), S::DTYPE))
        };
        let mut end = false;
        while data.len() < n && !end {
            let buf = r
                .fill_buf()
                .map_err(|e| ctx.bad(format!("ASCII data: unreadable after {} values: {e}", data.len())))?;
            end = buf.is_empty();
            let available = buf.len();
            let mut used = 0;
            // At the end of the stream one pass over an empty buffer ends the last token.
            for &b in buf.iter().chain(end.then_some(&b' ')) {
                used += 1;
                if !(b.is_ascii_whitespace() || b == b',') {
                    if tok.len() == MAX_TOKEN {
                        return Err(bad(data.len(), &tok));
                    }
                    tok.push(b);
                } else if !tok.is_empty() {
                    let v = std::str::from_utf8(&tok).ok().and_then(|t| t.parse::<S>().ok());
                    data.push(v.ok_or_else(|| bad(data.len(), &tok))?);
                    tok.clear();
                    if data.len() == n {
                        break;
                    }
                }
            }
            r.consume(used.min(available));
        }
        if data.len() < n {
            return Err(ctx.bad(format!("ASCII data has {} values, the header declares {n}", data.len())));
        }
        if let Some(extra) = next_token(&mut r, ctx)? {
            if std::str::from_utf8(&extra).is_ok_and(|t| t.parse::<f64>().is_ok()) {
                return Err(ctx.bad(format!(
                    "ASCII data has more values than the {n} the header declares: value {} is {:?}",
                    n + 1,
                    String::from_utf8_lossy(&extra)
                )));
            }
        }
        let grid = DenseGrid::new(lattice, data).map_err(|e| ctx.lib(e))?;
        ensure_finite(ctx, grid.first_non_finite())?;
        Ok(grid.into())
    }
    match dtype {
        DType::U8 => go::<u8>(ctx, r, lattice),
        DType::I8 => go::<i8>(ctx, r, lattice),
        DType::U16 => go::<u16>(ctx, r, lattice),
        DType::I16 => go::<i16>(ctx, r, lattice),
        DType::U32 => go::<u32>(ctx, r, lattice),
        DType::I32 => go::<i32>(ctx, r, lattice),
        DType::F32 => go::<f32>(ctx, r, lattice),
        DType::F64 => go::<f64>(ctx, r, lattice),
        other => Err(ctx.unsupported(format!("ASCII samples of type {other}"))),
    }
}

/// The next token of `r` (at most `MAX_TOKEN` bytes of it), `None` at the end.
fn next_token(r: &mut impl BufRead, ctx: Ctx) -> Result<Option<Vec<u8>>> {
    let mut tok = Vec::new();
    loop {
        let buf = r.fill_buf().map_err(|e| ctx.bad(format!("ASCII data: unreadable after its values: {e}")))?;
        if buf.is_empty() {
            return Ok((!tok.is_empty()).then_some(tok));
        }
        let mut used = 0;
        for &b in buf {
            if b.is_ascii_whitespace() || b == b',' {
                if !tok.is_empty() {
                    break;
                }
            } else if tok.len() < MAX_TOKEN {
                tok.push(b);
            } else {
                break;
            }
            used += 1;
        }
        let available = buf.len();
        r.consume(used);
        if used < available {
            return Ok(Some(tok));
        }
    }
}
