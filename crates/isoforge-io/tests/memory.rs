//! Issue 10 item 3, measured: peak memory of reads against --max-bytes, and of a DICOM series
//! against the same volume as NRRD. Each read runs in a fresh child process (this test binary
//! run again), whose peak resident memory (VmHWM) above its resident memory before the read is
//! reported: nothing else allocates there, and no freed memory of an earlier read is reused.
#![cfg(target_os = "linux")]

use std::path::Path;

use dicom_core::{DataElement, PrimitiveValue, VR};
use dicom_dictionary_std::tags;
use isoforge::grid::{AnyGrid, DenseGrid, Lattice};
use isoforge_io::{read_volume, Limits};

fn status_kb(field: &str) -> u64 {
    let s = std::fs::read_to_string("/proc/self/status").unwrap();
    let line = s.lines().find(|l| l.starts_with(field)).unwrap();
    line.split_whitespace().nth(1).unwrap().parse().unwrap()
}

const CHILD: &str = "ISOFORGE_MEMORY_CHILD";
const TEST: &str = "issue_10_reads_stay_within_their_memory";

/// In the child: reads the volume, prints its peak memory above the start and the outcome.
fn child(path: &str) {
    let limit: u64 = std::env::var("ISOFORGE_MEMORY_LIMIT").unwrap().parse().unwrap();
    let before = status_kb("VmRSS:");
    let r = read_volume(Path::new(path), &Limits::new(limit));
    let peak = status_kb("VmHWM:").saturating_sub(before) * 1024;
    let outcome = match &r {
        Ok(g) => format!("ok {:?}", g.dtype()),
        Err(e) => format!("err {e}"),
    };
    println!("PEAK {peak} {outcome}");
}

/// Peak memory (bytes) of reading `path` with `limit`, in a fresh process, and the outcome.
fn peak_of(path: &Path, limit: u64) -> (u64, String) {
    let out = std::process::Command::new(std::env::current_exe().unwrap())
        .args(["--exact", TEST, "--nocapture", "--test-threads=1"])
        .env(CHILD, path)
        .env("ISOFORGE_MEMORY_LIMIT", limit.to_string())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let line =
        text.lines().find_map(|l| l.split_once("PEAK ").map(|(_, r)| r)).unwrap_or_else(|| panic!("child: {text}"));
    let (peak, outcome) = line.split_once(' ').unwrap();
    (peak.parse().unwrap(), outcome.to_string())
}

/// A CT-like series of `dims` i16 slices (stored = value + 1024, intercept −1024) in `dir`, and
/// the same volume as a raw NRRD `nrrd`.
fn write_series(dir: &Path, nrrd: &Path, dims: [u32; 3]) {
    let [nx, ny, nz] = dims;
    let value = |i: u32, j: u32, k: u32| ((i * 7 + j * 13 + k * 31) % 2000) as i16 - 1000;
    for k in 0..nz {
        let mut obj = dicom_object::InMemDicomObject::new_empty();
        let mut put = |tag, vr, value: PrimitiveValue| {
            obj.put(DataElement::new(tag, vr, value));
        };
        put(tags::SOP_CLASS_UID, VR::UI, PrimitiveValue::from("1.2.840.10008.5.1.4.1.1.2"));
        put(tags::SOP_INSTANCE_UID, VR::UI, PrimitiveValue::from(format!("1.2.3.4.5.{k}")));
        put(tags::SERIES_INSTANCE_UID, VR::UI, PrimitiveValue::from("1.2.3.4.5"));
        put(tags::ROWS, VR::US, PrimitiveValue::from(ny as u16));
        put(tags::COLUMNS, VR::US, PrimitiveValue::from(nx as u16));
        put(tags::SAMPLES_PER_PIXEL, VR::US, PrimitiveValue::from(1u16));
        put(tags::PHOTOMETRIC_INTERPRETATION, VR::CS, PrimitiveValue::from("MONOCHROME2"));
        put(tags::BITS_ALLOCATED, VR::US, PrimitiveValue::from(16u16));
        put(tags::BITS_STORED, VR::US, PrimitiveValue::from(16u16));
        put(tags::HIGH_BIT, VR::US, PrimitiveValue::from(15u16));
        put(tags::PIXEL_REPRESENTATION, VR::US, PrimitiveValue::from(0u16));
        put(tags::PIXEL_SPACING, VR::DS, PrimitiveValue::from("1\\1"));
        put(tags::IMAGE_POSITION_PATIENT, VR::DS, PrimitiveValue::from(format!("0\\0\\{k}")));
        put(tags::IMAGE_ORIENTATION_PATIENT, VR::DS, PrimitiveValue::from("1\\0\\0\\0\\1\\0"));
        put(tags::RESCALE_SLOPE, VR::DS, PrimitiveValue::from("1"));
        put(tags::RESCALE_INTERCEPT, VR::DS, PrimitiveValue::from("-1024"));
        let mut px = Vec::with_capacity((nx * ny * 2) as usize);
        for j in 0..ny {
            for i in 0..nx {
                px.extend_from_slice(&((value(i, j, k) + 1024) as u16).to_le_bytes());
            }
        }
        put(tags::PIXEL_DATA, VR::OW, PrimitiveValue::from(px));
        let file =
            obj.with_meta(dicom_object::FileMetaTableBuilder::new().transfer_syntax("1.2.840.10008.1.2.1")).unwrap();
        file.write_to_file(dir.join(format!("slice{k:04}.dcm"))).unwrap();
    }
    let mut data = Vec::with_capacity((nx * ny * nz) as usize);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                data.push(value(i, j, k));
            }
        }
    }
    let grid: AnyGrid = DenseGrid::new(Lattice::new(dims).unwrap(), data).unwrap().into();
    isoforge_io::write_volume(nrrd, &grid).unwrap();
}

