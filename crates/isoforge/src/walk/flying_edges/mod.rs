//! The Flying Edges walker \[Schroeder15\]: any extractor on sampled grids, in passes over x-rows,
//! parallel over z-slabs, with output identical for every thread count.
//!
//! ```text
//! PASS 1 classify   every x-row → one bit per point (inside), in the sample's own type (AVX2 for f32);
//!                   blocks whose bounds exclude the iso are set without reading their samples
//! PASS 2 count      every row (j, k) → crossed x-, y-, z-edges starting in it (popcounts of XORed
//!                   bit rows); every cell row → its active cells' triangles, quads and placed
//!                   vertices (the extractor's counts: a table per case, the values where the
//!                   case does not decide; those cells' decisions are kept for the fill)
//! PASS 3 prefix     running sums → each row's first vertex, each plane's first vertex, triangle
//!                   and quad; exact allocation
//! PASS 4 fill       every slab in parallel writes its rows' vertices and its cells' polygons at
//!                   those offsets, no locks; an edge's vertex id = its row's base + its rank in
//!                   the row, kept by one running counter per row slot over the active cells
//!                   (`bits::SegmentRun`); the extractor sees each active cell through `Cell`
//!                   (with its count-pass decision: `Extractor::process_decided`)
//! ```
//! Vertex order: rows in (k, j) order; within a row its x-edges by i, then y-edges, then z-edges,
//! then the vertices its cells place. Crossings and normals come from the shared
//! [`edge_crossing`](super::edge_crossing) on the volume, so every vertex is bit-identical to the
//! [`SlabWalker`](super::SlabWalker)'s; only the numbering differs.
//!
//! Extractors whose output is not known before processing ([`Counting::Unknown`]: tetrahedra,
//! dual methods) run on the same slab partition: fixed groups of cell layers are walked in
//! parallel (active cells from the bits), each into its own mesh, and the meshes are stitched by
//! vertex key in group order (`keyed.rs`).
//!
//! [`stream`](FlyingEdgesWalker::stream) runs the same passes on a window that slides up a
//! [`SlabSource`](crate::volume::SlabSource) (5 slabs of samples, 3 of bits, 2 of row counts)
//! and hands each slab's vertices and polygons to a [`MeshSink`](crate::mesh::MeshSink): a volume
//! larger than memory in O(nx·ny) memory, with the same output.

mod bcc;
mod bits;
mod classify;
mod count;
mod families;
mod fill;
mod keyed;
mod stream;

pub use stream::StreamStats;

use self::bits::Bits;
use self::count::{CaseCounts, RowCount};
use self::families::Walked;
use self::fill::{fill_planes, FillOut, RowTable};
use super::{range_of, Progress, WalkStats, Walker};
use crate::cube::{CellRange, VertexKey};
use crate::error::{Error, Result};
use crate::extract::{Counting, Extractor};
use crate::grid::Sample;
use crate::mesh::{huge_vec, KeyRecord, MeshBuilder};
use crate::volume::{Iso, SampleSlabs, Volume};

/// The parallel walker for sampled grids (and streamed slabs): see the module documentation.
///
/// Runs on the current rayon pool (the `parallel` feature); the mesh is the same for every
/// thread count, byte for byte.
#[derive(Default, Clone, Copy)]
pub struct FlyingEdgesWalker<'p> {
    range: Option<CellRange>,
    progress: Option<&'p dyn Progress>,
}

impl<'p> FlyingEdgesWalker<'p> {
    /// A walker over the whole lattice.
    pub fn new() -> Self {
        FlyingEdgesWalker::default()
    }

    /// Walks only the cells of `range` (global lattice indices).
    pub fn with_range(mut self, range: CellRange) -> Self {
        self.range = Some(range);
        self
    }

    /// Reports progress once per slab.
    pub fn with_progress(mut self, progress: &'p dyn Progress) -> Self {
        self.progress = Some(progress);
        self
    }
}

