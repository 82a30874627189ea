//! A DICOM series: up to three slice files (split by the marker) in a folder read as a series.
//! The first byte is unused (variant selector).
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    let Some((_, body)) = data.split_first() else { return };
    let dir = common::scratch("dicom").join("series");
    let _ = std::fs::remove_dir_all(&dir);
    if std::fs::create_dir_all(&dir).is_err() {
        return;
    }
    let mut rest = body;
    for k in 0..3 {
        let (slice, next) = match rest.windows(common::SPLIT.len()).position(|w| w == common::SPLIT) {
            Some(at) => (&rest[..at], Some(&rest[at + common::SPLIT.len()..])),
            None => (rest, None),
        };
        if std::fs::write(dir.join(format!("s{k}.dcm")), slice).is_err() {
            return;
        }
        match next {
            Some(n) => rest = n,
            None => break,
        }
    }
    common::check_volume(&dir);
});
