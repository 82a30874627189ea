//! The Flying Edges walker [Schroeder15]: marching cubes on a sampled grid in four passes over
//! x-rows, parallel over z-slabs, with output identical for every thread count.
//!
//! ```text
//! PASS 1 classify   every x-row → one bit per point (inside), in the sample's own type (AVX2 for f32)
//! PASS 2 count      every row (j, k) → crossed x-, y-, z-edges starting in it (popcounts of
//!                   XORed bit rows); every cell row → triangles (table counts of its active cells)
//! PASS 3 prefix     running sums → each row's first vertex and first triangle; exact allocation
//! PASS 4 fill       every slab in parallel writes its rows' vertices and triangles at those
//!                   offsets, no locks; an edge's vertex id = its row's base + its rank in the row
//! ```
//! Vertex order: rows in (k, j) order; within a row its x-edges by i, then y-edges, then z-edges.
//! Crossings and normals come from [`hermite`] on a [`GridVolume`], so every vertex is bit-identical
//! to the [`SlabWalker`](super::SlabWalker)'s; only the numbering differs.
//!
//! [`flying_edges_streaming`] runs the same passes over a window that slides up the volume (4 slabs
//! of samples, 3 of bits, 2 of row counts) and hands each slab's vertices and triangles to a
//! [`MeshSink`]: a volume larger than memory in O(nx·ny) memory, with the same output.

use super::{hermite, Progress, WalkStats};
use crate::error::{Error, Result};
use crate::extract::cube::{Axis, EdgeKey, CASE_EDGES};
use crate::grid::{DenseGrid, Lattice, Sample};
use crate::mesh::{huge_vec, Mesh, MeshBuilder};
use crate::volume::{GridVolume, Iso, Volume};

/// An extractor whose triangles depend on the case alone (a fixed table): what Flying Edges needs
/// to count triangles before creating them.
pub trait CaseTable: Sync {
    /// The triangles of `case` as cube-edge triples, wound outward.
    fn case_triangles(&self, case: u8) -> &[[u8; 3]];
}

/// Bit rows (one bit per point, set = inside): `words` u64 per row, for global rows
/// `row0 ..` (row index `k · ny + j`). The whole lattice in memory, a 3-slab window when streaming.
struct Bits {
    words: usize,
    row0: usize,
    data: Vec<u64>,
}

impl Bits {
    #[inline]
    fn row(&self, r: usize) -> &[u64] {
        let r = r - self.row0;
        &self.data[r * self.words..(r + 1) * self.words]
    }
}

/// Where PASS 4 reads samples, by global linear index.
trait Samples<S>: Sync {
    fn at(&self, lin: usize) -> S;
    fn prefetch(&self, lin: usize);
}

impl<S: Sample> Samples<S> for [S] {
    #[inline(always)]
    fn at(&self, lin: usize) -> S {
        self[lin]
    }
    #[inline(always)]
    fn prefetch(&self, lin: usize) {
        prefetch(&self[lin]);
    }
}

/// `a ^ (a >> 1)` across word boundaries: bit i set ⇔ points i and i + 1 differ.
#[inline]
fn x_crossings(row: &[u64], out: &mut [u64], cells: usize) {
    for w in 0..row.len() {
        let next = if w + 1 < row.len() { row[w + 1] << 63 } else { 0 };
        out[w] = row[w] ^ ((row[w] >> 1) | next);
    }
    mask_tail(out, cells);
}

/// Clears bits at and past `len`.
#[inline]
fn mask_tail(words: &mut [u64], len: usize) {
    let full = len / 64;
    if full < words.len() {
        let rem = len % 64;
        words[full] &= if rem == 0 { 0 } else { (1u64 << rem) - 1 };
        for w in &mut words[full + 1..] {
            *w = 0;
        }
    }
}

#[inline]
fn popcount(words: &[u64]) -> u32 {
    words.iter().map(|w| w.count_ones()).sum()
}

/// Per-row crossing masks with prefix popcounts, for vertex ranks.
struct RankedMask {
    mask: Vec<u64>,
    before: Vec<u32>,
}

impl RankedMask {
    fn new(words: usize) -> Self {
        RankedMask { mask: vec![0; words], before: vec![0; words] }
    }
    fn rank_prefix(&mut self) {
        let mut acc = 0;
        for (b, m) in self.before.iter_mut().zip(&self.mask) {
            *b = acc;
            acc += m.count_ones();
        }
    }
    /// Number of set bits below bit `i`.
    #[inline(always)]
    fn rank(&self, i: usize) -> u32 {
        let (w, b) = (i / 64, i % 64);
        self.before[w] + (self.mask[w] & ((1u64 << b) - 1)).count_ones()
    }
}

