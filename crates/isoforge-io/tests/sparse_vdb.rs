//! Issue 44: OpenVDB files as sparse grids: every value pyopenvdb reported (testdata/vdb/*.json,
//! written by `make_vdb.py`) at the same world point, and level sets mesh closed and manifold.

use std::path::Path;

use isoforge::grid::AnySparse;
use isoforge::pipeline::{extract_sparse, Method, Options};
use isoforge::topo;
use isoforge::volume::Iso;
use isoforge_io::{read_sparse, Limits};

fn testdata(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../testdata/vdb").join(name)
}

/// The value of VDB index `ijk` in the grid (the background outside its lattice).
fn value(g: &AnySparse, ijk: [i64; 3]) -> Option<f64> {
    let o = g.index_origin();
    let p = [0, 1, 2].map(|a| ijk[a] - o[a] as i64);
    let dims = g.lattice().dims();
    if (0..3).any(|a| p[a] < 0 || p[a] >= dims[a] as i64) {
        return None;
    }
    let p = p.map(|v| v as u32);
    Some(match g {
        AnySparse::F32(g) => g.get(p) as f64,
        AnySparse::F64(g) => g.get(p),
    })
}

#[test]
fn vdb_grids_read_as_sparse_grids_hold_pyopenvdbs_values_where_it_put_them() {
    let mut files = 0;
    for entry in std::fs::read_dir(testdata("")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "vdb") {
            continue;
        }
        let oracle: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(path.with_extension("json")).unwrap()).unwrap();
        // Files pyopenvdb wrote for refusals (a frustum map) have no grids to compare.
        let Some(grids) = oracle["grids"].as_array() else { continue };
        for g in grids {
            let name = g["name"].as_str().unwrap();
            let Ok(file) = read_sparse(&path, Some(name), &Limits::new(1 << 30)) else {
                panic!("{}: grid {name} not read", path.display());
            };
            let grid = &file.grid;
            if let Some(n) = g["active_voxel_count"].as_u64() {
                assert_eq!(file.active_points, n, "{}: {name}", path.display());
            }
            for s in g["samples"].as_array().unwrap() {
                let ijk: Vec<i64> = s[0].as_array().unwrap().iter().map(|v| v.as_i64().unwrap()).collect();
                let want = s[1].as_f64().unwrap();
                let got = value(grid, [ijk[0], ijk[1], ijk[2]]).unwrap_or(g["background"].as_f64().unwrap());
                let tol = if g["type"] == "double" { 0.0 } else { 1e-7 * want.abs() };
                assert!((got - want).abs() <= tol, "{}: {name} at {ijk:?}: {got} vs {want}", path.display());
            }
            // World positions of index points: the lattice's, shifted by the index origin.
            let o = grid.index_origin();
            for pair in g["index_to_world"].as_array().unwrap() {
                let ijk: Vec<f64> = pair[0].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
                let want: Vec<f64> = pair[1].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
                let got = grid.lattice().to_world([0, 1, 2].map(|a| ijk[a] - o[a] as f64));
                for a in 0..3 {
                    assert!(
                        (got[a] - want[a]).abs() <= 1e-5 * (1.0 + want[a].abs()),
                        "{}: {name} world {got:?} vs {want:?}",
                        path.display()
                    );
                }
            }
            files += 1;
        }
    }
    assert!(files >= 10, "{files} grids checked");
}

#[test]
fn level_sets_from_openvdb_mesh_closed_and_manifold() {
    let file = read_sparse(&testdata("sphere.vdb"), None, &Limits::new(1 << 30)).unwrap();
    assert_eq!(file.class.as_deref(), Some("level set"));
    let AnySparse::F32(grid) = &file.grid else { panic!("a float grid") };
    for method in Method::ALL {
        let m = extract_sparse(grid, Iso::below(0.0), &Options { method, ..Options::default() }).unwrap().mesh;
        let r = topo::check(&m);
        assert!(r.triangles + r.quads > 0, "{}", method.name());
        assert!(r.is_closed(), "{}: {r:?}", method.name());
        if method.is_manifold() {
            assert_eq!(r.non_manifold_edges.count + r.non_manifold_vertices.count, 0, "{}", method.name());
        }
        assert_eq!(r.components.len(), 1, "{}", method.name());
    }
}
