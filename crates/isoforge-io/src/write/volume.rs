//! Volume writers: NRRD (raw or gzip) and NIfTI-1 (`.nii`, `.nii.gz`), little-endian, with the
//! lattice's spacing, origin and direction (NRRD `space directions` / `space origin`; NIfTI sform
//! and qform). Readers of this crate read them back to the same grid and geometry; `isoforge convert`
//! uses them.

use std::io::{self, Write};

use isoforge::grid::{as_bytes, AnyGrid, DType, Lattice, Sample, WorldSpace};

/// Writes the samples in little-endian order.
fn write_samples(w: &mut dyn Write, grid: &AnyGrid) -> io::Result<()> {
    fn go<S: Sample>(w: &mut dyn Write, data: &[S]) -> io::Result<()> {
        if cfg!(target_endian = "little") {
            return w.write_all(as_bytes(data));
        }
        for chunk in data.chunks(1 << 16) {
            let swapped: Vec<S> = chunk.iter().map(|s| s.swap_bytes()).collect();
            w.write_all(as_bytes(&swapped))?;
        }
        Ok(())
    }
    isoforge::with_grid!(grid, g => go(w, g.data()))
}

fn nrrd_type(t: DType) -> &'static str {
    match t {
        DType::U8 => "uchar",
        DType::I8 => "signed char",
        DType::U16 => "ushort",
        DType::I16 => "short",
        DType::U32 => "uint",
        DType::I32 => "int",
        DType::F32 => "float",
        _ => "double",
    }
}

/// The world vector of each index step: direction × spacing.
fn axes(l: &Lattice) -> [[f64; 3]; 3] {
    let (d, s) = (l.direction(), l.spacing());
    [0, 1, 2].map(|a| d[a].map(|x| x * s[a]))
}

/// Writes an attached NRRD (`gzip` compresses the data).
pub fn write_nrrd(w: &mut dyn Write, grid: &AnyGrid, gzip: bool) -> io::Result<()> {
    let l = grid.lattice();
    let [nx, ny, nz] = l.dims();
    let v = |x: [f64; 3]| format!("({},{},{})", x[0], x[1], x[2]);
    let ax = axes(l);
    write!(
        w,
        "NRRD0004\n# written by isoforge\ntype: {}\ndimension: 3\nsizes: {nx} {ny} {nz}\n{}\n\
         space directions: {} {} {}\nspace origin: {}\nendian: little\nencoding: {}\n\n",
        nrrd_type(grid.dtype()),
        match l.space() {
            Some(WorldSpace::Lps) => "space: left-posterior-superior",
            Some(WorldSpace::Ras) => "space: right-anterior-superior",
            None => "space dimension: 3",
        },
        v(ax[0]),
        v(ax[1]),
        v(ax[2]),
        v(l.origin()),
        if gzip { "gzip" } else { "raw" }
    )?;
    if gzip {
        let mut z = flate2::write::GzEncoder::new(w, flate2::Compression::fast());
        write_samples(&mut z, grid)?;
        z.finish()?;
        Ok(())
    } else {
        write_samples(w, grid)
    }
}

fn nifti_code(t: DType) -> (i16, i16) {
    match t {
        DType::U8 => (2, 8),
        DType::I8 => (256, 8),
        DType::U16 => (512, 16),
        DType::I16 => (4, 16),
        DType::U32 => (768, 32),
        DType::I32 => (8, 32),
        DType::F32 => (16, 32),
        _ => (64, 64),
    }
}