/// Counts of one row.
#[derive(Clone, Copy, Default)]
struct RowCount {
    x: u32,
    y: u32,
    z: u32,
    tris: u32,
}

/// Row counts and each row's first vertex id, for global rows `row0 ..`.
#[derive(Clone, Copy)]
struct RowTable<'a> {
    counts: &'a [RowCount],
    vbase: &'a [u64],
    row0: usize,
}

impl RowTable<'_> {
    #[inline(always)]
    fn count(&self, r: usize) -> RowCount {
        self.counts[r - self.row0]
    }
    #[inline(always)]
    fn vbase(&self, r: usize) -> u32 {
        self.vbase[r - self.row0] as u32
    }
}

/// Extracts the `iso` surface of `grid` with the triangle table of `table`.
///
/// Runs on the current rayon pool (all of it) when the `parallel` feature is on.
///
/// # Errors
/// [`Error::Limit`] when the mesh would exceed `u32` vertex indices.
pub fn flying_edges<S: Sample, T: CaseTable>(
    grid: &DenseGrid<S>,
    iso: Iso,
    table: &T,
    normals: bool,
) -> Result<(Mesh, WalkStats)> {
    let lattice = grid.lattice();
    let mut stats = WalkStats::default();
    if !lattice.has_cells() {
        return Ok((Mesh::default(), stats));
    }
    let [nx, ny, nz] = lattice.dims().map(|d| d as usize);
    let words = nx.div_ceil(64);
    let rows = ny * nz;
    let th = iso.threshold::<S>();
    let counts_of: [u8; 256] = std::array::from_fn(|c| table.case_triangles(c as u8).len() as u8);

    // PASS 1: classify every row.
    let mut bits = Bits { words, row0: 0, data: huge_vec(rows * words, 0u64) };
    let data = grid.data();
    for_each_slab(&mut bits.data, ny * words, |k, slab| {
        for (j, out) in slab.chunks_mut(words).enumerate() {
            let start = (k * ny + j) * nx;
            S::classify_row(&data[start..start + nx], th, out);
        }
    });

    // PASS 2: count vertices per row and triangles per cell row.
    let mut counts = vec![RowCount::default(); rows];
    let mut cell_stats = vec![[0u64; 2]; nz];
    {
        let bits = &bits;
        let counts_of = &counts_of;
        for_each_slab_with(&mut counts, ny, &mut cell_stats, |k, slab_counts, cs| {
            *cs = count_slab(bits, k, [nx, ny, nz], counts_of, slab_counts);
        });
    }
    stats.cells = ((nx - 1) * (ny - 1) * (nz - 1)) as u64;
    stats.cells_outside = cell_stats.iter().map(|c| c[0]).sum();
    stats.cells_inside = cell_stats.iter().map(|c| c[1]).sum();

    // PASS 3: prefix sums; exact allocation.
    let mut vbase = Vec::with_capacity(rows + 1);
    let mut tbase = Vec::with_capacity(rows + 1);
    let (mut v, mut t) = (0u64, 0u64);
    for c in &counts {
        vbase.push(v);
        tbase.push(t);
        v += (c.x + c.y + c.z) as u64;
        t += c.tris as u64;
    }
    vbase.push(v);
    tbase.push(t);
    if v > MeshBuilder::MAX_VERTICES {
        return Err(Error::Limit { what: "mesh vertices", requested: v, allowed: MeshBuilder::MAX_VERTICES });
    }
    let mut mesh = Mesh {
        positions: huge_vec(v as usize, [0.0; 3]),
        normals: if normals { huge_vec(v as usize, [0.0; 3]) } else { Vec::new() },
        triangles: huge_vec(t as usize, [0; 3]),
    };

    // PASS 4: fill, one task per slab, each owning its slices of the output.
    let vol = GridVolume::new(grid);
    let reverse = lattice.is_mirrored();
    let mut tasks = Vec::with_capacity(nz);
    {
        let (mut pos, mut nrm, mut tri) = (&mut mesh.positions[..], &mut mesh.normals[..], &mut mesh.triangles[..]);
        for k in 0..nz {
            let (v0, v1) = (vbase[k * ny], vbase[(k + 1) * ny]);
            let (t0, t1) = (tbase[k * ny], tbase[(k + 1) * ny]);
            let (p, rest) = pos.split_at_mut((v1 - v0) as usize);
            pos = rest;
            let (n, rest) = if normals { nrm.split_at_mut((v1 - v0) as usize) } else { (&mut [][..], nrm) };
            nrm = rest;
            let (tr, rest) = tri.split_at_mut((t1 - t0) as usize);
            tri = rest;
            tasks.push((k, p, n, tr));
        }
    }
    let ctx = Fill {
        bits: &bits,
        rows: RowTable { counts: &counts, vbase: &vbase, row0: 0 },
        vol: &vol,
        iso,
        table,
        nx,
        ny,
        nz,
        reverse,
        data,
        _sample: std::marker::PhantomData,
    };
    run_tasks(tasks, |(k, p, n, tr)| ctx.slab(k, p, n, tr));
    Ok((mesh, stats))
}

