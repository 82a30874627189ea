//! Raw samples: the first byte is unused (variant selector); the next 8 give the layout the
//! command line would (dims 1–16 per axis, sample type, byte order, header bytes, spacing
//! exponent), the rest is the file.
#![no_main]

use isoforge::grid::DType;
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

const TYPES: [DType; 8] =
    [DType::U8, DType::I8, DType::U16, DType::I16, DType::U32, DType::I32, DType::F32, DType::F64];

fuzz_target!(|data: &[u8]| {
    let Some((_, main, _)) = common::split(data, 1) else { return };
    let Some((layout, body)) = main.split_first_chunk::<8>() else { return };
    let dims = [layout[0], layout[1], layout[2]].map(|d| u32::from(d % 16) + 1);
    let mut spec = isoforge_io::RawSpec::new(dims, TYPES[layout[3] as usize % 8]);
    spec.big_endian = layout[4] & 1 == 1;
    spec.header_bytes = u64::from(layout[5] % 8);
    // Spacings from 2^-160 to 2^150: reaching past f32 must be refused, never meshed.
    spec.spacing = [1.0, 1.0, 2f64.powi(i32::from(layout[6]) - 160)];
    spec.origin = [f64::from(layout[7] as i8) * 1e37, 0.0, 0.0];
    let path = common::scratch("raw").join("f.raw");
    if std::fs::write(&path, body).is_ok() {
        if let Ok(grid) = isoforge_io::read::raw::read_raw(&path, &spec, &common::limits()) {
            let (lo, hi) = grid.lattice().world_bounds();
            assert!(lo.iter().chain(&hi).all(|x| x.is_finite() && x.abs() <= f32::MAX as f64));
            assert!(grid.first_non_finite().is_none());
        }
    }
});