/// The box of points a walk reads: the corners of its range's cells (and, for extractors that
/// place vertices, of the cells just before it). Rows and planes are box-local from here on.
#[derive(Debug, Clone, Copy)]
struct PointBox {
    /// Global index of the first point.
    lo: [u32; 3],
    /// Points per axis.
    dims: [usize; 3],
    /// The sample box of the volume (first point, points per x-row and per slab).
    s_lo: [u32; 3],
    s_nx: usize,
}

impl PointBox {
    /// The points of `cells`' corners, checked against the volume's samples.
    fn of<V: SampleSlabs>(vol: &V, first: [u32; 3], cells: &CellRange) -> Result<Self> {
        let (s_lo, s_dims) = vol.sample_box();
        let hi = cells.hi; // the last point on each axis (inclusive)
        for a in 0..3 {
            if first[a] < s_lo[a] || hi[a] >= s_lo[a] + s_dims[a] {
                return Err(Error::InvalidInput(format!(
                    "cells {:?}..{:?} need points {first:?}..={hi:?}, the samples hold {s_lo:?} and {s_dims:?} more",
                    cells.lo, cells.hi
                )));
            }
        }
        Ok(PointBox {
            lo: first,
            dims: [0, 1, 2].map(|a| (hi[a] - first[a] + 1) as usize),
            s_lo,
            s_nx: s_dims[0] as usize,
        })
    }

    /// Global index of box-local point `l`.
    #[inline(always)]
    fn global(&self, l: [usize; 3]) -> [u32; 3] {
        [0, 1, 2].map(|a| self.lo[a] + l[a] as u32)
    }

    /// Index in a slab of the volume of box-local point `(i, j)`.
    #[inline(always)]
    fn in_slab(&self, i: usize, j: usize) -> usize {
        (self.lo[1] - self.s_lo[1]) as usize * self.s_nx + j * self.s_nx + (self.lo[0] - self.s_lo[0]) as usize + i
    }

    /// Stride between neighbouring rows of a slab.
    #[inline(always)]
    fn row_stride(&self) -> usize {
        self.s_nx
    }

    /// Words of one bit row.
    fn words(&self) -> usize {
        self.dims[0].div_ceil(64)
    }
}

/// The offset values of the eight corners of box-local cell `[i, j, k]` ([`Iso::cell_offsets`]:
/// scaled together when one lies beyond `f32`'s range).
#[inline]
fn cell_values<V: SampleSlabs>(vol: &V, bx: &PointBox, iso: Iso, [i, j, k]: [usize; 3]) -> [f32; 8] {
    let z = bx.lo[2] + k as u32;
    let (s0, s1) = (vol.slab(z), vol.slab(z + 1));
    let (a, b) = (bx.in_slab(i, j), bx.in_slab(i, j + 1));
    let v = |s: &[V::Sample], at: usize| s[at].to_f64();
    iso.cell_offsets([v(s0, a), v(s0, a + 1), v(s0, b), v(s0, b + 1), v(s1, a), v(s1, a + 1), v(s1, b), v(s1, b + 1)])
}

/// The volume as the extractor's side of the passes sees it (the count pass, the cells of the
/// fill, keyed walks): a trait object, asked once per cell those passes decide from values or
/// hand to `process`, and per crossing a keyed walk makes (never per table cell or per sample).
/// So those passes are compiled once per extractor, and the volume's side (classification, the
/// fill's vertex rows, mt-bcc's tables) once per volume type: a walk compiles volumes +
/// extractors copies, not volumes × extractors.
trait CellSamples: Volume + Sync {
    /// The offset values of the eight corners of box-local cell `l` ([`cell_values`]).
    fn cell_values(&self, bx: &PointBox, iso: Iso, l: [usize; 3]) -> [f32; 8];
    /// The offset value at the centre of box-local cell `l` (`keyed::centre_value`).
    fn centre_value(&self, bx: &PointBox, iso: Iso, l: [usize; 3]) -> f32;
    /// [`SampleSlabs::centres_from_samples`].
    fn centres_from_samples(&self) -> bool;
}

impl<V: SampleSlabs + Sync> CellSamples for V {
    fn cell_values(&self, bx: &PointBox, iso: Iso, l: [usize; 3]) -> [f32; 8] {
        cell_values(self, bx, iso, l)
    }
    fn centre_value(&self, bx: &PointBox, iso: Iso, l: [usize; 3]) -> f32 {
        keyed::centre_value(self, bx, iso, l)
    }
    fn centres_from_samples(&self) -> bool {
        SampleSlabs::centres_from_samples(self)
    }
}

