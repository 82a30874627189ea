//! NRRD and NIfTI writers: every golden volume (written by pynrrd, nibabel, SimpleITK) read, written
//! back in each format and re-read gives the same samples, type and world geometry.

use std::path::PathBuf;

use isoforge::grid::AnyGrid;
use isoforge_io::{read_volume, write_volume, Limits};

fn volumes() -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../testdata/volumes");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            let n = p.to_string_lossy();
            !n.ends_with(".json") && !n.ends_with(".raw") && !n.ends_with(".py") && !n.ends_with(".img")
        })
        .collect();
    v.sort();
    v
}

fn samples(g: &AnyGrid) -> Vec<u64> {
    let [nx, ny, nz] = g.lattice().dims();
    let mut out = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                out.push(g.get_f64([i, j, k]).to_bits());
            }
        }
    }
    out
}

#[test]
fn written_volumes_read_back_identically() {
    let dir = tempfile::tempdir().unwrap();
    let list = volumes();
    assert!(list.len() >= 8, "golden volumes missing: {list:?}");
    for src in list {
        let a = read_volume(&src, &Limits::default()).unwrap_or_else(|e| panic!("{}: {e}", src.display()));
        for ext in ["nrrd", "nii", "nii.gz"] {
            let out = dir.path().join(format!("out.{ext}"));
            write_volume(&out, &a).unwrap();
            let b = read_volume(&out, &Limits::default()).unwrap();
            let what = format!("{} → .{ext}", src.display());
            assert_eq!(a.dtype(), b.dtype(), "{what}");
            assert_eq!(a.lattice().dims(), b.lattice().dims(), "{what}");
            assert_eq!(samples(&a), samples(&b), "{what}: samples differ");
            // World positions of the lattice corners: exact for NRRD (shortest round-trip text),
            // within f32 rounding for NIfTI (its header stores f32).
            // The same frame for both: NIfTI stores RAS, so LPS sources come back converted.
            let la = match (a.lattice().space(), b.lattice().space()) {
                (Some(x), Some(y)) if x != y => a.lattice().in_space(y).unwrap(),
                _ => a.lattice().clone(),
            };
            let d = a.lattice().dims().map(|n| (n - 1) as f64);
            let extent: f64 = (0..3).map(|k| d[k] * a.lattice().spacing()[k]).fold(1.0, f64::max);
            let tol = if ext == "nrrd" { 1e-12 } else { 1e-6 }
                * (extent + a.lattice().origin().iter().map(|o| o.abs()).fold(0.0, f64::max));
            for c in 0..8 {
                let p = [c & 1, (c >> 1) & 1, (c >> 2) & 1].map(|b| b as f64).map(|x| x);
                let p = [p[0] * d[0], p[1] * d[1], p[2] * d[2]];
                let (wa, wb) = (la.to_world(p), b.lattice().to_world(p));
                for k in 0..3 {
                    assert!((wa[k] - wb[k]).abs() <= tol, "{what}: corner {c}: {wa:?} vs {wb:?}");
                }
            }
            assert_eq!(a.lattice().is_mirrored(), b.lattice().is_mirrored(), "{what}: handedness");
        }
    }
}

#[test]
fn unsupported_targets_are_refused_without_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let src = volumes().into_iter().next().unwrap();
    let a = read_volume(&src, &Limits::default()).unwrap();
    for name in ["out.mha", "out.hdr", "out.png"] {
        let out = dir.path().join(name);
        let e = write_volume(&out, &a).unwrap_err().to_string();
        assert!(e.contains(name), "{e}");
        assert!(!out.exists());
    }
}

#[test]
fn a_folder_of_numbered_images_is_a_volume_in_number_order() {
    let images = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../testdata/images");
    let dir = tempfile::tempdir().unwrap();
    // 9 < 10 < 11 as numbers, not as text.
    for (name, src) in
        [("slice_9.png", "cthead_z50.png"), ("slice_10.png", "engine_z64.png"), ("slice_11.png", "cthead_z50.png")]
    {
        std::fs::copy(images.join(src), dir.path().join(name)).unwrap();
    }
    let g = read_volume(dir.path(), &Limits::default()).unwrap();
    assert_eq!(g.lattice().dims(), [256, 256, 3]);
    let engine = read_volume(&images.join("engine_z64.png"), &Limits::default()).unwrap();
    let cthead = read_volume(&images.join("cthead_z50.png"), &Limits::default()).unwrap();
    for (i, j) in [(0, 0), (100, 37), (255, 255), (128, 200)] {
        assert_eq!(g.get_f64([i, j, 0]), cthead.get_f64([i, j, 0]));
        assert_eq!(g.get_f64([i, j, 1]), engine.get_f64([i, j, 0]));
        assert_eq!(g.get_f64([i, j, 2]), cthead.get_f64([i, j, 0]));
    }
    // A missing number, and a slice of another size, are errors naming the files.
    std::fs::remove_file(dir.path().join("slice_10.png")).unwrap();
    let e = read_volume(dir.path(), &Limits::default()).unwrap_err().to_string();
    assert!(e.contains("jump from 9 (slice_9.png) to 11 (slice_11.png)"), "{e}");
    std::fs::copy(images.join("bunny_z180_u16.png"), dir.path().join("slice_10.png")).unwrap();
    let e = read_volume(dir.path(), &Limits::default()).unwrap_err().to_string();
    assert!(e.contains("slice_10.png") && e.contains("512 x 512 x 1 u16 differs"), "{e}");
}
