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
//!   interpolated; unevenly spaced positions are refused as irregular. Every slice must share the
//!   first one's PixelSpacing, size and orientation.
//! - **Gantry tilt**: positions that drift across the slice plane (a tilted gantry shears the
//!   stack) are refused with the tilt in degrees and mm per slice: a lattice's axes are
//!   orthonormal, and an untilted box would misplace every slice.
//! - **Values**: stored values × RescaleSlope + RescaleIntercept (Hounsfield units for CT),
//!   as i16 when that is exact (integer slope and intercept, range fits), f32 otherwise.
//! - **World**: DICOM patient coordinates (LPS, millimetres): origin = the first slice's
//!   ImagePositionPatient, axis directions = row direction, column direction, normal.
//! - **Transfer syntaxes**: whatever dicom-pixeldata decodes in pure Rust (native little/big
//!   endian, deflate, JPEG baseline/lossless) and RLE Lossless (decoded here: dicom-pixeldata's
//!   RLE decoder panics on short segments); single-frame greyscale slices.
//! - **Bounded**: a file is parsed from memory (at most `max_bytes` + 1 MiB) through a guard
//!   that refuses any element declaring more bytes than remain (a 566-byte file cannot make the
//!   parser allocate 4 GiB); rows × columns × bits are checked against the limits before pixels
//!   are decoded, and a JPEG's own frame size must match them. Slices are read twice — headers
//!   first (kept small), then pixels one slice at a time straight into the volume — so memory is
//!   the volume plus one slice.

use std::cell::{Cell, RefCell};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::rc::Rc;

use dicom_core::header::DataElementHeader;
use dicom_core::value::PrimitiveValue;
use dicom_dictionary_std::tags;
use dicom_encoding::transfer_syntax::TransferSyntaxIndex;
use dicom_encoding::Codec;
use dicom_object::{DefaultDicomObject, FileMetaTable, InMemDicomObject, Tag};
use dicom_parser::stateful::decode::{Result as DecodeResult, StatefulDecode};
use dicom_parser::DynStatefulDecoder;
use dicom_pixeldata::PixelDecoder;
use dicom_transfer_syntax_registry::TransferSyntaxRegistry;
use isoforge::grid::{AnyGrid, DType, DenseGrid};

use super::decode;
use super::stream::VolumeReader;
use crate::error::{Ctx, Result};
use crate::limits::Limits;

/// Largest number of files looked at in one folder.
const MAX_FILES: usize = 100_000;

/// Room for a slice file's header beyond its pixels.
const HEADER_ALLOWANCE: u64 = 1 << 20;

/// What the series needs of one slice, read from its header (no pixels kept).
struct Slice {
    path: PathBuf,
    position: [f64; 3],
    orientation: [f64; 6],
    rows: u32,
    cols: u32,
    pixel: [f64; 2],
    thickness: Option<f64>,
    slope: f64,
    inter: f64,
    along: f64,
}

/// Largest relative difference between the PixelSpacing of two slices of one series.
const SPACING_TOLERANCE: f64 = 1e-4;

/// Largest sideways drift of a slice position (off the slice normal through the first slice),
/// as a fraction of the smaller pixel spacing: below it, no sample moves by a tenth of a pixel.
const TILT_TOLERANCE: f64 = 0.1;

/// Refuses a gantry-tilted series: slice positions that drift across the slice plane (the slices
/// are sheared, not stacked). A lattice's directions are orthonormal, so the only faithful reading
/// would be a resampling; reading it as a box would silently move every slice.
fn check_tilt(ctx: Ctx, slices: &[Slice], normal: [f64; 3], pixel: [f64; 2]) -> Result<()> {
    let len = normal.iter().map(|x| x * x).sum::<f64>().sqrt();
    let (Some(first), true) = (slices.first(), len > 0.5) else {
        return Ok(()); // a bad orientation is refused with the lattice
    };
    let unit = normal.map(|x| x / len);
    // The slice farthest off the normal through the first one.
    let drift = |s: &Slice| {
        let d: [f64; 3] = std::array::from_fn(|a| s.position[a] - first.position[a]);
        let along: f64 = (0..3).map(|a| d[a] * unit[a]).sum();
        let across = (0..3).map(|a| (d[a] - along * unit[a]).powi(2)).sum::<f64>().sqrt();
        (across, along)
    };
    let Some((i, (across, along))) = slices.iter().map(drift).enumerate().max_by(|a, b| a.1 .0.total_cmp(&b.1 .0))
    else {
        return Ok(());
    };
    if across <= TILT_TOLERANCE * pixel[0].min(pixel[1]) || i == 0 {
        return Ok(());
    }
    Err(ctx.bad(format!(
        "gantry tilt: ImagePositionPatient moves {:.3} mm across the slice plane per slice, a tilt of {:.2} degrees ({across:.3} mm from {} to {}); a tilted series is refused, not read as an untilted box (resample it first)",
        across / i as f64,
        across.atan2(along.abs()).to_degrees(),
        first_name(&first.path),
        first_name(&slices[i].path),
    )))
}