/// When row `r` = (j, k) and its neighbours (j+1, k), (j, k+1), (j+1, k+1) (those that exist)
/// are all entirely outside (0) or all entirely inside (1), that class: the row starts no crossed
/// edge and its cell row has no active cell.
#[inline]
fn uniform_block(bits: &Bits, r: usize, j: usize, k: usize, ny: usize, nz: usize, nx: usize) -> Option<u8> {
    let a = bits.row(r);
    let full = |w: usize| cell_mask(w, nx);
    let class = if a[0] & 1 == 1 { 1u8 } else { 0 };
    let want = |w: usize| if class == 1 { full(w) } else { 0 };
    let same = |row: &[u64]| row.iter().enumerate().all(|(w, &x)| x == want(w));
    if !same(a) {
        return None;
    }
    if j + 1 < ny && !same(bits.row(r + 1)) {
        return None;
    }
    if k + 1 < nz && !same(bits.row(r + ny)) {
        return None;
    }
    if j + 1 < ny && k + 1 < nz && !same(bits.row(r + ny + 1)) {
        return None;
    }
    Some(class)
}

/// PASS 2 for slab k: each row's crossed-edge counts and each cell row's triangle count, from the
/// bits of slabs k and k + 1. Returns the all-outside and all-inside cell counts.
fn count_slab(bits: &Bits, k: usize, dims: [usize; 3], counts_of: &[u8; 256], out: &mut [RowCount]) -> [u64; 2] {
    let [nx, ny, nz] = dims;
    let mut cs = [0u64; 2];
    let mut scratch = Scratch::new(bits.words);
    for (j, c) in out.iter_mut().enumerate() {
        let r = k * ny + j;
        *c = RowCount::default();
        if let Some(class) = uniform_block(bits, r, j, k, ny, nz, nx) {
            // No crossing in or out of this row and its cell row: only cell counts.
            if j + 1 < ny && k + 1 < nz {
                cs[class as usize] += (nx - 1) as u64;
            }
            continue;
        }
        x_crossings(bits.row(r), &mut scratch.x.mask, nx - 1);
        c.x = popcount(&scratch.x.mask);
        c.y = if j + 1 < ny { xor_count(bits.row(r), bits.row(r + 1)) } else { 0 };
        c.z = if k + 1 < nz { xor_count(bits.row(r), bits.row(r + ny)) } else { 0 };
        if j + 1 < ny && k + 1 < nz {
            let (tris, outside, inside) = scratch.count_cells(bits, r, ny, nx, counts_of);
            c.tris = tris;
            cs[0] += outside;
            cs[1] += inside;
        }
    }
    cs
}

#[inline]
fn xor_count(a: &[u64], b: &[u64]) -> u32 {
    a.iter().zip(b).map(|(x, y)| (x ^ y).count_ones()).sum()
}

/// Per-task buffers for one cell row's four bit rows.
struct Scratch {
    x: RankedMask,
    active: Vec<u64>,
}

impl Scratch {
    fn new(words: usize) -> Self {
        Scratch { x: RankedMask::new(words), active: vec![0; words] }
    }

