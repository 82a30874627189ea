//! Helpers shared by the integration tests.
#![allow(dead_code)]

use isoforge::extract::{Extractor, MarchingCubes};
use isoforge::grid::{DenseGrid, Lattice, Sample};
use isoforge::mesh::{Mesh, MeshBuilder, Normals};
use isoforge::pipeline::Method;
use isoforge::volume::{GridVolume, Iso, Volume};
use isoforge::walk::{FlyingEdgesWalker, ReferenceWalker, SlabWalker, WalkStats, Walker};

/// Extracts with marching cubes through the given walker.
pub fn mc_with<V, W: Walker<V>>(walker: &mut W, vol: &V, iso: Iso) -> (Mesh, WalkStats) {
    walk_with(walker, vol, iso, &MarchingCubes)
}

/// Extracts with `x` through the given walker (normals on).
pub fn walk_with<V, W: Walker<V>, X: Extractor + Sync>(walker: &mut W, vol: &V, iso: Iso, x: &X) -> (Mesh, WalkStats) {
    let mut out = MeshBuilder::new(Normals::Gradient);
    let stats = walker.walk(vol, iso, x, &mut out).expect("walk");
    (out.finish().expect("finish"), stats)
}

/// Marching cubes through the parallel Flying Edges walker.
pub fn fe<S: Sample>(g: &DenseGrid<S>, iso: Iso) -> (Mesh, WalkStats) {
    mc_with(&mut FlyingEdgesWalker::new(), &GridVolume::new(g), iso)
}

/// Marching cubes through the slab walker.
pub fn mc<V: Volume>(vol: &V, iso: Iso) -> Mesh {
    mc_with(&mut SlabWalker::new(), vol, iso).0
}

/// Marching cubes through the reference walker.
pub fn mc_reference<V: Volume>(vol: &V, iso: Iso) -> Mesh {
    mc_with(&mut ReferenceWalker, vol, iso).0
}

/// A grid from values in x-fastest order.
pub fn grid(dims: [u32; 3], values: Vec<f32>) -> DenseGrid<f32> {
    DenseGrid::new(Lattice::new(dims).unwrap(), values).unwrap()
}

/// Number of lattice edges whose ends differ in class (value < iso vs not).
pub fn crossed_edges(g: &DenseGrid<f32>, iso: f32) -> usize {
    let [nx, ny, nz] = g.lattice().dims();
    let mut n = 0;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let a = g.get([i, j, k]) < iso;
                for (di, dj, dk) in [(1, 0, 0), (0, 1, 0), (0, 0, 1)] {
                    let (x, y, z) = (i + di, j + dj, k + dk);
                    if x < nx && y < ny && z < nz && (g.get([x, y, z]) < iso) != a {
                        n += 1;
                    }
                }
            }
        }
    }
    n
}

/// Wraps a grid as a volume.
pub fn vol(g: &DenseGrid<f32>) -> GridVolume<'_, f32> {
    GridVolume::new(g)
}

/// splitmix64: a seeded stream for reproducible lattices.
pub struct Rng(pub u64);

impl Rng {
    /// The next 64 random bits.
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [−1, 1).
    pub fn uniform(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    }
    /// Uniform in 0..n.
    pub fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    /// True with probability 1/n.
    pub fn one_in(&mut self, n: u64) -> bool {
        self.below(n) == 0
    }
}

/// An integer-valued lattice (issue 10): small value ranges, an iso at an integer (values equal
/// to iso, outside by the tie rule) or halfway between two, and a border of outside points.
pub struct IntLattice {
    /// The lattice, border included; every value an integer.
    pub grid: DenseGrid<f32>,
    /// The iso (inside ⇔ value < iso).
    pub iso: f64,
    /// The seed that made it (`integer_lattice(&mut Rng(seed))` makes it again).
    pub seed: u64,
}

impl IntLattice {
    /// The values offset by iso (inside ⇔ < 0; exact for these small integers).
    pub fn offset(&self) -> DenseGrid<f32> {
        let iso = self.iso as f32;
        DenseGrid::from_fn(self.grid.lattice().clone(), |p| self.grid.get(p) - iso)
    }
}

impl std::fmt::Display for IntLattice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let d = self.grid.lattice().dims();
        let v: Vec<f32> = self.grid.data().to_vec();
        write!(f, "seed {:#x}: dims {d:?} (border included) iso {} values {v:?}", self.seed, self.iso)
    }
}