/// Opens the DICOM series in folder `dir`.
///
/// # Errors
/// [`Error::Read`](crate::Error::Read) for an empty folder, mixed series, slices that disagree on
/// size, orientation or spacing, missing or duplicate slices (positions named), damaged files or
/// undecodable pixel data (the file named); [`Error::Limit`](crate::Error::Limit) when the
/// volume (or one file) exceeds `limits`.
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
    // PASS 1: headers.
    let mut slices: Vec<Slice> = Vec::new();
    let mut series: Vec<(String, usize)> = Vec::new();
    for path in files {
        let fctx = Ctx::new(&path, "DICOM");
        let Some(obj) = read_object(fctx, &path, limits)? else { continue }; // not DICOM: skipped
        if obj.element_opt(tags::PIXEL_DATA).ok().flatten().is_none() {
            // Image storage SOP classes (1.2.840.10008.5.1.4.1.1.*) must carry pixels; others
            // (DICOMDIR, reports, presentation states) are skipped.
            let class = obj.meta().media_storage_sop_class_uid().trim_end_matches('\0').to_string();
            if class.starts_with("1.2.840.10008.5.1.4.1.1.") || obj.element_opt(tags::ROWS).ok().flatten().is_some() {
                // An image whose pixels are gone (a cut file) must not silently drop a slice.
                return Err(fctx.bad("an image without PixelData (truncated file?)"));
            }
            continue; // DICOMDIR, structured reports, …
        }
        let uid = text(&obj, tags::SERIES_INSTANCE_UID).unwrap_or_default();
        match series.iter_mut().find(|(u, _)| *u == uid) {
            Some((_, n)) => *n += 1,
            None => series.push((uid, 1)),
        }
        let slice = Slice {
            position: floats::<3>(fctx, &obj, tags::IMAGE_POSITION_PATIENT, "ImagePositionPatient")?,
            orientation: floats::<6>(fctx, &obj, tags::IMAGE_ORIENTATION_PATIENT, "ImageOrientationPatient")?,
            rows: uint(fctx, &obj, tags::ROWS, "Rows")?,
            cols: uint(fctx, &obj, tags::COLUMNS, "Columns")?,
            pixel: floats::<2>(fctx, &obj, tags::PIXEL_SPACING, "PixelSpacing")?,
            thickness: text(&obj, tags::SLICE_THICKNESS).and_then(|t| t.trim().parse().ok()).filter(|v: &f64| *v > 0.0),
            slope: number(&obj, tags::RESCALE_SLOPE).unwrap_or(1.0),
            inter: number(&obj, tags::RESCALE_INTERCEPT).unwrap_or(0.0),
            along: 0.0,
            path,
        };
        slices.push(slice);
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
    let (iop, pixel, rows, cols, thickness) = (first.orientation, first.pixel, first.rows, first.cols, first.thickness);
    if let Some(p) = pixel.iter().find(|p| !(**p > 0.0)) {
        return Err(fctx.bad(format!("PixelSpacing {pixel:?}: {p} is not a positive distance")));
    }
    let row = [iop[0], iop[1], iop[2]];
    let col = [iop[3], iop[4], iop[5]];
    let normal =
        [row[1] * col[2] - row[2] * col[1], row[2] * col[0] - row[0] * col[2], row[0] * col[1] - row[1] * col[0]];
    for s in &mut slices {
        s.along = (0..3).map(|a| s.position[a] * normal[a]).sum();
        let sctx = Ctx::new(&s.path, "DICOM");
        if s.orientation.iter().zip(&iop).any(|(a, b)| (a - b).abs() > 1e-4) {
            return Err(sctx.bad(format!(
                "ImageOrientationPatient {:?} differs from {iop:?} of {}",
                s.orientation,
                first_name(&first_path)
            )));
        }
        if s.pixel.iter().zip(&pixel).any(|(a, b)| (a - b).abs() > SPACING_TOLERANCE * b.abs()) {
            return Err(sctx.bad(format!(
                "PixelSpacing {:?} differs from {pixel:?} of {}: a series has one pixel size",
                s.pixel,
                first_name(&first_path)
            )));
        }
        if (s.rows, s.cols) != (rows, cols) {
            return Err(
                sctx.bad(format!("{} x {} pixels, the series' first slice has {cols} x {rows}", s.cols, s.rows))
            );
        }
    }
    slices.sort_by(|a, b| a.along.total_cmp(&b.along));
    check_tilt(ctx, &slices, normal, pixel)?;
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
            let off = |want: f64| (gap - want).abs() > 0.01 * want.max(1e-3) + 1e-3;
            if off(median) {
                let between = format!(
                    "{gap:.3} mm between positions {:.3} ({}) and {:.3} ({})",
                    w[0].along,
                    first_name(&w[0].path),
                    w[1].along,
                    first_name(&w[1].path),
                );
                // A whole multiple of the spacing is a gap; anything else is irregular spacing.
                let multiple = (gap / median).round();
                if multiple >= 2.0 && !off(multiple * median) {
                    return Err(ctx.bad(format!(
                        "slices are not evenly spaced: {between} where the spacing is {median:.3} mm; a slice is missing ({} slices would fill the gap)",
                        multiple - 1.0
                    )));
                }
                return Err(ctx.bad(format!(
                    "slices are irregularly spaced: {between}, {median:.3} mm elsewhere (the median spacing); a lattice needs one spacing"
                )));
            }
        }
        median
    } else {
        thickness.unwrap_or(1.0)
    };
    let dims = [cols, rows, n as u32];
    // Integral rescaling may give i16 (2 bytes a sample); the limit is checked for f32 (4).
    decode::sample_bytes(ctx, dims, DType::F32, limits)?;
    let origin = slices[0].position;
    let lattice = decode::lattice(
        ctx,
        "PixelSpacing, ImagePositionPatient, ImageOrientationPatient",
        dims,
        [pixel[1], pixel[0], spacing_z],
        origin,
        Some([row, col, normal]),
    )?
    .with_space(Some(isoforge::grid::WorldSpace::Lps));
    // PASS 2: pixels, one slice at a time, rescaled straight into the volume.
    let plane = rows as usize * cols as usize;
    let integral = slices.iter().all(|s| s.slope.fract() == 0.0 && s.inter.fract() == 0.0);
    let mut values = Values::new(integral, plane * n);
    for s in &slices {
        let sctx = Ctx::new(&s.path, "DICOM");
        let obj = read_object(sctx, &s.path, limits)?.ok_or_else(|| sctx.bad("no longer a DICOM file"))?;
        check_pixels(sctx, &obj, s, limits)?;
        let (bytes, bits, signed) = pixels(sctx, &obj, s)?;
        let size = (bits as usize).div_ceil(8).max(1);
        if bytes.len() < plane * size {
            return Err(sctx.bad(format!("pixel data holds {} of the {plane} pixels", bytes.len() / size)));
        }
        let rescale = |v: f64| v * s.slope + s.inter;
        let samples = &bytes[..plane * size];
        match (bits, signed) {
            (8, false) => samples.iter().for_each(|&b| values.push(rescale(b as f64))),
            (8, true) => samples.iter().for_each(|&b| values.push(rescale(b as i8 as f64))),
            (16, false) => {
                samples.chunks_exact(2).for_each(|b| values.push(rescale(u16::from_ne_bytes([b[0], b[1]]) as f64)))
            }
            (16, true) => {
                samples.chunks_exact(2).for_each(|b| values.push(rescale(i16::from_ne_bytes([b[0], b[1]]) as f64)))
            }
            (32, false) => samples
                .chunks_exact(4)
                .for_each(|b| values.push(rescale(u32::from_ne_bytes([b[0], b[1], b[2], b[3]]) as f64))),
            (32, true) => samples
                .chunks_exact(4)
                .for_each(|b| values.push(rescale(i32::from_ne_bytes([b[0], b[1], b[2], b[3]]) as f64))),
            (b, _) => return Err(sctx.unsupported(format!("BitsAllocated {b}"))),
        }
    }
    let grid = match values {
        Values::I16(v) => AnyGrid::I16(DenseGrid::new(lattice, v).map_err(|e| ctx.lib(e))?),
        Values::F32(v) => AnyGrid::F32(DenseGrid::new(lattice, v).map_err(|e| ctx.lib(e))?),
    };
    Ok(VolumeReader::decoded(ctx, grid))
}

