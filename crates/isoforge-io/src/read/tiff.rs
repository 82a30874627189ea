//! TIFF images and multi-page stacks (8/16/32-bit integer and 32/64-bit float greyscale;
//! uncompressed, LZW or deflate): page p becomes slice z = p, x = column, y = row.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use isoforge::grid::{AnyGrid, DenseGrid, Lattice};
use tiff::decoder::{Decoder, DecodingResult};

use super::stream::VolumeReader;
use crate::error::{Ctx, Result};
use crate::limits::Limits;

/// Opens (decodes) a TIFF file; every page must have the first page's size and sample type.
///
/// # Errors
/// [`Error::Read`](crate::Error::Read) for a malformed file or pages that differ (the page is
/// named), [`Error::Unsupported`](crate::Error::Unsupported) for colour or signed/64-bit integer
/// pages, [`Error::Limit`](crate::Error::Limit) when the stack exceeds `limits`.
pub fn open_tiff(path: &Path, limits: &Limits) -> Result<VolumeReader> {
    let ctx = Ctx::new(path, "TIFF");
    let file = File::open(path).map_err(|e| ctx.io(e))?;
    let mut dec = Decoder::new(BufReader::new(file)).map_err(|e| ctx.bad(format!("header: {e}")))?;
    let (w, h) = dec.dimensions().map_err(|e| ctx.bad(format!("page 0: {e}")))?;
    let mut pages: Vec<DecodingResult> = Vec::new();
    let mut total = 0u64;
    loop {
        let p = pages.len();
        let dims = dec.dimensions().map_err(|e| ctx.bad(format!("page {p}: {e}")))?;
        if dims != (w, h) {
            return Err(ctx.bad(format!("page {p} is {} x {}, page 0 is {w} x {h}", dims.0, dims.1)));
        }
        let color = dec.colortype().map_err(|e| ctx.bad(format!("page {p}: {e}")))?;
        let bits = match color {
            tiff::ColorType::Gray(b) => b as u64,
            other => {
                return Err(ctx.unsupported(format!(
                    "page {p}: colour type {other:?}: isoforge reads greyscale pages (one value per pixel)"
                )))
            }
        };
        total += w as u64 * h as u64 * bits.div_ceil(8);
        if total > limits.max_bytes {
            return Err(ctx.limit(format!("{w} x {h} x {} pages", p + 1), total, limits.max_bytes));
        }
        let img = dec.read_image().map_err(|e| ctx.bad(format!("page {p}: {e}")))?;
        if let Some(first) = pages.first() {
            if std::mem::discriminant(first) != std::mem::discriminant(&img) {
                return Err(ctx.bad(format!("page {p} has another sample type than page 0")));
            }
        }
        pages.push(img);
        if !dec.more_images() {
            break;
        }
        dec.next_image().map_err(|e| ctx.bad(format!("page {}: {e}", p + 1)))?;
    }
    let lattice = Lattice::new([w, h, pages.len() as u32]).map_err(|e| ctx.lib(e))?;
    macro_rules! stack {
        ($variant:ident, $grid:ident) => {{
            let mut data = Vec::with_capacity(lattice.num_points() as usize);
            for page in pages {
                if let DecodingResult::$variant(v) = page {
                    data.extend(v);
                }
            }
            AnyGrid::$grid(DenseGrid::new(lattice, data).map_err(|e| ctx.lib(e))?)
        }};
    }
    let grid = match &pages[0] {
        DecodingResult::U8(_) => stack!(U8, U8),
        DecodingResult::U16(_) => stack!(U16, U16),
        DecodingResult::U32(_) => stack!(U32, U32),
        DecodingResult::I8(_) => stack!(I8, I8),
        DecodingResult::I16(_) => stack!(I16, I16),
        DecodingResult::I32(_) => stack!(I32, I32),
        DecodingResult::F32(_) => stack!(F32, F32),
        DecodingResult::F64(_) => stack!(F64, F64),
        _ => return Err(ctx.unsupported("sample type (64-bit integer or 16-bit float pages) is not supported")),
    };
    Ok(VolumeReader::decoded(ctx, grid))
}