    /// Marks the active cells of cell row `r` = (j, k) in `self.active`; returns the all-outside
    /// and all-inside cell counts.
    ///
    /// A cell is inactive iff its 8 corners agree: both of its columns are uniform (the four rows
    /// agree at i and at i + 1) and row A agrees between i and i + 1.
    fn mark_active(&mut self, bits: &Bits, r: usize, ny: usize, nx: usize) -> (u64, u64) {
        let (a, b, c, e) = (bits.row(r), bits.row(r + 1), bits.row(r + ny), bits.row(r + ny + 1));
        let words = a.len();
        let column = |w: usize| (a[w] ^ b[w]) | (a[w] ^ c[w]) | (a[w] ^ e[w]);
        let (mut outside, mut inside) = (0u64, 0u64);
        for w in 0..words {
            let d = column(w);
            let next_d = if w + 1 < words { column(w + 1) << 63 } else { 0 };
            let next_a = if w + 1 < words { a[w + 1] << 63 } else { 0 };
            let a_shift = (a[w] >> 1) | next_a;
            self.active[w] = d | (d >> 1) | next_d | (a[w] ^ a_shift);
        }
        mask_tail(&mut self.active, nx - 1);
        for w in 0..words {
            let cells = cell_mask(w, nx - 1);
            let idle = !self.active[w] & cells;
            inside += (idle & a[w]).count_ones() as u64;
            outside += (idle & !a[w]).count_ones() as u64;
        }
        (outside, inside)
    }

    fn count_cells(&mut self, bits: &Bits, r: usize, ny: usize, nx: usize, counts_of: &[u8; 256]) -> (u32, u64, u64) {
        let (outside, inside) = self.mark_active(bits, r, ny, nx);
        let mut tris = 0u32;
        let rows = [bits.row(r), bits.row(r + 1), bits.row(r + ny), bits.row(r + ny + 1)];
        for_each_bit(&self.active, |i| tris += counts_of[case_at(&rows, i) as usize] as u32);
        (tris, outside, inside)
    }
}

/// Mask of the valid cells (bits < `cells`) in word `w`.
#[inline]
fn cell_mask(w: usize, cells: usize) -> u64 {
    let lo = w * 64;
    if lo + 64 <= cells {
        !0
    } else if lo >= cells {
        0
    } else {
        (1u64 << (cells - lo)) - 1
    }
}

/// The case of cell i from rows A = (j, k), B = (j+1, k), C = (j, k+1), E = (j+1, k+1):
/// corner c = x + 2y + 4z (see extract/cube.rs).
#[inline(always)]
fn case_at(rows: &[&[u64]; 4], i: usize) -> u8 {
    let (w, b) = (i / 64, i % 64);
    let mut case = 0u8;
    for (q, row) in rows.iter().enumerate() {
        // Bits i and i + 1 of the row, possibly straddling two words.
        let pair = if b < 63 { row[w] >> b } else { (row[w] >> 63) | (row[w + 1] << 1) };
        case |= ((pair & 3) as u8) << (2 * q);
    }
    case
}

#[inline(always)]
fn for_each_bit(words: &[u64], mut f: impl FnMut(usize)) {
    for (w, &word) in words.iter().enumerate() {
        let mut m = word;
        while m != 0 {
            let b = m.trailing_zeros() as usize;
            f(w * 64 + b);
            m &= m - 1;
        }
    }
}

/// What PASS 4 needs, shared by all tasks.
struct Fill<'a, S, T, D: ?Sized, V> {
    bits: &'a Bits,
    rows: RowTable<'a>,
    vol: &'a V,
    iso: Iso,
    table: &'a T,
    nx: usize,
    ny: usize,
    nz: usize,
    reverse: bool,
    data: &'a D,
    _sample: std::marker::PhantomData<S>,
}