/// Rescaled samples: i16 while every value is a whole number in its range (integral rescaling,
/// the usual CT case: 2 bytes a sample), switching to f32 at the first value that is not.
enum Values {
    I16(Vec<i16>),
    F32(Vec<f32>),
}

impl Values {
    fn new(integral: bool, capacity: usize) -> Self {
        if integral {
            Values::I16(Vec::with_capacity(capacity))
        } else {
            Values::F32(Vec::with_capacity(capacity))
        }
    }

    fn push(&mut self, v: f64) {
        match self {
            Values::I16(d) if (i16::MIN as f64..=i16::MAX as f64).contains(&v) && v.fract() == 0.0 => d.push(v as i16),
            Values::I16(d) => {
                let mut f: Vec<f32> = Vec::with_capacity(d.capacity());
                f.extend(d.iter().map(|&x| x as f32));
                f.push(v as f32);
                *self = Values::F32(f);
            }
            Values::F32(d) => d.push(v as f32),
        }
    }
}

/// RLE Lossless: decoded here, not by dicom-pixeldata, whose decoder indexes past a segment
/// that decodes to fewer bytes than the image (found by the `read_dicom` fuzz target).
const RLE_LOSSLESS: &str = "1.2.840.10008.1.2.5";

/// The decoded samples of one single-frame greyscale slice (native byte order, as
/// dicom-pixeldata gives them), with bits allocated and signedness.
fn pixels(ctx: Ctx, obj: &DefaultDicomObject, s: &Slice) -> Result<(Vec<u8>, u16, bool)> {
    if obj.meta().transfer_syntax() == RLE_LOSSLESS {
        let bits = uint(ctx, obj, tags::BITS_ALLOCATED, "BitsAllocated")? as u16;
        let signed =
            obj.element_opt(tags::PIXEL_REPRESENTATION).ok().flatten().and_then(|e| e.to_int::<u16>().ok()) == Some(1);
        let fragments = obj
            .element(tags::PIXEL_DATA)
            .ok()
            .and_then(|e| e.value().fragments().map(|f| f.to_vec()))
            .ok_or_else(|| ctx.bad("RLE pixel data is not encapsulated"))?;
        let [frame] = fragments.as_slice() else {
            return Err(ctx.unsupported(format!("{} RLE frames: single-frame slices are supported", fragments.len())));
        };
        return Ok((decode_rle(ctx, frame, s.rows as usize * s.cols as usize, bits as usize / 8)?, bits, signed));
    }
    let px = obj.decode_pixel_data().map_err(|e| ctx.bad(format!("pixel data: {e}")))?;
    if px.samples_per_pixel() != 1 || px.number_of_frames() != 1 {
        return Err(ctx.unsupported(format!(
            "{} samples per pixel, {} frames: single-frame greyscale slices are supported",
            px.samples_per_pixel(),
            px.number_of_frames()
        )));
    }
    let bytes = px.frame_data(0).map_err(|e| ctx.bad(format!("pixel data: {e}")))?.to_vec();
    let signed = matches!(px.pixel_representation(), dicom_pixeldata::PixelRepresentation::Signed);
    Ok((bytes, px.bits_allocated(), signed))
}

