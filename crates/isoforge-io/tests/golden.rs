//! Volumes written by independent libraries (pynrrd, nibabel, SimpleITK; see
//! testdata/make_volumes.py) must read back with the dims, world positions and values those
//! libraries report in each `.expect.json`.

use std::path::{Path, PathBuf};

use isoforge::topo;
use isoforge_io::{read_mesh, read_volume, Limits};

fn testdata() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../testdata")
}

#[test]
fn volumes_match_their_independent_writers() {
    let dir = testdata().join("volumes");
    let mut checked = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let expect_path = entry.unwrap().path();
        let Some(name) = expect_path.file_name().unwrap().to_str().unwrap().strip_suffix(".expect.json") else {
            continue;
        };
        let expect: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&expect_path).unwrap()).unwrap();
        let grid = read_volume(&dir.join(name), &Limits::default()).unwrap_or_else(|e| panic!("{name}: {e}"));
        let dims: Vec<u64> = expect["dims"].as_array().unwrap().iter().map(|d| d.as_u64().unwrap()).collect();
        assert_eq!(grid.lattice().dims().map(u64::from).to_vec(), dims, "{name}");
        for probe in expect["probes"].as_array().unwrap() {
            let ijk: Vec<u32> = probe["ijk"].as_array().unwrap().iter().map(|v| v.as_u64().unwrap() as u32).collect();
            let ijk = [ijk[0], ijk[1], ijk[2]];
            let world = grid.lattice().to_world(ijk.map(f64::from));
            for a in 0..3 {
                let w = probe["world"][a].as_f64().unwrap();
                assert!(
                    (world[a] - w).abs() < 1e-4 * (1.0 + w.abs()),
                    "{name}: point {ijk:?} at {world:?}, expected {}",
                    probe["world"]
                );
            }
            let v = probe["value"].as_f64().unwrap();
            assert!(
                (grid.get_f64(ijk) - v).abs() < 1e-6 * (1.0 + v.abs()),
                "{name}: value at {ijk:?} is {}, expected {v}",
                grid.get_f64(ijk)
            );
        }
        checked += 1;
    }
    assert!(checked >= 10, "only {checked} golden volumes found in {}", dir.display());
}

fn mesh(name: &str) -> isoforge::mesh::Mesh {
    read_mesh(&testdata().join("meshes").join(name), &Limits::default()).unwrap_or_else(|e| panic!("{name}: {e}"))
}

#[test]
fn golden_meshes_read_as_closed_solids() {
    for name in ["tetra_ascii.ply", "tetra_be_double.ply", "tetra.off", "tetra_ascii.stl", "cube_quads.obj"] {
        let m = mesh(name);
        let r = topo::check(&m);
        assert!(r.is_watertight(), "{name}: {r:?}");
        assert_eq!(r.genus(), Some(0), "{name}");
        let expected_volume = if name.starts_with("cube") { 1.0 } else { 1.0 / 6.0 };
        assert!((r.volume.abs() - expected_volume).abs() < 1e-9, "{name}: volume {}", r.volume);
    }
    assert_eq!(mesh("cube_quads.obj").num_triangles(), 12);
    assert_eq!(mesh("tetra_ascii.stl").num_vertices(), 4, "STL corners are joined");
}

#[test]
fn written_meshes_read_back_identically() {
    let b = isoforge::volume::catalog::parse("torus?n=20").unwrap();
    let m = isoforge::pipeline::extract_builtin(&b, b.iso, &Default::default(), None).unwrap().mesh;
    let dir = std::env::temp_dir().join(format!("isoforge-io-roundtrip-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    use isoforge_io::MeshFormat::*;
    for (file, format) in [("a.ply", Ply), ("b.ply", PlyAscii), ("c.obj", Obj), ("d.stl", Stl), ("e.off", Off)] {
        let p: &Path = &dir.join(file);
        isoforge_io::write_mesh(p, &m, format).unwrap();
        let back = read_mesh(p, &Limits::default()).unwrap();
        assert_eq!(back.num_triangles(), m.num_triangles(), "{file}");
        assert_eq!(back.canonical_triangles(), m.canonical_triangles(), "{file}: geometry or winding changed");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