/// The integer lattices real scans are made of, in miniature: values in `0..=K` for a small K,
/// constant plateaus, and faces that repeat because the block is mirrored, repeated or transposed
/// (a cell next to its mirror image shares an ambiguous face with an identical decision on both
/// sides, and equal corner values make equal crossings, distances and saddle values).
///
/// `inner` bounds the points per axis inside the border (at least 2).
pub fn integer_lattice(seed: u64, inner: u32) -> IntLattice {
    let rng = &mut Rng(seed);
    let k = 1 + rng.below(4) as u32;
    let dims: [u32; 3] = [0; 3].map(|_| 2 + rng.below(u64::from(inner.max(2) - 1)) as u32);
    let at = |p: [u32; 3]| (p[0] + dims[0] * (p[1] + dims[1] * p[2])) as usize;
    let mut v: Vec<u32> = (0..dims.iter().product::<u32>()).map(|_| rng.below(u64::from(k) + 1) as u32).collect();
    // Plateaus: boxes of one value.
    for _ in 0..rng.below(3) {
        let lo = dims.map(|n| rng.below(u64::from(n)) as u32);
        let hi = [0, 1, 2].map(|a| lo[a] + rng.below(u64::from(dims[a] - lo[a])) as u32);
        let c = rng.below(u64::from(k) + 1) as u32;
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    v[at([x, y, z])] = c;
                }
            }
        }
    }
    // Symmetries, per axis: a mirror about the middle, a reflection wave (cells alternate with
    // their mirror images) or a repetition (identical cells side by side).
    let mut source: [Vec<u32>; 3] = dims.map(|n| (0..n).collect());
    for a in 0..3 {
        let n = dims[a];
        source[a] = match rng.below(5) {
            0 => (0..n).map(|i| i.min(n - 1 - i)).collect(),
            1 => {
                let p = 1 + rng.below(2) as u32;
                (0..n).map(|i| if (i / p).is_multiple_of(2) { i % p } else { p - i % p }).collect()
            }
            2 => {
                let p = 1 + rng.below(2) as u32;
                (0..n).map(|i| i % (p + 1)).collect()
            }
            _ => (0..n).collect(),
        };
    }
    let sym: Vec<u32> = (0..v.len())
        .map(|lin| {
            let l = lin as u32;
            let p = [l % dims[0], (l / dims[0]) % dims[1], l / (dims[0] * dims[1])];
            v[at([0, 1, 2].map(|a| source[a][p[a] as usize].min(dims[a] - 1)))]
        })
        .collect();
    v = sym;
    // A transposition: values symmetric under swapping two axes of equal length.
    if rng.one_in(4) {
        let (a, b) = [(0, 1), (1, 2), (0, 2)][rng.below(3) as usize];
        if dims[a] == dims[b] {
            for lin in 0..v.len() {
                let l = lin as u32;
                let p = [l % dims[0], (l / dims[0]) % dims[1], l / (dims[0] * dims[1])];
                if p[a] > p[b] {
                    let mut q = p;
                    q.swap(a, b);
                    v[lin] = v[at(q)];
                }
            }
        }
    }
    // An integer iso (values equal to it are outside) or one halfway between two values.
    let iso = if rng.one_in(2) { (1 + rng.below(u64::from(k))) as f64 } else { rng.below(u64::from(k)) as f64 + 0.5 };
    let outer = Lattice::new(dims.map(|d| d + 2)).unwrap();
    let border = (k + 1) as f32;
    let grid = DenseGrid::from_fn(outer, |p| {
        if p.iter().zip(dims).all(|(&x, d)| x >= 1 && x <= d) {
            v[at([p[0] - 1, p[1] - 1, p[2] - 1])] as f32
        } else {
            border
        }
    });
    IntLattice { grid, iso, seed }
}

/// Extracts with `method`'s extractor through the given walker, normals included.
pub fn walk_method<V, W: Walker<V>>(walker: &mut W, vol: &V, iso: Iso, method: Method) -> Mesh {
    let opts = isoforge::pipeline::Options { method, normals: Normals::Gradient, ..Default::default() };
    let mut out = MeshBuilder::new(Normals::Gradient);
    isoforge::pipeline::run(walker, vol, iso, &opts, &mut out).expect("walk");
    out.finish().expect("finish")
}

/// Vertex positions (bit patterns) sorted, and polygons as position tuples rotated to their
/// smallest vertex and sorted: a mesh up to vertex numbering and polygon order.
pub fn canonical(m: &Mesh) -> (Vec<[u32; 3]>, Vec<Vec<[u32; 3]>>) {
    let key = |v: u32| m.positions[v as usize].map(f32::to_bits);
    let mut verts: Vec<[u32; 3]> = m.positions.iter().map(|p| p.map(f32::to_bits)).collect();
    verts.sort_unstable();
    let mut polys: Vec<Vec<[u32; 3]>> = m
        .polygons()
        .map(|p| {
            let k: Vec<[u32; 3]> = p.iter().map(|&v| key(v)).collect();
            let at = (0..k.len()).min_by_key(|&i| k[i]).unwrap_or(0);
            k[at..].iter().chain(&k[..at]).copied().collect()
        })
        .collect();
    polys.sort_unstable();
    (verts, polys)
}

/// [`canonical`] with each vertex's normal (bit patterns) beside its position.
pub fn canonical_with_normals(m: &Mesh) -> (Vec<[u32; 6]>, Vec<Vec<[u32; 3]>>) {
    let mut verts: Vec<[u32; 6]> = (0..m.positions.len())
        .map(|v| {
            let (p, n) = (m.positions[v].map(f32::to_bits), m.normals.get(v).copied().unwrap_or_default());
            [p[0], p[1], p[2], n[0].to_bits(), n[1].to_bits(), n[2].to_bits()]
        })
        .collect();
    verts.sort_unstable();
    (verts, canonical(m).1)
}
