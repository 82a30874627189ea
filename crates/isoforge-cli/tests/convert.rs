//! `isoforge convert` between dense volumes and OpenVDB files (issue 44): a volume written as
//! .vdb meshes as the volume does, .vdb regions come back as dense volumes, bad requests exit 2
//! with one line and leave no file.

mod common;

use std::path::{Path, PathBuf};

use common::{fails, isoforge, p};

use isoforge::grid::AnyGrid;
use isoforge::mesh::Mesh;
use isoforge_io::Limits;

fn ok(args: &[&str]) {
    let o = isoforge(args);
    assert_eq!(o.status.code(), Some(0), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
}

fn volume(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../testdata/volumes").join(name)
}

/// The triangles of a mesh as position triples, each rotated to start at its smallest corner,
/// sorted: equal for the same surface whatever the vertex numbering.
fn triangle_soup(m: &Mesh) -> Vec<[[u32; 3]; 3]> {
    let pos = |v: u32| m.positions[v as usize].map(f32::to_bits);
    let mut out: Vec<[[u32; 3]; 3]> = m
        .triangles
        .iter()
        .map(|t| {
            let c = t.map(pos);
            let first = (0..3).min_by_key(|&i| c[i]).unwrap();
            [c[first], c[(first + 1) % 3], c[(first + 2) % 3]]
        })
        .collect();
    out.sort_unstable();
    out
}

fn mesh(path: &Path) -> Mesh {
    isoforge_io::read_mesh(path, &Limits::default()).unwrap()
}

#[test]
fn a_volume_written_as_vdb_meshes_as_the_volume_does() {
    let dir = tempfile::tempdir().unwrap();
    for (name, iso) in
        [("u8_raw.nrrd", "11"), ("i16_gzip.nrrd", "8.5"), ("f64_ascii.nrrd", "2.75"), ("f32_qform.nii.gz", "0.5")]
    {
        let vdb = dir.path().join(format!("{name}.vdb"));
        ok(&["convert", p(&volume(name)), p(&vdb), "--iso", iso]);
        // `info` describes what we wrote.
        let o = isoforge(&["info", p(&vdb)]);
        let info = String::from_utf8_lossy(&o.stdout);
        assert_eq!(o.status.code(), Some(0), "{info}");
        assert!(info.contains("grid:        density"), "{info}");
        // The .vdb read back has a border of background (outside): compare with --close.
        let (dense, sparse) = (dir.path().join(format!("{name}.d.ply")), dir.path().join(format!("{name}.s.ply")));
        ok(&["extract", "-i", p(&volume(name)), "--iso", iso, "--close", "-o", p(&dense)]);
        ok(&["extract", "-i", p(&vdb), "--iso", iso, "-o", p(&sparse)]);
        let (d, s) = (mesh(&dense), mesh(&sparse));
        assert!(!d.triangles.is_empty(), "{name}: no surface at iso {iso}");
        assert_eq!(d.triangles.len(), s.triangles.len(), "{name}");
        assert_eq!(triangle_soup(&d), triangle_soup(&s), "{name}: meshes differ");
    }
}

#[test]
fn a_vdb_region_comes_back_as_the_volumes_samples() {
    let dir = tempfile::tempdir().unwrap();
    let (vdb, whole, part) = (dir.path().join("v.vdb"), dir.path().join("whole.nrrd"), dir.path().join("part.nrrd"));
    let src = volume("f32_big.nrrd");
    ok(&["convert", p(&src), p(&vdb), "--iso", "2.5"]);
    // Default region: the active points, which are every point of the 6 × 5 × 7 volume.
    ok(&["convert", p(&vdb), p(&whole)]);
    ok(&["convert", p(&vdb), p(&part), "--region", "1:4,0:2,3:7"]);
    let read = |path: &Path| isoforge_io::read_volume(path, &Limits::default()).unwrap();
    let (orig, whole, part) = (read(&src), read(&whole), read(&part));
    let values = |g: &AnyGrid| -> Vec<f64> {
        isoforge::with_grid!(g, g => g.data().iter().map(|v| isoforge::grid::Sample::to_f64(*v)).collect())
    };
    assert_eq!(whole.lattice().dims(), orig.lattice().dims());
    assert_eq!(values(&whole), values(&orig));
    assert_eq!(whole.lattice().origin(), orig.lattice().origin());
    assert_eq!(whole.lattice().spacing(), orig.lattice().spacing());
    assert_eq!(part.lattice().dims(), [3, 2, 4]);
    let (od, ov, pv) = (orig.lattice().dims(), values(&orig), values(&part));
    for z in 0..4usize {
        for y in 0..2usize {
            for x in 0..3usize {
                let o = ((z + 3) * od[1] as usize + y) * od[0] as usize + x + 1;
                assert_eq!(pv[(z * 2 + y) * 3 + x], ov[o], "point {:?}", [x + 1, y, z + 3]);
            }
        }
    }
    let w = orig.lattice().to_world([1.0, 0.0, 3.0]);
    assert!((0..3).all(|a| (part.lattice().origin()[a] - w[a]).abs() < 1e-9), "{:?} vs {w:?}", part.lattice().origin());
}

#[test]
fn bad_regions_and_requests_are_refused_with_exit_2_and_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let vdb = dir.path().join("v.vdb");
    ok(&["convert", p(&volume("u8_raw.nrrd")), p(&vdb), "--iso", "11"]);
    let out = dir.path().join("out.nrrd");
    let run = |extra: &[&str], needle: &str| {
        let mut args = vec!["convert", p(&vdb), p(&out)];
        args.extend_from_slice(extra);
        fails(&args, needle, &out);
    };
    run(&["--region", "0:3,5:3,0:2"], "axis y: 5:3 holds no point");
    run(&["--region", "0:3,0:3"], "expected I0:I1,J0:J1,K0:K1");
    run(&["--region", "0:3,0:x,0:2"], "\"x\" is not an index");
    run(&["--region", "0:3,0:3,0:2000000000"], "over the limit");
    run(&["--region", "0:64,0:64,0:64", "--max-bytes", "1000"], "over the limit of 1000 bytes");
    run(&["--grid", "nope"], "no float or double grid named");
    let vdb_out = dir.path().join("o.vdb");
    fails(&["convert", p(&volume("u8_raw.nrrd")), p(&vdb_out)], "needs --iso", &vdb_out);
    fails(&["convert", p(&volume("u8_raw.nrrd")), p(&vdb_out), "--iso", "11", "--band", "1"], "--band 1", &vdb_out);
    fails(&["convert", p(&volume("u8_raw.nrrd")), p(&out), "--region", "0:1,0:1,0:1"], "--region applies", &out);
}