/// A volume seen by the extractor's side of the passes.
type Cells<'a> = dyn CellSamples + 'a;

/// What every pass of one walk shares. The volume's side of the passes runs on `Passes<V, ()>`,
/// the extractor's on `Passes<Cells, X>` (see [`CellSamples`]).
struct Passes<'a, V: ?Sized, X> {
    vol: &'a V,
    x: &'a X,
    iso: Iso,
    bx: PointBox,
    table: &'a CaseCounts,
    /// The segment families rows number, and the crossed cell segments of each case and parity.
    walked: Walked,
    crossed: &'a [[u32; 2]; 256],
    /// The walked range (the box may start one cell earlier, for placing extractors).
    range: CellRange,
    /// Mirrored lattice: polygons are reversed so they stay counter-clockwise from outside.
    reverse: bool,
    normals: bool,
    record: KeyRecord,
}

impl<V: SampleSlabs + Sync> Walker<V> for FlyingEdgesWalker<'_> {
    fn walk<X: Extractor + Sync>(&mut self, vol: &V, iso: Iso, x: &X, out: &mut MeshBuilder) -> Result<WalkStats> {
        walk_in_memory(self, vol, iso, x, out)
    }
}

fn walk_in_memory<V: SampleSlabs + Sync, X: Extractor + Sync>(
    w: &FlyingEdgesWalker<'_>,
    vol: &V,
    iso: Iso,
    x: &X,
    out: &mut MeshBuilder,
) -> Result<WalkStats> {
    let lattice = vol.lattice();
    let range = range_of(w.range, lattice.dims());
    if range.is_empty() {
        return Ok(WalkStats::default());
    }
    let first = if X::PLACES_VERTICES { range.lo.map(|v| v.saturating_sub(1)) } else { range.lo };
    let bx = PointBox::of(vol, first, &range)?;
    let table = CaseCounts::of(x);
    let walked = Walked::new(x.segments(), bx.lo);
    let crossed = walked.crossed();
    let p = Passes {
        vol: vol as &Cells<'_>,
        x,
        iso,
        bx,
        table: &table,
        walked,
        crossed: &crossed,
        range,
        reverse: lattice.is_mirrored(),
        normals: out.wants_normals(),
        record: out.key_record(),
    };
    let [_, ny, nz] = bx.dims;
    let words = bx.words();
    let mut scratch = Scratch::take();
    let mut bits = Bits { words, row0: 0, data: reuse_words(&mut scratch.bits, ny * nz * words) };
    let walked = match x.body_centred().filter(|_| bcc::applies(vol, &bx, &range)) {
        // The counted body-centred walk classifies as it takes the cells' centres.
        Some(t) => p.on(vol).bcc_counted(t, &mut bits, out, w.progress, &mut scratch),
        None => {
            // PASS 1: classify every row.
            classify_planes(vol, &bx, iso, &mut bits);
            if crate::walk::is_cancelled(w.progress) {
                scratch.bits = bits.data;
                scratch.keep();
                return Err(crate::Error::Cancelled);
            }
            if Paths::<X>::COUNTED {
                p.counted(&p.on(vol), &bits, out, w.progress, &mut scratch)
            } else {
                p.keyed(&bits, out, w.progress)
            }
        }
    };
    scratch.bits = bits.data;
    scratch.keep();
    walked
}

/// The paths a walk takes for extractors of type `X`, as constants the compiler resolves per
/// type: each walk compiles only its extractor's path (an `if` on a constant is not
/// instantiated on its dead side; a `match` on a constant enum would be).
pub(super) struct Paths<X>(std::marker::PhantomData<X>);

impl<X: Extractor> Paths<X> {
    /// Counted in advance ([`Counting::Known`]): count → prefix sums → fill. Otherwise keyed.
    pub(super) const COUNTED: bool = matches!(X::COUNTING, Counting::Known);
}

