//! PASS 3 (prefix sums) and PASS 4 (fill): rows write their vertices by rank, active cells run the
//! extractor through [`FillCell`], polygons land at their precomputed offsets.

use std::cell::OnceCell;
use std::mem::MaybeUninit;
use std::sync::atomic::{AtomicU64, Ordering};

use super::bits::{cell_rows, for_each_bit, for_each_case, mark_active, slot_bases, Bits, SegmentRun};
use super::count::RowCount;
use super::families::FAMILIES;
use super::{map_tasks, Cells, Passes};
use crate::cube::{cell_segment, CellPoint, CubeEdge, EdgeKey, VertexKey, CELL_SEGMENTS};
use crate::error::{Error, Result};
use crate::extract::Placed;
use crate::extract::{Decision, Extractor};
use crate::grid::Sample;
use crate::mesh::{huge_capacity, Mesh, MeshBuilder, VertexId};
use crate::volume::SampleSlabs;
use crate::walk::segment;
use crate::walk::{cell_crossing, edge_crossing, edge_hermite, edge_normal, Cell, Hermite, Progress};

/// What the running sums take from a row's counts: its vertices, triangles and quads.
pub(super) trait Counted: Copy + Default {
    fn sums(&self) -> [u64; 3];
}

impl Counted for RowCount {
    #[inline]
    fn sums(&self) -> [u64; 3] {
        [self.vertices() as u64, self.tris as u64, self.quads as u64]
    }
}

/// Row counts, each row's first vertex and each plane's first vertex, triangle and quad, for box
/// rows `row0 ..` (whole planes of `ny` rows: all of them in memory, a window when streaming).
/// `C`: the counts of one row (the extractors' [`RowCount`], mt-bcc's `BccRow`).
///
/// Only the vertex sum is kept per row (4 bytes, against the 40 of `RowCount`): the fills number
/// a row's vertices from it, while triangles and quads are written per plane, from the plane's
/// first. Vertex ids are `u32` ([`MeshBuilder::MAX_VERTICES`], checked by every
/// [`restart`](RowTable::restart)), so a row's first vertex fits too.
pub(super) struct RowTable<C = RowCount> {
    pub(super) counts: Vec<C>,
    /// The first vertex of each row.
    first: Vec<u32>,
    /// `[vertex, triangle, quad]` before each plane; one more entry holds the totals.
    planes: Vec<[u64; 3]>,
    /// Rows per plane.
    ny: usize,
    /// The first row held (a multiple of `ny`).
    pub(super) row0: usize,
}

impl<C: Counted> RowTable<C> {
    /// PASS 3: running sums over all rows (`ny` a plane), in `first`'s buffer (its contents
    /// dropped).
    ///
    /// # Errors
    /// [`Error::Limit`] past `u32` vertex indices.
    pub(super) fn prefix(counts: Vec<C>, ny: usize, first: Vec<u32>) -> Result<Self> {
        let mut table = RowTable { counts, first, planes: Vec::new(), ny, row0: 0 };
        table.restart(0, [0; 3])?;
        Ok(table)
    }

    /// A table for a window of `planes` planes of `ny` rows (streaming: the counts are set later,
    /// the sums with [`restart`](RowTable::restart)).
    pub(super) fn window(planes: usize, ny: usize) -> Self {
        let rows = planes * ny;
        RowTable {
            counts: vec![C::default(); rows],
            first: Vec::with_capacity(rows),
            planes: Vec::with_capacity(planes + 1),
            ny,
            row0: 0,
        }
    }

    /// Recomputes the running sums from `start` (the sums before row `row0`, the first held, which
    /// starts a plane).
    ///
    /// # Errors
    /// [`Error::Limit`] past `u32` vertex indices.
    pub(super) fn restart(&mut self, row0: usize, start: [u64; 3]) -> Result<()> {
        debug_assert_eq!(row0 % self.ny, 0, "a table starts at a plane");
        self.row0 = row0;
        self.first.clear();
        self.first.reserve(self.counts.len());
        self.planes.clear();
        self.planes.reserve(self.counts.len() / self.ny + 1);
        let mut acc = start;
        for plane in self.counts.chunks(self.ny) {
            self.planes.push(acc);
            for c in plane {
                // Past u32 the check below fails the walk, so the truncated ids are never used.
                self.first.push(acc[0] as u32);
                for (a, s) in acc.iter_mut().zip(c.sums()) {
                    *a += s;
                }
            }
        }
        self.planes.push(acc);
        check_vertices(acc[0])
    }

