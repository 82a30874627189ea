//! Voxelization throughput (issue 46): a torus meshed at 96³ (about 37k triangles), voxelized at
//! 64, 128 and 256 cells along its longest side, clean and with 10 % of its faces removed and
//! 10 % flipped (the winding numbers then decide more points one by one).
//!
//! `cargo bench -p isoforge-bench --bench voxelize` (never run by CI, which only type-checks it).
//! Whole-command timings against OpenVDB's `meshToVolume` live in `bench/peers`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use isoforge::grid::Lattice;
use isoforge::math::Vec3;
use isoforge::mesh::Mesh;
use isoforge::pipeline::{self, Options};
use isoforge::volume::{Iso, Sampled};
use isoforge::voxelize::{self, Resolution, VoxelizeOptions};

fn torus() -> Mesh {
    let lattice = Lattice::spanning([96; 3], [-1.2; 3], [1.2; 3]).unwrap();
    let f = |p: Vec3| {
        let q = ((p.x * p.x + p.y * p.y).sqrt() - 0.7, p.z);
        (q.0 * q.0 + q.1 * q.1).sqrt() - 0.3
    };
    pipeline::extract(&Sampled::new(f, lattice), Iso::below(0.0), &Options::default()).unwrap().mesh
}

/// Every tenth face removed and every tenth (offset by five) reversed.
fn damaged(m: &Mesh) -> Mesh {
    let triangles = m
        .triangles
        .iter()
        .enumerate()
        .filter(|(i, _)| i % 10 != 0)
        .map(|(i, t)| if i % 10 == 5 { [t[0], t[2], t[1]] } else { *t })
        .collect();
    Mesh { positions: m.positions.clone(), triangles, ..Mesh::default() }
}

fn bench(c: &mut Criterion) {
    let clean = torus();
    let broken = damaged(&clean);
    let mut g = c.benchmark_group("voxelize");
    g.sample_size(10);
    for cells in [64u32, 128, 256] {
        for (name, mesh) in [("clean", &clean), ("holes+flips", &broken)] {
            let lattice = voxelize::lattice_for(mesh, Resolution::Cells(cells), 4).unwrap();
            g.bench_with_input(BenchmarkId::new(name, cells), &lattice, |b, l| {
                b.iter(|| voxelize::voxelize(mesh, l.clone(), &VoxelizeOptions::default()).unwrap().grid.num_leaves())
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
