//! MRC2014 / CCP4 maps (cryo-EM, crystallography): modes 0 (int8), 1 (int16), 2 (float32),
//! 6 (uint16) and 12 (float16, widened to float32); little- or big-endian (machine stamp).
//!
//! Geometry: voxel size = cell length / sampling (`CELLA / MX`, in Å; a cell length of 0 means
//! "not set" and gives unit voxels, negative or non-finite ones are refused); origin = the `ORIGIN`
//! fields when set (MRC2014), else the start indices times the voxel size (CCP4); axes in file
//! order (`MAPC MAPR MAPS` = 1 2 3; other orders are refused rather than guessed). The extended
//! header (`NSYMBT` bytes) is skipped.

use std::io::Read;
use std::path::Path;

use isoforge::grid::{AnyGrid, DType, DenseGrid};

use super::decode;
use super::stream::{open_data, Compression, VolumeReader};
use crate::error::{Ctx, Result};
use crate::limits::Limits;

const HEADER: usize = 1024;

/// Opens an MRC or CCP4 map (`.mrc`, `.map`, `.ccp4`, `.mrcs` with one volume).
///
/// # Errors
/// [`Error::Read`](crate::Error::Read) for a short or malformed header (the word is named),
/// [`Error::Unsupported`](crate::Error::Unsupported) for complex or 4-bit modes and permuted axes,
/// [`Error::Limit`](crate::Error::Limit) when the map exceeds `limits`.
pub fn open_mrc(path: &Path, limits: &Limits) -> Result<VolumeReader> {
    let ctx = Ctx::new(path, "MRC");
    let mut h = [0u8; HEADER];
    let crate::file::Input { file: mut f, len } = crate::file::open(ctx, path)?;
    if len < HEADER as u64 {
        return Err(ctx.bad(format!("the file has {len} bytes; an MRC header alone has {HEADER}")));
    }
    f.read_exact(&mut h).map_err(|e| ctx.io(e))?;
    // Machine stamp (bytes 212–213): 0x44 0x4? little-endian, 0x11 0x11 big-endian. Old files
    // leave it zero; then the mode word decides (a sane mode reads small in the right order).
    let big = match (h[212], h[213]) {
        (0x44, _) => false,
        (0x11, 0x11) => true,
        _ => i32::from_le_bytes([h[12], h[13], h[14], h[15]]) as u32 > 0xffff,
    };
    let word = |at: usize| -> [u8; 4] { [h[at], h[at + 1], h[at + 2], h[at + 3]] };
    let i = |at: usize| if big { i32::from_be_bytes(word(at)) } else { i32::from_le_bytes(word(at)) };
    let fl = |at: usize| if big { f32::from_be_bytes(word(at)) } else { f32::from_le_bytes(word(at)) } as f64;
    let names = ["NX", "NY", "NZ"];
    let mut dims = [0u32; 3];
    for a in 0..3 {
        let n = i(4 * a);
        if n <= 0 {
            return Err(ctx.bad(format!("{} = {n}: must be a positive number of samples", names[a])));
        }
        dims[a] = n as u32;
    }
    let mode = i(12);
    let (dtype, file_bytes) = match mode {
        0 => (DType::I8, 1),
        1 => (DType::I16, 2),
        2 => (DType::F32, 4),
        6 => (DType::U16, 2),
        12 => (DType::F32, 2),
        3 | 4 => return Err(ctx.unsupported(format!("MODE {mode}: complex maps are not scalar volumes"))),
        101 => return Err(ctx.unsupported("MODE 101: 4-bit maps are not supported")),
        m => return Err(ctx.bad(format!("MODE {m}: unknown (0, 1, 2, 6 and 12 are supported)"))),
    };
    let map = [i(64), i(68), i(72)];
    if map != [1, 2, 3] && map != [0, 0, 0] {
        return Err(ctx.unsupported(format!("MAPC MAPR MAPS = {map:?}: only the file order 1 2 3 is supported")));
    }
    let nsymbt = i(92);
    if nsymbt < 0 {
        return Err(ctx.bad(format!("NSYMBT = {nsymbt}: the extended header size must be >= 0")));
    }
    let sampling = [i(28), i(32), i(36)];
    let cell = [fl(40), fl(44), fl(48)];
    // Voxel size = CELLA / M. A cell length of 0 means "not set" (many writers leave it so):
    // unit voxels then. Anything else must be a finite positive length over a positive count.
    let mut spacing = [1.0; 3];
    let (cella, m) = (["CELLA.X", "CELLA.Y", "CELLA.Z"], ["MX", "MY", "MZ"]);
    for a in 0..3 {
        if cell[a] == 0.0 {
            continue;
        }
        if !(cell[a].is_finite() && cell[a] > 0.0) {
            return Err(ctx
                .bad(format!("{} = {}: cell lengths must be finite and positive (or 0: not set)", cella[a], cell[a])));
        }
        if sampling[a] <= 0 {
            return Err(ctx.bad(format!(
                "{} = {} with {} = {}: the sampling must be positive to give a voxel size",
                m[a], sampling[a], cella[a], cell[a]
            )));
        }
        spacing[a] = cell[a] / sampling[a] as f64;
    }
    let start = [i(16), i(20), i(24)];
    let stored = [fl(196), fl(200), fl(204)];
    if let Some(o) = stored.iter().find(|o| !o.is_finite()) {
        return Err(ctx.bad(format!("ORIGIN {stored:?}: {o} is not a finite coordinate")));
    }
    let origin =
        if stored.iter().any(|&o| o != 0.0) { stored } else { [0, 1, 2].map(|a| start[a] as f64 * spacing[a]) };
    let n = dims.iter().map(|&d| d as u64).product::<u64>();
    let need = n.checked_mul(file_bytes).ok_or_else(|| ctx.bad(format!("dims {dims:?}: the size overflows")))?;
    decode::sample_bytes(ctx, dims, dtype, limits)?;
    let lattice = decode::lattice(ctx, "CELLA / MX MY MZ, ORIGIN", dims, spacing, origin, None)?;
    let offset = HEADER as u64 + nsymbt as u64;
    let mut data = open_data(ctx, path, offset, Compression::None, need, "map data")?;
    if mode != 12 {
        return Ok(VolumeReader::stream(ctx, lattice, dtype, big, data));
    }
    // float16: widen while reading.
    let mut raw = vec![0u8; need as usize];
    data.reader.read_exact(&mut raw).map_err(|e| ctx.bad(format!("map data: {e}")))?;
    let values: Vec<f32> = raw
        .chunks_exact(2)
        .map(|b| half_to_f32(if big { u16::from_be_bytes([b[0], b[1]]) } else { u16::from_le_bytes([b[0], b[1]]) }))
        .collect();
    // Non-finite samples are rejected by `read_grid`, as for every reader.
    let grid = DenseGrid::new(lattice, values).map_err(|e| ctx.lib(e))?;
    Ok(VolumeReader::decoded(ctx, AnyGrid::F32(grid)))
}

