//! TIFF images and multi-page stacks (8/16/32-bit integer and 32/64-bit float greyscale;
//! uncompressed, LZW or deflate): page p becomes slice z = p, x = column, y = row.

use std::io::BufReader;
use std::path::Path;

use isoforge::grid::{AnyGrid, DenseGrid, Lattice};
use tiff::decoder::{Decoder, DecodingResult};

use super::stream::VolumeReader;
use crate::error::{Ctx, Result};
use crate::file::Bounded;
use crate::limits::Limits;

/// A TIFF decoder over the regular file `path`, its own buffers limited by `limits`.
fn decoder(ctx: Ctx, path: &Path, limits: &Limits) -> Result<Decoder<BufReader<Bounded>>> {
    let file = Bounded::new(crate::file::open(ctx, path)?);
    let mut own = tiff::decoder::Limits::default();
    own.decoding_buffer_size = usize::try_from(limits.max_bytes).unwrap_or(usize::MAX);
    Ok(Decoder::new(BufReader::new(file)).map_err(|e| ctx.bad(format!("header: {e}")))?.with_limits(own))
}

/// Walks the pages' headers (no pixels decoded): every page must be `w` × `h` and of a colour
/// type `accept` takes (returning its bytes per pixel); the total is checked against `limits`
/// before anything is decoded. Returns the page count, positioned back at page 0.
fn count_pages(
    ctx: Ctx,
    dec: &mut Decoder<BufReader<Bounded>>,
    limits: &Limits,
    what: &str,
    accept: impl Fn(usize, tiff::ColorType) -> Result<u64>,
) -> Result<(u32, u32, u32)> {
    let (w, h) = dec.dimensions().map_err(|e| ctx.bad(format!("page 0: {e}")))?;
    let mut pages = 0u32;
    let mut total = 0u64;
    loop {
        let p = pages as usize;
        let dims = dec.dimensions().map_err(|e| ctx.bad(format!("page {p}: {e}")))?;
        if dims != (w, h) {
            return Err(ctx.bad(format!("page {p} is {} x {}, page 0 is {w} x {h}", dims.0, dims.1)));
        }
        let color = dec.colortype().map_err(|e| ctx.bad(format!("page {p}: {e}")))?;
        total = total.saturating_add(w as u64 * h as u64 * accept(p, color)?);
        pages = pages.checked_add(1).ok_or_else(|| ctx.bad("too many pages"))?;
        if total > limits.max_bytes {
            return Err(ctx.limit(format!("{w} x {h} x {pages} {what}"), total, limits.max_bytes));
        }
        if !dec.more_images() {
            break;
        }
        dec.next_image().map_err(|e| ctx.bad(format!("page {}: {e}", p + 1)))?;
    }
    dec.seek_to_image(0).map_err(|e| ctx.bad(format!("page 0: {e}")))?;
    Ok((w, h, pages))
}

/// Opens (decodes) a TIFF file; every page must have the first page's size and sample type.
/// The pages' sizes are checked against `limits` before any is decoded, and each page is
/// appended to the volume as it is decoded (memory: the volume and one page).
///
/// # Errors
/// [`Error::Read`](crate::Error::Read) for a malformed file or pages that differ (the page is
/// named), [`Error::Unsupported`](crate::Error::Unsupported) for colour or signed/64-bit integer
/// pages, [`Error::Limit`](crate::Error::Limit) when the stack exceeds `limits`.
pub fn open_tiff(path: &Path, limits: &Limits) -> Result<VolumeReader> {
    let ctx = Ctx::new(path, "TIFF");
    let mut dec = decoder(ctx, path, limits)?;
    let (w, h, pages) = count_pages(ctx, &mut dec, limits, "pages", |p, color| match color {
        tiff::ColorType::Gray(b) => Ok((b as u64).div_ceil(8)),
        other => Err(ctx.unsupported(format!(
            "page {p}: colour type {other:?}: isoforge reads greyscale pages (one value per pixel)"
        ))),
    })?;
    let lattice = Lattice::new([w, h, pages]).map_err(|e| ctx.lib(e))?;
    let n = lattice.num_points() as usize;
    let mut acc: Option<DecodingResult> = None;
    for p in 0..pages {
        if p > 0 {
            dec.next_image().map_err(|e| ctx.bad(format!("page {p}: {e}")))?;
        }
        let img = dec.read_image().map_err(|e| ctx.bad(format!("page {p}: {e}")))?;
        macro_rules! append {
            ($($v:ident),*) => {
                match (&mut acc, img) {
                    $( (Some(DecodingResult::$v(all)), DecodingResult::$v(page)) => all.extend_from_slice(&page), )*
                    (Some(_), _) => return Err(ctx.bad(format!("page {p} has another sample type than page 0"))),
                    (None, first) => {
                        acc = Some(match first {
                            $( DecodingResult::$v(mut v) => {
                                v.reserve_exact(n.saturating_sub(v.len()));
                                DecodingResult::$v(v)
                            } )*
                            _ => return Err(ctx.unsupported("sample type (64-bit integer or 16-bit float pages) is not supported")),
                        })
                    }
                }
            };
        }
        append!(U8, U16, U32, I8, I16, I32, F32, F64);
    }
    macro_rules! grid {
        ($($v:ident),*) => {
            match acc {
                $( Some(DecodingResult::$v(data)) => AnyGrid::$v(DenseGrid::new(lattice, data).map_err(|e| ctx.lib(e))?), )*
                _ => return Err(ctx.unsupported("sample type (64-bit integer or 16-bit float pages) is not supported")),
            }
        };
    }
    let grid = grid!(U8, U16, U32, I8, I16, I32, F32, F64);
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
    let mut dec = decoder(ctx, path, limits)?;
    let channels_of = |p: usize, color| match color {
        tiff::ColorType::RGB(8) => Ok(3),
        tiff::ColorType::RGBA(8) => Ok(4),
        other => Err(ctx.unsupported(format!("page {p}: colour type {other:?}: 8-bit RGB pages are needed"))),
    };
    let (w, h, pages) = count_pages(ctx, &mut dec, limits, "RGB pages", |p, c| channels_of(p, c).map(|_| 3))?;
    let mut data: Vec<[u8; 3]> = Vec::with_capacity(w as usize * h as usize * pages as usize);
    for p in 0..pages {
        if p > 0 {
            dec.next_image().map_err(|e| ctx.bad(format!("page {p}: {e}")))?;
        }
        let channels = channels_of(p as usize, dec.colortype().map_err(|e| ctx.bad(format!("page {p}: {e}")))?)?;
        let DecodingResult::U8(px) = dec.read_image().map_err(|e| ctx.bad(format!("page {p}: {e}")))? else {
            return Err(ctx.bad(format!("page {p}: not 8-bit samples")));
        };
        data.extend(px.chunks_exact(channels).map(|c| [c[0], c[1], c[2]]));
    }
    if data.len() != (w as usize) * (h as usize) * pages as usize {
        return Err(ctx.bad("RGB pixel data does not fill the pages"));
    }
    Ok(RgbVolume { dims: [w, h, pages], data })
}
