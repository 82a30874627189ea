//! PolyMender's signed octree grids: first byte 0 = the bytes in memory (`read_sog_bytes`), 1 =
//! a file read as a volume (`read_volume`: the sign grid). Besides "no panic": a tree read holds
//! the reader's promises (vertices finite and in their cells, leaves at the finest level), writes
//! back to a file that reads as the same tree, and contours without a panic into a mesh whose
//! indices are in range.
#![no_main]

use std::path::Path;

use isoforge::extract::contour_octree;
use isoforge_io::read::sog::read_sog_bytes;
use isoforge_io::write::sog::write_sog;
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, main)) = data.split_first() else { return };
    if pick % 2 == 1 {
        common::volume_file("sog", "sog", main, None);
        return;
    }
    match read_sog_bytes(Path::new("f.sog"), main, &common::limits()) {
        Ok(tree) => {
            let h = tree.spacing();
            for l in tree.leaves() {
                assert!(l.ijk.iter().all(|&c| c < tree.dim()), "leaf {:?}", l.ijk);
                for a in 0..3 {
                    let t = (l.vertex[a] as f64 - tree.origin()[a] as f64) / h - l.ijk[a] as f64;
                    assert!(t.is_finite() && (-0.001..=1.001).contains(&t), "vertex {:?} of cell {:?}", l.vertex, l.ijk);
                }
            }
            let mut bytes = Vec::new();
            write_sog(&mut bytes, &tree).unwrap();
            let back = read_sog_bytes(Path::new("f.sog"), &bytes, &common::limits()).unwrap();
            assert!(back == tree, "written and read back, the tree differs");
            let out = contour_octree(&tree);
            let n = out.mesh.positions.len();
            assert!(out.mesh.quads.iter().flatten().all(|&v| (v as usize) < n), "index out of range");
        }
        Err(e) => {
            let msg = e.to_string();
            assert!(msg.starts_with("f.sog: ") && !msg.contains('\n'), "message: {msg}");
        }
    }
});
