//! Issue 11: one architecture. Every walker runs every method and they agree; the parallel walker
//! gives the same bytes for every thread count; cell ranges stitched by vertex key give exactly the
//! whole-lattice mesh; streamed equals in memory; and each widened `Cell` contract (Hermite data,
//! placed vertices and neighbours', quads, provenance keys, block bounds) does what it says.

mod common;

use common::*;
use isoforge::cube::{CellRange, CubeEdge, EdgeKey, VertexKey, CASE_EDGES};
use isoforge::extract::Extractor;
use isoforge::grid::{AnyGrid, BlockBounds, DenseGrid, Lattice};
use isoforge::mesh::{KeyRecord, Mesh, MeshBatch, MeshBuilder, MeshSink, Normals};
use isoforge::pipeline::{self, run, Method, Options};
use isoforge::topo;
use isoforge::volume::{GridVolume, Iso, SlabSource, Volume};
use isoforge::walk::{self, stitch, Cell, FlyingEdgesWalker, KeyedMesh, ReferenceWalker, SlabWalker, Walker};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};

fn config(cases: u32) -> Config {
    Config { cases, rng_seed: RngSeed::Fixed(0x11_a7c4), failure_persistence: None, ..Config::default() }
}

/// Random lattices with integer values 0..=4 (ties, plateaus, symmetric faces) and iso x.5 or an
/// integer (values exactly at iso), or smooth noise; one in four mirrored (i along −x: every walker
/// reverses its polygons to keep them counter-clockwise from outside).
fn lattices() -> impl Strategy<Value = (DenseGrid<f32>, Iso)> {
    ([2u32..=9, 2u32..=9, 2u32..=9], any::<u64>(), 0u8..4, 0u8..4).prop_map(|(dims, seed, iso_kind, mirror)| {
        let mut s = seed | 1;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        let mut lattice = Lattice::new(dims).unwrap();
        if mirror == 0 {
            lattice = lattice.with_direction([[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]).unwrap();
        }
        let g = DenseGrid::from_fn(lattice, |_| (next() % 5) as f32);
        let iso = match iso_kind {
            0 => Iso::below(1.5),
            1 => Iso::below(2.0),
            2 => Iso::above(2.5),
            _ => Iso::above(1.0),
        };
        (g, iso)
    })
}

fn walk_method<V, W: Walker<V>>(
    w: &mut W,
    vol: &V,
    iso: Iso,
    method: Method,
    normals: Normals,
) -> (Mesh, walk::WalkStats) {
    let opts = Options { method, normals, ..Default::default() };
    let mut out = MeshBuilder::new(normals);
    let stats = run(w, vol, iso, &opts, &mut out).expect("walk");
    (out.finish().expect("finish"), stats)
}

proptest! {
    #![proptest_config(config(300))]

    /// Every method on every walker: the Flying Edges walker (counted and stitched paths), the slab
    /// walker and the reference walker make the same vertices and polygons.
    #[test]
    fn every_walker_runs_every_method_alike((g, iso) in lattices()) {
        let vol = GridVolume::new(&g);
        for method in Method::ALL {
            let (a, sa) = walk_method(&mut FlyingEdgesWalker::new(), &vol, iso, method, Normals::Gradient);
            let (b, sb) = walk_method(&mut SlabWalker::new(), &vol, iso, method, Normals::Gradient);
            let (c, _) = walk_method(&mut ReferenceWalker, &vol, iso, method, Normals::Gradient);
            prop_assert_eq!(canonical(&a), canonical(&b), "{} flying edges vs slab", method.name());
            prop_assert_eq!(canonical(&b), canonical(&c), "{} slab vs reference", method.name());
            prop_assert_eq!(sa, sb, "{} stats", method.name());
            prop_assert_eq!(a.num_vertices(), b.num_vertices());
        }
    }

    /// Cell ranges that tile the lattice (sizes that do not divide it), each walked on a chunk of
    /// data holding only its halo points, stitched by key: exactly the whole-lattice mesh.
    #[test]
    fn chunks_with_halos_stitch_into_the_whole_mesh((g, iso) in lattices(), size in [1u32..=5, 1u32..=5, 1u32..=5]) {
        let dims = g.lattice().dims();
        let whole = GridVolume::new(&g);
        for method in Method::ALL {
            let (single, _) = walk_method(&mut FlyingEdgesWalker::new(), &whole, iso, method, Normals::Gradient);
            let mut parts = Vec::new();
            let mut slab_parts = Vec::new();
            for tile in CellRange::all(dims).tiles(size) {
                let (lo, hi) = tile.halo_points(dims);
                let chunk = DenseGrid::from_fn(Lattice::new([0, 1, 2].map(|a| hi[a] - lo[a])).unwrap(), |p| {
                    g.get([p[0] + lo[0], p[1] + lo[1], p[2] + lo[2]])
                });
                let vol = GridVolume::window(&chunk, lo, g.lattice().clone()).unwrap();
                let opts = Options { method, normals: Normals::Gradient, ..Default::default() };
                for (w, into) in [(0, &mut parts), (1, &mut slab_parts)] {
                    let mut out = MeshBuilder::new(Normals::Gradient).with_keys(KeyRecord::Boundary(tile));
                    if w == 0 {
                        run(&mut FlyingEdgesWalker::new().with_range(tile), &vol, iso, &opts, &mut out).unwrap();
                    } else {
                        run(&mut SlabWalker::new().with_range(tile), &vol, iso, &opts, &mut out).unwrap();
                    }
                    into.push(KeyedMesh::from_builder(out).unwrap());
                }
            }
            let stitched = stitch(&parts).unwrap();
            prop_assert_eq!(stitched.num_vertices(), single.num_vertices(), "{}: vertex count", method.name());
            prop_assert_eq!(canonical(&stitched), canonical(&single), "{}", method.name());
            prop_assert_eq!(canonical(&stitch(&slab_parts).unwrap()), canonical(&single), "{} (slab walker)", method.name());
        }
    }

    /// Streamed slab by slab equals in memory, array for array, for every method.
    #[test]
    fn streaming_equals_in_memory_for_every_method((g, iso) in lattices(), normals in any::<bool>()) {
        let normals = if normals { Normals::Gradient } else { Normals::None };
        for method in Method::ALL {
            let (a, sa) = walk_method(&mut FlyingEdgesWalker::new(), &GridVolume::new(&g), iso, method, normals);
            // One thread reads inline; two read ahead in a background thread (`Prefetch`).
            for threads in [1, 2] {
                let mut sink = Collect::default();
                let opts = Options { method, normals, threads: Some(threads), ..Default::default() };
                let s = pipeline::extract_streamed(&mut Slabs { grid: &g, k: 0 }, iso, &opts, &mut sink, None).unwrap();
                prop_assert_eq!(s.walk, sa, "{} threads {}", method.name(), threads);
                prop_assert_eq!(&sink.0, &a, "{} threads {}", method.name(), threads);
            }
        }
    }

    /// A mask wraps every method on every walker alike (the counted walk asks the masked
    /// extractor's counts cell by cell).
    #[test]
    fn masks_wrap_every_method_on_every_walker((g, iso) in lattices(), seed in any::<u64>()) {
        let dims = g.lattice().dims();
        let mut s = seed | 1;
        let flags: Vec<bool> = (0..g.lattice().num_points())
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                s % 5 != 0
            })
            .collect();
        let mask = std::sync::Arc::new(isoforge::extract::PointMask::new(dims, flags).unwrap());
        let vol = GridVolume::new(&g);
        for method in Method::ALL {
            let opts = Options { method, mask: Some(mask.clone()), ..Default::default() };
            let go = |w: &mut dyn FnMut(&mut MeshBuilder) -> isoforge::Result<walk::WalkStats>| {
                let mut out = MeshBuilder::new(Normals::None);
                w(&mut out).unwrap();
                out.finish().unwrap()
            };
            let a = go(&mut |o| run(&mut FlyingEdgesWalker::new(), &vol, iso, &opts, o));
            let b = go(&mut |o| run(&mut SlabWalker::new(), &vol, iso, &opts, o));
            let c = go(&mut |o| run(&mut ReferenceWalker, &vol, iso, &opts, o));
            prop_assert_eq!(canonical(&a), canonical(&b), "{} masked, flying edges vs slab", method.name());
            prop_assert_eq!(canonical(&b), canonical(&c), "{} masked, slab vs reference", method.name());
        }
    }

    /// Block bounds skip what cannot hold a crossing and change nothing else.
    #[test]
    fn block_bounds_change_nothing_but_the_work((g, iso) in lattices()) {
        let bounds = BlockBounds::of(&g);
        let with = GridVolume::new(&g).with_block_bounds(&bounds).unwrap();
        let without = GridVolume::new(&g);
        for method in [Method::MarchingCubes, Method::Tetrahedra6, Method::TetrahedraBcc] {
            for fe in [true, false] {
                let run2 = |v: &GridVolume<'_, f32>| if fe {
                    walk_method(&mut FlyingEdgesWalker::new(), v, iso, method, Normals::None)
                } else {
                    walk_method(&mut SlabWalker::new(), v, iso, method, Normals::None)
                };
                let ((a, sa), (b, sb)) = (run2(&with), run2(&without));
                prop_assert_eq!(&a, &b, "{} fe={}", method.name(), fe);
                prop_assert_eq!(sa, sb);
            }
        }
    }
}

