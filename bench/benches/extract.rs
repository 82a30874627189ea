//! Extraction throughput on fields like the peer harness's (sphere r 0.7, a gyroid with 4 periods
//! across the cube, three metaballs) on [-1, 1]³, sampled into f32 grids at 128³ and 256³.
//!
//! `cargo bench -p isoforge-bench` (never run by CI, which only builds it). Groups: every method
//! on the `flying_edges` walker (the grid path of `isoforge extract`, one thread), and classic MC
//! on the serial `slab_walker`, each with and without gradient normals. Throughput in lattice
//! points per second; the triangle count is in the benchmark id.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use isoforge::grid::{DenseGrid, Lattice};
use isoforge::mesh::MeshBuilder;
use isoforge::pipeline::{run, Method, Normals, Options};
use isoforge::volume::{GridVolume, Iso};
use isoforge::walk::{FlyingEdgesWalker, SlabWalker, Walker};

/// One extraction of `grid` with `opts` through `walker`; returns the triangle count.
fn once<W: Walker<GridVolume<'static, f32>>>(
    w: &mut W,
    vol: &GridVolume<'static, f32>,
    iso: Iso,
    opts: &Options,
) -> usize {
    let mut out = MeshBuilder::new(opts.normals);
    run(w, vol, iso, opts, &mut out).unwrap();
    out.finish().unwrap().num_triangles()
}

fn sample(n: u32, f: impl Fn(f32, f32, f32) -> f32) -> DenseGrid<f32> {
    let l = Lattice::spanning([n; 3], [-1.0; 3], [1.0; 3]).unwrap();
    let s = 2.0 / (n - 1) as f32;
    DenseGrid::from_fn(l, |[i, j, k]| f(-1.0 + i as f32 * s, -1.0 + j as f32 * s, -1.0 + k as f32 * s))
}

fn fields(n: u32) -> Vec<(&'static str, DenseGrid<f32>, f64)> {
    let tau = std::f32::consts::TAU;
    vec![
        ("sphere", sample(n, |x, y, z| (x * x + y * y + z * z).sqrt() - 0.7), 0.0),
        // 4 periods across the 2-unit cube.
        (
            "gyroid",
            sample(n, |x, y, z| {
                let (x, y, z) = (x * 2.0 * tau, y * 2.0 * tau, z * 2.0 * tau);
                x.sin() * y.cos() + y.sin() * z.cos() + z.sin() * x.cos()
            }),
            0.0,
        ),
        (
            "metaballs",
            sample(n, |x, y, z| {
                let c = [(-0.3f32, 0.0f32, 0.0f32, 1.0f32), (0.35, 0.2, 0.0, 0.8), (0.0, -0.3, 0.3, 0.6)];
                -c.iter()
                    .map(|&(a, b, d, q)| q / ((x - a).powi(2) + (y - b).powi(2) + (z - d).powi(2) + 1e-6))
                    .sum::<f32>()
            }),
            -12.0,
        ),
    ]
}

fn bench(c: &mut Criterion) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    for n in [128u32, 256] {
        for (name, grid, iso) in fields(n) {
            let grid: &'static DenseGrid<f32> = Box::leak(Box::new(grid));
            let vol = GridVolume::new(grid);
            let iso = Iso::below(iso);
            for (label, normals) in [("normals", Normals::Gradient), ("no-normals", Normals::None)] {
                let mut g = c.benchmark_group("extract");
                g.sample_size(10);
                g.throughput(Throughput::Elements(u64::from(n).pow(3)));
                for method in Method::ALL {
                    let opts = Options { method, normals, ..Default::default() };
                    let tris = pool.install(|| once(&mut FlyingEdgesWalker::new(), &vol, iso, &opts));
                    let id = BenchmarkId::new(
                        format!("flying_edges/{}/{name}-{n}-{label}", method.name()),
                        format!("{tris}tris"),
                    );
                    g.bench_function(id, |b| {
                        b.iter(|| pool.install(|| once(&mut FlyingEdgesWalker::new(), &vol, iso, &opts)))
                    });
                }
                let opts = Options { normals, ..Default::default() };
                let id = BenchmarkId::new(format!("slab_walker/mc/{name}-{n}-{label}"), "");
                g.bench_function(id, |b| b.iter(|| once(&mut SlabWalker::new(), &vol, iso, &opts)));
                g.finish();
            }
        }
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
