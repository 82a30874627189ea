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
            let d = a.lattice().dims().map(|n| (n - 1) as f64);
            let extent: f64 = (0..3).map(|k| d[k] * a.lattice().spacing()[k]).fold(1.0, f64::max);
            let tol = if ext == "nrrd" { 1e-12 } else { 1e-6 }
                * (extent + a.lattice().origin().iter().map(|o| o.abs()).fold(0.0, f64::max));
            for c in 0..8 {
                let p = [c & 1, (c >> 1) & 1, (c >> 2) & 1].map(|b| b as f64).map(|x| x);
                let p = [p[0] * d[0], p[1] * d[1], p[2] * d[2]];
                let (wa, wb) = (a.lattice().to_world(p), b.lattice().to_world(p));
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
