//! Issue 10 (hardening 8): the streaming checker gives `topo::check`'s report, on meshes streamed
//! by the out-of-core walker and on arbitrary defective batches that keep the sink contract, in a
//! window bounded by two batches.

use isoforge::extract::{Decomposition, MarchingCubes, MarchingTetrahedra};
use isoforge::grid::{DenseGrid, Lattice};
use isoforge::mesh::{ExternalError, Mesh, MeshBatch, MeshSink, Normals};
use isoforge::topo::{self, CheckOptions, MeshReport, StreamCheck};
use isoforge::volume::{Iso, SlabSource};
use isoforge::walk::FlyingEdgesWalker;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};

fn config(cases: u32) -> Config {
    Config { cases, rng_seed: RngSeed::Fixed(0x1010_5eed), failure_persistence: None, ..Config::default() }
}

/// A grid served slab by slab.
struct GridSlabs<'a> {
    grid: &'a DenseGrid<f32>,
    k: usize,
}

impl SlabSource<f32> for GridSlabs<'_> {
    fn lattice(&self) -> &Lattice {
        self.grid.lattice()
    }
    fn read_slab(&mut self, out: &mut [f32]) -> Result<(), ExternalError> {
        let n = out.len();
        out.copy_from_slice(&self.grid.data()[self.k * n..(self.k + 1) * n]);
        self.k += 1;
        Ok(())
    }
}

/// Collects the batches into a mesh and feeds them to a streaming checker; notes the largest
/// three consecutive batches.
struct Both {
    mesh: Mesh,
    check: StreamCheck,
    last: [usize; 2],
    largest_run: usize,
}

impl Both {
    fn new(opts: &CheckOptions) -> Self {
        Both { mesh: Mesh::default(), check: StreamCheck::new(opts), last: [0; 2], largest_run: 0 }
    }
}

impl MeshSink for Both {
    fn push(&mut self, b: MeshBatch<'_>) -> Result<(), ExternalError> {
        self.mesh.positions.extend_from_slice(b.positions);
        self.mesh.normals.extend_from_slice(b.normals);
        self.mesh.triangles.extend_from_slice(b.triangles);
        let size = b.positions.len() + b.triangles.len();
        self.largest_run = self.largest_run.max(self.last[0] + self.last[1] + size);
        self.last = [self.last[1], size];
        MeshSink::push(&mut self.check, b)
    }
}

/// Asserts two reports are equal: every count, finding and example exactly, the area and volume
/// sums (whose rounding depends on the order of summation) to 1e-9 relative.
fn assert_same(stream: &MeshReport, whole: &MeshReport) {
    let close = |a: f64, b: f64, what: &str| {
        let scale = a.abs().max(b.abs()).max(1e-12);
        assert!((a - b).abs() <= 1e-9 * scale + 1e-9, "{what}: streamed {a} vs whole {b}");
    };
    close(stream.area, whole.area, "area");
    close(stream.volume, whole.volume, "volume");
    close(stream.min_angle_mean_deg, whole.min_angle_mean_deg, "mean smallest angle");
    assert_eq!(stream.components.len(), whole.components.len(), "components");
    for (a, b) in stream.components.iter().zip(&whole.components) {
        close(a.area, b.area, "component area");
        close(a.volume, b.volume, "component volume");
    }
    let mut s = stream.clone();
    s.area = whole.area;
    s.volume = whole.volume;
    s.min_angle_mean_deg = whole.min_angle_mean_deg;
    for (a, b) in s.components.iter_mut().zip(&whole.components) {
        a.area = b.area;
        a.volume = b.volume;
    }
    assert_eq!(&s, whole);
}

/// Random lattices of 2..=9 × 2..=6 × 2..=12 points, values from a small set (ties at iso).
fn lattices() -> impl Strategy<Value = ([u32; 3], Vec<f32>)> {
    [2u32..=9, 2u32..=6, 2u32..=12].prop_flat_map(|dims| {
        let n = (dims[0] * dims[1] * dims[2]) as usize;
        (Just(dims), prop::collection::vec(prop::sample::select(vec![-2.0f32, -1.0, -0.5, 0.0, 0.25, 1.0, 3.0]), n))
    })
}