impl<S: Sample, T: CaseTable, D: Samples<S> + ?Sized, V: Volume + Sync> Fill<'_, S, T, D, V> {
    fn slab(&self, k: usize, pos: &mut [[f32; 3]], nrm: &mut [[f32; 3]], tris: &mut [[u32; 3]]) {
        let (nx, ny) = (self.nx, self.ny);
        let words = self.bits.words;
        let normals = !nrm.is_empty();
        let mut out_v = 0usize;
        let mut scratch = Scratch::new(words);
        let mut ymask = vec![0u64; words];
        let mut emit = |key: EdgeKey, lin0: usize, lin1: usize, out_v: &mut usize| {
            let (d0, d1) = (self.iso.offset(self.data.at(lin0).to_f64()), self.iso.offset(self.data.at(lin1).to_f64()));
            let h = hermite(self.vol, key, d0, d1, self.iso, normals);
            pos[*out_v] = h.point;
            if normals {
                nrm[*out_v] = h.normal;
            }
            *out_v += 1;
        };
        // Vertices of the slab's rows: x-edges, then y-edges, then z-edges of each row. The samples
        // a row needs are scattered (sparse surfaces) and the hardware cannot guess them; their
        // positions are known from the bits, so they are prefetched PREFETCH_ROWS rows ahead.
        for j in 0..PREFETCH_ROWS.min(ny) {
            self.prefetch_row(k, j, &mut ymask);
        }
        for j in 0..ny {
            if j + PREFETCH_ROWS < ny {
                self.prefetch_row(k, j + PREFETCH_ROWS, &mut ymask);
            }
            let r = k * ny + j;
            let lin = r * nx;
            let (jj, kk) = (j as u32, k as u32);
            x_crossings(self.bits.row(r), &mut scratch.x.mask, nx - 1);
            for_each_bit(&scratch.x.mask, |i| {
                emit(EdgeKey { origin: [i as u32, jj, kk], axis: Axis::X }, lin + i, lin + i + 1, &mut out_v)
            });
            if j + 1 < ny {
                xor_into(self.bits.row(r), self.bits.row(r + 1), &mut ymask);
                for_each_bit(&ymask, |i| {
                    emit(EdgeKey { origin: [i as u32, jj, kk], axis: Axis::Y }, lin + i, lin + i + nx, &mut out_v)
                });
            }
            if k + 1 < self.nz {
                xor_into(self.bits.row(r), self.bits.row(r + ny), &mut ymask);
                for_each_bit(&ymask, |i| {
                    emit(EdgeKey { origin: [i as u32, jj, kk], axis: Axis::Z }, lin + i, lin + i + nx * ny, &mut out_v)
                });
            }
        }
        debug_assert_eq!(out_v, pos.len());
        if k + 1 >= self.nz {
            return;
        }
        // Triangles of the cell rows of layer k.
        let mut ranked = RowMasks::new(words);
        let mut out_t = 0usize;
        for j in 0..ny - 1 {
            let r = k * ny + j;
            if self.rows.count(r).tris == 0 {
                continue;
            }
            scratch.mark_active(self.bits, r, ny, nx);
            ranked.load(self.bits, r, ny, nx, self.rows);
            let rows = [self.bits.row(r), self.bits.row(r + 1), self.bits.row(r + ny), self.bits.row(r + ny + 1)];
            let mut ids = [0u32; 12];
            for_each_bit(&scratch.active, |i| {
                let case = case_at(&rows, i);
                // Each crossed edge's id once per cell; triangles then only look them up.
                let mut crossed = CASE_EDGES[case as usize];
                while crossed != 0 {
                    let e = crossed.trailing_zeros() as u8;
                    let (slot, off) = EDGE_SLOT[e as usize];
                    ids[e as usize] = ranked.base[slot as usize] + ranked.masks[slot as usize].rank(i + off as usize);
                    crossed &= crossed - 1;
                }
                for t in self.table.case_triangles(case) {
                    let (a, b, c) = (ids[t[0] as usize], ids[t[1] as usize], ids[t[2] as usize]);
                    tris[out_t] = if self.reverse { [a, c, b] } else { [a, b, c] };
                    out_t += 1;
                }
            });
        }
        debug_assert_eq!(out_t, tris.len());
    }
}

impl<S: Sample, T: CaseTable, D: Samples<S> + ?Sized, V: Volume + Sync> Fill<'_, S, T, D, V> {
    /// Prefetches the samples that row (j, k)'s crossings will read: rows (j, k), (j + 1, k) and
    /// (j, k + 1) around every point where an edge starting in row (j, k) crosses.
    #[inline]
    fn prefetch_row(&self, k: usize, j: usize, union: &mut [u64]) {
        let (nx, ny) = (self.nx, self.ny);
        let r = k * ny + j;
        let a = self.bits.row(r);
        for w in 0..union.len() {
            let next = if w + 1 < a.len() { a[w + 1] << 63 } else { 0 };
            let mut m = a[w] ^ ((a[w] >> 1) | next) | (a[w] << 1 ^ a[w]);
            if j + 1 < ny {
                m |= a[w] ^ self.bits.row(r + 1)[w];
            }
            if k + 1 < self.nz {
                m |= a[w] ^ self.bits.row(r + ny)[w];
            }
            union[w] = m;
        }
        let lin = r * nx;
        let mut last_line = usize::MAX;
        for_each_bit(union, |i| {
            let i = i.min(nx - 1);
            // One prefetch per 64-byte line of the row.
            let line = i * std::mem::size_of::<S>() / 64;
            if line == last_line {
                return;
            }
            last_line = line;
            self.data.prefetch(lin + i);
            if j + 1 < ny {
                self.data.prefetch(lin + nx + i);
            }
            if k + 1 < self.nz {
                self.data.prefetch(lin + nx * ny + i);
            }
        });
    }
}

