//! Inputs the fuzzers found (fuzz/README.md), replayed through the readers as the targets read
//! them. Each must fail cleanly, and — this binary counts allocations — no single allocation
//! may exceed what the input could justify: libFuzzer reports any allocation above its memory
//! limit as out-of-memory, even one that is never touched.

use std::path::{Path, PathBuf};

use isoforge_io::{read_volume, Limits};

mod largest;
use largest::largest_allocation;

const SPLIT: &[u8] = b"\n--ISOFORGE-FUZZ-SPLIT--\n";

fn artifact(target: &str, name: &str) -> Vec<u8> {
    std::fs::read(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../testdata/fuzz").join(target).join(name))
        .unwrap()
}

/// Lays out a `read_dicom` input as the target does: slice files split by the marker.
fn dicom_series(dir: &Path, input: &[u8]) -> PathBuf {
    let series = dir.join("series");
    std::fs::create_dir_all(&series).unwrap();
    let mut rest = &input[1..];
    for k in 0..3 {
        let (slice, next) = match rest.windows(SPLIT.len()).position(|w| w == SPLIT) {
            Some(at) => (&rest[..at], Some(&rest[at + SPLIT.len()..])),
            None => (rest, None),
        };
        std::fs::write(series.join(format!("s{k}.dcm")), slice).unwrap();
        match next {
            Some(n) => rest = n,
            None => break,
        }
    }
    series
}

/// Issue 10 item 10, read_dicom: an encapsulated pixel data item declaring 822 MB made
/// dicom-parser reserve its basic offset table (4 bytes per declared byte: 3.3 GB) before the
/// value was read; the guard now refuses an item header longer than the file left.
#[test]
fn issue_10_fuzz_dicom_item_lengths_are_refused_at_the_header() {
    let dir = tempfile::tempdir().unwrap();
    let series = dicom_series(dir.path(), &artifact("read_dicom", "oom-offset-table-reservation"));
    let (largest, r) = largest_allocation(|| read_volume(&series, &Limits::new(16 << 20)));
    let e = r.unwrap_err().to_string();
    assert!(e.contains("damaged DICOM file: an item declares"), "{e}");
    assert!(largest < 4 << 20, "largest allocation {largest} bytes");
}

/// Issue 10 item 10, read_dicom: an RLE slice whose Columns grew past its segment's bytes made
/// dicom-pixeldata's RLE decoder index out of bounds (a panic); RLE is decoded here now and a
/// segment that ends early is an error naming it.
#[test]
fn issue_10_fuzz_dicom_rle_segment_shorter_than_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let series = dicom_series(dir.path(), &artifact("read_dicom", "crash-rle-segment-shorter-than-image"));
    let e = read_volume(&series, &Limits::new(16 << 20)).unwrap_err().to_string();
    assert!(e.contains("s0.dcm: RLE segment 0"), "{e}");
}

/// Issue 44, read_vdb: a grid type holding newlines and 5 KB of other bytes was put into the
/// message as it was; names and types from the file are now quoted (escaped) and cut.
#[test]
fn issue_44_fuzz_vdb_names_in_messages_stay_on_one_line() {
    let data = artifact("read_vdb", "crash-control-characters-in-type-name");
    let e = isoforge_io::read::vdb::read_vdb_bytes(Path::new("f.vdb"), &data[1..], &Limits::new(16 << 20))
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("f.vdb: ") && !e.contains('\n') && e.len() < 400, "{e}");
    assert!(e.contains(r#"type "\0Tree_float_5_4_3"#), "{e}");
}
