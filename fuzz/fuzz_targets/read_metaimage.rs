//! MetaImage: first byte 0 = `.mha` (data inside), 1 = `.mhd` with `d.raw` after the split marker.
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    if let Some((variant, main, companion)) = common::split(data, 2) {
        match variant {
            0 => common::volume_file("metaimage", "mha", main, None),
            _ => common::volume_file("metaimage", "mhd", main, Some(("d.raw", companion))),
        }
    }
});
