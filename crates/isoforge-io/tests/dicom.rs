//! DICOM series: a small CT series written by dicom-rs inside the test (known values), read back
//! through `read_volume(folder)`: Hounsfield units, spacing, slice order from positions (files
//! shuffled), orientation, and the rejection of mixed series, missing and duplicate slices.

use std::path::Path;

use dicom_core::{DataElement, PrimitiveValue, VR};
use dicom_dictionary_std::tags;
use dicom_object::{FileMetaTableBuilder, InMemDicomObject};
use isoforge::grid::AnyGrid;
use isoforge_io::{read_volume, Limits};

const COLS: u32 = 5;
const ROWS: u32 = 6;
const SPACING: f64 = 2.5;

/// Stored value of pixel (i, j) of slice k (HU = stored − 1024).
fn stored(i: u32, j: u32, k: u32) -> i16 {
    (100 * k + 10 * j + i) as i16 + 900
}

struct Series<'a> {
    uid: &'a str,
    row: [f64; 3],
    col: [f64; 3],
    origin: [f64; 3],
}

impl Series<'_> {
    fn normal(&self) -> [f64; 3] {
        let (r, c) = (self.row, self.col);
        [r[1] * c[2] - r[2] * c[1], r[2] * c[0] - r[0] * c[2], r[0] * c[1] - r[1] * c[0]]
    }

    /// Writes slice k as `dir/name`.
    fn write(&self, dir: &Path, name: &str, k: u32) {
        let n = self.normal();
        let pos: Vec<f64> = (0..3).map(|a| self.origin[a] + SPACING * k as f64 * n[a]).collect();
        self.write_at(dir, name, k, &pos, "0.8\\0.7");
    }

    /// Writes slice k (its pixels) as `dir/name` at ImagePositionPatient `pos` with PixelSpacing
    /// `pixel_spacing`.
    fn write_at(&self, dir: &Path, name: &str, k: u32, pos: &[f64], pixel_spacing: &str) {
        let ds = |v: &[f64]| v.iter().map(|x| format!("{x}")).collect::<Vec<_>>().join("\\");
        let mut obj = InMemDicomObject::new_empty();
        let mut put = |tag, vr, value: PrimitiveValue| {
            obj.put(DataElement::new(tag, vr, value));
        };
        let sop = format!("1.2.826.0.1.3680043.2.1125.{}.{k}", self.uid.len());
        put(tags::SOP_CLASS_UID, VR::UI, PrimitiveValue::from("1.2.840.10008.5.1.4.1.1.2"));
        put(tags::SOP_INSTANCE_UID, VR::UI, PrimitiveValue::from(format!("{sop}.{}", self.uid)));
        put(tags::SERIES_INSTANCE_UID, VR::UI, PrimitiveValue::from(self.uid));
        put(tags::MODALITY, VR::CS, PrimitiveValue::from("CT"));
        put(tags::INSTANCE_NUMBER, VR::IS, PrimitiveValue::from(format!("{}", 10 - k)));
        put(tags::ROWS, VR::US, PrimitiveValue::from(ROWS as u16));
        put(tags::COLUMNS, VR::US, PrimitiveValue::from(COLS as u16));
        put(tags::SAMPLES_PER_PIXEL, VR::US, PrimitiveValue::from(1u16));
        put(tags::PHOTOMETRIC_INTERPRETATION, VR::CS, PrimitiveValue::from("MONOCHROME2"));
        put(tags::BITS_ALLOCATED, VR::US, PrimitiveValue::from(16u16));
        put(tags::BITS_STORED, VR::US, PrimitiveValue::from(16u16));
        put(tags::HIGH_BIT, VR::US, PrimitiveValue::from(15u16));
        put(tags::PIXEL_REPRESENTATION, VR::US, PrimitiveValue::from(1u16));
        put(tags::PIXEL_SPACING, VR::DS, PrimitiveValue::from(pixel_spacing));
        put(tags::SLICE_THICKNESS, VR::DS, PrimitiveValue::from("2.5"));
        put(tags::IMAGE_POSITION_PATIENT, VR::DS, PrimitiveValue::from(ds(pos)));
        let iop: Vec<f64> = self.row.iter().chain(&self.col).copied().collect();
        put(tags::IMAGE_ORIENTATION_PATIENT, VR::DS, PrimitiveValue::from(ds(&iop)));
        put(tags::RESCALE_SLOPE, VR::DS, PrimitiveValue::from("1"));
        put(tags::RESCALE_INTERCEPT, VR::DS, PrimitiveValue::from("-1024"));
        let mut px = Vec::new();
        for j in 0..ROWS {
            for i in 0..COLS {
                px.extend_from_slice(&stored(i, j, k).to_le_bytes());
            }
        }
        put(tags::PIXEL_DATA, VR::OW, PrimitiveValue::from(px));
        let file = obj.with_meta(FileMetaTableBuilder::new().transfer_syntax("1.2.840.10008.1.2.1")).expect("meta");
        file.write_to_file(dir.join(name)).expect("write DICOM");
    }
}

