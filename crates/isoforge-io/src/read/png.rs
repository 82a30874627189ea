//! PNG images (8- and 16-bit greyscale, with or without alpha; palette and low bit depths are
//! expanded) as a one-slice volume: x = column, y = row (top row first), z = 0.

use std::io::BufReader;
use std::path::Path;

use isoforge::grid::{AnyGrid, DenseGrid, Lattice};

use super::stream::VolumeReader;
use crate::error::{Ctx, Result};
use crate::file::Bounded;
use crate::limits::Limits;

/// Opens (decodes) a PNG image.
///
/// # Errors
/// [`Error::Read`](crate::Error::Read) for a malformed file, [`Error::Unsupported`](crate::Error::Unsupported)
/// for colour images (convert to greyscale first: the value of a pixel must be one number),
/// [`Error::Limit`](crate::Error::Limit) when the image exceeds `limits`.
pub fn open_png(path: &Path, limits: &Limits) -> Result<VolumeReader> {
    let ctx = Ctx::new(path, "PNG");
    let file = Bounded::new(crate::file::open(ctx, path)?);
    // The decoder's own buffers (rows, zlib window, text chunks) count against the limit too.
    let own = png::Limits { bytes: usize::try_from(limits.max_bytes).unwrap_or(usize::MAX) };
    let mut decoder = png::Decoder::new_with_limits(BufReader::new(file), own);
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(|e| ctx.bad(format!("header: {e}")))?;
    let (w, h) = (reader.info().width, reader.info().height);
    let (color, depth) = reader.output_color_type();
    let channels = match color {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        other => {
            return Err(ctx.unsupported(format!(
                "colour type {other:?}: isoforge reads greyscale images (one value per pixel); convert it first"
            )))
        }
    };
    let bytes_per = if depth == png::BitDepth::Sixteen { 2 } else { 1 };
    // Checked before decoding: the decoded frame (all channels) and the grid kept from it.
    let need = w as u64 * h as u64 * (channels * bytes_per) as u64;
    if need > limits.max_bytes {
        return Err(ctx.limit(format!("{w} x {h} image"), need, limits.max_bytes));
    }
    let size = reader.output_buffer_size().ok_or_else(|| ctx.bad(format!("image {w} x {h} is too large")))?;
    if size as u64 > need.saturating_add(h as u64 * 8) {
        return Err(ctx.bad(format!("image {w} x {h}: the decoder asks for {size} bytes, {need} expected")));
    }
    let mut buf = vec![0u8; size];
    let frame = reader.next_frame(&mut buf).map_err(|e| ctx.bad(format!("pixel data: {e}")))?;
    let stride = frame.line_size;
    let lattice = Lattice::new([w, h, 1]).map_err(|e| ctx.lib(e))?;
    if bytes_per == 1 && channels == 1 && stride == w as usize {
        // 8-bit grey rows without padding are the grid's samples already: no copy.
        buf.truncate(w as usize * h as usize);
        let grid = AnyGrid::U8(DenseGrid::new(lattice, buf).map_err(|e| ctx.lib(e))?);
        return Ok(VolumeReader::decoded(ctx, grid));
    }
    let px = |x: usize, y: usize| -> usize { y * stride + x * channels * bytes_per };
    let grid = if bytes_per == 2 {
        let data = (0..h as usize)
            .flat_map(|y| (0..w as usize).map(move |x| (y, x)))
            .map(|(y, x)| u16::from_be_bytes([buf[px(x, y)], buf[px(x, y) + 1]]))
            .collect();
        AnyGrid::U16(DenseGrid::new(lattice, data).map_err(|e| ctx.lib(e))?)
    } else {
        let data =
            (0..h as usize).flat_map(|y| (0..w as usize).map(move |x| (y, x))).map(|(y, x)| buf[px(x, y)]).collect();
        AnyGrid::U8(DenseGrid::new(lattice, data).map_err(|e| ctx.lib(e))?)
    };
    Ok(VolumeReader::decoded(ctx, grid))
}