/// A grid served slab by slab, in its own sample type.
struct Slabs<'a> {
    grid: &'a DenseGrid<f32>,
    k: usize,
}

impl<S: isoforge::grid::Sample> SlabSource<S> for Slabs<'_> {
    fn lattice(&self) -> &Lattice {
        self.grid.lattice()
    }
    fn read_slab(&mut self, out: &mut [S]) -> Result<(), isoforge::mesh::ExternalError> {
        let n = out.len();
        for (o, v) in out.iter_mut().zip(&self.grid.data()[self.k * n..(self.k + 1) * n]) {
            *o = S::from_f64(*v as f64);
        }
        self.k += 1;
        Ok(())
    }
}

impl pipeline::AnySlabSource for Slabs<'_> {
    fn dtype(&self) -> isoforge::grid::DType {
        isoforge::grid::DType::F32
    }
}

/// Collects a streamed mesh, checking the sink contract: a batch's polygons refer to vertices of
/// earlier batches, of itself, or of the next batch only.
#[derive(Default)]
struct Collect(Mesh, Option<u32>);

impl MeshSink for Collect {
    fn push(&mut self, b: MeshBatch<'_>) -> Result<(), isoforge::mesh::ExternalError> {
        let total = (self.0.positions.len() + b.positions.len()) as u32;
        if let Some(max) = self.1 {
            assert!(max < total, "a batch referred to vertex {max} beyond the next batch (ends at {total})");
        }
        let ids = b.triangles.iter().flatten().chain(b.quads.iter().flatten());
        self.1 = ids.copied().max();
        self.0.positions.extend_from_slice(b.positions);
        self.0.normals.extend_from_slice(b.normals);
        self.0.triangles.extend_from_slice(b.triangles);
        self.0.quads.extend_from_slice(b.quads);
        Ok(())
    }
}