/// One RLE Lossless frame (PS3.5 annex G) of `pixels` greyscale samples of `size` bytes: a
/// 64-byte header (segment count, 15 offsets), then one PackBits segment per byte of a sample,
/// most significant first. Every segment must decode to `pixels` bytes.
fn decode_rle(ctx: Ctx, frame: &[u8], pixels: usize, size: usize) -> Result<Vec<u8>> {
    let word = |i: usize| frame.get(4 * i..4 * i + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize);
    let count = word(0).ok_or_else(|| ctx.bad("RLE header: shorter than 64 bytes"))?;
    if count != size {
        return Err(ctx.bad(format!("RLE header: {count} segments, {size} expected (one per byte of a sample)")));
    }
    let mut out = vec![0u8; pixels * size];
    for seg in 0..size {
        let start = word(1 + seg).ok_or_else(|| ctx.bad("RLE header: shorter than 64 bytes"))?;
        let end = if seg + 1 < size { word(2 + seg).unwrap_or(frame.len()) } else { frame.len() };
        let data = frame
            .get(start..end)
            .ok_or_else(|| ctx.bad(format!("RLE segment {seg}: offsets {start}..{end} outside the frame")))?;
        // Segment `seg` holds byte `size - 1 - seg` of each sample (little-endian position).
        let byte = if cfg!(target_endian = "little") { size - 1 - seg } else { seg };
        let (mut i, mut n) = (0usize, 0usize);
        while n < pixels && i < data.len() {
            let h = data[i] as i8;
            i += 1;
            match h {
                0..=127 => {
                    let run = (h as usize + 1).min(pixels - n);
                    let lit = data
                        .get(i..i + run)
                        .ok_or_else(|| ctx.bad(format!("RLE segment {seg}: a literal run is cut short")))?;
                    for &b in lit {
                        out[n * size + byte] = b;
                        n += 1;
                    }
                    i += h as usize + 1;
                }
                -127..=-1 => {
                    let b =
                        *data.get(i).ok_or_else(|| ctx.bad(format!("RLE segment {seg}: a repeat run is cut short")))?;
                    i += 1;
                    for _ in 0..(1 - h as isize) as usize {
                        if n == pixels {
                            break;
                        }
                        out[n * size + byte] = b;
                        n += 1;
                    }
                }
                _ => {} // -128: no operation
            }
        }
        if n < pixels {
            return Err(ctx.bad(format!("RLE segment {seg} decodes to {n} of the {pixels} bytes")));
        }
    }
    Ok(out)
}