/// PASS 1 of an in-memory walk: every bit row of the box (one copy per volume type).
fn classify_planes<V: SampleSlabs + Sync>(vol: &V, bx: &PointBox, iso: Iso, bits: &mut Bits) {
    let plane = bx.dims[1] * bits.words;
    for_each_chunk(&mut bits.data, plane, &|k, plane| {
        classify::classify_plane(vol, bx, bx.lo[2] + k as u32, iso, plane)
    });
}

/// The buffers of an in-memory walk that do not outlive it (bit rows, row counts and the rows'
/// first vertices; mt-bcc's centre and active-cell bits and its own row counts), kept by the
/// thread between walks up to [`Scratch::KEEP_BYTES`]: a repeated extraction reuses them instead
/// of having fresh pages faulted in and zeroed. No pass reads what it has not written in the same
/// walk (classify writes every word of every bit row, the centre pass every centre and active
/// word, count every row count (or, in a newly allocated table, leaves the zeros of rows without
/// crossings), the prefix every sum), so they are never cleared.
#[derive(Default)]
struct Scratch {
    bits: Vec<u64>,
    counts: Vec<RowCount>,
    first: Vec<u32>,
    /// mt-bcc's: centre bits, active cells, row counts (`bcc.rs`).
    centres: Vec<u64>,
    active: Vec<u64>,
    bcc_counts: Vec<bcc::BccRow>,
    /// mt-bcc's centre values of active cells, per cell layer.
    bcc_values: Vec<bcc::LayerCentres>,
}

thread_local! {
    static SCRATCH: std::cell::Cell<Scratch> = std::cell::Cell::new(Scratch::default());
}

impl Scratch {
    /// Largest scratch a thread keeps between walks (a 512³ walk needs 38 MB with mc, 73 MB with
    /// mt-bcc).
    const KEEP_BYTES: usize = 96 << 20;

    /// This thread's buffers (empty the first time, or while a walk holds them).
    fn take() -> Self {
        SCRATCH.with(|s| s.take())
    }

    /// Gives the buffers back to the thread, unless they are larger than it keeps.
    fn keep(self) {
        fn bytes<T>(v: &Vec<T>) -> usize {
            v.capacity() * std::mem::size_of::<T>()
        }
        let bytes = bytes(&self.bits)
            + bytes(&self.counts)
            + bytes(&self.first)
            + bytes(&self.centres)
            + bytes(&self.active)
            + bytes(&self.bcc_counts)
            + self.bcc_values.iter().map(bcc::LayerCentres::capacity_bytes).sum::<usize>();
        if bytes <= Self::KEEP_BYTES {
            SCRATCH.with(|s| s.set(self));
        }
    }
}

/// `n` words taken from a thread's `kept` buffer, with whatever they held (huge pages when newly
/// allocated).
fn reuse_words(kept: &mut Vec<u64>, n: usize) -> Vec<u64> {
    let mut v = std::mem::take(kept);
    if v.capacity() < n {
        v = huge_vec(n, 0);
    }
    v.resize(n, 0);
    v
}

/// `n` records taken from a thread's `kept` buffer, with whatever they held, and whether they are
/// newly allocated instead: zero pages straight from the allocator (calloc), first touched by the
/// pass that writes them, on every thread, instead of faulted in and zeroed by one thread before
/// it (`vec!` writes a struct's zeros element by element). The count passes then skip writing the
/// zero counts of rows without crossings, so a sparse surface leaves most pages of its row table
/// untouched: the prefix pass reads them as the kernel's shared zero page, which costs no fresh
/// page (a fresh process's first extraction pays several microseconds per fresh page on this VM,
/// BENCHMARKS §6.12).
fn reuse_zeroed<T: bytemuck::Zeroable + Copy>(kept: &mut Vec<T>, n: usize) -> (Vec<T>, bool) {
    let mut v = std::mem::take(kept);
    let fresh = v.capacity() < n;
    if fresh {
        v = bytemuck::zeroed_vec(n);
    }
    v.resize(n, T::zeroed());
    (v, fresh)
}

