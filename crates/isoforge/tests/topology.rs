//! Topology of MC33 and marching tetrahedra on random lattices, against an independent oracle:
//! the trilinear interpolant refined 16× (and 24× when in doubt) and meshed with classic MC.
//!
//! `ISOFORGE_TOPO_CASES=N` sets the number of random lattices (default 300; `.ci/run` runs 3000
//! in release and the closing note of issue 4 reports the counts).

mod common;

use isoforge::extract::{Decomposition, Extractor, MarchingCubes, MarchingCubes33, MarchingTetrahedra};
use isoforge::grid::{upsample_trilinear, DenseGrid, Lattice};
use isoforge::mesh::{Mesh, MeshBuilder};
use isoforge::topo::{self, MeshReport};
use isoforge::volume::{GridVolume, Iso};
use isoforge::walk::{flying_edges, ReferenceWalker, SlabWalker, Walker};

/// splitmix64: a seeded stream for reproducible lattices.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn uniform(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

/// Random values in [−1, 1) on 2–3 points per axis, surrounded by a border of outside points.
fn random_lattice(rng: &mut Rng) -> DenseGrid<f32> {
    let dims = [0; 3].map(|_| 2 + rng.below(2) as u32);
    let outer = Lattice::new(dims.map(|d| d + 2)).unwrap();
    let inner: Vec<f32> = (0..dims.iter().product::<u32>()).map(|_| rng.uniform()).collect();
    let inner_lat = Lattice::new(dims).unwrap();
    DenseGrid::from_fn(outer, |p| {
        if p.iter().zip(dims).all(|(&x, d)| x >= 1 && x <= d) {
            inner[inner_lat.linear([p[0] - 1, p[1] - 1, p[2] - 1])]
        } else {
            1.0
        }
    })
}

/// The inner block of a bordered lattice as `dims values…` (for failure messages and replay).
fn describe(g: &DenseGrid<f32>) -> String {
    let d = g.lattice().dims().map(|n| n - 2);
    let mut v = Vec::new();
    for k in 1..=d[2] {
        for j in 1..=d[1] {
            for i in 1..=d[0] {
                v.push(g.get([i, j, k]));
            }
        }
    }
    format!("dims {d:?} values {v:?}")
}

fn extract<X: Extractor>(g: &DenseGrid<f32>, x: &mut X) -> Mesh {
    let mut out = MeshBuilder::new(false);
    SlabWalker::new().walk(&GridVolume::new(g), Iso::below(0.0), x, &mut out).expect("walk");
    out.finish().expect("finish")
}

/// The genus of every component, sorted (so also the number of components).
fn genera(r: &MeshReport) -> Vec<i64> {
    let mut g: Vec<i64> = r.components.iter().map(|c| c.genus.unwrap_or(-99)).collect();
    g.sort();
    g
}

/// The trilinear interpolant's components and genera, from classic MC on the grid refined
/// `factor` times.
fn oracle(g: &DenseGrid<f32>, factor: u32) -> Vec<i64> {
    let fine = upsample_trilinear(g, factor).unwrap();
    let (mesh, _) = flying_edges(&fine, Iso::below(0.0), &MarchingCubes, false).unwrap();
    let r = topo::check(&mesh);
    assert!(r.is_watertight(), "the oracle mesh is not watertight");
    genera(&r)
}