/// An RGB volume: 8-bit colours on a lattice of `dims` points (index = world; pages are z).
#[derive(Debug, Clone, PartialEq)]
pub struct RgbVolume {
    /// Points per axis.
    pub dims: [u32; 3],
    /// One colour per point, x fastest.
    pub data: Vec<[u8; 3]>,
}

impl RgbVolume {
    /// The colour at index-space point `p` (trilinear per channel, clamped to the lattice).
    pub fn sample(&self, p: [f64; 3]) -> [u8; 3] {
        let d = self.dims;
        let c = [0, 1, 2].map(|a| p[a].clamp(0.0, (d[a] - 1) as f64));
        let lo = [0, 1, 2].map(|a| (c[a].floor() as u32).min(d[a].saturating_sub(2)));
        let f = [0, 1, 2].map(|a| if d[a] < 2 { 0.0 } else { c[a] - lo[a] as f64 });
        let mut acc = [0.0f64; 3];
        for k in 0..8u32 {
            let o = [k & 1, (k >> 1) & 1, (k >> 2) & 1];
            let q = [0, 1, 2].map(|a| (lo[a] + o[a]).min(d[a] - 1));
            let w: f64 = (0..3).map(|a| if o[a] == 1 { f[a] } else { 1.0 - f[a] }).product();
            let v = self.data[((q[2] * d[1] + q[1]) * d[0] + q[0]) as usize];
            for ch in 0..3 {
                acc[ch] += w * v[ch] as f64;
            }
        }
        acc.map(|x| x.round().clamp(0.0, 255.0) as u8)
    }
}

/// Reads an 8-bit RGB (or RGBA, alpha dropped) TIFF, one page per slice.
///
/// # Errors
/// As [`open_tiff`]; [`Error::Unsupported`](crate::Error::Unsupported) for pages that are not
/// 8-bit RGB(A).
pub fn read_tiff_rgb(path: &Path, limits: &Limits) -> Result<RgbVolume> {
    let ctx = Ctx::new(path, "TIFF");
    let file = File::open(path).map_err(|e| ctx.io(e))?;
    let mut dec = Decoder::new(BufReader::new(file)).map_err(|e| ctx.bad(format!("header: {e}")))?;
    let (w, h) = dec.dimensions().map_err(|e| ctx.bad(format!("page 0: {e}")))?;
    let mut data: Vec<[u8; 3]> = Vec::new();
    let mut pages = 0u32;
    loop {
        let dims = dec.dimensions().map_err(|e| ctx.bad(format!("page {pages}: {e}")))?;
        if dims != (w, h) {
            return Err(ctx.bad(format!("page {pages} is {} x {}, page 0 is {w} x {h}", dims.0, dims.1)));
        }
        let channels = match dec.colortype().map_err(|e| ctx.bad(format!("page {pages}: {e}")))? {
            tiff::ColorType::RGB(8) => 3,
            tiff::ColorType::RGBA(8) => 4,
            other => {
                return Err(ctx.unsupported(format!("page {pages}: colour type {other:?}: 8-bit RGB pages are needed")))
            }
        };
        let need = (data.len() as u64 + w as u64 * h as u64) * 3;
        if need > limits.max_bytes {
            return Err(ctx.limit(format!("{w} x {h} x {} RGB pages", pages + 1), need, limits.max_bytes));
        }
        let DecodingResult::U8(px) = dec.read_image().map_err(|e| ctx.bad(format!("page {pages}: {e}")))? else {
            return Err(ctx.bad(format!("page {pages}: not 8-bit samples")));
        };
        data.extend(px.chunks_exact(channels).map(|c| [c[0], c[1], c[2]]));
        pages += 1;
        if !dec.more_images() {
            break;
        }
        dec.next_image().map_err(|e| ctx.bad(format!("page {pages}: {e}")))?;
    }
    if data.len() != (w as usize) * (h as usize) * pages as usize {
        return Err(ctx.bad("RGB pixel data does not fill the pages"));
    }
    Ok(RgbVolume { dims: [w, h, pages], data })
}