/// Checks what decoding the pixels of `obj` would produce before decoding: one frame, one
/// sample per pixel, the header's size (as in pass 1), within the limits; for JPEG, the
/// codestream's own frame size must agree (the decoder trusts it).
fn check_pixels(ctx: Ctx, obj: &DefaultDicomObject, s: &Slice, limits: &Limits) -> Result<()> {
    let (rows, cols) = (uint(ctx, obj, tags::ROWS, "Rows")?, uint(ctx, obj, tags::COLUMNS, "Columns")?);
    if (rows, cols) != (s.rows, s.cols) {
        return Err(ctx.bad(format!("Rows/Columns changed while reading ({cols} x {rows})")));
    }
    let frames = text(obj, tags::NUMBER_OF_FRAMES).map_or(Some(1), |t| t.parse::<u64>().ok()).unwrap_or(0);
    let spp = obj.element_opt(tags::SAMPLES_PER_PIXEL).ok().flatten().map_or(Some(1), |e| e.to_int::<u32>().ok());
    if frames != 1 || spp != Some(1) {
        return Err(ctx.unsupported(format!(
            "NumberOfFrames {frames}, SamplesPerPixel {}: single-frame greyscale slices are supported",
            spp.map_or("?".to_string(), |v| v.to_string())
        )));
    }
    let bits = uint(ctx, obj, tags::BITS_ALLOCATED, "BitsAllocated")?;
    if !matches!(bits, 8 | 16 | 32) {
        return Err(ctx.unsupported(format!("BitsAllocated {bits}: 8, 16 or 32 are supported")));
    }
    let bytes = rows as u64 * cols as u64 * (bits as u64 / 8);
    if bytes > limits.max_bytes {
        return Err(ctx.limit(format!("{cols} x {rows} pixels of {bits} bits"), bytes, limits.max_bytes));
    }
    let ts = obj.meta().transfer_syntax();
    if ts.starts_with("1.2.840.10008.1.2.4.5") || ts.starts_with("1.2.840.10008.1.2.4.7") {
        // JPEG baseline, extended, lossless: the frame header (SOF) of the first fragment.
        let Ok(pd) = obj.element(tags::PIXEL_DATA) else { return Ok(()) };
        let Some(fragments) = pd.value().fragments() else {
            return Err(ctx.bad("JPEG pixel data is not encapsulated"));
        };
        let first: Vec<u8> = fragments.iter().flat_map(|f| f.iter().copied()).take(1 << 20).collect();
        match jpeg_frame(&first) {
            Some((precision, h, w, comps)) if (h as u32, w as u32, comps) == (rows, cols, 1) && precision as u32 <= bits => {}
            Some((precision, h, w, comps)) => {
                return Err(ctx.bad(format!(
                    "the JPEG frame is {w} x {h} with {comps} components of {precision} bits; the header says {cols} x {rows}, 1 sample of {bits} bits"
                )))
            }
            None => return Err(ctx.bad("JPEG pixel data without a frame header (SOF)")),
        }
    }
    Ok(())
}