fn cases() -> usize {
    std::env::var("ISOFORGE_TOPO_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(300)
}

fn assert_watertight(r: &MeshReport, what: &str, g: &DenseGrid<f32>) {
    assert!(
        r.is_watertight() && r.collapsed_triangles.count == 0,
        "{what}: not watertight ({} boundary, {} non-manifold edges, {} non-manifold vertices, {} inconsistent, {} collapsed) on {}",
        r.boundary_edges.count,
        r.non_manifold_edges.count,
        r.non_manifold_vertices.count,
        r.inconsistent_edges.count,
        r.collapsed_triangles.count,
        describe(g)
    );
}

#[test]
fn mc33_has_the_topology_of_the_trilinear_interpolant() {
    let mut rng = Rng(0x33_c0de);
    let n = cases();
    let (mut mc_differs, mut unresolved, mut compared, mut refined) = (0, 0, 0, 0);
    for _ in 0..n {
        let g = random_lattice(&mut rng);
        let m33 = extract(&g, &mut MarchingCubes33);
        let r33 = topo::check(&m33);
        assert_watertight(&r33, "mc33", &g);
        let mc = genera(&topo::check(&extract(&g, &mut MarchingCubes)));
        let got = genera(&r33);
        let mut want = oracle(&g, 16);
        if got != want {
            // A feature thinner than 1/16 cell (a tunnel near its birth, two sheets nearly
            // touching) can fool the oracle itself: settle with 48× and 96× agreeing.
            let (fine, finer) = (oracle(&g, 48), oracle(&g, 96));
            if fine != finer {
                unresolved += 1;
                continue;
            }
            refined += 1;
            want = fine;
        }
        compared += 1;
        assert_eq!(got, want, "mc33 genera differ from the trilinear interpolant's on {}", describe(&g));
        if mc != want {
            mc_differs += 1;
        }
    }
    eprintln!(
        "mc33 topology: {compared} lattices compared ({refined} needed the 48×/96× oracle), 0 mismatches, \
         {unresolved} left out (oracle unsettled at 96×); classic MC differs on {mc_differs} of {compared}"
    );
    assert!(compared * 10 >= n * 9, "too many unresolved lattices: {unresolved} of {n}");
}

#[test]
fn tetrahedra_give_watertight_meshes_on_random_lattices() {
    let mut rng = Rng(0x7e7a);
    for _ in 0..cases() {
        let g = random_lattice(&mut rng);
        for d in [Decomposition::Five, Decomposition::Six, Decomposition::BodyCentred] {
            let m = extract(&g, &mut MarchingTetrahedra { decomposition: d });
            let r = topo::check(&m);
            assert_watertight(&r, &format!("{d:?}"), &g);
            if r.triangles > 0 {
                assert!(r.volume > 0.0, "{d:?}: inside-out mesh (volume {})", r.volume);
            }
        }
    }
}

#[test]
fn ties_at_iso_never_crack_a_mesh() {
    // Values from a small set: corners exactly at iso, face saddles exactly at iso (a·c = b·d),
    // equal values on both ends of edges.
    const SET: [f32; 7] = [-2.0, -1.0, -0.5, 0.0, 0.25, 1.0, 2.0];
    let mut rng = Rng(0x7135);
    for _ in 0..cases() {
        let dims = [0; 3].map(|_| 2 + rng.below(3) as u32);
        let inner: Vec<f32> = (0..dims.iter().product::<u32>()).map(|_| SET[rng.below(7) as usize]).collect();
        let inner_lat = Lattice::new(dims).unwrap();
        let g = DenseGrid::from_fn(Lattice::new(dims.map(|d| d + 2)).unwrap(), |p| {
            if p.iter().zip(dims).all(|(&x, d)| x >= 1 && x <= d) {
                inner[inner_lat.linear([p[0] - 1, p[1] - 1, p[2] - 1])]
            } else {
                1.0
            }
        });
        assert_watertight(&topo::check(&extract(&g, &mut MarchingCubes33)), "mc33", &g);
        for d in [Decomposition::Five, Decomposition::Six, Decomposition::BodyCentred] {
            assert_watertight(&topo::check(&extract(&g, &mut MarchingTetrahedra { decomposition: d })), "mt", &g);
        }
    }
}

#[test]
fn mc33_and_tetrahedra_agree_between_walkers() {
    // The slab walker's caches against the reference walker (no caches, crossings recomputed).
    let mut rng = Rng(0x5eed);
    for _ in 0..cases() / 3 {
        let g = random_lattice(&mut rng);
        let vol = GridVolume::new(&g);
        for method in 0..4 {
            let run = |walker: &mut dyn FnMut(&mut MeshBuilder) -> isoforge::Result<()>| {
                let mut out = MeshBuilder::new(true);
                walker(&mut out).unwrap();
                out.finish().unwrap()
            };
            let iso = Iso::below(0.0);
            let (a, b) = match method {
                0 => (
                    run(&mut |o| SlabWalker::new().walk(&vol, iso, &mut MarchingCubes33, o).map(|_| ())),
                    run(&mut |o| ReferenceWalker.walk(&vol, iso, &mut MarchingCubes33, o).map(|_| ())),
                ),
                m => {
                    let d = [Decomposition::Five, Decomposition::Six, Decomposition::BodyCentred][m - 1];
                    let mut x = MarchingTetrahedra { decomposition: d };
                    let mut y = x;
                    (
                        run(&mut |o| SlabWalker::new().walk(&vol, iso, &mut x, o).map(|_| ())),
                        run(&mut |o| ReferenceWalker.walk(&vol, iso, &mut y, o).map(|_| ())),
                    )
                }
            };
            assert_eq!(a.positions, b.positions, "method {method}");
            assert_eq!(a.triangles, b.triangles, "method {method}");
            assert_eq!(a.normals, b.normals, "method {method}");
        }
    }
}

#[test]
#[ignore]
fn debug_case() {
    // ISOFORGE_CASE="3 2 3 v0 v1 …" (dims then values, as `describe` prints them).
    let spec = std::env::var("ISOFORGE_CASE").expect("set ISOFORGE_CASE");
    let nums: Vec<f32> = spec.split(|c: char| c == ',' || c.is_whitespace() || c == '[' || c == ']').filter(|s| !s.is_empty()).map(|s| s.parse().unwrap()).collect();
    let dims = [nums[0] as u32, nums[1] as u32, nums[2] as u32];
    let inner = nums[3..].to_vec();
    let outer = Lattice::new(dims.map(|d| d + 2)).unwrap();
    let inner_lat = Lattice::new(dims).unwrap();
    let g = DenseGrid::from_fn(outer, |p| {
        if p.iter().zip(dims).all(|(&x, d)| x >= 1 && x <= d) { inner[inner_lat.linear([p[0] - 1, p[1] - 1, p[2] - 1])] } else { 1.0 }
    });
    for f in [16, 24, 48, 96] {
        eprintln!("oracle {f}: {:?}", oracle(&g, f));
    }
    let r = topo::check(&extract(&g, &mut MarchingCubes33));
    eprintln!("mc33 {:?} non-manifold edges {:?}", genera(&r), r.non_manifold_edges.examples);
    let od = g.lattice().dims();
    for k in 0..od[2] - 1 {
        for j in 0..od[1] - 1 {
            for i in 0..od[0] - 1 {
                let c: Vec<f32> = (0..8u32).map(|c| g.get([i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1)])).collect();
                let cell = DenseGrid::from_fn(Lattice::new([4, 4, 4]).unwrap(), |p| {
                    if p.iter().all(|&x| (1..=2).contains(&x)) { c[((p[0] - 1) + 2 * (p[1] - 1) + 4 * (p[2] - 1)) as usize] } else { 1.0 }
                });
                let (a, b) = (genera(&topo::check(&extract(&cell, &mut MarchingCubes33))), oracle(&cell, 64));
                if a != b {
                    eprintln!("cell {:?}: mc33 {a:?} oracle {b:?} values {c:?}", [i, j, k]);
                    let m = extract(&cell, &mut MarchingCubes33);
                    let r = topo::check(&m);
                    for e in &r.non_manifold_edges.examples {
                        for t in &m.triangles {
                            if t.contains(&e.edge[0]) && t.contains(&e.edge[1]) {
                                eprintln!("  tri {:?}", t.map(|v| m.positions[v as usize]));
                            }
                        }
                    }
                }
            }
        }
    }
    eprintln!("mc {:?}", genera(&topo::check(&extract(&g, &mut MarchingCubes))));
}
