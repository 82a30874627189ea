//! DICOM series from a folder (dicom-rs): every file of the folder that parses as DICOM is one
//! slice of a single series.
//!
//! - **Series**: all slices must share SeriesInstanceUID; several series are refused, naming their
//!   UIDs and file counts. Files that are not DICOM (DICOMDIR, notes) are skipped.
//! - **Order**: slices are sorted by their position along the slice normal (ImagePositionPatient ·
//!   (row × column direction from ImageOrientationPatient)), not by file name or InstanceNumber.
//! - **Spacing**: PixelSpacing (row spacing, column spacing) in-plane; the measured distance
//!   between consecutive slice positions along the normal. Positions must be evenly spaced: a gap
//!   (a missing slice) or a duplicate position is an error naming the positions, never silently
//!   interpolated.
//! - **Values**: stored values × RescaleSlope + RescaleIntercept (Hounsfield units for CT),
//!   as i16 when that is exact (integer slope and intercept, range fits), f32 otherwise.
//! - **World**: DICOM patient coordinates (LPS, millimetres): origin = the first slice's
//!   ImagePositionPatient, axis directions = row direction, column direction, normal.
//! - **Transfer syntaxes**: whatever dicom-pixeldata decodes in pure Rust (native little/big
//!   endian, deflate, RLE, JPEG baseline/lossless); single-frame greyscale slices.

use std::path::{Path, PathBuf};

use dicom_dictionary_std::tags;
use dicom_object::{open_file, DefaultDicomObject, Tag};
use dicom_pixeldata::PixelDecoder;
use isoforge::grid::{AnyGrid, DenseGrid};

use super::decode;
use super::stream::VolumeReader;
use crate::error::{Ctx, Result};
use crate::limits::Limits;

/// Largest number of files looked at in one folder.
const MAX_FILES: usize = 100_000;

struct Slice {
    path: PathBuf,
    obj: DefaultDicomObject,
    position: [f64; 3],
    along: f64,
}

