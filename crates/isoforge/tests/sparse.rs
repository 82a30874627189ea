//! Issue 44: sparse grids mesh exactly as the same samples stored densely, for every method; a
//! bound on the field skips what the surface cannot reach; no component is missed; memory grows
//! with the surface.

mod common;

use common::{canonical, canonical_with_normals, Rng};
use isoforge::grid::{AnyGrid, DenseGrid, Lattice, Sample, SparseGrid};
use isoforge::math::Vec3;
use isoforge::mesh::{Mesh, Normals};
use isoforge::pipeline::{self, extract_following, extract_grid, extract_sparse, Method, Options, Seeds};
use isoforge::topo;
use isoforge::volume::{Iso, Sampled, Volume};
use isoforge::walk::walk_ranges;

/// Every method's mesh of `sparse` equals its mesh of `dense`, vertices (with normals) and
/// polygons, up to numbering.
fn assert_same_meshes<S: Sample>(sparse: &SparseGrid<S>, dense: &DenseGrid<S>, iso: Iso, what: &str) -> usize
where
    AnyGrid: From<DenseGrid<S>>,
{
    let mut triangles = 0;
    for method in Method::ALL {
        for normals in [Normals::None, Normals::Gradient] {
            let opts = Options { method, normals, ..Options::default() };
            let a = extract_sparse(sparse, iso, &opts).expect("sparse").mesh;
            let b = extract_grid(&dense.clone().into(), iso, &opts, None).expect("dense").mesh;
            assert_eq!(a.num_vertices(), b.num_vertices(), "{what}: {} vertices", method.name());
            assert_eq!(canonical_with_normals(&a), canonical_with_normals(&b), "{what}: {} {normals:?}", method.name());
            triangles += b.num_triangles() + b.num_quads();
            // Tiles of one block: many ranges, stitched.
            let ranges = sparse.active_ranges_in(iso, method == Method::TetrahedraBcc, 1);
            let (c, _) = pipeline::with_extractor(method, Walk { sparse, ranges: &ranges, iso, normals });
            assert_eq!(
                canonical_with_normals(&c.mesh),
                canonical_with_normals(&b),
                "{what}: {} in {} ranges",
                method.name(),
                ranges.len()
            );
        }
    }
    triangles
}

/// A walk of given ranges of a sparse grid with a method's extractor.
struct Walk<'a, S> {
    sparse: &'a SparseGrid<S>,
    ranges: &'a [isoforge::cube::CellRange],
    iso: Iso,
    normals: Normals,
}

impl<S: Sample> pipeline::ExtractorVisitor for Walk<'_, S> {
    type Output = (isoforge::walk::KeyedMesh, isoforge::walk::WalkStats);
    fn visit<X: isoforge::extract::Extractor + Sync>(self, x: X) -> Self::Output {
        walk_ranges(self.sparse, self.ranges, self.iso, &x, self.normals, isoforge::mesh::KeyRecord::None).unwrap()
    }
}

/// Balls of random centres and radii (some touching, some a fraction of a cell wide) and a
/// wavy term: a field with many components, crossing leaf and node boundaries.
fn blobs(dims: [u32; 3], n: usize, seed: u64) -> DenseGrid<f32> {
    let mut rng = Rng(seed);
    let balls: Vec<([f32; 3], f32)> = (0..n)
        .map(|_| {
            let c = dims.map(|d| (rng.next() % (d as u64 * 100)) as f32 / 100.0);
            (c, 0.4 + (rng.next() % 600) as f32 / 100.0)
        })
        .collect();
    DenseGrid::from_fn(Lattice::new(dims).unwrap(), |p| {
        let p = p.map(|v| v as f32);
        balls
            .iter()
            .map(|(c, r)| (0..3).map(|a| (p[a] - c[a]).powi(2)).sum::<f32>().sqrt() - r)
            .fold(f32::INFINITY, f32::min)
            + 0.05 * (p[0] * 0.7).sin()
    })
}