/// A noisy, smooth test volume with several components and saddles.
fn noise(n: u32) -> DenseGrid<f32> {
    DenseGrid::from_fn(Lattice::spanning([n, n + 3, n - 2], [-1.0; 3], [1.0; 3]).unwrap(), |[i, j, k]| {
        let (x, y, z) = (i as f32 * 0.37, j as f32 * 0.29, k as f32 * 0.41);
        (x.sin() * y.cos() + (y * 1.3).sin() * z.cos() + (z * 0.7).sin() * (x * 1.1).cos()) * 100.0
    })
}

/// Issue 11: the same bytes for `--threads 1` and `--threads 2`, for every method.
#[test]
fn issue_11_output_is_identical_for_every_thread_count() {
    let g = AnyGrid::F32(noise(48));
    for method in Method::ALL {
        for normals in [Normals::None, Normals::Gradient] {
            let at = |threads| {
                let opts = Options { method, normals, threads: Some(threads), ..Default::default() };
                pipeline::extract_grid(&g, Iso::below(12.5), &opts, None).unwrap().mesh
            };
            let one = at(1);
            assert!(!one.is_empty(), "{}", method.name());
            for threads in [2, 3, 7] {
                assert!(at(threads) == one, "{} with {threads} threads differs from 1 thread", method.name());
            }
        }
    }
    // Fields (tabulated, then the parallel walker) too.
    let b = isoforge::volume::catalog::parse("metaballs?n=40").unwrap();
    for method in Method::ALL {
        let at = |threads| {
            let opts = Options { method, threads: Some(threads), ..Default::default() };
            pipeline::extract_builtin(&b, b.iso, &opts, None).unwrap().mesh
        };
        assert!(at(1) == at(2), "field, {}", method.name());
    }
}

