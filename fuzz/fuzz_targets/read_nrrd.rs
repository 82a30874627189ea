//! NRRD: first byte 0 = attached header (`f.nrrd`), 1 = detached (`f.nhdr`, its data file
//! `d.raw` after the split marker).
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    if let Some((variant, main, companion)) = common::split(data, 2) {
        match variant {
            0 => common::volume_file("nrrd", "nrrd", main, None),
            _ => common::volume_file("nrrd", "nhdr", main, Some(("d.raw", companion))),
        }
    }
});