#[test]
fn issue_10_reads_stay_within_their_memory() {
    if let Ok(path) = std::env::var(CHILD) {
        return child(&path);
    }
    let dir = tempfile::tempdir().unwrap();

    // A 566-byte DICOM slice declaring a 4 GiB pixel data element reached 4.2 GB with
    // --max-bytes 1M. Now the guard refuses the length first.
    let one = dir.path().join("one");
    std::fs::create_dir(&one).unwrap();
    write_series(&one, &dir.path().join("one.nrrd"), [2, 2, 1]);
    let slice = one.join("slice0000.dcm");
    let mut bytes = std::fs::read(&slice).unwrap();
    let at = bytes.windows(6).position(|w| w == [0xE0, 0x7F, 0x10, 0x00, b'O', b'W']).unwrap();
    bytes[at + 8..at + 12].copy_from_slice(&0xFFFF_FFFEu32.to_le_bytes());
    bytes.truncate(at + 16);
    std::fs::write(&slice, &bytes).unwrap();
    let (peak, e) = peak_of(&one, 1 << 20);
    assert!(e.starts_with("err ") && e.contains("declares 4294967294 bytes"), "{e}");
    println!("4 GiB pixel data element in a {}-byte file: peak {} KiB, {e}", bytes.len(), peak >> 10);
    assert!(peak < 32 << 20, "peak {peak} bytes");

    // A normal series needs about the memory of the same volume as NRRD (it needed 6 times it).
    let dims: [u32; 3] = match std::env::var("ISOFORGE_MEMORY_DIMS") {
        Ok(s) => {
            let v: Vec<u32> = s.split(',').map(|t| t.parse().unwrap()).collect();
            [v[0], v[1], v[2]]
        }
        Err(_) => [256, 256, 96],
    };
    let series = dir.path().join("series");
    std::fs::create_dir(&series).unwrap();
    let nrrd = dir.path().join("volume.nrrd");
    write_series(&series, &nrrd, dims);
    let (nrrd_peak, o1) = peak_of(&nrrd, Limits::DEFAULT_MAX_BYTES);
    let (dicom_peak, o2) = peak_of(&series, Limits::DEFAULT_MAX_BYTES);
    assert_eq!((o1.as_str(), o2.as_str()), ("ok I16", "ok I16"), "integral rescaling gives i16");
    let nrrd_bytes = dims.iter().map(|&d| d as u64).product::<u64>() * 2;
    let ratio = dicom_peak as f64 / nrrd_peak as f64;
    println!(
        "{}x{}x{} i16 ({} MiB): peak NRRD {} MiB, DICOM series {} MiB, ratio {ratio:.2}",
        dims[0],
        dims[1],
        dims[2],
        nrrd_bytes >> 20,
        nrrd_peak >> 20,
        dicom_peak >> 20
    );
    // The volume itself, plus about one slice of parsing and decoding.
    let slice_bytes = dims[0] as u64 * dims[1] as u64 * 2;
    assert!(dicom_peak <= nrrd_peak + nrrd_peak / 4 + 8 * slice_bytes + (2 << 20), "ratio {ratio:.2}");
}
