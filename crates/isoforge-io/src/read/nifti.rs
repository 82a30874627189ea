//! NIfTI-1 (`.nii`, `.nii.gz`; `.hdr`/`.img` pairs): the common data types, `scl_slope` /
//! `scl_inter`, and the sform (preferred) or qform to world coordinates, as nibabel chooses.
//!
//! Hand-written (348-byte fixed header) so every size is checked before allocating and no byte
//! pattern can panic. World coordinates are NIfTI's RAS+ scanner space. Voxel sizes
//! `pixdim[1..3]` (qform and pixdim-only methods) must be finite and positive; a negative `qfac`
//! (`pixdim[0]`) flips the third axis, as the standard says. `vox_offset` must be a whole number
//! of bytes.

use std::path::Path;

use std::io::Read;

use isoforge::grid::{AnyGrid, DType};

use super::decode;
use super::stream::{self, open_data, Compression, VolumeReader};
use crate::error::{Ctx, Result};
use crate::limits::Limits;

const HEADER_SIZE: usize = 348;

/// Reads a NIfTI-1 volume.
///
/// # Errors
/// As [`open_nifti`] and [`VolumeReader::read_grid`].
pub fn read_nifti(path: &Path, limits: &Limits) -> Result<AnyGrid> {
    open_nifti(path, limits)?.read_grid(limits)
}

/// Opens a NIfTI-1 volume: parses the header and positions the sample stream (scaling by
/// `scl_slope`/`scl_inter` is applied as samples are read).
///
/// # Errors
/// A [`crate::Error`] naming the header field and value, or data shorter than declared.
pub fn open_nifti(path: &Path, limits: &Limits) -> Result<VolumeReader> {
    let ctx = Ctx::new(path, "NIfTI");
    let crate::file::Input { mut file, len } = crate::file::open(ctx, path)?;
    let mut magic = [0u8; 2];
    let n = (&mut file).take(2).read(&mut magic).map_err(|e| ctx.io(e))?;
    let gz = n == 2 && magic == [0x1f, 0x8b];
    std::io::Seek::rewind(&mut file).map_err(|e| ctx.io(e))?;
    let mut stream = stream::wrap(
        std::io::BufReader::with_capacity(1 << 20, file.take(len)),
        if gz { Compression::Gzip } else { Compression::None },
        "data",
    );
    let mut head = vec![0u8; HEADER_SIZE];
    let mut got = 0;
    while got < HEADER_SIZE {
        match stream.reader.read(&mut head[got..]) {
            Ok(0) => break,
            Ok(k) => got += k,
            Err(e) => return Err(ctx.bad(format!("header: corrupt or unreadable after {got} bytes: {e}"))),
        }
    }
    if got < HEADER_SIZE {
        return Err(ctx.bad(format!("file has {got} bytes, a NIfTI-1 header needs {HEADER_SIZE}")));
    }
    let h = Header::parse(ctx, &head)?;
    let need = decode::sample_bytes(ctx, h.dims, h.dtype, limits)? as u64;
    let lattice = decode::lattice(ctx, h.geometry, h.dims, h.spacing, h.origin, Some(h.direction))?
        .with_space(Some(isoforge::grid::WorldSpace::Ras));
    let reader = if h.magic_pair {
        let img = path.with_extension("img");
        let ictx = Ctx::new(&img, "NIfTI image");
        let data = open_data(ictx, &img, h.vox_offset as u64, Compression::None, need, "image data")?;
        VolumeReader::stream(ictx, lattice, h.dtype, h.big_endian, data)
    } else if gz {
        stream::skip(ctx, &mut stream.reader, (h.vox_offset - HEADER_SIZE) as u64, "data")?;
        VolumeReader::stream(ctx, lattice, h.dtype, h.big_endian, stream)
    } else {
        let data = open_data(ctx, path, h.vox_offset as u64, Compression::None, need, "data")?;
        VolumeReader::stream(ctx, lattice, h.dtype, h.big_endian, data)
    };
    Ok(reader.with_scale(h.scale))
}