impl<X: Extractor + Sync> Passes<'_, Cells<'_>, X> {
    /// PASS 2–4 for extractors whose output is counted in advance; `vertices`: the same passes
    /// on the volume's side (the fill's vertex rows).
    fn counted<V: SampleSlabs + Sync>(
        &self,
        vertices: &Passes<'_, V, ()>,
        bits: &Bits,
        out: &mut MeshBuilder,
        progress: Option<&dyn Progress>,
        scratch: &mut Scratch,
    ) -> Result<WalkStats> {
        let [_, ny, nz] = self.bx.dims;
        let rows = ny * nz;
        // PASS 2: count (every row's count is set: written from zero, or left zero when fresh).
        let (mut counts, zeroed) = reuse_zeroed(&mut scratch.counts, rows);
        // Per plane: all-outside and all-inside cells, and the decisions of cells counted from
        // their values (handed back to the extractor in the fill).
        let mut cell_stats = vec![([0u64; 2], Vec::new()); nz];
        for_each_chunk_with(&mut counts, ny, &mut cell_stats, &|k, plane, (cs, decisions)| {
            // Cancelled: the counts are never used (the walk returns before its fill).
            if !crate::walk::is_cancelled(progress) {
                *cs = self.count_plane(bits, k, plane, decisions, zeroed);
            }
        });
        if crate::walk::is_cancelled(progress) {
            scratch.counts = counts;
            return Err(crate::Error::Cancelled);
        }
        let mut stats = WalkStats { cells: self.range.num_cells(), ..Default::default() };
        stats.cells_outside = cell_stats.iter().map(|c| c.0[0]).sum();
        stats.cells_inside = cell_stats.iter().map(|c| c.0[1]).sum();
        // PASS 3: prefix sums.
        let table = RowTable::prefix(counts, ny, std::mem::take(&mut scratch.first))?;
        // PASS 4: fill, one task per slab, each owning its slots of the exactly allocated output.
        // SAFETY: `fill_plane` returns only after writing every slot of its slab (asserted row by
        // row).
        let (mesh, keys) = unsafe {
            fill_planes(&table, ny, self.normals, progress, &|k, slab| {
                vertices.fill_vertices(bits, &table, k, slab);
                self.fill_polygons(bits, &table, k, &cell_stats[k].1, slab)
            })
        };
        out.set_assembled(mesh, keys);
        (scratch.counts, scratch.first) = table.into_parts();
        Ok(stats)
    }
}

impl<'a, V: ?Sized, X> Passes<'a, V, X> {
    /// These passes on the volume's side (`vol`, the same volume by its own type): without the
    /// extractor, for the passes that never call it (classification, the fill's vertex rows,
    /// mt-bcc's tables), compiled once per volume type instead of once per extractor.
    fn on<'v, W: Volume + ?Sized>(&self, vol: &'v W) -> Passes<'v, W, ()>
    where
        'a: 'v,
    {
        Passes {
            vol,
            x: &(),
            iso: self.iso,
            bx: self.bx,
            table: self.table,
            walked: self.walked,
            crossed: self.crossed,
            range: self.range,
            reverse: self.reverse,
            normals: self.normals,
            record: self.record,
        }
    }

    /// Whether a vertex with this key is recorded.
    #[inline]
    fn records(&self, key: &VertexKey) -> bool {
        match self.record {
            KeyRecord::None => false,
            KeyRecord::All => true,
            KeyRecord::Boundary(r) => crate::mesh::touches_boundary(key, &r),
        }
    }

    /// Writes vertex `at` of a slab's output (`first`: the slab's first vertex id) with its
    /// normal when there is one, and records its key (`key()`, built only then) when this walk
    /// records it.
    #[inline(always)]
    fn put_vertex(
        &self,
        out: &mut impl FillOut,
        at: usize,
        first: u64,
        p: [f32; 3],
        n: Option<[f32; 3]>,
        key: impl FnOnce() -> VertexKey,
    ) {
        out.set_position(at, p);
        if let Some(n) = n {
            out.set_normal(at, n);
        }
        if self.record != KeyRecord::None {
            let key = key();
            if self.records(&key) {
                out.keys().push(((first + at as u64) as u32, key));
            }
        }
    }
}

// The parallel helpers take their work as `&dyn Fn`: rayon's machinery (jobs, splitting,
// bridges) is then compiled once per element type, not once per closure of every walk.