const AXIAL: Series =
    Series { uid: "1.2.3.4.5", row: [1.0, 0.0, 0.0], col: [0.0, 1.0, 0.0], origin: [-20.0, 15.0, 100.0] };

#[test]
fn a_shuffled_series_reads_in_position_order_with_hounsfield_units() {
    for series in [
        AXIAL,
        // Oblique: rows along (0.6, 0.8, 0), columns along (0, 0, −1).
        Series { uid: "1.2.3.4.6", row: [0.6, 0.8, 0.0], col: [0.0, 0.0, -1.0], origin: [5.0, -7.0, 30.0] },
    ] {
        let dir = tempfile::tempdir().unwrap();
        // File names in an order unrelated to position; InstanceNumber runs backwards.
        for (name, k) in [("c.dcm", 2), ("a.dcm", 3), ("d.dcm", 0), ("b.dcm", 1)] {
            series.write(dir.path(), name, k);
        }
        std::fs::write(dir.path().join("README.txt"), "not DICOM").unwrap();
        let g = read_volume(dir.path(), &Limits::default()).unwrap();
        let AnyGrid::I16(g) = g else { panic!("CT in HU should read as i16, got {}", g.dtype()) };
        let l = g.lattice();
        assert_eq!(l.dims(), [COLS, ROWS, 4]);
        let s = l.spacing();
        assert!((s[0] - 0.7).abs() < 1e-9 && (s[1] - 0.8).abs() < 1e-9 && (s[2] - SPACING).abs() < 1e-6, "{s:?}");
        for k in 0..4 {
            for j in 0..ROWS {
                for i in 0..COLS {
                    assert_eq!(g.get([i, j, k]), stored(i, j, k) - 1024, "HU at ({i}, {j}, {k})");
                }
            }
        }
        // World = ImagePositionPatient + i·0.7·row + j·0.8·col + k·2.5·normal (LPS).
        let n = series.normal();
        for (i, j, k) in [(0, 0, 0), (4, 5, 3), (2, 1, 2)] {
            let want: Vec<f64> = (0..3)
                .map(|a| {
                    series.origin[a]
                        + 0.7 * i as f64 * series.row[a]
                        + 0.8 * j as f64 * series.col[a]
                        + SPACING * k as f64 * n[a]
                })
                .collect();
            let got = l.to_world([i as f64, j as f64, k as f64]);
            for a in 0..3 {
                assert!((got[a] - want[a]).abs() < 1e-6, "({i}, {j}, {k}): {got:?} vs {want:?}");
            }
        }
    }
}

#[test]
fn mixed_missing_and_duplicate_slices_are_refused() {
    let err = |dir: &Path| read_volume(dir, &Limits::default()).unwrap_err().to_string();
    // Two series in one folder: both UIDs named.
    let dir = tempfile::tempdir().unwrap();
    AXIAL.write(dir.path(), "1.dcm", 0);
    AXIAL.write(dir.path(), "2.dcm", 1);
    Series { uid: "9.9.9", ..AXIAL }.write(dir.path(), "3.dcm", 2);
    let e = err(dir.path());
    assert!(e.contains("2 series") && e.contains("1.2.3.4.5 (2 files)") && e.contains("9.9.9 (1 files)"), "{e}");
    // A missing slice: the gap is named, not interpolated.
    let dir = tempfile::tempdir().unwrap();
    for k in [0, 1, 3, 4] {
        AXIAL.write(dir.path(), &format!("{k}.dcm"), k);
    }
    let e = err(dir.path());
    assert!(
        e.contains("not evenly spaced")
            && e.contains("5.000 mm between positions 102.500")
            && e.contains("1 slices would fill"),
        "{e}"
    );
    // The same position twice.
    let dir = tempfile::tempdir().unwrap();
    AXIAL.write(dir.path(), "a.dcm", 0);
    AXIAL.write(dir.path(), "b.dcm", 1);
    AXIAL.write(dir.path(), "c.dcm", 1);
    assert!(err(dir.path()).contains("same position"), "{}", err(dir.path()));
    // No DICOM at all.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("x.txt"), "hello").unwrap();
    assert!(err(dir.path()).contains("no DICOM image"));
}