#[test]
fn sparse_copies_of_grids_mesh_as_the_grids_for_every_method() {
    // Lattices that are not multiples of a leaf, and one spanning two nodes along x.
    for (dims, n, seed) in [([37, 29, 41], 12, 1), ([23, 17, 9], 5, 2), ([140, 19, 21], 20, 3)] {
        let g = blobs(dims, n, seed);
        for iso in [Iso::below(0.0), Iso::above(1.5)] {
            let sparse = SparseGrid::from_dense(&g, iso);
            let t = assert_same_meshes(&sparse, &g, iso, &format!("{dims:?} {iso:?}"));
            assert!(t > 0, "{dims:?}: no surface");
            assert!(sparse.num_leaves() > 0);
        }
    }
    // Integer samples, values at the iso (ties) included.
    let g = blobs([33, 30, 27], 9, 4);
    let ints = DenseGrid::from_fn(g.lattice().clone(), |p| (g.get(p) * 3.0).round() as i16);
    let iso = Iso::below(0.0);
    assert_same_meshes(&SparseGrid::from_dense(&ints, iso), &ints, iso, "i16 with ties");
    let bytes = DenseGrid::from_fn(g.lattice().clone(), |p| (g.get(p) * 20.0 + 100.0).clamp(0.0, 255.0) as u8);
    let iso = Iso::above(100.0);
    assert_same_meshes(&SparseGrid::from_dense(&bytes, iso), &bytes, iso, "u8 inside above");
}

/// What the sparse grid stores where a walk reads: every point within two of a crossed cell's
/// corners is in a leaf, with the grid's sample.
#[test]
fn walks_read_leaf_samples_only() {
    let g = blobs([41, 38, 35], 14, 5);
    let iso = Iso::below(0.0);
    let sparse = SparseGrid::from_dense(&g, iso);
    let dims = g.lattice().dims();
    let inside = |p: [u32; 3]| iso.exact_offset(g.get(p) as f64) < 0.0;
    let mut checked = 0;
    for k in 0..dims[2] - 1 {
        for j in 0..dims[1] - 1 {
            for i in 0..dims[0] - 1 {
                let corners = (0..8u32).map(|c| [i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1)]);
                let (ins, outs) = corners.fold((0, 0), |(a, b), p| if inside(p) { (a + 1, b) } else { (a, b + 1) });
                if ins == 0 || outs == 0 {
                    continue;
                }
                for dz in 0..6u32 {
                    for dy in 0..6u32 {
                        for dx in 0..6u32 {
                            let p = [i + dx, j + dy, k + dz].map(|v| v.checked_sub(2));
                            let [Some(x), Some(y), Some(z)] = p else { continue };
                            if x >= dims[0] || y >= dims[1] || z >= dims[2] {
                                continue;
                            }
                            let p = [x, y, z];
                            let o = p.map(|v| v / 8 * 8);
                            assert!(
                                sparse.block_at(o).is_err(),
                                "point {p:?} near cell {:?} is not in a leaf",
                                [i, j, k]
                            );
                            assert_eq!(sparse.get(p), g.get(p));
                            checked += 1;
                        }
                    }
                }
            }
        }
    }
    assert!(checked > 1000);
}

/// A signed distance field and its Lipschitz bound.
fn sphere(c: [f32; 3], r: f32) -> impl Fn(Vec3) -> f32 + Sync + Clone {
    move |p: Vec3| (p - Vec3::from(c)).length() - r
}

/// The field's samples stored densely (what the dense path meshes).
fn dense_samples(vol: &(dyn Volume + Sync)) -> DenseGrid<f32> {
    DenseGrid::from_fn(vol.lattice().clone(), |p| vol.value_at(p.map(f64::from), Iso::below(0.0)))
}