/// The first frame header of a JPEG codestream: precision, height, width, components.
fn jpeg_frame(b: &[u8]) -> Option<(u8, u16, u16, u8)> {
    let mut i = b.windows(2).position(|w| w == [0xFF, 0xD8])? + 2;
    while i + 4 <= b.len() {
        if b[i] != 0xFF {
            return None;
        }
        let marker = b[i + 1];
        if marker == 0xFF {
            i += 1; // fill byte
            continue;
        }
        let len = u16::from_be_bytes([b[i + 2], b[i + 3]]) as usize;
        // SOF0–SOF15 except DHT (C4), JPG (C8) and DAC (CC).
        if (0xC0..=0xCF).contains(&marker) && !matches!(marker, 0xC4 | 0xC8 | 0xCC) {
            let f = b.get(i + 4..i + 10)?;
            return Some((f[0], u16::from_be_bytes([f[1], f[2]]), u16::from_be_bytes([f[3], f[4]]), f[5]));
        }
        if marker == 0xDA || len < 2 {
            return None; // scan data before any frame header
        }
        i += 2 + len;
    }
    None
}

/// Reads and parses one file; `None` when it is not DICOM (no "DICM" magic at byte 128 or 0).
fn read_object(ctx: Ctx, path: &Path, limits: &Limits) -> Result<Option<DefaultDicomObject>> {
    let head = crate::file::read_prefix(ctx, path, 132)?;
    if head.get(128..132) != Some(b"DICM") && head.get(..4) != Some(b"DICM") {
        return Ok(None);
    }
    let bytes = crate::file::read_all(ctx, path, limits.max_bytes.saturating_add(HEADER_ALLOWANCE))?;
    parse(ctx, &bytes, limits).map(Some)
}

/// Parses a DICOM file held in memory, never letting the parser allocate more than remains.
fn parse(ctx: Ctx, bytes: &[u8], limits: &Limits) -> Result<DefaultDicomObject> {
    let damaged = |detail: &dyn std::fmt::Display| ctx.bad(format!("damaged DICOM file: {detail}"));
    let start = if bytes.get(128..132) == Some(b"DICM") { 128 } else { 0 };
    let mut rest = bytes.get(start..).unwrap_or_default();
    check_meta(rest.get(4..).unwrap_or_default()).map_err(|e| damaged(&e))?;
    let meta = FileMetaTable::from_reader(&mut rest).map_err(|e| damaged(&e))?;
    let uid = meta.transfer_syntax().to_string();
    let ts = TransferSyntaxRegistry
        .get(&uid)
        .ok_or_else(|| ctx.unsupported(format!("transfer syntax {uid} is not supported")))?;
    let guard = Rc::new(GuardState::default());
    let read = match ts.codec() {
        // Deflated data sets: the inflated stream may hold up to the limit.
        Codec::Dataset(Some(adapter)) => {
            read_guarded(adapter.adapt_reader(Box::new(rest)), ts, limits.max_bytes, guard.clone())
        }
        Codec::Dataset(None) => {
            return Err(ctx.unsupported(format!("transfer syntax {uid} ({}) is not supported", ts.name())))
        }
        _ => read_guarded(rest, ts, rest.len() as u64, guard.clone()),
    };
    let obj = read.map_err(|e| match guard.reason.borrow_mut().take() {
        Some(reason) => damaged(&reason),
        None => damaged(&e),
    })?;
    Ok(obj.with_exact_meta(meta))
}