/// Calls `f(k, chunk)` for each of the `data.len() / per` chunks, in parallel when enabled.
fn for_each_chunk<D: Send>(data: &mut [D], per: usize, f: &(dyn Fn(usize, &mut [D]) + Sync)) {
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        data.par_chunks_mut(per).enumerate().for_each(|(k, s)| f(k, s));
    }
    #[cfg(not(feature = "parallel"))]
    data.chunks_mut(per).enumerate().for_each(|(k, s)| f(k, s));
}

/// As [`for_each_chunk`], with one extra per-chunk accumulator.
fn for_each_chunk_with<D: Send, A: Send>(
    data: &mut [D],
    per: usize,
    acc: &mut [A],
    f: &(dyn Fn(usize, &mut [D], &mut A) + Sync),
) {
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        data.par_chunks_mut(per).zip(acc.par_iter_mut()).enumerate().for_each(|(k, (s, a))| f(k, s, a));
    }
    #[cfg(not(feature = "parallel"))]
    data.chunks_mut(per).zip(acc.iter_mut()).enumerate().for_each(|(k, (s, a))| f(k, s, a));
}

/// Runs `f` on every task, in parallel when enabled; results in task order.
pub(crate) fn map_tasks<T: Send, R: Send>(tasks: Vec<T>, f: &(dyn Fn(T) -> R + Sync)) -> Vec<R> {
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        tasks.into_par_iter().map(f).collect()
    }
    #[cfg(not(feature = "parallel"))]
    tasks.into_iter().map(f).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::extract::{BodyCentredTetrahedra, MarchingCubes, MarchingCubes33};
    use crate::grid::{DenseGrid, Lattice};
    use crate::mesh::{Mesh, Normals};
    use crate::volume::GridVolume;

    fn walk<X: Extractor + Sync>(g: &DenseGrid<f32>, x: &X) -> Mesh {
        let mut out = MeshBuilder::new(Normals::Gradient);
        FlyingEdgesWalker::new().walk(&GridVolume::new(g), Iso::below(0.0), x, &mut out).unwrap();
        out.finish().unwrap()
    }

    fn ball(dims: [u32; 3], r: f32) -> DenseGrid<f32> {
        DenseGrid::from_fn(Lattice::new(dims).unwrap(), move |p| {
            let c = dims.map(|n| (n - 1) as f32 / 2.0);
            (0..3).map(|a| (p[a] as f32 - c[a]).powi(2)).sum::<f32>().sqrt() - r
        })
    }

    /// Cancels once `after` plane tasks asked (counting the asks).
    struct CancelAfter {
        asks: std::sync::atomic::AtomicU64,
        after: u64,
    }

    impl Progress for CancelAfter {
        fn advance(&self, _: u64, _: u64) {}
        fn cancelled(&self) -> bool {
            self.asks.fetch_add(1, std::sync::atomic::Ordering::Relaxed) >= self.after
        }
    }

    #[test]
    fn a_cancelled_walk_stops_before_its_fill_and_an_uncancelled_one_is_unchanged() {
        let g = ball([24, 20, 16], 6.0);
        let reference = walk(&g, &MarchingCubes33);
        let run = |after| {
            let p = CancelAfter { asks: Default::default(), after };
            let mut out = MeshBuilder::new(Normals::Gradient);
            let r = FlyingEdgesWalker::new().with_progress(&p).walk(
                &GridVolume::new(&g),
                Iso::below(0.0),
                &MarchingCubes33,
                &mut out,
            );
            (r.map(|_| out.finish().unwrap()), p.asks.into_inner())
        };
        // Cancelled at once (after classification), and in the middle of the count.
        for after in [0, 5] {
            let (r, _) = run(after);
            assert!(matches!(r, Err(crate::Error::Cancelled)), "after {after}: {r:?}");
        }
        // Never cancelled: the same mesh; asked once after classifying, once per plane, once after.
        let (r, asks) = run(u64::MAX);
        assert_eq!(r.unwrap(), reference);
        assert_eq!(asks, 1 + 16 + 1);
    }

    /// Marching cubes through `process`, with counts off by `extra` triangles per active cell:
    /// the fill must notice (its per-row and per-slab checks guard the uninitialised output).
    struct Miscounted {
        extra: i32,
    }

    impl Extractor for Miscounted {
        fn process<C: crate::walk::Cell>(&self, cell: &mut C) {
            MarchingCubes.process(cell)
        }
        const COUNTING: Counting = Counting::Known;
        fn counts(
            &self,
            case: u8,
            _ijk: [u32; 3],
            _values: impl FnOnce() -> [f32; 8],
        ) -> (crate::extract::CellCounts, crate::extract::Decision) {
            let n = MarchingCubes.case_triangles(case, false).map_or(0, |t| t.len() as i32);
            let counts = crate::extract::CellCounts { triangles: (n + self.extra).max(0) as u16, ..Default::default() };
            (counts, Default::default())
        }
    }

    /// The slabs of a grid, in order.
    struct Slabs<'g> {
        grid: &'g DenseGrid<f32>,
        next: usize,
    }

    impl crate::volume::SlabSource<f32> for Slabs<'_> {
        fn lattice(&self) -> &Lattice {
            self.grid.lattice()
        }
        fn read_slab(&mut self, out: &mut [f32]) -> std::result::Result<(), crate::mesh::ExternalError> {
            out.copy_from_slice(&self.grid.data()[self.next * out.len()..(self.next + 1) * out.len()]);
            self.next += 1;
            Ok(())
        }
    }

    /// [`walk`] through [`FlyingEdgesWalker::stream`], slab by slab.
    fn stream<X: Extractor + Sync>(g: &DenseGrid<f32>, x: &X) -> Result<Mesh> {
        let mut sink = Mesh::default();
        struct Keep<'m>(&'m mut Mesh);
        impl crate::mesh::MeshSink for Keep<'_> {
            fn push(&mut self, b: crate::mesh::MeshBatch<'_>) -> std::result::Result<(), crate::mesh::ExternalError> {
                self.0.positions.extend_from_slice(b.positions);
                self.0.normals.extend_from_slice(b.normals);
                self.0.triangles.extend_from_slice(b.triangles);
                Ok(())
            }
        }
        let mut src = Slabs { grid: g, next: 0 };
        FlyingEdgesWalker::new()
            .stream(&mut src, Iso::below(0.0), x, Normals::Gradient, &mut Keep(&mut sink))
            .map(|_| sink)
    }

    /// Output slots are uninitialised until the fill writes them: counts the fill does not meet
    /// (too many or too few polygons) stop the walk with a panic, in memory and streamed,
    /// instead of handing out unwritten slots; honest counts make the mesh of `MarchingCubes`.
    #[test]
    fn a_fill_that_misses_its_counts_panics_in_memory_and_streamed() {
        let g = ball([14, 13, 12], 4.5);
        let stream = |x: &Miscounted| stream(&g, x);
        let honest = Miscounted { extra: 0 };
        assert_eq!(walk(&g, &honest), walk(&g, &MarchingCubes));
        assert_eq!(stream(&honest).unwrap(), walk(&g, &MarchingCubes));
        for extra in [1, -1] {
            let x = Miscounted { extra };
            let in_memory = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| walk(&g, &x)));
            assert!(in_memory.is_err(), "in memory, {extra:+} triangles per cell");
            let streamed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| stream(&x)));
            assert!(streamed.is_err(), "streamed, {extra:+} triangles per cell");
        }
    }

    /// mt-bcc's passes compiled for x86-64-v3 (`bcc::v3`) and as built make the same mesh, byte
    /// for byte: on integer values, some at iso (ties), on smooth fields, rows of more than
    /// one word, and a mirrored lattice; in memory and streamed.
    #[test]
    fn mt_bcc_is_the_same_on_the_baseline_copy() {
        use std::sync::atomic::Ordering::Relaxed;
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let ties = DenseGrid::from_fn(Lattice::new([67, 9, 8]).unwrap(), |_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s % 5) as f32 - 2.0
        });
        let mirrored = Lattice::new([23, 17, 11])
            .unwrap()
            .with_direction([[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
            .unwrap();
        let wavy =
            DenseGrid::from_fn(mirrored, |p| (p[0] as f32 * 0.4).sin() + (p[1] as f32 * 0.7 + p[2] as f32).cos());
        let bcc = BodyCentredTetrahedra;
        let both = |g: &DenseGrid<f32>| {
            bcc::BASELINE_ONLY.store(true, Relaxed);
            let baseline = (walk(g, &bcc), stream(g, &bcc).unwrap());
            bcc::BASELINE_ONLY.store(false, Relaxed);
            (baseline, (walk(g, &bcc), stream(g, &bcc).unwrap()))
        };
        for g in [ties, wavy, ball([41, 38, 35], 15.0)] {
            let (baseline, v3) = both(&g);
            assert!(baseline.0.num_triangles() > 0);
            assert_eq!(baseline.0, baseline.1, "streamed");
            assert_eq!(baseline, v3);
        }
    }

    /// mt-bcc's in-memory walk classifies and takes the cells' centres in groups of planes
    /// (`bcc_counted`), each group classifying the next one's first plane again; the stream
    /// goes plane by plane. Lattices one plane deep, shallower than a group, ending a group or
    /// one plane past one make the same mesh both ways.
    #[test]
    fn mt_bcc_in_groups_of_planes_makes_the_streamed_mesh() {
        let bcc = BodyCentredTetrahedra;
        for nz in [1, 2, 3, 8, 9, 16, 17, 26] {
            let g = DenseGrid::from_fn(Lattice::new([19, 7, nz]).unwrap(), |p| {
                (p[0] as f32 * 0.5).sin() + (p[1] as f32 * 0.8 + p[2] as f32 * 0.6).cos() - 0.3
            });
            let m = walk(&g, &bcc);
            assert_eq!(m.num_triangles() > 0, nz > 1, "depth {nz}");
            assert_eq!(m, stream(&g, &bcc).unwrap(), "depth {nz}");
        }
    }

    /// A walk reuses the scratch that earlier walks left on its thread (bit rows, row counts and
    /// sums, mt-bcc's centre and active bits, of other sizes and contents, never cleared) and makes
    /// the very mesh a walk on a fresh thread makes (whose new row tables keep the allocator's
    /// zeros in rows without crossings, unwritten).
    #[test]
    fn scratch_left_by_earlier_walks_changes_nothing() {
        let big = ball([41, 38, 35], 15.0);
        let small = ball([9, 12, 7], 3.5);
        // Rows of 70 points: two words per bit row, the second one partly past the row.
        let wavy = DenseGrid::from_fn(Lattice::new([70, 6, 9]).unwrap(), |p| {
            (p[0] as f32 * 0.3).sin() + (p[1] as f32 * 0.9).cos() * (p[2] as f32 * 0.5).sin()
        });
        let grids = [small, wavy];
        let bcc = BodyCentredTetrahedra;
        let fresh: Vec<(Mesh, Mesh, Mesh)> = std::thread::scope(|s| {
            grids
                .iter()
                .map(|g| s.spawn(|| (walk(g, &MarchingCubes), walk(g, &MarchingCubes33), walk(g, &bcc))))
                .collect::<Vec<_>>()
                .into_iter()
                .map(|h| h.join().unwrap())
                .collect()
        });
        assert!(fresh.iter().all(|(m, _, t)| m.num_triangles() > 0 && t.num_triangles() > 0));
        for (g, (mc, mc33, tet)) in grids.iter().zip(&fresh) {
            walk(&big, &MarchingCubes);
            assert_eq!(&walk(g, &MarchingCubes), mc);
            walk(&big, &MarchingCubes33);
            assert_eq!(&walk(g, &MarchingCubes33), mc33);
            assert_eq!(&walk(g, &MarchingCubes), mc, "twice in a row");
            walk(&big, &bcc);
            assert_eq!(&walk(g, &bcc), tet, "mt-bcc after a larger mt-bcc walk");
            assert_eq!(&walk(g, &bcc), tet, "mt-bcc twice in a row");
            walk(&big, &MarchingCubes);
            assert_eq!(&walk(g, &bcc), tet, "mt-bcc after a larger mc walk");
        }
    }
}