/// Values beyond `f32`'s range (huge or tiny `f64` samples) give every method the mesh of the same
/// field at an ordinary scale: crossings are taken from the samples where their `f32` offsets
/// overflow or underflow, and a cell's offsets are scaled together (VTK's doubles give the same).
#[test]
fn extreme_sample_values_give_the_mesh_of_an_ordinary_scale() {
    let base = noise(14);
    let scaled = |e: i32| {
        let s = 2f64.powi(e / 2) * 2f64.powi(e - e / 2);
        AnyGrid::F64(DenseGrid::from_fn(base.lattice().clone(), |p| base.get(p) as f64 * s))
    };
    for method in Method::ALL {
        let mesh = |g: &AnyGrid| {
            let opts = Options { method, ..Default::default() };
            pipeline::extract_grid(g, Iso::below(0.0), &opts, None).unwrap().mesh
        };
        let ordinary = mesh(&scaled(0));
        assert!(!ordinary.is_empty(), "{}", method.name());
        for e in [1000, -1000, -1060, 140, -140] {
            let m = mesh(&scaled(e));
            assert_eq!(m.triangles, ordinary.triangles, "{} at 2^{e}", method.name());
            assert_eq!(m.quads, ordinary.quads, "{} at 2^{e}", method.name());
            assert_eq!(m.positions.len(), ordinary.positions.len());
            for (p, q) in m.positions.iter().zip(&ordinary.positions) {
                assert!((0..3).all(|a| (p[a] - q[a]).abs() < 1e-5), "{} at 2^{e}: {p:?} vs {q:?}", method.name());
            }
        }
    }
}

/// Records what each cell's Hermite data and placed/neighbour vertices are, to check them.
struct Probe;

impl Extractor for Probe {
    const PLACES_VERTICES: bool = true;

    fn place<C: Cell>(&self, cell: &mut C) {
        // Two vertices per cell: the crossings of the low and the high half of the edges.
        let crossed = CASE_EDGES[cell.case() as usize];
        cell.place_vertex([0.25; 3], crossed & 0x00ff);
        cell.place_vertex([0.75; 3], crossed & 0xff00);
    }