fn read_guarded<'r>(
    r: impl Read + 'r,
    ts: &dicom_encoding::TransferSyntax,
    budget: u64,
    state: Rc<GuardState>,
) -> std::result::Result<InMemDicomObject, String> {
    let source: Box<dyn Read + 'r> = Box::new(Counted { inner: r.take(budget), state: state.clone() });
    let decoder = DynStatefulDecoder::new_with_ts(source, ts, 0).map_err(|e| e.to_string())?;
    InMemDicomObject::read_dataset(Guard { inner: decoder, state, budget }).map_err(|e| e.to_string())
}

/// Shared between the counted source and the guard.
#[derive(Default)]
struct GuardState {
    /// Bytes the decoder has taken from the source.
    consumed: Cell<u64>,
    /// Once set, the source fails every read: how the guard makes the decoder stop.
    poisoned: Cell<bool>,
    /// Why the guard stopped the decoder.
    reason: RefCell<Option<String>>,
}

/// The decoder's byte source: counts what is read, fails once poisoned.
struct Counted<R> {
    inner: R,
    state: Rc<GuardState>,
}

impl<R: Read> Read for Counted<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.state.poisoned.get() {
            return Err(std::io::Error::other("stopped by the length guard"));
        }
        let n = self.inner.read(buf)?;
        self.state.consumed.set(self.state.consumed.get() + n as u64);
        Ok(n)
    }
}

/// A decoder that refuses to read a value longer than the bytes that remain: the wrapped
/// decoder allocates a value's declared length before reading it.
struct Guard<D> {
    inner: D,
    state: Rc<GuardState>,
    budget: u64,
}

impl<D: StatefulDecode> Guard<D> {
    /// Ok when `len` bytes can still be read; otherwise an error from the (now failing) source.
    fn check(&mut self, tag: Option<Tag>, len: u32) -> DecodeResult<()> {
        let left = self.budget.saturating_sub(self.state.consumed.get());
        if len == u32::MAX || u64::from(len) <= left {
            return Ok(());
        }
        let what = tag.map_or("an item".to_string(), |t| format!("element ({:04X},{:04X})", t.0, t.1));
        *self.state.reason.borrow_mut() = Some(format!("{what} declares {len} bytes, only {left} remain"));
        self.state.poisoned.set(true);
        // Any read now fails: skipping a byte turns the poisoned source into the decoder's error
        // (the loop ends at its first turn).
        loop {
            self.inner.skip_bytes(1)?;
        }
    }
}

impl<D: StatefulDecode> StatefulDecode for Guard<D> {
    type Reader = D::Reader;

    // Headers are checked as soon as they are read: the data set reader reserves an item's
    // declared length (pixel fragments, the offset table: 4 bytes per declared byte) before it
    // asks for the value.
    fn decode_header(&mut self) -> DecodeResult<DataElementHeader> {
        let h = self.inner.decode_header()?;
        self.check(Some(h.tag), h.len.0)?;
        Ok(h)
    }
    fn decode_item_header(&mut self) -> DecodeResult<dicom_core::header::SequenceItemHeader> {
        let h = self.inner.decode_item_header()?;
        if let dicom_core::header::SequenceItemHeader::Item { len } = h {
            self.check(None, len.0)?;
        }
        Ok(h)
    }
    fn read_value(&mut self, header: &DataElementHeader) -> DecodeResult<PrimitiveValue> {
        self.check(Some(header.tag), header.len.0)?;
        self.inner.read_value(header)
    }
    fn read_value_preserved(&mut self, header: &DataElementHeader) -> DecodeResult<PrimitiveValue> {
        self.check(Some(header.tag), header.len.0)?;
        self.inner.read_value_preserved(header)
    }
    fn read_value_bytes(&mut self, header: &DataElementHeader) -> DecodeResult<PrimitiveValue> {
        self.check(Some(header.tag), header.len.0)?;
        self.inner.read_value_bytes(header)
    }
    fn read_to_vec(&mut self, length: u32, vec: &mut Vec<u8>) -> DecodeResult<()> {
        self.check(None, length)?;
        self.inner.read_to_vec(length, vec)
    }
    fn read_u32_to_vec(&mut self, length: u32, vec: &mut Vec<u32>) -> DecodeResult<()> {
        self.check(None, length)?;
        self.inner.read_u32_to_vec(length, vec)
    }
    fn read_to<W>(&mut self, length: u32, out: W) -> DecodeResult<()>
    where
        Self: Sized,
        W: std::io::Write,
    {
        self.check(None, length)?;
        self.inner.read_to(length, out)
    }
    fn skip_bytes(&mut self, length: u32) -> DecodeResult<()> {
        self.inner.skip_bytes(length)
    }
    fn seek(&mut self, position: u64) -> DecodeResult<()>
    where
        Self::Reader: std::io::Seek,
    {
        self.inner.seek(position)
    }
    fn position(&self) -> u64 {
        self.inner.position()
    }
}