#[test]
fn fields_with_a_bound_are_sampled_near_the_surface_only_and_mesh_as_their_samples() {
    let lattice = Lattice::spanning([150, 97, 81], [-1.5, -1.0, -0.8], [1.5, 0.94, 0.8]).unwrap();
    // A sphere (L = 1) and a gyroid clipped to a ball (max(gyroid, sphere): L ≤ max of theirs).
    let ball = sphere([0.1, -0.05, 0.0], 0.71);
    let gyroid = move |p: Vec3| {
        let q = p * 9.0;
        let g = (q.x.sin() * q.y.cos() + q.y.sin() * q.z.cos() + q.z.sin() * q.x.cos()) / 9.0;
        g.max(ball(p))
    };
    for (name, vol, l) in [
        (
            "sphere",
            Box::new(Sampled::new(sphere([0.1, -0.05, 0.0], 0.71), lattice.clone())) as Box<dyn Volume + Sync>,
            1.0,
        ),
        ("gyroid in a ball", Box::new(Sampled::new(gyroid, lattice.clone())), 3.0f64.sqrt()),
    ] {
        let iso = Iso::below(0.0);
        let sparse = SparseGrid::from_field(&*vol, iso, Some(l)).unwrap();
        let dense = dense_samples(&*vol);
        assert_same_meshes(&sparse, &dense, iso, name);
        // Leaves hold the field's values; far blocks were never stored.
        for n in 0..sparse.num_leaves() {
            let o = sparse.leaf_origin(n);
            let p = [o[0] + 3, o[1] + 5, o[2] + 1];
            if (0..3).all(|a| p[a] < lattice.dims()[a]) {
                assert_eq!(sparse.get(p), dense.get(p), "{name}: leaf sample at {p:?}");
            }
        }
        // The sphere's surface crosses a few blocks of each column; the gyroid's most blocks of
        // the ball (a period is 35 points): both leave the far blocks unsampled.
        let stored = sparse.stats().stored_samples as f64 / lattice.num_points() as f64;
        assert!(stored < if name == "sphere" { 0.3 } else { 0.7 }, "{name}: {stored} of the points stored");
    }
}

#[test]
fn without_a_bound_no_component_is_missed() {
    // Many blobs down to a fraction of a cell: only those that contain a lattice point inside
    // can show; every one of them must.
    let g = blobs([61, 47, 52], 60, 6);
    struct Samples(DenseGrid<f32>);
    impl Volume for Samples {
        fn lattice(&self) -> &Lattice {
            self.0.lattice()
        }
        fn fill_slab(&self, k: u32, iso: Iso, out: &mut [f32]) {
            isoforge::volume::GridVolume::new(&self.0).fill_slab(k, iso, out)
        }
        fn crossing(&self, e: isoforge::cube::EdgeKey, d0: f32, d1: f32, iso: Iso) -> f32 {
            isoforge::volume::GridVolume::new(&self.0).crossing(e, d0, d1, iso)
        }
        fn gradient(&self, e: isoforge::cube::EdgeKey, t: f32) -> Vec3 {
            isoforge::volume::GridVolume::new(&self.0).gradient(e, t)
        }
        fn value_at(&self, p: [f64; 3], iso: Iso) -> f32 {
            isoforge::volume::GridVolume::new(&self.0).value_at(p, iso)
        }
        fn gradient_at(&self, p: [f64; 3]) -> Vec3 {
            isoforge::volume::GridVolume::new(&self.0).gradient_at(p)
        }
    }
    let vol = Samples(g.clone());
    let iso = Iso::below(0.0);
    let sparse = SparseGrid::from_field(&vol, iso, None).unwrap();
    assert_same_meshes(&sparse, &g, iso, "blobs without a bound");
    let mesh =
        extract_sparse(&sparse, iso, &Options { method: Method::MarchingCubes, ..Options::default() }).unwrap().mesh;
    assert_eq!(topo::check(&mesh).components.len(), inside_components(&g, iso), "components against the sign grid");
}