    /// The buffers of the counts and of the rows' first vertices, for reuse.
    pub(super) fn into_parts(self) -> (Vec<C>, Vec<u32>) {
        (self.counts, self.first)
    }

    /// Vertices, triangles and quads of all rows.
    pub(super) fn totals(&self) -> [usize; 3] {
        self.planes[self.planes.len() - 1].map(|x| x as usize)
    }

    /// Vertices, triangles and quads of the `ny` rows of box plane `k`.
    pub(super) fn plane_sizes(&self, k: usize, ny: usize) -> [usize; 3] {
        debug_assert_eq!(ny, self.ny);
        let (a, b) = (self.plane_base(k), self.plane_base(k + 1));
        [0, 1, 2].map(|i| (b[i] - a[i]) as usize)
    }

    #[inline(always)]
    pub(super) fn count(&self, r: usize) -> &C {
        &self.counts[r - self.row0]
    }

    /// The first vertex of row `r`.
    #[inline(always)]
    pub(super) fn first_vertex(&self, r: usize) -> u32 {
        self.first[r - self.row0]
    }

    /// `[vertex, triangle, quad]` before box plane `k` (`k` one past the last plane held: the
    /// sums of all of them).
    #[inline(always)]
    pub(super) fn plane_base(&self, k: usize) -> [u64; 3] {
        self.planes[k - self.row0 / self.ny]
    }
}

fn check_vertices(n: u64) -> Result<()> {
    if n > MeshBuilder::MAX_VERTICES {
        return Err(Error::Limit { what: "mesh vertices", requested: n, allowed: MeshBuilder::MAX_VERTICES });
    }
    Ok(())
}

/// Where PASS 4 writes one slab's vertices, triangles and quads (each slot exactly once, at its
/// counted offset) and the keys it records.
pub(super) trait FillOut {
    fn set_position(&mut self, at: usize, p: [f32; 3]);
    fn set_normal(&mut self, at: usize, n: [f32; 3]);
    fn set_triangle(&mut self, at: usize, t: [u32; 3]);
    fn set_quad(&mut self, at: usize, q: [u32; 4]);
    /// The slab's triangle slots, for fills that write runs of them.
    fn triangles(&mut self) -> &mut [MaybeUninit<[u32; 3]>];
    /// Vertices, triangles and quads of the slab.
    fn sizes(&self) -> [usize; 3];
    fn keys(&mut self) -> &mut Vec<(u32, VertexKey)>;
}

/// One slab's share of the output (of the final mesh in memory, of a reused batch when
/// streaming) as uninitialised slots (no zeroing pass before the fill writes them): [`fill_plane`](Passes::fill_plane) asserts that it wrote every one.
pub(super) struct SlabSlots<'a> {
    pub(super) positions: &'a mut [MaybeUninit<[f32; 3]>],
    /// Empty when normals are off.
    pub(super) normals: &'a mut [MaybeUninit<[f32; 3]>],
    pub(super) triangles: &'a mut [MaybeUninit<[u32; 3]>],
    pub(super) quads: &'a mut [MaybeUninit<[u32; 4]>],
    pub(super) keys: Vec<(u32, VertexKey)>,
}

impl FillOut for SlabSlots<'_> {
    #[inline(always)]
    fn set_position(&mut self, at: usize, p: [f32; 3]) {
        self.positions[at].write(p);
    }
    #[inline(always)]
    fn set_normal(&mut self, at: usize, n: [f32; 3]) {
        self.normals[at].write(n);
    }
    #[inline(always)]
    fn set_triangle(&mut self, at: usize, t: [u32; 3]) {
        self.triangles[at].write(t);
    }
    #[inline(always)]
    fn set_quad(&mut self, at: usize, q: [u32; 4]) {
        self.quads[at].write(q);
    }
    #[inline(always)]
    fn triangles(&mut self) -> &mut [MaybeUninit<[u32; 3]>] {
        self.triangles
    }
    fn sizes(&self) -> [usize; 3] {
        [self.positions.len(), self.triangles.len(), self.quads.len()]
    }
    fn keys(&mut self) -> &mut Vec<(u32, VertexKey)> {
        &mut self.keys
    }
}