/// Opens the DICOM series in folder `dir`.
///
/// # Errors
/// [`Error::Read`](crate::Error::Read) for an empty folder, mixed series, slices that disagree on
/// size, orientation or spacing, missing or duplicate slices (positions named), undecodable pixel
/// data (the file named); [`Error::Limit`](crate::Error::Limit) when the volume exceeds `limits`.
pub fn open_dicom_dir(dir: &Path, limits: &Limits) -> Result<VolumeReader> {
    let ctx = Ctx::new(dir, "DICOM");
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| ctx.io(e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .collect();
    if files.len() > MAX_FILES {
        return Err(ctx.limit(format!("{} files in the folder", files.len()), files.len() as u64, MAX_FILES as u64));
    }
    files.sort();
    let mut slices: Vec<Slice> = Vec::new();
    let mut series: Vec<(String, usize)> = Vec::new();
    for path in files {
        let obj = match open_file(&path) {
            Ok(obj) => obj,
            // A file with the DICOM preamble that does not parse is damaged, not "other".
            Err(e) if has_dicom_magic(&path) => {
                return Err(Ctx::new(&path, "DICOM").bad(format!("damaged DICOM file: {e}")));
            }
            Err(_) => continue, // not DICOM: skipped
        };
        if obj.element_opt(tags::PIXEL_DATA).ok().flatten().is_none() {
            // Image storage SOP classes (1.2.840.10008.5.1.4.1.1.*) must carry pixels; others
            // (DICOMDIR, reports, presentation states) are skipped.
            let class = obj.meta().media_storage_sop_class_uid().trim_end_matches('\0').to_string();
            if class.starts_with("1.2.840.10008.5.1.4.1.1.") || obj.element_opt(tags::ROWS).ok().flatten().is_some() {
                // An image whose pixels are gone (a cut file) must not silently drop a slice.
                return Err(Ctx::new(&path, "DICOM").bad("an image without PixelData (truncated file?)"));
            }
            continue; // DICOMDIR, structured reports, …
        }
        let uid = text(&obj, tags::SERIES_INSTANCE_UID).unwrap_or_default();
        match series.iter_mut().find(|(u, _)| *u == uid) {
            Some((_, n)) => *n += 1,
            None => series.push((uid, 1)),
        }
        let fctx = Ctx::new(&path, "DICOM");
        let position = floats::<3>(fctx, &obj, tags::IMAGE_POSITION_PATIENT, "ImagePositionPatient")?;
        slices.push(Slice { path, obj, position, along: 0.0 });
    }
    if series.len() > 1 {
        let list: Vec<String> = series.iter().map(|(u, n)| format!("{u} ({n} files)")).collect();
        return Err(ctx.bad(format!(
            "the folder holds {} series: {}; put one series per folder",
            series.len(),
            list.join(", ")
        )));
    }
    let Some(first) = slices.first() else {
        return Err(ctx.bad("no DICOM image in the folder"));
    };
    let first_path = first.path.clone();
    let fctx = Ctx::new(&first_path, "DICOM");
    let thickness =
        text(&first.obj, tags::SLICE_THICKNESS).and_then(|t| t.trim().parse().ok()).filter(|v: &f64| *v > 0.0);
    let iop = floats::<6>(fctx, &first.obj, tags::IMAGE_ORIENTATION_PATIENT, "ImageOrientationPatient")?;
    let row = [iop[0], iop[1], iop[2]];
    let col = [iop[3], iop[4], iop[5]];
    let normal =
        [row[1] * col[2] - row[2] * col[1], row[2] * col[0] - row[0] * col[2], row[0] * col[1] - row[1] * col[0]];
    let pixel = floats::<2>(fctx, &first.obj, tags::PIXEL_SPACING, "PixelSpacing")?;
    let (rows, cols) = (uint(fctx, &first.obj, tags::ROWS, "Rows")?, uint(fctx, &first.obj, tags::COLUMNS, "Columns")?);
    for s in &mut slices {
        s.along = (0..3).map(|a| s.position[a] * normal[a]).sum();
        let sctx = Ctx::new(&s.path, "DICOM");
        let other = floats::<6>(sctx, &s.obj, tags::IMAGE_ORIENTATION_PATIENT, "ImageOrientationPatient")?;
        if other.iter().zip(&iop).any(|(a, b)| (a - b).abs() > 1e-4) {
            return Err(sctx.bad(format!(
                "ImageOrientationPatient {other:?} differs from {iop:?} of {}",
                first_name(&first_path)
            )));
        }
        let (r, c) = (uint(sctx, &s.obj, tags::ROWS, "Rows")?, uint(sctx, &s.obj, tags::COLUMNS, "Columns")?);
        if (r, c) != (rows, cols) {
            return Err(sctx.bad(format!("{c} x {r} pixels, the series' first slice has {cols} x {rows}")));
        }
    }
    slices.sort_by(|a, b| a.along.total_cmp(&b.along));
    let n = slices.len();
    let spacing_z = if n > 1 {
        let mut gaps: Vec<f64> = slices.windows(2).map(|w| w[1].along - w[0].along).collect();
        gaps.sort_by(f64::total_cmp);
        let median = gaps[gaps.len() / 2];
        for w in slices.windows(2) {
            let gap = w[1].along - w[0].along;
            if gap < 1e-3 {
                return Err(ctx.bad(format!(
                    "{} and {} are at the same position {:.3} mm along the slice normal (duplicate slice?)",
                    first_name(&w[0].path),
                    first_name(&w[1].path),
                    w[0].along
                )));
            }
            if (gap - median).abs() > 0.01 * median.max(1e-3) + 1e-3 {
                return Err(ctx.bad(format!(
                    "slices are not evenly spaced: {:.3} mm between positions {:.3} ({}) and {:.3} ({}) where the spacing is {:.3} mm; a slice is missing ({} slices would fill the gap)",
                    gap,
                    w[0].along,
                    first_name(&w[0].path),
                    w[1].along,
                    first_name(&w[1].path),
                    median,
                    (gap / median).round() as i64 - 1
                )));
            }
        }
        median
    } else {
        thickness.unwrap_or(1.0)
    };
    let dims = [cols, rows, n as u32];
    decode::sample_bytes(ctx, dims, isoforge::grid::DType::F32, limits)?;
    let origin = slices[0].position;
    let lattice = decode::lattice(ctx, dims, [pixel[1], pixel[0], spacing_z], origin, Some([row, col, normal]))?
        .with_space(Some(isoforge::grid::WorldSpace::Lps));
    // Pixels, rescaled.
    let plane = (rows * cols) as usize;
    let mut values: Vec<f64> = Vec::with_capacity(plane * n);
    let mut integral = true;
    for s in &slices {
        let sctx = Ctx::new(&s.path, "DICOM");
        let slope = number(&s.obj, tags::RESCALE_SLOPE).unwrap_or(1.0);
        let inter = number(&s.obj, tags::RESCALE_INTERCEPT).unwrap_or(0.0);
        integral &= slope.fract() == 0.0 && inter.fract() == 0.0;
        let px = s.obj.decode_pixel_data().map_err(|e| sctx.bad(format!("pixel data: {e}")))?;
        if px.samples_per_pixel() != 1 || px.number_of_frames() != 1 {
            return Err(sctx.unsupported(format!(
                "{} samples per pixel, {} frames: single-frame greyscale slices are supported",
                px.samples_per_pixel(),
                px.number_of_frames()
            )));
        }
        let bytes = px.frame_data(0).map_err(|e| sctx.bad(format!("pixel data: {e}")))?;
        let signed = matches!(px.pixel_representation(), dicom_pixeldata::PixelRepresentation::Signed);
        let stored: Vec<f64> = match (px.bits_allocated(), signed) {
            (8, false) => bytes.iter().map(|&b| b as f64).collect(),
            (8, true) => bytes.iter().map(|&b| b as i8 as f64).collect(),
            (16, false) => bytes.chunks_exact(2).map(|b| u16::from_ne_bytes([b[0], b[1]]) as f64).collect(),
            (16, true) => bytes.chunks_exact(2).map(|b| i16::from_ne_bytes([b[0], b[1]]) as f64).collect(),
            (32, false) => bytes.chunks_exact(4).map(|b| u32::from_ne_bytes([b[0], b[1], b[2], b[3]]) as f64).collect(),
            (32, true) => bytes.chunks_exact(4).map(|b| i32::from_ne_bytes([b[0], b[1], b[2], b[3]]) as f64).collect(),
            (b, _) => return Err(sctx.unsupported(format!("BitsAllocated {b}"))),
        };
        if stored.len() < plane {
            return Err(sctx.bad(format!("pixel data holds {} of the {plane} pixels", stored.len())));
        }
        values.extend(stored[..plane].iter().map(|v| v * slope + inter));
    }
    let fits_i16 = values.iter().all(|&v| (i16::MIN as f64..=i16::MAX as f64).contains(&v));
    let grid = if integral && fits_i16 {
        AnyGrid::I16(DenseGrid::new(lattice, values.iter().map(|&v| v as i16).collect()).map_err(|e| ctx.lib(e))?)
    } else {
        AnyGrid::F32(DenseGrid::new(lattice, values.iter().map(|&v| v as f32).collect()).map_err(|e| ctx.lib(e))?)
    };
    Ok(VolumeReader::decoded(ctx, grid))
}

/// Whether the file starts with the 128-byte preamble and "DICM".
fn has_dicom_magic(p: &Path) -> bool {
    use std::io::Read;
    let mut head = [0u8; 132];
    std::fs::File::open(p).and_then(|mut f| f.read_exact(&mut head)).is_ok() && &head[128..] == b"DICM"
}

fn first_name(p: &Path) -> String {
    p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
}

fn text(obj: &DefaultDicomObject, tag: Tag) -> Option<String> {
    obj.element_opt(tag)
        .ok()
        .flatten()
        .and_then(|e| e.to_str().ok())
        .map(|s| s.trim_end_matches('\0').trim().to_string())
}

fn number(obj: &DefaultDicomObject, tag: Tag) -> Option<f64> {
    obj.element_opt(tag).ok().flatten().and_then(|e| e.to_float64().ok()).filter(|v| v.is_finite())
}

fn uint(ctx: Ctx, obj: &DefaultDicomObject, tag: Tag, name: &str) -> Result<u32> {
    let e = obj.element_opt(tag).ok().flatten().ok_or_else(|| ctx.bad(format!("{name} is missing")))?;
    e.to_int::<u32>()
        .ok()
        .filter(|&v| v > 0)
        .ok_or_else(|| ctx.bad(format!("{name} {:?}: not a positive integer", e.to_str().unwrap_or_default())))
}

fn floats<const N: usize>(ctx: Ctx, obj: &DefaultDicomObject, tag: Tag, name: &str) -> Result<[f64; N]> {
    let e = obj.element_opt(tag).ok().flatten().ok_or_else(|| ctx.bad(format!("{name} is missing")))?;
    let v = e
        .to_multi_float64()
        .map_err(|_| ctx.bad(format!("{name} {:?}: not numbers", e.to_str().unwrap_or_default())))?;
    if v.len() != N || v.iter().any(|x| !x.is_finite()) {
        return Err(ctx.bad(format!("{name} {v:?}: expected {N} finite numbers")));
    }
    Ok(std::array::from_fn(|i| v[i]))
}