proptest! {
    #![proptest_config(config(1000))]

    /// Open and closed surfaces (with or without an outside border), several components, in a
    /// placed, possibly mirrored lattice: the report of the streamed batches is `check`'s.
    #[test]
    fn issue_10_stream_check_equals_check_on_streamed_lattices(
        (dims, values) in lattices(),
        border in any::<bool>(),
        mirrored in any::<bool>(),
        iso in prop::sample::select(vec![-0.75f64, 0.0, 0.1, 0.5]),
    ) {
        let d = if border { dims.map(|d| d + 2) } else { dims };
        let inner = Lattice::new(dims).unwrap();
        let mut lattice = Lattice::with_geometry(d, [0.5, 1.25, 2.0], [-3.0, 10.0, 100.0]).unwrap();
        if mirrored {
            lattice = lattice.with_direction([[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]).unwrap();
        }
        let g = DenseGrid::from_fn(lattice.clone(), |p| {
            if !border {
                values[inner.linear(p)]
            } else if p.iter().zip(dims).all(|(&x, d)| x >= 1 && x <= d) {
                values[inner.linear([p[0] - 1, p[1] - 1, p[2] - 1])]
            } else {
                5.0
            }
        });
        let opts = CheckOptions { max_examples: 4, lattice: Some(lattice), ..CheckOptions::default() };
        // Counted batches (own and next batch's vertices) and batches made as the walk goes
        // (own and previous batch's vertices).
        for tetrahedra in [false, true] {
            let mut both = Both::new(&opts);
            let walker = FlyingEdgesWalker::new();
            let src = &mut GridSlabs { grid: &g, k: 0 };
            if tetrahedra {
                let x = MarchingTetrahedra { decomposition: Decomposition::Six };
                walker.stream(src, Iso::below(iso), &x, Normals::None, &mut both).unwrap();
            } else {
                walker.stream(src, Iso::below(iso), &MarchingCubes, Normals::None, &mut both).unwrap();
            }
            let whole = topo::check_with(&both.mesh, &opts);
            let window_bound = 7 * both.largest_run;
            let peak = both.check.peak_window();
            let stream = both.check.finish().unwrap();
            assert_same(&stream, &whole);
            if border {
                prop_assert!(stream.is_watertight(), "{stream:?}");
            }
            prop_assert!(peak <= window_bound, "window {peak} > 7 × largest three batches {}", window_bound / 7);
        }
    }
}

/// One batch: vertex positions and triangles.
type Batch = (Vec<[f32; 3]>, Vec<[u32; 3]>);

/// Batches of 0..=5 vertices at small integer positions (coincident and collinear corners give
/// zero-area triangles) and triangles on any vertex of the batch before, their own and the next (repeated
/// corners, duplicates, flips, edges with three faces, pinched vertices); the last batch may
/// also name vertices never sent. Both checkers must agree on all of it.
fn soups() -> impl Strategy<Value = Vec<Batch>> {
    prop::collection::vec((0usize..=5, 0usize..=6), 1..=12).prop_flat_map(|sizes| {
        let mut starts = vec![0usize];
        for (v, _) in &sizes {
            starts.push(starts.last().unwrap() + v);
        }
        let total = *starts.last().unwrap();
        let batches: Vec<_> = sizes
            .iter()
            .enumerate()
            .map(|(m, &(nv, nt))| {
                let lo = starts[m.saturating_sub(1)];
                let hi = if m + 1 < sizes.len() { starts[m + 2] } else { total + 2 };
                let positions =
                    prop::collection::vec(prop::array::uniform3(prop::sample::select(vec![0.0f32, 1.0, 2.0])), nv);
                let triangles = if hi > lo {
                    prop::collection::vec(prop::array::uniform3((lo as u32)..(hi as u32)), nt).boxed()
                } else {
                    Just(Vec::new()).boxed()
                };
                (positions, triangles)
            })
            .collect();
        batches
    })
}

proptest! {
    #![proptest_config(config(3000))]

    #[test]
    fn issue_10_stream_check_equals_check_on_defective_batches(batches in soups()) {
        let opts = CheckOptions { max_examples: 3, ..CheckOptions::default() };
        let mut both = Both::new(&opts);
        for (p, t) in &batches {
            MeshSink::push(&mut both, MeshBatch { positions: p, normals: &[], triangles: t, quads: &[] }).unwrap();
        }
        let whole = topo::check_with(&both.mesh, &opts);
        let stream = both.check.finish().unwrap();
        assert_same(&stream, &whole);
    }
}

#[test]
fn a_batch_that_breaks_the_contract_is_refused() {
    let mut s = StreamCheck::new(&CheckOptions::default());
    s.push(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], &[[0, 1, 2]]).unwrap();
    // The previous batch's vertices may be named.
    s.push(&[[0.0, 0.0, 1.0]], &[[0, 1, 3]]).unwrap();
    s.push(&[[1.0; 3]], &[[0, 3, 4]]).unwrap();
    // Batch 2's triangle names vertex 0 of batch 0, settled when batch 3 arrives.
    let e = s.push(&[[2.0; 3]], &[]).unwrap_err().to_string();
    assert!(e.contains("streamed triangle 2 uses vertex 0"), "{e}");

    // A triangle naming a vertex two batches ahead.
    let mut s = StreamCheck::new(&CheckOptions::default());
    s.push(&[[0.0; 3], [1.0, 0.0, 0.0]], &[[0, 1, 3]]).unwrap();
    let e = s.push(&[[0.0, 1.0, 0.0]], &[]).unwrap_err().to_string();
    assert!(e.contains("uses vertex 3"), "{e}");
}