/// Writes a single-file NIfTI-1 (`.nii`; `gzip` for `.nii.gz`) with sform and qform set to the
/// lattice (code 2, aligned), in RAS: LPS lattices (DICOM, MetaImage, LPS NRRD) are converted.
pub fn write_nifti(w: &mut dyn Write, grid: &AnyGrid, gzip: bool) -> io::Result<()> {
    // NIfTI world coordinates are RAS: an LPS lattice is re-expressed.
    let l = &match grid.lattice().space() {
        Some(WorldSpace::Lps) => grid.lattice().in_space(WorldSpace::Ras).map_err(io::Error::other)?,
        _ => grid.lattice().clone(),
    };
    let mut h = vec![0u8; 352];
    let put_i32 = |h: &mut Vec<u8>, at: usize, v: i32| h[at..at + 4].copy_from_slice(&v.to_le_bytes());
    let put_i16 = |h: &mut Vec<u8>, at: usize, v: i16| h[at..at + 2].copy_from_slice(&v.to_le_bytes());
    let put_f32 = |h: &mut Vec<u8>, at: usize, v: f64| h[at..at + 4].copy_from_slice(&(v as f32).to_le_bytes());
    put_i32(&mut h, 0, 348);
    let dims = l.dims();
    put_i16(&mut h, 40, 3);
    for (a, &d) in dims.iter().enumerate() {
        put_i16(&mut h, 42 + 2 * a, d.min(i16::MAX as u32) as i16);
    }
    put_i16(&mut h, 48, 1);
    put_i16(&mut h, 50, 1);
    put_i16(&mut h, 52, 1);
    put_i16(&mut h, 54, 1);
    let (code, bits) = nifti_code(grid.dtype());
    put_i16(&mut h, 70, code);
    put_i16(&mut h, 72, bits);
    // qfac in pixdim[0]: −1 when the index frame is left-handed.
    let mirrored = l.is_mirrored();
    put_f32(&mut h, 76, if mirrored { -1.0 } else { 1.0 });
    for (a, &s) in l.spacing().iter().enumerate() {
        put_f32(&mut h, 80 + 4 * a, s);
    }
    put_f32(&mut h, 108, 352.0); // vox_offset
    put_f32(&mut h, 112, 1.0); // scl_slope
    h[123] = 10 | 8; // xyzt_units: mm, s
    put_i16(&mut h, 252, 2); // qform_code: aligned
    put_i16(&mut h, 254, 2); // sform_code: aligned
                             // qform quaternion from the rotation (third column negated when mirrored, as qfac says).
    let d = l.direction();
    let mut r = [[0.0f64; 3]; 3]; // r[row][col], columns = index axes
    for c in 0..3 {
        let sign = if c == 2 && mirrored { -1.0 } else { 1.0 };
        for row in 0..3 {
            r[row][c] = d[c][row] * sign;
        }
    }
    let (qb, qc, qd) = quaternion(r);
    put_f32(&mut h, 256, qb);
    put_f32(&mut h, 260, qc);
    put_f32(&mut h, 264, qd);
    let o = l.origin();
    put_f32(&mut h, 268, o[0]);
    put_f32(&mut h, 272, o[1]);
    put_f32(&mut h, 276, o[2]);
    let ax = axes(l);
    for row in 0..3 {
        for c in 0..3 {
            put_f32(&mut h, 280 + 16 * row + 4 * c, ax[c][row]);
        }
        put_f32(&mut h, 280 + 16 * row + 12, o[row]);
    }
    h[344..348].copy_from_slice(b"n+1\0");
    if gzip {
        let mut z = flate2::write::GzEncoder::new(w, flate2::Compression::fast());
        z.write_all(&h)?;
        write_samples(&mut z, grid)?;
        z.finish()?;
        Ok(())
    } else {
        w.write_all(&h)?;
        write_samples(w, grid)
    }
}

/// (b, c, d) of the unit quaternion of a proper rotation matrix, with a ≥ 0 (NIfTI's convention).
fn quaternion(r: [[f64; 3]; 3]) -> (f64, f64, f64) {
    let a = 0.5 * (1.0 + r[0][0] + r[1][1] + r[2][2]).max(0.0).sqrt();
    if a > 0.5e-3 {
        return ((r[2][1] - r[1][2]) / (4.0 * a), (r[0][2] - r[2][0]) / (4.0 * a), (r[1][0] - r[0][1]) / (4.0 * a));
    }
    // a ≈ 0: a rotation by π; take the largest diagonal term.
    let b = 0.5 * (1.0 + r[0][0] - r[1][1] - r[2][2]).max(0.0).sqrt();
    let c = 0.5 * (1.0 - r[0][0] + r[1][1] - r[2][2]).max(0.0).sqrt();
    let d = 0.5 * (1.0 - r[0][0] - r[1][1] + r[2][2]).max(0.0).sqrt();
    if b >= c && b >= d {
        (b, (r[0][1] + r[1][0]) / (4.0 * b), (r[0][2] + r[2][0]) / (4.0 * b))
    } else if c >= d {
        ((r[0][1] + r[1][0]) / (4.0 * c), c, (r[1][2] + r[2][1]) / (4.0 * c))
    } else {
        ((r[0][2] + r[2][0]) / (4.0 * d), (r[1][2] + r[2][1]) / (4.0 * d), d)
    }
}