/// Rows of look-ahead for the sample prefetch (enough to cover memory latency on sparse rows).
const PREFETCH_ROWS: usize = 2;

#[inline(always)]
fn prefetch<S>(x: &S) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint; it never faults and does not read the value into a register.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>((x as *const S).cast::<i8>());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}

/// For each cube edge: the mask slot holding its row's crossings (see [`RowMasks`]) and the offset
/// of its lower point from the cell's i.
const EDGE_SLOT: [(u8, u8); 12] = {
    let mut t = [(0u8, 0u8); 12];
    let mut e = 0;
    while e < 12 {
        let (lo, hi) = ((e & 1) as u8, ((e >> 1) & 1) as u8);
        t[e] = match e / 4 {
            0 => (lo + 2 * hi, 0), // x-edge at (y = lo, z = hi): rows A, B, C, E → slots 0–3
            1 => (4 + hi, lo),     // y-edge at (x = lo, z = hi): rows A, C → slots 4, 5
            _ => (6 + hi, lo),     // z-edge at (x = lo, y = hi): rows A, B → slots 6, 7
        };
        e += 1;
    }
    t
};

#[inline]
fn xor_into(a: &[u64], b: &[u64], out: &mut [u64]) {
    for ((o, x), y) in out.iter_mut().zip(a).zip(b) {
        *o = x ^ y;
    }
}

/// Ranked crossing masks of a cell row and the id of each mask's first vertex, by slot:
/// 0–3 x-edges of rows A, B, C, E; 4–5 y-edges of rows A, C; 6–7 z-edges of rows A, B.
struct RowMasks {
    masks: [RankedMask; 8],
    base: [u32; 8],
}

impl RowMasks {
    fn new(words: usize) -> Self {
        RowMasks { masks: std::array::from_fn(|_| RankedMask::new(words)), base: [0; 8] }
    }

    fn load(&mut self, bits: &Bits, r: usize, ny: usize, nx: usize, rows: RowTable) {
        let row_of = [r, r + 1, r + ny, r + ny + 1];
        let (vbase, counts) = (|r: usize| rows.vbase(r), |r: usize| rows.count(r));
        for q in 0..4 {
            x_crossings(bits.row(row_of[q]), &mut self.masks[q].mask, nx - 1);
            self.base[q] = vbase(row_of[q]);
        }
        // y-edges of A = (j, k) and C = (j, k + 1), after their rows' x-edges.
        for (h, row) in [r, r + ny].into_iter().enumerate() {
            xor_into(bits.row(row), bits.row(row + 1), &mut self.masks[4 + h].mask);
            self.base[4 + h] = vbase(row) + counts(row).x;
        }
        // z-edges of A = (j, k) and B = (j + 1, k), after their rows' x- and y-edges.
        for (h, row) in [r, r + 1].into_iter().enumerate() {
            xor_into(bits.row(row), bits.row(row + ny), &mut self.masks[6 + h].mask);
            self.base[6 + h] = vbase(row) + counts(row).x + counts(row).y;
        }
        for m in &mut self.masks {
            m.rank_prefix();
        }
    }
}

/// Calls `f(k, slab)` for each of the `data.len() / per` slabs, in parallel when enabled.
fn for_each_slab<D: Send>(data: &mut [D], per: usize, f: impl Fn(usize, &mut [D]) + Sync) {
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        data.par_chunks_mut(per).enumerate().for_each(|(k, s)| f(k, s));
    }
    #[cfg(not(feature = "parallel"))]
    data.chunks_mut(per).enumerate().for_each(|(k, s)| f(k, s));
}

/// As [`for_each_slab`], with one extra per-slab accumulator.
fn for_each_slab_with<D: Send, A: Send>(
    data: &mut [D],
    per: usize,
    acc: &mut [A],
    f: impl Fn(usize, &mut [D], &mut A) + Sync,
) {
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        data.par_chunks_mut(per).zip(acc.par_iter_mut()).enumerate().for_each(|(k, (s, a))| f(k, s, a));
    }
    #[cfg(not(feature = "parallel"))]
    data.chunks_mut(per).zip(acc.iter_mut()).enumerate().for_each(|(k, (s, a))| f(k, s, a));
}

