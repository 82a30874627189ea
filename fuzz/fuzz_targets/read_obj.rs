//! Arbitrary bytes as a OBJ mesh (first byte: unused variant selector, for one seed format).
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    if let Some((_, main, _)) = common::split(data, 1) {
        common::mesh_file("obj", "obj", main);
    }
});