/// IEEE 754 half precision to single.
fn half_to_f32(h: u16) -> f32 {
    let sign = ((h >> 15) as u32) << 31;
    let exp = ((h >> 10) & 0x1f) as u32;
    let frac = (h & 0x3ff) as u32;
    let bits = match (exp, frac) {
        (0, 0) => sign,
        (0, f) => {
            // Subnormal: f · 2^-24.
            let v = f as f32 * 2.0f32.powi(-24);
            return if sign != 0 { -v } else { v };
        }
        (31, 0) => sign | 0x7f80_0000,
        (31, f) => sign | 0x7f80_0000 | (f << 13),
        (e, f) => sign | ((e + 112) << 23) | (f << 13),
    };
    f32::from_bits(bits)
}

#[cfg(test)]
mod tests {
    use super::half_to_f32;

    #[test]
    fn half_floats_widen_exactly() {
        assert_eq!(half_to_f32(0x3c00), 1.0);
        assert_eq!(half_to_f32(0xc000), -2.0);
        assert_eq!(half_to_f32(0x7bff), 65504.0);
        assert_eq!(half_to_f32(0x0001), 2.0f32.powi(-24));
        assert_eq!(half_to_f32(0x8001), -(2.0f32.powi(-24)));
        assert!(half_to_f32(0x7c00).is_infinite());
        assert!(half_to_f32(0x7e00).is_nan());
        assert_eq!(half_to_f32(0x3555), 0.333_251_95);
    }
}
