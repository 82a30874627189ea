//! Golden meshes of tiny volumes, stored as canonical text in `testdata/golden/`.
//!
//! `ISOFORGE_BLESS=1 cargo test --test golden` rewrites them; review the diff before committing.

mod common;

use std::fmt::Write as _;
use std::path::PathBuf;

use isoforge::grid::{DenseGrid, Lattice};
use isoforge::mesh::Mesh;
use isoforge::volume::{catalog, Iso};

/// Triangles as position triples (6 decimals), rotated to start at the smallest, sorted.
fn canonical_text(m: &Mesh) -> String {
    let mut tris: Vec<String> = m
        .triangles
        .iter()
        .map(|t| {
            let p: Vec<String> = t
                .iter()
                .map(|&v| {
                    let q = m.positions[v as usize];
                    format!("{:.6} {:.6} {:.6}", q[0], q[1], q[2])
                })
                .collect();
            let s = (0..3).min_by_key(|&i| &p[i]).unwrap();
            format!("{} | {} | {}", p[s], p[(s + 1) % 3], p[(s + 2) % 3])
        })
        .collect();
    tris.sort();
    let mut out = format!("# vertices {} triangles {}\n", m.num_vertices(), m.num_triangles());
    for t in tris {
        writeln!(out, "{t}").unwrap();
    }
    out
}

fn golden(name: &str, mesh: &Mesh) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../testdata/golden").join(format!("{name}.txt"));
    let actual = canonical_text(mesh);
    if std::env::var_os("ISOFORGE_BLESS").is_some() {
        std::fs::write(&path, &actual).unwrap();
        return;
    }
    let expected =
        std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e} (bless to create)", path.display()));
    if expected != actual {
        panic!("golden {name} differs\n--- expected ({})\n{expected}\n--- actual\n{actual}", path.display());
    }
}

#[test]
fn golden_integer_grid_5() {
    // A small u8 volume with a saddle, ties at iso and spacing/origin (world coordinates).
    let l = Lattice::with_geometry([5, 5, 5], [0.5, 1.0, 2.0], [10.0, -1.0, 0.0]).unwrap();
    let g = DenseGrid::from_fn(l, |[i, j, k]| ((i * 7 + j * 3 + k * 5 + i * j * k) % 9) as u8);
    let m = common::mc(&isoforge::volume::GridVolume::new(&g), Iso::below(4.0));
    golden("u8_5x5x5_iso4", &m);
}

#[test]
fn golden_torus_8() {
    // Classic MC (the golden predates mc33 as the default).
    let b = catalog::parse("torus?n=8").unwrap();
    let mc = isoforge::pipeline::Options { method: isoforge::pipeline::Method::MarchingCubes, ..Default::default() };
    let out = isoforge::pipeline::extract_builtin(&b, b.iso, &mc, None).unwrap();
    golden("torus_n8", &out.mesh);
}
