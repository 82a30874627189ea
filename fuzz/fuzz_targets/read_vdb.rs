//! OpenVDB: first byte 0 = the bytes in memory (`read_vdb_bytes`), 1 = through a file
//! (`read_vdb`, a buffered seekable read); the rest is the file (a `.vdb` has no companion, so
//! the split marker is not looked for: searching 50 kB inputs for it took half the time of a
//! run under libFuzzer's memcmp hooks). Besides "no panic": every grid read holds the
//! reader's promises (finite values, background and transform; leaves on multiples of 8; tiles
//! of size 8, 128 or 4096 on multiples of their size; the output within the limit).
#![no_main]

use std::path::Path;

use isoforge_io::read::vdb::{read_vdb, read_vdb_bytes, VdbFile, VdbLeaf, VdbLeaves, VdbTile};
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

/// Checks a float or double grid's leaves; their size in bytes.
fn check_leaves<T: Copy + Into<f64>>(leaves: &[VdbLeaf<T>]) -> u64 {
    for l in leaves {
        assert!(l.origin.iter().all(|c| c.rem_euclid(8) == 0), "leaf origin {:?}", l.origin);
        assert!(l.values.iter().all(|&v| v.into().is_finite()), "a non-finite value was accepted");
    }
    leaves.len() as u64 * (std::mem::size_of::<VdbLeaf<T>>() + 512 * std::mem::size_of::<T>()) as u64
}

fn check(file: &VdbFile) {
    assert!(!file.grids.is_empty(), "a file without grids was accepted");
    let mut bytes = 0u64;
    for g in &file.grids {
        assert!(g.background.is_finite(), "background {}", g.background);
        assert!(g.transform.matrix.iter().flatten().all(|v| v.is_finite()), "matrix {:?}", g.transform.matrix);
        for t in &g.tiles {
            assert!([8, 128, 4096].contains(&t.size), "tile size {}", t.size);
            assert!(t.origin.iter().all(|c| c.rem_euclid(t.size as i32) == 0), "tile at {:?}", t.origin);
            assert!(t.value.is_finite() && (t.active || t.value != g.background), "tile {t:?}");
        }
        bytes += g.tiles.len() as u64 * std::mem::size_of::<VdbTile>() as u64;
        bytes += match &g.leaves {
            VdbLeaves::Float(l) => check_leaves(l),
            VdbLeaves::Double(l) => check_leaves(l),
        };
        let _ = g.active_bounds();
    }
    assert!(bytes <= common::limits().max_bytes, "{bytes} bytes of output past the limit");
}

fuzz_target!(|data: &[u8]| {
    if let Some((&pick, main)) = data.split_first() {
        let r = if pick % 2 == 0 {
            read_vdb_bytes(Path::new("f.vdb"), main, &common::limits())
        } else {
            let path = common::scratch("vdb").join("f.vdb");
            if std::fs::write(&path, main).is_err() {
                return;
            }
            read_vdb(&path, &common::limits())
        };
        match r {
            Ok(file) => check(&file),
            Err(e) => {
                let msg = e.to_string();
                assert!(msg.contains("f.vdb: ") && !msg.contains('\n'), "message: {msg}");
            }
        }
    }
});