/// Components of the inside points of `g` joined across lattice edges: an independent oracle
/// for `mc`'s components (its table keeps apart two inside corners that meet only across a face
/// diagonal: checked here on many blobs, and by `tests/cases.rs` on single cells).
fn inside_components(g: &DenseGrid<f32>, iso: Iso) -> usize {
    let dims = g.lattice().dims();
    let inside = |p: [i64; 3]| {
        (0..3).all(|a| p[a] >= 0 && p[a] < dims[a] as i64) && iso.exact_offset(g.get(p.map(|v| v as u32)) as f64) < 0.0
    };
    let lin = |p: [i64; 3]| ((p[2] * dims[1] as i64 + p[1]) * dims[0] as i64 + p[0]) as usize;
    let mut seen = vec![false; g.lattice().num_points() as usize];
    let mut count = 0;
    for start in 0..seen.len() {
        let s = g.lattice().ijk(start).map(i64::from);
        if seen[start] || !inside(s) {
            continue;
        }
        count += 1;
        seen[start] = true;
        let mut stack = vec![s];
        while let Some(p) = stack.pop() {
            let mut next = Vec::new();
            for a in 0..3 {
                for d in [-1, 1] {
                    let mut q = p;
                    q[a] += d;
                    next.push(q);
                }
            }
            for q in next {
                if inside(q) && !seen[lin(q)] {
                    seen[lin(q)] = true;
                    stack.push(q);
                }
            }
        }
    }
    count
}

/// Two spheres whose surfaces are 0.1 cell apart (a case a competing crate meshes as one of the
/// two): found by the sparse sampling with and without a bound, two closed components for every
/// method whose interpolant keeps them apart. mt-bcc's does not: the cell centres between the
/// spheres are inside (the mean of a tie plane and inside points), so its octahedra join them,
/// as they do on the dense grid.
#[test]
fn two_spheres_a_tenth_of_a_cell_apart_are_two_components() {
    // Radius 5 cells, centres 10.1 cells apart: the gap passes just past the lattice plane
    // x = 15, whose points sit on the first sphere (a tie: outside).
    let lattice = Lattice::new([40, 24, 24]).unwrap();
    let field = move |p: Vec3| {
        let a = (p - Vec3::new(10.0, 11.5, 11.5)).length() - 5.0;
        let b = (p - Vec3::new(20.1, 11.5, 11.5)).length() - 5.0;
        a.min(b)
    };
    let vol = Sampled::new(field, lattice);
    let iso = Iso::below(0.0);
    for bound in [Some(1.0), None] {
        let sparse = SparseGrid::from_field(&vol, iso, bound).unwrap();
        let dense = dense_samples(&vol);
        for method in Method::ALL {
            let opts = Options { method, ..Options::default() };
            let m: Mesh = extract_sparse(&sparse, iso, &opts).unwrap().mesh;
            let d = extract_grid(&dense.clone().into(), iso, &opts, None).unwrap().mesh;
            let (r, rd) = (topo::check(&m), topo::check(&d));
            assert_eq!(r.components.len(), rd.components.len(), "{} with bound {bound:?}", method.name());
            let want = if method == Method::TetrahedraBcc { 1 } else { 2 };
            assert_eq!(r.components.len(), want, "{} with bound {bound:?}", method.name());
            assert!(r.is_closed(), "{}", method.name());
        }
    }
}

#[test]
fn memory_grows_with_the_surface() {
    // A sphere at two resolutions: four times the leaves for twice the points per axis, and a
    // few bytes per stored sample.
    let leaves = [96u32, 192].map(|n| {
        let lattice = Lattice::spanning([n; 3], [-1.0; 3], [1.0; 3]).unwrap();
        let vol = Sampled::new(sphere([0.03, -0.02, 0.01], 0.8), lattice);
        let s = SparseGrid::from_field(&vol, Iso::below(0.0), Some(1.0)).unwrap().stats();
        assert!(s.bytes as f64 / (s.stored_samples as f64) < 16.0, "{n}³: {s:?}");
        s.leaves as f64
    });
    let ratio = leaves[1] / leaves[0];
    assert!((3.0..5.0).contains(&ratio), "leaves {leaves:?}: ratio {ratio}");
}