fn run_tasks<X: Send>(tasks: Vec<X>, f: impl Fn(X) + Sync) {
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        tasks.into_par_iter().for_each(&f);
    }
    #[cfg(not(feature = "parallel"))]
    tasks.into_iter().for_each(f);
}

/// An error from a [`SlabSource`] or a [`MeshSink`] (file I/O, decoding).
pub type ExternalError = Box<dyn std::error::Error + Send + Sync>;

/// Supplies a volume's z-slabs in order (k = 0, 1, …), nx·ny samples each, x fastest.
pub trait SlabSource<S> {
    /// The lattice of the whole volume.
    fn lattice(&self) -> &Lattice;
    /// Writes the next slab into `out`.
    ///
    /// # Errors
    /// Whatever reading the slab fails with.
    fn read_slab(&mut self, out: &mut [S]) -> std::result::Result<(), ExternalError>;
}

/// Receives a mesh as it is produced, slab by slab. Vertices are numbered from 0 in arrival
/// order; a call's triangles may refer to vertices of the next call (those of the slab above).
pub trait MeshSink {
    /// Takes the next vertices (and normals, empty when off) and triangles.
    ///
    /// # Errors
    /// Whatever writing fails with.
    fn push(
        &mut self,
        positions: &[[f32; 3]],
        normals: &[[f32; 3]],
        triangles: &[[u32; 3]],
    ) -> std::result::Result<(), ExternalError>;
}

/// Counts of a streamed extraction.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StreamStats {
    /// Cell counts, as for an in-memory walk.
    pub walk: WalkStats,
    /// Vertices pushed.
    pub vertices: u64,
    /// Triangles pushed.
    pub triangles: u64,
}

/// Out-of-core Flying Edges: reads `src` one slab at a time and pushes the mesh to `sink` as it is
/// produced, keeping O(nx·ny) state (4 slabs of samples, 3 of bits, 2 of row counts). The vertices
/// and triangles arrive in exactly the order [`flying_edges`] stores them, with the same values.
///
/// # Errors
/// [`Error::External`] from the source or the sink; [`Error::Limit`] past `u32` vertex indices.
pub fn flying_edges_streaming<S: Sample, T: CaseTable>(
    src: &mut dyn SlabSource<S>,
    iso: Iso,
    table: &T,
    normals: bool,
    sink: &mut dyn MeshSink,
    progress: Option<&dyn Progress>,
) -> Result<StreamStats> {
    let lattice = src.lattice().clone();
    let mut out = StreamStats::default();
    if !lattice.has_cells() {
        return Ok(out);
    }
    let [nx, ny, nz] = lattice.dims().map(|d| d as usize);
    let words = nx.div_ceil(64);
    let slab_len = nx * ny;
    let th = iso.threshold::<S>();
    let counts_of: [u8; 256] = std::array::from_fn(|c| table.case_triangles(c as u8).len() as u8);
    let mut ring = SlabRing {
        slabs: std::array::from_fn(|_| vec![S::from_f64(0.0); slab_len]),
        slab_len,
        lattice: lattice.clone(),
    };
    let mut bits = Bits { words, row0: 0, data: vec![0u64; 3 * ny * words] };
    let external = |e: ExternalError| Error::External(e);

    // Reads slab k into the ring and classifies it into the bit window.
    let mut load = |k: usize, ring: &mut SlabRing<S>, bits: &mut Bits| -> Result<()> {
        let slot = &mut ring.slabs[k % 4];
        src.read_slab(slot).map_err(external)?;
        let at = (k * ny - bits.row0) * words;
        for (j, row) in bits.data[at..at + ny * words].chunks_mut(words).enumerate() {
            S::classify_row(&slot[j * nx..(j + 1) * nx], th, row);
        }
        Ok(())
    };
    for k in 0..nz.min(3) {
        load(k, &mut ring, &mut bits)?;
    }

    // Row counts and first vertex ids of slabs k (first ny) and k + 1 (next ny).
    let mut counts = vec![RowCount::default(); 2 * ny];
    let mut vbase = vec![0u64; 2 * ny];
    let mut next_vertex = 0u64;
    let count = |k: usize,
                 half: usize,
                 counts: &mut [RowCount],
                 vbase: &mut [u64],
                 bits: &Bits,
                 out: &mut StreamStats,
                 next: &mut u64| {
        let part = &mut counts[half * ny..(half + 1) * ny];
        let cs = count_slab(bits, k, [nx, ny, nz], &counts_of, part);
        out.walk.cells_outside += cs[0];
        out.walk.cells_inside += cs[1];
        for (j, c) in part.iter().enumerate() {
            vbase[half * ny + j] = *next;
            *next += (c.x + c.y + c.z) as u64;
        }
    };
    count(0, 0, &mut counts, &mut vbase, &bits, &mut out, &mut next_vertex);
    let (mut pos, mut nrm, mut tri) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..nz {
        if k + 1 < nz {
            count(k + 1, 1, &mut counts, &mut vbase, &bits, &mut out, &mut next_vertex);
        }
        if next_vertex > MeshBuilder::MAX_VERTICES {
            return Err(Error::Limit {
                what: "mesh vertices",
                requested: next_vertex,
                allowed: MeshBuilder::MAX_VERTICES,
            });
        }
        // PASS 4 for slab k, into reused buffers sized from the counts.
        let nv: usize = counts[..ny].iter().map(|c| (c.x + c.y + c.z) as usize).sum();
        let nt: usize = counts[..ny].iter().map(|c| c.tris as usize).sum();
        pos.clear();
        pos.resize(nv, [0.0; 3]);
        nrm.clear();
        nrm.resize(if normals { nv } else { 0 }, [0.0; 3]);
        tri.clear();
        tri.resize(nt, [0u32; 3]);
        let fill = Fill {
            bits: &bits,
            rows: RowTable { counts: &counts, vbase: &vbase, row0: k * ny },
            vol: &ring,
            iso,
            table,
            nx,
            ny,
            nz,
            reverse: lattice.is_mirrored(),
            data: &ring,
            _sample: std::marker::PhantomData,
        };
        fill.slab(k, &mut pos, &mut nrm, &mut tri);
        sink.push(&pos, &nrm, &tri).map_err(external)?;
        out.vertices += nv as u64;
        out.triangles += nt as u64;
        // Slide the windows up one slab.
        counts.copy_within(ny.., 0);
        vbase.copy_within(ny.., 0);
        bits.data.copy_within(ny * words.., 0);
        bits.row0 += ny;
        if k + 3 < nz {
            load(k + 3, &mut ring, &mut bits)?;
        }
        if let Some(p) = progress {
            p.advance(k as u64 + 1, nz as u64);
        }
    }
    out.walk.cells = ((nx - 1) * (ny - 1) * (nz - 1)) as u64;
    Ok(out)
}