struct Header {
    dims: [u32; 3],
    dtype: DType,
    big_endian: bool,
    spacing: [f64; 3],
    origin: [f64; 3],
    direction: [[f64; 3]; 3],
    vox_offset: usize,
    scale: Option<(f64, f64)>,
    magic_pair: bool,
    /// Where the geometry came from ("sform", "qform", "pixdim"), for messages.
    geometry: &'static str,
}

struct Bytes<'a> {
    b: &'a [u8],
    big: bool,
}

impl Bytes<'_> {
    fn i16(&self, at: usize) -> i16 {
        let v = [self.b[at], self.b[at + 1]];
        if self.big {
            i16::from_be_bytes(v)
        } else {
            i16::from_le_bytes(v)
        }
    }
    fn i32(&self, at: usize) -> i32 {
        let v = [self.b[at], self.b[at + 1], self.b[at + 2], self.b[at + 3]];
        if self.big {
            i32::from_be_bytes(v)
        } else {
            i32::from_le_bytes(v)
        }
    }
    fn f32(&self, at: usize) -> f64 {
        f32::from_bits(self.i32(at) as u32) as f64
    }
}

impl Header {
    fn parse(ctx: Ctx, head: &[u8]) -> Result<Header> {
        debug_assert!(head.len() >= HEADER_SIZE);
        let le = i32::from_le_bytes([head[0], head[1], head[2], head[3]]);
        let big = match le {
            348 => false,
            _ if i32::from_be_bytes([head[0], head[1], head[2], head[3]]) == 348 => true,
            _ => {
                return Err(
                    ctx.bad(format!("sizeof_hdr is {le}, not 348: not a NIfTI-1 file (NIfTI-2 is not supported)"))
                )
            }
        };
        let b = Bytes { b: head, big };
        let magic = &head[344..348];
        let magic_pair = match magic {
            b"n+1\0" => false,
            b"ni1\0" => true,
            _ => {
                return Err(
                    ctx.bad(format!("magic {:?} is neither \"n+1\" nor \"ni1\"", String::from_utf8_lossy(&magic[..3])))
                )
            }
        };
        let ndim = b.i16(40);
        if !(1..=7).contains(&ndim) {
            return Err(ctx.bad(format!("dim[0] = {ndim}: must be 1 to 7")));
        }
        let mut dims = [1u32; 3];
        for a in 0..7 {
            let d = if (a as i16) < ndim { b.i16(42 + 2 * a) } else { 1 };
            if a < 3 {
                if d < 1 {
                    return Err(ctx.bad(format!("dim[{}] = {d}: sizes must be positive", a + 1)));
                }
                dims[a] = d as u32;
            } else if d > 1 {
                return Err(ctx.unsupported(format!(
                    "dim[{}] = {d}: only single 3D volumes are supported (no time series or vectors)",
                    a + 1
                )));
            }
        }
        let code = b.i16(70);
        let dtype = match code {
            2 => DType::U8,
            4 => DType::I16,
            8 => DType::I32,
            16 => DType::F32,
            64 => DType::F64,
            256 => DType::I8,
            512 => DType::U16,
            768 => DType::U32,
            other => {
                return Err(ctx
                    .unsupported(format!("datatype {other}: unsupported (u8, i8, u16, i16, u32, i32, f32, f64 are)")))
            }
        };
        let bitpix = b.i16(72);
        if bitpix as usize != dtype.size() * 8 {
            return Err(ctx.bad(format!("bitpix {bitpix} does not match datatype {code} ({dtype})")));
        }
        let pix = |i: usize| b.f32(76 + 4 * i);
        // Voxel sizes for the qform and for the pixdim-only method: finite and positive; an axis
        // with one point has no size to speak of (1). A flip lives in qfac or in the sform.
        let voxel_sizes = || -> Result<[f64; 3]> {
            let mut s = [1.0; 3];
            for a in 0..3 {
                let v = pix(a + 1);
                if v.is_finite() && v > 0.0 {
                    s[a] = v;
                } else if dims[a] > 1 {
                    return Err(ctx.bad(format!(
                        "pixdim[{}] = {v}: voxel sizes must be finite and positive (NIfTI stores a flip in qfac = pixdim[0] or in the sform)",
                        a + 1
                    )));
                }
            }
            Ok(s)
        };
        let vox = b.f32(108);
        if !(vox.is_finite() && vox >= 0.0 && vox <= (1u64 << 32) as f64 && vox.fract() == 0.0) {
            return Err(ctx.bad(format!("vox_offset {vox}: must be a non-negative whole byte offset")));
        }
        let vox_offset = if magic_pair { vox as usize } else { (vox as usize).max(HEADER_SIZE) };
        let (slope, inter) = (b.f32(112), b.f32(116));
        let scale = if slope != 0.0 && slope.is_finite() && inter.is_finite() && !(slope == 1.0 && inter == 0.0) {
            Some((slope, inter))
        } else {
            None
        };
        let (qcode, scode) = (b.i16(252), b.i16(254));
        let axes_origin = if scode > 0 {
            let row = |r: usize| [0, 1, 2, 3].map(|c| b.f32(280 + 16 * r + 4 * c));
            let (x, y, z) = (row(0), row(1), row(2));
            // Columns of the affine are the index axes in world space.
            let axes = [[x[0], y[0], z[0]], [x[1], y[1], z[1]], [x[2], y[2], z[2]]];
            (axes, [x[3], y[3], z[3]], "sform")
        } else if qcode > 0 {
            let (qb, qc, qd) = (b.f32(256), b.f32(260), b.f32(264));
            let qa = (1.0 - (qb * qb + qc * qc + qd * qd)).max(0.0).sqrt();
            let r = [
                [qa * qa + qb * qb - qc * qc - qd * qd, 2.0 * (qb * qc - qa * qd), 2.0 * (qb * qd + qa * qc)],
                [2.0 * (qb * qc + qa * qd), qa * qa + qc * qc - qb * qb - qd * qd, 2.0 * (qc * qd - qa * qb)],
                [2.0 * (qb * qd - qa * qc), 2.0 * (qc * qd + qa * qb), qa * qa + qd * qd - qc * qc - qb * qb],
            ];
            // qfac = pixdim[0]: negative for a left-handed index frame (the third axis flipped),
            // as nifti1_io reads it; 0 and positive values mean 1.
            let qfac = if pix(0) < 0.0 { -1.0 } else { 1.0 };
            let v = voxel_sizes()?;
            let s = [v[0], v[1], v[2] * qfac];
            let axes = [0, 1, 2].map(|c| [r[0][c] * s[c], r[1][c] * s[c], r[2][c] * s[c]]);
            (axes, [b.f32(268), b.f32(272), b.f32(276)], "qform")
        } else {
            let s = voxel_sizes()?;
            ([[s[0], 0.0, 0.0], [0.0, s[1], 0.0], [0.0, 0.0, s[2]]], [0.0; 3], "pixdim")
        };
        let (axes, origin, source) = axes_origin;
        let (spacing, direction) = decode::split_axes(axes)
            .ok_or_else(|| ctx.bad(format!("{source}: an axis has zero or non-finite length ({axes:?})")))?;
        if origin.iter().any(|o| !o.is_finite()) {
            return Err(ctx.bad(format!("{source}: origin {origin:?} is not finite")));
        }
        Ok(Header {
            dims,
            dtype,
            big_endian: big,
            spacing,
            origin,
            direction,
            vox_offset,
            scale,
            magic_pair,
            geometry: source,
        })
    }
}