    fn process<C: Cell>(&self, cell: &mut C) {
        let crossed = CASE_EDGES[cell.case() as usize];
        for e in 0..12u8 {
            if crossed & (1 << e) == 0 {
                continue;
            }
            let h = cell.hermite(CubeEdge(e));
            // Hermite's point is the crossing the edge's vertex sits on (checked through the keys
            // below); its normal is a unit vector; asking again gives the same bits; in the
            // cell's frame it is the crossing a placing extractor sees, on this cell's edge.
            cell.edge_vertex(CubeEdge(e));
            assert_eq!(cell.crossing(CubeEdge(e)), h.local, "edge {e}");
            assert_eq!(h.on_edge(CubeEdge(e)), h, "edge {e}: in this cell's frame");
            let len: f32 = h.normal.iter().map(|x| x * x).sum::<f32>().sqrt();
            assert!((len - 1.0).abs() < 1e-4, "normal {:?}", h.normal);
            assert_eq!(cell.hermite(CubeEdge(e)), h, "cached");
        }
        // Neighbours' placed vertices: the one serving each corner-0 edge, per its mask.
        for axis in 0..3u8 {
            let e = CubeEdge(4 * axis);
            if crossed & (1 << e.0) == 0 {
                continue;
            }
            let own = cell.placed_vertex([0, 0, 0], e).expect("this cell placed a vertex for its crossed edge");
            let back = match axis {
                0 => [0, -1, 0],
                1 => [0, 0, -1],
                _ => [-1, 0, 0],
            };
            if let Some(n) = cell.placed_vertex(back, e) {
                assert_ne!(n, own, "a neighbour's vertex is its own");
            }
        }
    }
}

#[test]
fn issue_11_hermite_data_and_placed_vertices_reach_extractors_on_every_walker() {
    let g = noise(20);
    let vol = GridVolume::new(&g);
    let iso = Iso::below(0.0);
    for w in 0..3 {
        let mut out = MeshBuilder::new(Normals::None).with_keys(KeyRecord::All);
        match w {
            0 => FlyingEdgesWalker::new().walk(&vol, iso, &Probe, &mut out),
            1 => SlabWalker::new().walk(&vol, iso, &Probe, &mut out),
            _ => ReferenceWalker.walk(&vol, iso, &Probe, &mut out),
        }
        .unwrap();
        let (m, keys) = out.finish_keyed().unwrap();
        // Every vertex has its key: edge vertices sit at their edge's crossing, placed ones in their cell.
        assert_eq!(keys.len(), m.num_vertices());
        for (id, key) in keys {
            let p = m.positions[id as usize];
            match key {
                VertexKey::Edge(e) => {
                    let q = vol.lattice().to_index(p.map(f64::from));
                    let o = e.origin.map(f64::from);
                    for a in 0..3 {
                        let (lo, hi) = if a == e.axis.index() { (o[a], o[a] + 1.0) } else { (o[a], o[a]) };
                        assert!(q[a] >= lo - 1e-4 && q[a] <= hi + 1e-4, "{e:?} vertex at {q:?}");
                    }
                }
                VertexKey::Cell { ijk, n } => {
                    let q = vol.lattice().to_index(p.map(f64::from));
                    let want = if n == 0 { 0.25 } else { 0.75 };
                    for a in 0..3 {
                        assert!((q[a] - (ijk[a] as f64 + want)).abs() < 1e-4);
                    }
                }
                VertexKey::Segment(_) => panic!("the probe names no segment"),
            }
        }
    }
}

/// mt-bcc's counted fill builds vertex keys only when a walk records them, from what names each
/// vertex (its lattice edge, its centre → corner or centre → centre segment, a boundary face's
/// diagonal): recording every key, each vertex has the key the reference walker gives the vertex
/// at the same position, and every vertex of that walk is there.
#[test]
fn issue_11_counted_mt_bcc_records_the_reference_keys() {
    use isoforge::extract::BodyCentredTetrahedra;
    let bcc = BodyCentredTetrahedra;
    let g = noise(13);
    let vol = GridVolume::new(&g);
    let iso = Iso::below(0.0);
    let keyed = |counted: bool| {
        let mut out = MeshBuilder::new(Normals::None).with_keys(KeyRecord::All);
        if counted {
            FlyingEdgesWalker::new().walk(&vol, iso, &bcc, &mut out).unwrap();
        } else {
            ReferenceWalker.walk(&vol, iso, &bcc, &mut out).unwrap();
        }
        let (m, keys) = out.finish_keyed().unwrap();
        assert_eq!(keys.len(), m.num_vertices(), "every vertex has its key");
        let mut by_key: Vec<(VertexKey, [u32; 3])> =
            keys.into_iter().map(|(id, k)| (k, m.positions[id as usize].map(f32::to_bits))).collect();
        by_key.sort();
        by_key
    };
    let (counted, reference) = (keyed(true), keyed(false));
    assert!(counted.iter().any(|(k, _)| matches!(k, VertexKey::Segment(_))), "centre segments are crossed");
    assert!(counted.iter().any(|(k, _)| matches!(k, VertexKey::Edge(_))), "lattice edges are crossed");
    assert_eq!(counted, reference);
}