/// PASS 4 in memory: the mesh of all rows of `table` (`ny` rows a plane), allocated exactly and
/// left uninitialised, split into one [`SlabSlots`] per box plane (its sizes, in order), filled
/// by `fill(k, slots)` on every plane (in parallel when enabled; `progress` once per plane), its
/// lengths then committed. Returns the mesh and the recorded keys, in plane order.
///
/// # Safety
/// `fill` returns only after writing every slot of the [`SlabSlots`] it is given (the fills
/// assert it row by row and per plane, and panic otherwise).
pub(super) unsafe fn fill_planes<C: Counted>(
    table: &RowTable<C>,
    ny: usize,
    normals: bool,
    progress: Option<&dyn Progress>,
    fill: &(dyn Fn(usize, &mut SlabSlots<'_>) + Sync),
) -> (Mesh, Vec<(u32, VertexKey)>) {
    let [v, t, q] = table.totals();
    let planes = table.counts.len() / ny;
    let nv = if normals { v } else { 0 };
    let mut mesh = Mesh {
        positions: huge_capacity(v),
        normals: huge_capacity(nv),
        triangles: huge_capacity(t),
        quads: Vec::with_capacity(q),
    };
    let mut tasks = Vec::with_capacity(planes);
    {
        let (mut pos, mut nrm, mut tri, mut qua) = (
            &mut mesh.positions.spare_capacity_mut()[..v],
            &mut mesh.normals.spare_capacity_mut()[..nv],
            &mut mesh.triangles.spare_capacity_mut()[..t],
            &mut mesh.quads.spare_capacity_mut()[..q],
        );
        for k in 0..planes {
            let [dv, dt, dq] = table.plane_sizes(k, ny);
            let (p, rest) = pos.split_at_mut(dv);
            pos = rest;
            let (n, rest) = if normals { nrm.split_at_mut(dv) } else { (&mut [][..], nrm) };
            nrm = rest;
            let (tr, rest) = tri.split_at_mut(dt);
            tri = rest;
            let (qu, rest) = qua.split_at_mut(dq);
            qua = rest;
            tasks.push((k, SlabSlots { positions: p, normals: n, triangles: tr, quads: qu, keys: Vec::new() }));
        }
    }
    let done = AtomicU64::new(0);
    let keys = map_tasks(tasks, &|(k, mut slab)| {
        fill(k, &mut slab);
        if let Some(p) = progress {
            p.advance(done.fetch_add(1, Ordering::Relaxed) + 1, planes as u64);
        }
        slab.keys
    });
    // SAFETY: the planes' slots partition the first v, nv, t and q slots of the four buffers
    // (split in order above), and `fill` returned for every plane, which (the caller's promise)
    // it does only after writing each slot of its plane; a panic propagates out of `map_tasks`
    // before this point. So those slots are initialised.
    unsafe {
        mesh.positions.set_len(v);
        mesh.normals.set_len(nv);
        mesh.triangles.set_len(t);
        mesh.quads.set_len(q);
    }
    (mesh, keys.concat())
}

/// Rows of look-ahead for the sample prefetch (enough to cover memory latency on sparse rows).
pub(super) const PREFETCH_ROWS: usize = 2;

// PASS 4 for box plane `k` is two calls on the same slots: `fill_vertices` (the volume's side:
// the vertices of its rows) then `fill_polygons` (the extractor's: the polygons of its cell rows).
// Every slot of the output is written exactly once: vertices in row order, each row from its
// counted first vertex, polygons in walk order from the slab's first. This is asserted as it goes
// (a compare per row), as [`SlabSlots`] relies on it; a disagreement of counts and fill (an
// internal error) panics.

impl<V: SampleSlabs> Passes<'_, V, ()> {
    /// PASS 4a for box plane `k`: the vertices of its rows, by family and rank (placed vertices'
    /// slots are left to the cells that place them).
    pub(super) fn fill_vertices<O: FillOut>(&self, bits: &Bits, table: &RowTable, k: usize, out: &mut O) {
        let [out_vertices, _, _] = out.sizes();
        let bx = &self.bx;
        let [_, ny, nz] = bx.dims;
        let words = bits.words;
        let z = bx.lo[2] + k as u32;
        let s0 = self.vol.slab(z);
        let s1 = if k + 1 < nz { self.vol.slab(z + 1) } else { s0 };
        let plane = table.plane_base(k);
        let stride = bx.row_stride();
        let mut out_v = 0usize;
        let mut mask = vec![0u64; words];
        let mut ymask = vec![0u64; words];
        let offset = |a: V::Sample| self.iso.offset(a.to_f64());
        // Vertices of the slab's rows: each family's crossings in turn (x-, y-, z-edges, then
        // the diagonals the extractor names), then room for the vertices its cells place. The
        // samples a row needs are scattered (sparse surfaces) and the hardware cannot guess them;
        // their positions are known from the bits, so they are prefetched PREFETCH_ROWS rows ahead.
        // Rows without crossings (most rows of a sparse surface) are skipped: the counts know them.
        let has_crossings = |r: usize| table.count(r).v.iter().any(|&n| n > 0);
        for j in 0..PREFETCH_ROWS.min(ny) {
            if has_crossings(k * ny + j) {
                self.prefetch_row(bits, k, j, s0, s1, &mut ymask);
            }
        }
        for j in 0..ny {
            if j + PREFETCH_ROWS < ny && has_crossings(k * ny + j + PREFETCH_ROWS) {
                self.prefetch_row(bits, k, j + PREFETCH_ROWS, s0, s1, &mut ymask);
            }
            let r = k * ny + j;
            assert_eq!(plane[0] + out_v as u64, table.first_vertex(r) as u64, "internal: row {r} starts off its count");
            if !has_crossings(r) {
                out_v += table.count(r).placed as usize;
                continue;
            }
            let at = bx.in_slab(0, j);
            for f in 0..FAMILIES {
                if !self.walked.has(f) || !self.walked.mask(f, bits, r, [j, k], bx.dims, &mut mask) {
                    continue;
                }
                for_each_bit(&mask, |i| {
                    let g = bx.global([i, j, k]);
                    let sample = |o: [usize; 3]| {
                        let s = if o[2] == 0 { s0 } else { s1 };
                        s[at + o[1] * stride + i + o[0]]
                    };
                    let (ends, key) = self.walked.segment(f, g);
                    let (d0, d1) = (offset(sample(ends[0])), offset(sample(ends[1])));
                    let (p, n) = match key {
                        VertexKey::Edge(e) => {
                            let (p, t) = edge_crossing(self.vol, e, d0, d1, self.iso);
                            (p, self.normals.then(|| edge_normal(self.vol, e, t, d0, self.iso)))
                        }
                        VertexKey::Segment(sk) => {
                            let p = segment::segment_point(self.vol, sk, d0, d1, self.iso);
                            let n = self.normals.then(|| segment::segment_normal(self.vol, sk, p, d0, self.iso));
                            (segment::world_point(self.vol, p), n)
                        }
                        VertexKey::Cell { .. } => unreachable!("families name edges and segments"),
                    };
                    self.put_vertex(out, out_v, plane[0], p, n, || key);
                    out_v += 1;
                });
            }
            out_v += table.count(r).placed as usize;
        }
        assert_eq!(out_v, out_vertices, "internal: slab {k} vertices off their count");
    }

    /// Prefetches the samples that row (j, k)'s crossings will read: rows (j, k), (j + 1, k) and
    /// (j, k + 1) around every point where an edge starting in row (j, k) crosses.
    #[inline]
    fn prefetch_row(&self, bits: &Bits, k: usize, j: usize, s0: &[V::Sample], s1: &[V::Sample], union: &mut [u64]) {
        let [nx, ny, nz] = self.bx.dims;
        let r = k * ny + j;
        let a = bits.row(r);
        for w in 0..union.len() {
            let next = if w + 1 < a.len() { a[w + 1] << 63 } else { 0 };
            let mut m = a[w] ^ ((a[w] >> 1) | next) | (a[w] << 1 ^ a[w]);
            if j + 1 < ny {
                m |= a[w] ^ bits.row(r + 1)[w];
            }
            if k + 1 < nz {
                m |= a[w] ^ bits.row(r + ny)[w];
            }
            union[w] = m;
        }
        let at = self.bx.in_slab(0, j);
        let stride = self.bx.row_stride();
        let mut last_line = usize::MAX;
        for_each_bit(union, |i| {
            let i = i.min(nx - 1);
            // One prefetch per 64-byte line of the row.
            let line = i * std::mem::size_of::<V::Sample>() / 64;
            if line == last_line {
                return;
            }
            last_line = line;
            prefetch((&s0[at + i] as *const V::Sample).cast());
            if j + 1 < ny {
                prefetch((&s0[at + i + stride] as *const V::Sample).cast());
            }
            if k + 1 < nz {
                prefetch((&s1[at + i] as *const V::Sample).cast());
            }
        });
    }
}

impl<X: Extractor> Passes<'_, Cells<'_>, X> {
    /// PASS 4b for box plane `k`: the polygons of its cell rows (and the vertices they place);
    /// `decisions` are the count pass's for the cells it counted from their values, in walk order.
    pub(super) fn fill_polygons<O: FillOut>(
        &self,
        bits: &Bits,
        table: &RowTable,
        k: usize,
        decisions: &[Decision],
        out: &mut O,
    ) {
        let [_, out_triangles, out_quads] = out.sizes();
        let bx = &self.bx;
        let [nx, ny, nz] = bx.dims;
        if k + 1 >= nz {
            assert_eq!([out_triangles, out_quads], [0, 0], "internal: polygons counted past the last layer");
            return;
        }
        let plane = table.plane_base(k);
        // Polygons of the cell rows of layer k.
        let mut active = vec![0u64; bits.words];
        let mut state = FillState { t: 0, q: 0, plane_v: plane[0], next_placed: 0 };
        // Cells without a table entry, in walk order, each with its decision from the count pass
        // (rows skipped below for having no output left theirs out there too).
        let mut decided = decisions.iter();
        let edges_only = self.walked.edges_only();
        for j in 0..ny - 1 {
            let r = k * ny + j;
            let c = table.count(r);
            if c.tris == 0 && c.quads == 0 && c.placed == 0 {
                continue;
            }
            let rows = cell_rows(bits, r, ny);
            mark_active(rows, nx - 1, &mut active);
            let mut run = SegmentRun::new(slot_bases(table, r, ny));
            state.next_placed = table.first_vertex(r) as u64 + c.before(FAMILIES) as u64;
            let parity = self.walked.parity0 + j + k;
            for_each_case(&rows, &active, |i, case| {
                let l = [i, j, k];
                let odd = (parity + i) % 2 == 1;
                // Each crossed segment's id once per cell; triangles then only look them up.
                let crossed = self.crossed[case as usize][odd as usize];
                let ids: [u32; CELL_SEGMENTS] = if edges_only {
                    let mut ids = [0; CELL_SEGMENTS];
                    ids[..12].copy_from_slice(&run.cell::<12>(crossed));
                    ids
                } else {
                    run.cell(crossed)
                };
                // The extractor's table, by case or else by the count pass's decision: the cell's
                // triangles without a `Cell`.
                let mut decision = Decision::default();
                let table = match self.x.case_triangles(case, odd) {
                    Some(table) => Some(table),
                    None => {
                        let d = decided.next().copied();
                        debug_assert!(d.is_some(), "fewer decisions than counted cells");
                        decision = d.unwrap_or_default();
                        self.x.decided_triangles(decision)
                    }
                };
                if let Some(table) = table {
                    for t in table {
                        let (a, b, c) = (ids[t[0] as usize], ids[t[1] as usize], ids[t[2] as usize]);
                        out.set_triangle(state.t, if self.reverse { [a, c, b] } else { [a, b, c] });
                        state.t += 1;
                    }
                    return;
                }
                let mut cell = FillCell {
                    p: self,
                    l,
                    ijk: bx.global(l),
                    case,
                    odd,
                    values: OnceCell::new(),
                    ids,
                    placed: 0,
                    out,
                    state: &mut state,
                };
                self.x.process_decided(&mut cell, decision);
            });
            assert_eq!(
                state.next_placed,
                table.first_vertex(r) as u64 + c.vertices() as u64,
                "internal: row {r} placed vertices off their count"
            );
        }
        debug_assert!(decided.next().is_none(), "more decisions than counted cells");
        assert_eq!([state.t, state.q], [out_triangles, out_quads], "internal: slab {k} polygons off their count");
        // Placed vertices sit between their rows' edge vertices but were keyed after them.
        out.keys().sort_unstable_by_key(|&(id, _)| id);
    }
}

/// Prefetches the lines of `rows` (sample rows, point i at index i) that hold the corners i and
/// i + 1 of the cells set in `cells`: per word of cells, every line from its first set cell's to
/// its last's upper corner (a surface's cells cluster along a row).
#[inline(always)]
pub(super) fn prefetch_cells<S, const N: usize>(cells: &[u64], rows: [&[S]; N]) {
    for (w, &word) in cells.iter().enumerate() {
        if word == 0 {
            continue;
        }
        let lo = 64 * w + word.trailing_zeros() as usize;
        let hi = 64 * w + 64 - word.leading_zeros() as usize;
        for row in rows {
            let Some(span) = row.get(lo..(hi + 1).min(row.len())) else { continue };
            let start = span.as_ptr().cast::<i8>();
            let bytes = std::mem::size_of_val(span) as isize;
            // Offsets from `start`, from the start of its line.
            let mut at = -((start as usize % 64) as isize);
            while at < bytes {
                prefetch(start.wrapping_offset(at));
                at += 64;
            }
        }
    }
}

/// A hint to fetch the line holding `at` (never faults; `at` is not read).
#[inline(always)]
pub(super) fn prefetch(at: *const i8) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint; it never faults and does not read the value into a register.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(at);
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = at;
}