/// Four consecutive slabs k − 1 … k + 2 of a streamed volume, slab k in slot k mod 4; indices
/// are global, so crossings and normals are computed exactly as on the whole grid.
struct SlabRing<S> {
    slabs: [Vec<S>; 4],
    slab_len: usize,
    lattice: Lattice,
}

impl<S: Sample> SlabRing<S> {
    #[inline(always)]
    fn get(&self, lin: usize) -> S {
        self.slabs[(lin / self.slab_len) % 4][lin % self.slab_len]
    }
}

impl<S: Sample> Samples<S> for SlabRing<S> {
    #[inline(always)]
    fn at(&self, lin: usize) -> S {
        self.get(lin)
    }
    #[inline(always)]
    fn prefetch(&self, lin: usize) {
        prefetch(&self.slabs[(lin / self.slab_len) % 4][lin % self.slab_len]);
    }
}

impl<S: Sample> Volume for SlabRing<S> {
    fn lattice(&self) -> &Lattice {
        &self.lattice
    }
    fn fill_slab(&self, k: u32, iso: Iso, out: &mut [f32]) {
        for (o, v) in out.iter_mut().zip(&self.slabs[k as usize % 4]) {
            *o = iso.offset(v.to_f64());
        }
    }
    #[inline]
    fn crossing(&self, _e: EdgeKey, d0: f32, d1: f32, _iso: Iso) -> f32 {
        crate::volume::linear_crossing(d0, d1)
    }
    fn gradient(&self, e: EdgeKey, t: f32) -> glam::Vec3 {
        crate::volume::edge_gradient(&self.lattice, e, t, &|p| self.get(self.lattice.linear(p)).to_f64())
    }
    fn value_at(&self, p: [f64; 3], iso: Iso) -> f32 {
        let v = crate::volume::trilinear_value(self.lattice.dims(), p, &|q| self.get(self.lattice.linear(q)).to_f64());
        iso.offset(v)
    }
    fn gradient_at(&self, p: [f64; 3]) -> glam::Vec3 {
        crate::volume::point_gradient_at(&self.lattice, p, &|q| self.get(self.lattice.linear(q)).to_f64())
    }
}