/// Surface nets uses placed vertices, neighbours' vertices and quads: on a closed shape the quads
/// form a closed, oriented surface with one quad per crossed lattice edge.
#[test]
fn issue_11_surface_nets_make_closed_oriented_quads() {
    let n = 24;
    let g = DenseGrid::from_fn(Lattice::spanning([n; 3], [-1.0; 3], [1.0; 3]).unwrap(), |[i, j, k]| {
        let p = [i, j, k].map(|x| -1.0 + 2.0 * x as f32 / (n - 1) as f32);
        (p[0] * p[0] + p[1] * p[1] * 1.5 + p[2] * p[2]).sqrt() - 0.7
    });
    let opts = Options { method: Method::SurfaceNets, ..Default::default() };
    let m = pipeline::extract_grid(&AnyGrid::F32(g.clone()), Iso::below(0.0), &opts, None).unwrap().mesh;
    assert!(m.triangles.is_empty());
    assert_eq!(m.num_quads(), crossed_edges(&g, 0.0), "one quad per crossed edge");
    let mut tri = m.clone();
    tri.triangulate();
    let r = topo::check(&tri);
    assert!(
        r.is_closed() && r.is_oriented(),
        "{} boundary, {} inconsistent edges",
        r.boundary_edges.count,
        r.inconsistent_edges.count
    );
    assert!(r.volume > 0.0, "oriented outward");
    assert_eq!(r.genus(), Some(0));
}

/// Vertex keys on a range's boundary are the ones another range can share.
#[test]
fn issue_11_boundary_keys_are_exactly_the_shared_vertices() {
    let g = noise(16);
    let dims = g.lattice().dims();
    let vol = GridVolume::new(&g);
    let tiles = CellRange::all(dims).tiles([7, 20, 20]);
    assert_eq!(tiles.len(), 3);
    let mut parts = Vec::new();
    for t in &tiles {
        let mut out = MeshBuilder::new(Normals::None).with_keys(KeyRecord::Boundary(*t));
        FlyingEdgesWalker::new()
            .with_range(*t)
            .walk(&vol, Iso::below(0.0), &isoforge::extract::MarchingCubes, &mut out)
            .unwrap();
        parts.push(KeyedMesh::from_builder(out).unwrap());
    }
    // Every x-edge crossing on the plane between tiles 0 and 1 is recorded by both.
    let plane = tiles[0].hi[0];
    let on_plane = |m: &KeyedMesh| -> Vec<EdgeKey> {
        let mut v: Vec<EdgeKey> = m
            .keys
            .iter()
            .filter_map(|(_, k)| match k {
                VertexKey::Edge(e) if e.origin[0] == plane && e.axis.index() != 0 => Some(*e),
                _ => None,
            })
            .collect();
        v.sort();
        v
    };
    let (a, b) = (on_plane(&parts[0]), on_plane(&parts[1]));
    assert!(!a.is_empty());
    assert_eq!(a, b);
    let whole =
        walk_method(&mut FlyingEdgesWalker::new(), &vol, Iso::below(0.0), Method::MarchingCubes, Normals::None).0;
    assert_eq!(stitch(&parts).unwrap().num_vertices(), whole.num_vertices());
}
