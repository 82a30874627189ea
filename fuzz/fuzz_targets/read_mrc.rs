//! Arbitrary bytes as a `.mrc` volume (first byte: unused variant selector).
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    if let Some((_, main, _)) = common::split(data, 1) {
        common::volume_file("mrc", "mrc", main, None);
    }
});