#[test]
fn dense_round_trip_and_random_access_agree() {
    let g = blobs([45, 33, 150], 16, 7);
    let iso = Iso::above(0.7);
    let sparse = SparseGrid::from_dense(&g, iso);
    let back = sparse.to_dense().unwrap();
    let mut box_ = Vec::new();
    sparse.fill_box([3, 5, 100], [44, 20, 149], &mut box_);
    for (lin, v) in back.data().iter().enumerate() {
        let p = g.lattice().ijk(lin);
        assert_eq!(*v, sparse.get(p));
        // Stored where it matters, a value on the same side elsewhere.
        assert_eq!(iso.exact_offset(*v as f64) < 0.0, iso.exact_offset(g.get(p) as f64) < 0.0, "side at {p:?}");
        if (3..44).contains(&p[0]) && (5..20).contains(&p[1]) && (100..149).contains(&p[2]) {
            assert_eq!(box_[((p[2] - 100) as usize * 15 + (p[1] - 5) as usize) * 41 + (p[0] - 3) as usize], *v);
        }
    }
    assert_eq!(
        canonical(&extract_grid(&back.into(), iso, &Options::default(), None).unwrap().mesh),
        canonical(&extract_grid(&g.into(), iso, &Options::default(), None).unwrap().mesh)
    );
}

/// Cells with corners on both sides of the iso: what surface following must visit.
fn crossed_cells(g: &DenseGrid<f32>, iso: Iso) -> u64 {
    let dims = g.lattice().dims();
    let mut n = 0;
    for k in 0..dims[2] - 1 {
        for j in 0..dims[1] - 1 {
            for i in 0..dims[0] - 1 {
                let inside = (0..8u32)
                    .filter(|c| iso.exact_offset(g.get([i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1)]) as f64) < 0.0)
                    .count();
                n += u64::from(inside != 0 && inside != 8);
            }
        }
    }
    n
}

#[test]
fn following_from_the_tree_finds_every_component_and_visits_only_crossed_cells() {
    let g = blobs([52, 41, 47], 30, 8);
    for iso in [Iso::below(0.0), Iso::above(0.8)] {
        let sparse = SparseGrid::from_dense(&g, iso);
        for method in Method::ALL.into_iter().filter(|&m| m != Method::TetrahedraBcc) {
            let opts = Options { method, normals: Normals::Gradient, ..Options::default() };
            let (followed, stats) = extract_following(&sparse, iso, &opts, Seeds::Tree).unwrap();
            let walked = extract_sparse(&sparse, iso, &opts).unwrap();
            assert_eq!(
                canonical_with_normals(&followed.mesh),
                canonical_with_normals(&walked.mesh),
                "{} {iso:?}",
                method.name()
            );
            assert_eq!(stats.visited, crossed_cells(&g, iso), "{}: visited", method.name());
            // A flood covers every mesh component it touches: at most one per component.
            let components = topo::check(&walked.mesh).components.len() as u64;
            assert!((1..=components).contains(&stats.floods), "{}: {} floods", method.name(), stats.floods);
        }
    }
    let opts = Options { method: Method::TetrahedraBcc, ..Options::default() };
    let sparse = SparseGrid::from_dense(&g, Iso::below(0.0));
    assert!(extract_following(&sparse, Iso::below(0.0), &opts, Seeds::Tree).is_err());
}

#[test]
fn following_from_a_point_meshes_the_component_around_it() {
    // Two balls far apart; a point inside the second finds its surface only.
    let lattice = Lattice::new([48, 24, 24]).unwrap();
    let field = |p: Vec3| {
        let a = (p - Vec3::new(10.0, 11.5, 11.5)).length() - 6.0;
        let b = (p - Vec3::new(34.0, 11.5, 11.5)).length() - 7.0;
        a.min(b)
    };
    let vol = Sampled::new(field, lattice);
    let iso = Iso::below(0.0);
    let sparse = SparseGrid::from_field(&vol, iso, Some(1.0)).unwrap();
    let opts = Options { method: Method::MarchingCubes33, ..Options::default() };
    let (one, stats) = extract_following(&sparse, iso, &opts, Seeds::Points(&[[34.0, 11.5, 11.5]])).unwrap();
    let r = topo::check(&one.mesh);
    assert_eq!(r.components.len(), 1);
    assert!(r.is_closed());
    assert!(one.mesh.positions.iter().all(|p| p[0] > 26.0), "only the second ball");
    assert_eq!(stats.floods, 1);
    // Both: the whole mesh.
    let (both, _) =
        extract_following(&sparse, iso, &opts, Seeds::Points(&[[34.0, 11.5, 11.5], [9.0, 11.0, 12.0]])).unwrap();
    assert_eq!(canonical(&both.mesh), canonical(&extract_sparse(&sparse, iso, &opts).unwrap().mesh));
}