#[test]
fn truncated_slices_are_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    for k in 0..3 {
        AXIAL.write(dir.path(), &format!("{k}.dcm"), k);
    }
    let whole = std::fs::read(dir.path().join("1.dcm")).unwrap();
    // Every length past the preamble: an error naming the file or, where the cut leaves a
    // readable object without pixels, a refusal of the series; never a panic or a silent read.
    for len in (132..whole.len()).step_by(7) {
        std::fs::write(dir.path().join("1.dcm"), &whole[..len]).unwrap();
        match read_volume(dir.path(), &Limits::default()) {
            Err(e) => {
                let e = e.to_string();
                assert!(
                    e.contains("1.dcm") || e.contains("not evenly spaced") || e.contains("pixel"),
                    "cut at {len}: {e}"
                );
            }
            Ok(g) => panic!("cut at {len} of {}: read {:?}", whole.len(), g.lattice().dims()),
        }
    }
}

/// Issue 50: a gantry-tilted series (positions (0, 0.5k, k): 0.5 mm across the slice plane per
/// 1 mm slice) read as an untilted box. Refused, naming the tilt in degrees and mm per slice.
#[test]
fn issue_50_gantry_tilt_is_refused_naming_the_tilt() {
    let dir = tempfile::tempdir().unwrap();
    for k in 0..4 {
        AXIAL.write_at(dir.path(), &format!("{k}.dcm"), k, &[0.0, 0.5 * k as f64, k as f64], "1\\1");
    }
    let e = read_volume(dir.path(), &Limits::default()).unwrap_err().to_string();
    assert!(!e.contains('\n'), "not one line: {e}");
    assert!(
        e.contains("gantry tilt")
            && e.contains("0.500 mm across the slice plane per slice")
            && e.contains("26.57 degrees")
            && e.contains("0.dcm to 3.dcm"),
        "{e}"
    );
    // Positions rounded to a hundredth of a millimetre are not a tilt.
    let dir = tempfile::tempdir().unwrap();
    for k in 0..4 {
        AXIAL.write_at(dir.path(), &format!("{k}.dcm"), k, &[0.004 * (k % 2) as f64, 0.0, k as f64], "1\\1");
    }
    let g = read_volume(dir.path(), &Limits::default()).unwrap();
    assert_eq!(g.lattice().dims(), [COLS, ROWS, 4]);
}

/// Issue 50: one slice of PixelSpacing 2.0 among 1.0 was read with the first slice's spacing.
#[test]
fn issue_50_mixed_pixel_spacing_is_refused_naming_both_values_and_the_slice() {
    let dir = tempfile::tempdir().unwrap();
    for k in 0..4 {
        let spacing = if k == 2 { "2\\2" } else { "1\\1" };
        AXIAL.write_at(dir.path(), &format!("{k}.dcm"), k, &[0.0, 0.0, k as f64], spacing);
    }
    let e = read_volume(dir.path(), &Limits::default()).unwrap_err().to_string();
    assert!(!e.contains('\n'), "not one line: {e}");
    assert!(e.contains("2.dcm: PixelSpacing [2.0, 2.0] differs from [1.0, 1.0] of 0.dcm"), "{e}");
}

/// Issue 50: positions 0, 1, 4, 9, 16 said "-1 slices would fill the gap"; irregular spacing is
/// named as such with both spacings (a true gap still counts the missing slices).
#[test]
fn issue_50_irregular_spacing_is_not_called_a_missing_slice() {
    let dir = tempfile::tempdir().unwrap();
    for k in 0..5u32 {
        AXIAL.write_at(dir.path(), &format!("{k}.dcm"), k, &[0.0, 0.0, (k * k) as f64], "1\\1");
    }
    let e = read_volume(dir.path(), &Limits::default()).unwrap_err().to_string();
    assert!(
        e.contains(
            "irregularly spaced: 1.000 mm between positions 0.000 (0.dcm) and 1.000 (1.dcm), 5.000 mm elsewhere"
        ) && !e.contains("would fill"),
        "{e}"
    );
}
