//! NIfTI-1: first byte 0 = `.nii`, 1 = `.nii.gz` (the bytes as given: gzip or not), 2 = a
//! `.hdr` whose `.img` follows the split marker.
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    if let Some((variant, main, companion)) = common::split(data, 3) {
        match variant {
            0 => common::volume_file("nifti", "nii", main, None),
            1 => common::volume_file("nifti", "nii.gz", main, None),
            _ => common::volume_file("nifti", "hdr", main, Some(("f.img", companion))),
        }
    }
});