#[test]
fn coarser_levels_are_block_means_and_mesh_the_same_shape() {
    let g = blobs([70, 45, 53], 10, 9);
    let iso = Iso::below(0.0);
    let sparse = SparseGrid::from_dense(&g, iso);
    let coarse = sparse.downsample().unwrap();
    let dense_coarse = isoforge::grid::downsample_mean(&g, 2).unwrap();
    assert_eq!(coarse.lattice(), dense_coarse.lattice());
    // Where the eight fine points are leaf samples, the coarse value is their mean.
    let mut compared = 0;
    for n in 0..coarse.num_leaves() {
        let o = coarse.leaf_origin(n);
        for (at, &v) in coarse.leaf_values(n).iter().enumerate() {
            let p = [o[0] + at as u32 % 8, o[1] + at as u32 / 8 % 8, o[2] + at as u32 / 64];
            if (0..3).any(|a| p[a] >= coarse.lattice().dims()[a]) {
                continue;
            }
            let fine_in_leaves = (0..8u32).all(|c| {
                let f = [0, 1, 2].map(|a| 2 * p[a] + (c >> a & 1));
                sparse.block_at(f.map(|x| x / 8 * 8)).is_err()
            });
            if fine_in_leaves {
                let want = dense_coarse.get(p);
                assert!((v - want).abs() <= 1e-5 * want.abs().max(1.0), "{p:?}: {v} vs {want}");
                compared += 1;
            }
        }
    }
    assert!(compared > 1000);
    // A sphere field at two levels: closed, one component, on the sphere within a coarse cell.
    let lattice = Lattice::spanning([129; 3], [-1.0; 3], [1.0; 3]).unwrap();
    let vol = Sampled::new(sphere([0.02, 0.01, -0.03], 0.6), lattice);
    let grid = SparseGrid::from_field(&vol, iso, Some(1.0)).unwrap();
    for level in [1, 2] {
        let opts = Options { method: Method::MarchingCubes, level, ..Options::default() };
        let m = extract_sparse(&grid, iso, &opts).unwrap().mesh;
        let r = topo::check(&m);
        assert!(r.is_closed() && r.components.len() == 1, "level {level}");
        let h = 2.0 / 128.0 * f32::powi(2.0, level as i32);
        for p in &m.positions {
            let d = (Vec3::from(*p) - Vec3::new(0.02, 0.01, -0.03)).length() - 0.6;
            assert!(d.abs() < h, "level {level}: vertex {p:?} off the sphere by {d}");
        }
    }
}

/// Tiles of opposite sides side by side, without a leaf between (as files may hold): the surface
/// between them is meshed as on the dense samples, for child tiles and for whole-node tiles.
#[test]
fn surfaces_between_tiles_are_meshed() {
    use isoforge::grid::SparseNode;
    // 300 × 140 × 60 points: node (1, 0, 0) is one tile of −1; in node (0, 0, 0) the blocks at
    // 8..32 on each axis are tiles of −1; the rest is the background 1.
    let lattice = Lattice::new([300, 140, 60]).unwrap();
    let dims = lattice.dims();
    let grid = SparseGrid::build(lattice, 1.0f32, &|coord: [u32; 3]| {
        if coord == [1, 0, 0] {
            return SparseNode::tile(-1.0);
        }
        SparseNode::blocks(coord, dims, 1.0, &mut |o: [u32; 3], _: &mut [f32]| {
            Some(if coord == [0, 0, 0] && o.iter().all(|&v| (8..32).contains(&v)) { -1.0 } else { 1.0 })
        })
    });
    assert_eq!(grid.num_leaves(), 0);
    let dense = grid.to_dense().unwrap();
    let iso = Iso::below(0.0);
    let t = assert_same_meshes(&grid, &dense, iso, "tiles only");
    assert!(t > 0);
}