/// Walks the file meta group (explicit VR little endian, after "DICM") as `FileMetaTable` will,
/// refusing an element that declares more bytes than the file has left (the meta parser
/// allocates declared lengths before reading).
fn check_meta(b: &[u8]) -> std::result::Result<(), String> {
    let u16_at = |i: usize| b.get(i..i + 2).map(|x| u16::from_le_bytes([x[0], x[1]]));
    let u32_at = |i: usize| b.get(i..i + 4).map(|x| u32::from_le_bytes([x[0], x[1], x[2], x[3]]));
    // (0002,0000) UL, length 4: the group length. FileMetaTable refuses anything else itself.
    let Some(group_length) = u32_at(8) else { return Ok(()) };
    let mut pos = 12usize;
    let mut read = 0u64;
    while read < group_length as u64 {
        let (Some(group), Some(element)) = (u16_at(pos), u16_at(pos + 2)) else { return Ok(()) };
        let (len, header) = if group == 0xFFFE {
            (u32_at(pos + 4), 8)
        } else {
            let short = matches!(
                b.get(pos + 4..pos + 6),
                Some(
                    b"AE"
                        | b"AS"
                        | b"AT"
                        | b"CS"
                        | b"DA"
                        | b"DS"
                        | b"DT"
                        | b"FL"
                        | b"FD"
                        | b"IS"
                        | b"LO"
                        | b"LT"
                        | b"PN"
                        | b"SH"
                        | b"SL"
                        | b"SS"
                        | b"ST"
                        | b"TM"
                        | b"UI"
                        | b"UL"
                        | b"US"
                )
            );
            if short {
                (u16_at(pos + 6).map(u32::from), 8)
            } else {
                (u32_at(pos + 8), 12)
            }
        };
        let Some(len) = len else { return Ok(()) };
        if len == u32::MAX {
            return Ok(()); // refused by FileMetaTable before any allocation
        }
        let left = b.len().saturating_sub(pos + header);
        if len as usize > left {
            return Err(format!(
                "file meta element ({group:04X},{element:04X}) declares {len} bytes, only {left} remain"
            ));
        }
        pos += header + len as usize;
        read += (header + len as usize) as u64;
    }
    Ok(())
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rle_segments_interleave_most_significant_first() {
        let ctx = Ctx::new(Path::new("x.dcm"), "DICOM");
        // Two 16-bit samples 0x0102 and 0x0304: segment 0 = [01, 03], segment 1 = [02, 04], as
        // a literal run and a repeat run.
        let mut frame = vec![0u8; 64];
        frame[0..4].copy_from_slice(&2u32.to_le_bytes());
        frame[4..8].copy_from_slice(&64u32.to_le_bytes());
        frame[8..12].copy_from_slice(&67u32.to_le_bytes());
        frame.extend_from_slice(&[1, 0x01, 0x03, 1, 0x02, 0x04]);
        let out = decode_rle(ctx, &frame, 2, 2).unwrap();
        let v: Vec<u16> = out.chunks_exact(2).map(|b| u16::from_ne_bytes([b[0], b[1]])).collect();
        assert_eq!(v, [0x0102, 0x0304]);
        // A repeat run (-1: twice) fills both; a segment one byte short is named.
        let mut short = frame[..64].to_vec();
        short[8..12].copy_from_slice(&66u32.to_le_bytes());
        short.extend_from_slice(&[0xFF, 0x07, 0, 0x09]);
        let e = decode_rle(ctx, &short, 2, 2).unwrap_err().to_string();
        assert!(e.contains("RLE segment 1 decodes to 1 of the 2 bytes"), "{e}");
        assert!(decode_rle(ctx, &frame[..10], 2, 2).is_err());
        assert!(decode_rle(ctx, &frame, 2, 1).unwrap_err().to_string().contains("2 segments, 1 expected"));
    }
}