/// Write cursors of one slab's cell pass.
struct FillState {
    t: usize,
    q: usize,
    /// Global id of the slab's first vertex.
    plane_v: u64,
    /// Global id of the next vertex a cell of the current row places.
    next_placed: u64,
}

/// A cell of the fill pass: edge vertex ids by rank (computed once per cell), polygons and placed
/// vertices written at their counted offsets.
struct FillCell<'a, X, O> {
    p: &'a Passes<'a, Cells<'a>, X>,
    l: [usize; 3],
    ijk: [u32; 3],
    case: u8,
    odd: bool,
    values: OnceCell<[f32; 8]>,
    /// Vertex ids of the crossed cell segments.
    ids: [u32; CELL_SEGMENTS],
    placed: u8,
    out: &'a mut O,
    state: &'a mut FillState,
}

impl<X: Extractor, O: FillOut> Cell for FillCell<'_, X, O> {
    #[inline]
    fn ijk(&self) -> [u32; 3] {
        self.ijk
    }
    #[inline]
    fn values(&self) -> &[f32; 8] {
        self.values.get_or_init(|| self.p.vol.cell_values(&self.p.bx, self.p.iso, self.l))
    }
    #[inline]
    fn case(&self) -> u8 {
        self.case
    }

    fn hermite(&mut self, e: CubeEdge) -> Hermite {
        let [c0, c1] = e.corners();
        let d = *self.values();
        edge_hermite(self.p.vol, EdgeKey::of_cell(self.ijk, e), d[c0 as usize], d[c1 as usize], self.p.iso).on_edge(e)
    }

    fn crossing(&mut self, e: CubeEdge) -> [f32; 3] {
        let d = *self.values();
        cell_crossing(self.p.vol, self.ijk, e, &d, self.p.iso)
    }

    #[inline(always)]
    fn edge_vertex(&mut self, e: CubeEdge) -> VertexId {
        debug_assert!(
            self.p.crossed[self.case as usize][self.odd as usize] & (1 << e.0) != 0,
            "edge {} does not cross",
            e.0
        );
        VertexId(self.ids[e.0 as usize])
    }

    #[inline]
    fn has_neighbour(&self, face: u8) -> bool {
        segment::has_neighbour(self.p.vol.lattice().dims(), self.ijk, face)
    }

    fn point_value(&mut self, p: CellPoint) -> f32 {
        let d = *self.values();
        segment::point_value(self.p.vol, self.p.iso, self.ijk, &d, &mut [f32::NAN; 7], p)
    }

    fn segment_vertex(&mut self, a: CellPoint, b: CellPoint) -> VertexId {
        let s = match (a, b) {
            (CellPoint::Corner(a), CellPoint::Corner(b)) => {
                cell_segment(a, b, self.p.walked.segments.diagonals, self.odd)
            }
            _ => None,
        };
        match s {
            Some(s) if self.p.crossed[self.case as usize][self.odd as usize] & (1 << s) != 0 => {
                VertexId(self.ids[s as usize])
            }
            _ => unreachable!("an extractor with Counting::Known named a segment it does not declare"),
        }
    }

    fn place_vertex(&mut self, local: [f32; 3], _edges: u16) -> VertexId {
        let (id, n) = (self.state.next_placed, self.placed);
        self.state.next_placed += 1;
        self.placed += 1;
        let at = (id - self.state.plane_v) as usize;
        let p = [0, 1, 2].map(|a| self.ijk[a] as f64 + local[a] as f64);
        let w = self.p.vol.lattice().to_world(p);
        self.out.set_position(at, [w[0] as f32, w[1] as f32, w[2] as f32]);
        if self.p.normals {
            let g = (self.p.vol.gradient_at(p) * self.p.iso.sign()).normalize_or_zero();
            self.out.set_normal(at, g.to_array());
        }
        let key = VertexKey::Cell { ijk: self.ijk, n };
        if self.p.records(&key) {
            self.out.keys().push((id as u32, key));
        }
        VertexId(id as u32)
    }

    fn placed(&mut self, _offset: [i8; 3], _e: CubeEdge) -> Option<Placed> {
        debug_assert!(false, "an extractor with Counting::Known asked for a neighbour's placed vertex");
        None
    }

    #[inline(always)]
    fn push_triangle(&mut self, t: [VertexId; 3]) {
        let t = if self.p.reverse { [t[0].0, t[2].0, t[1].0] } else { [t[0].0, t[1].0, t[2].0] };
        self.out.set_triangle(self.state.t, t);
        self.state.t += 1;
    }

    #[inline]
    fn push_quad(&mut self, q: [VertexId; 4]) {
        let q = if self.p.reverse { [q[0].0, q[3].0, q[2].0, q[1].0] } else { q.map(|v| v.0) };
        self.out.set_quad(self.state.q, q);
        self.state.q += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Row counts with every field varying from row to row.
    fn counts(n: usize) -> Vec<RowCount> {
        (0..n as u32)
            .map(|i| RowCount {
                v: [i * 7 % 5, i % 3, 1, i % 2, 0, i * 5 % 3, 0],
                placed: i % 2,
                tris: i * 3 % 4,
                quads: i / 3 % 2,
            })
            .collect()
    }

    /// Each row's first vertex and each plane's first vertex, triangle and quad are the running
    /// sums of the rows before it: in the whole table, and in a streaming window of two planes
    /// restarted at each plane from the whole table's sums.
    #[test]
    fn first_vertices_and_plane_bases_are_running_sums() {
        let (ny, nz) = (5, 4);
        let all = counts(ny * nz);
        let table = RowTable::prefix(all.clone(), ny, Vec::new()).unwrap();
        let mut acc = [0u64; 3];
        for (r, c) in all.iter().enumerate() {
            if r % ny == 0 {
                assert_eq!(table.plane_base(r / ny), acc, "plane {}", r / ny);
            }
            assert_eq!(table.first_vertex(r) as u64, acc[0], "row {r}");
            for (a, s) in acc.iter_mut().zip(c.sums()) {
                *a += s;
            }
        }
        assert!(acc.iter().all(|&a| a > 0));
        assert_eq!(table.plane_base(nz), acc);
        assert_eq!(table.totals(), acc.map(|a| a as usize));
        let mut window = RowTable::<RowCount>::window(2, ny);
        for k in 0..nz - 1 {
            window.counts.copy_from_slice(&all[k * ny..(k + 2) * ny]);
            window.restart(k * ny, table.plane_base(k)).unwrap();
            for r in k * ny..(k + 2) * ny {
                assert_eq!(window.first_vertex(r), table.first_vertex(r), "window at {k}, row {r}");
            }
            assert_eq!(window.plane_sizes(k, ny), table.plane_sizes(k, ny));
            assert_eq!(window.plane_base(k + 2), table.plane_base(k + 2));
        }
    }

    /// Vertex ids are `u32`: a table of exactly `MeshBuilder::MAX_VERTICES` vertices is built
    /// (its rows' first vertices exact), one more vertex fails with `Error::Limit`.
    #[test]
    fn vertex_sums_stop_at_u32_ids() {
        let rows = |a: u32, b: u32| {
            vec![RowCount { placed: a, ..Default::default() }, RowCount { placed: b, ..Default::default() }]
        };
        let half = (MeshBuilder::MAX_VERTICES / 2) as u32;
        assert_eq!(2 * half as u64, MeshBuilder::MAX_VERTICES);
        let table = RowTable::prefix(rows(half, half), 1, Vec::new()).unwrap();
        assert_eq!([table.first_vertex(0), table.first_vertex(1)], [0, half]);
        assert_eq!(table.totals()[0] as u64, MeshBuilder::MAX_VERTICES);
        let over = RowTable::prefix(rows(half, half + 1), 1, Vec::new());
        assert!(matches!(over, Err(Error::Limit { what: "mesh vertices", .. })), "{:?}", over.err());
    }
}