/// A bound, tight (a signed distance's Lipschitz constant), loose (the clipped gyroid's interval
/// arithmetic, a Lipschitz constant far above the truth) or absent, changes what is sampled but
/// never what is kept: a leaf exactly where the samples within the margin straddle the iso, with
/// the samples' values, nowhere else.
#[test]
fn fields_keep_the_leaves_their_samples_ask_for_whatever_the_bound() {
    use isoforge::grid::sparse::{LEAF, SURFACE_MARGIN};
    use isoforge::volume::catalog;
    use isoforge::volume::{Field, FieldVisitor};
    struct Check(&'static str, catalog::Builtin);
    impl FieldVisitor for Check {
        type Output = ();
        fn visit<F: Field + Clone + Sync>(self, field: &F) {
            let Check(spec, b) = self;
            let vol = Sampled::new(field.clone(), b.lattice.clone());
            let dense = dense_samples(&vol);
            let dims = b.lattice.dims();
            // The blocks whose points within the margin straddle the iso, in (z, y, x) order.
            let inside = |p: [u32; 3]| b.iso.exact_offset(dense.get(p) as f64) < 0.0;
            let mut want = Vec::new();
            for bz in (0..dims[2]).step_by(LEAF as usize) {
                for by in (0..dims[1]).step_by(LEAF as usize) {
                    for bx in (0..dims[0]).step_by(LEAF as usize) {
                        let o = [bx, by, bz];
                        let lo = o.map(|v| v.saturating_sub(SURFACE_MARGIN));
                        let hi = [0, 1, 2].map(|a| (o[a] + LEAF + SURFACE_MARGIN).min(dims[a]));
                        let (mut i, mut u) = (false, false);
                        for z in lo[2]..hi[2] {
                            for y in lo[1]..hi[1] {
                                for x in lo[0]..hi[0] {
                                    let s = inside([x, y, z]);
                                    i |= s;
                                    u |= !s;
                                }
                            }
                        }
                        if i && u {
                            want.push(o);
                        }
                    }
                }
            }
            assert!(want.len() > 20, "{spec}: {} blocks straddle", want.len());
            let mut bounds = vec![None, field.lipschitz().map(|l| l * 7.0)];
            bounds.extend(field.lipschitz().map(Some));
            for l in bounds {
                let what = format!("{spec} with lipschitz {l:?}");
                let sparse = SparseGrid::from_field(&vol, b.iso, l).unwrap();
                let mut got: Vec<[u32; 3]> = (0..sparse.num_leaves()).map(|n| sparse.leaf_origin(n)).collect();
                got.sort_unstable_by_key(|o| (o[2], o[1], o[0]));
                assert_eq!(got, want, "{what}: leaves");
                for n in 0..sparse.num_leaves() {
                    let o = sparse.leaf_origin(n);
                    let values = sparse.leaf_values(n);
                    for (k, v) in values.iter().enumerate() {
                        let p =
                            [o[0] + k as u32 % LEAF, o[1] + k as u32 / LEAF % LEAF, o[2] + k as u32 / (LEAF * LEAF)];
                        if (0..3).all(|a| p[a] < dims[a]) {
                            assert_eq!(v.to_bits(), dense.get(p).to_bits(), "{what}: sample at {p:?}");
                        }
                    }
                }
            }
        }
    }
    for spec in ["sphere?n=77", "gyroid?n=90&periods=3&clip=0.9", "torus?n=61"] {
        let b = catalog::parse(spec).unwrap();
        let field = b.field;
        field.visit(Check(spec, b));
    }
}
