//! The counted path for the body-centred tetrahedra (`mt-bcc`): the same passes as the table fast
//! path of MC, mt5 and mt6, with one more bit plane (cell centres) and more segment families.
//!
//! ```text
//!   PASS 1b centres  every cell row → one bit per cell (centre inside): the corners' class where
//!                    they agree (a grid's centre lies between its corners), else the centre's
//!                    value from the samples (the trilinear interpolant's bits, `centre_in`);
//!                    its active cells, which passes 2 and 4 visit (with their neighbours); and
//!                    the active cells' centre values, which the fill reads (`LayerCentres`).
//!                    In memory, run with PASS 1 in groups of planes (layer k right after plane
//!                    k + 1 is classified, its samples still in cache)
//!   PASS 2 count     every row (j, k) → crossings of its families, popcounts of XORed bit rows:
//!                      X Y Z        lattice edges from the row's points (as for MC)
//!                      CC0 … CC7    centre of cell (i, j, k) → its corner c
//!                      CCX CCY CCZ  centre of cell (i, j, k) → centre across its lower face
//!                      BD0 … BD5    diagonal of boundary face f of the cell (pyramid split)
//!                    every cell row → its triangles: the octahedra around its lower faces (two
//!                    centres + the face's corners: 6 sign bits) and the pyramids on its faces on
//!                    the lattice boundary (centre + corners: 5 bits), by table (`BodyCentredTables`)
//!   PASS 3 prefix    running sums per row; PASS 4 fill: vertices by rank, triangles from the
//!                    tables with each crossed segment's id = its row's base + its rank; the
//!                    samples of the active cells prefetched PREFETCH_ROWS cell rows ahead
//! ```
//! Every segment of every solid is owned by exactly one row, so each crossing is one vertex, and
//! the numbering depends on the lattice alone: the same mesh for every thread count, and a
//! stream (a window of slabs) makes it array for array. The triangles are those of
//! [`MarchingTetrahedra`](crate::extract::MarchingTetrahedra)'s `process` on every cell (the
//! keyed path and the other walkers), in cell order, with the same vertices bit for bit (the
//! shared `edge_crossing` and `walk::segment` routines, centres from the samples).
//!
//! Taken for whole-lattice walks of volumes whose centres come from their samples and lie between
//! their corners (grids, the streaming window); ranges (chunks, keys at their boundary) and
//! tabulated fields take the keyed path.

use std::cell::Cell;
use std::mem::MaybeUninit;
use std::sync::atomic::{AtomicU64, Ordering};

use super::bits::{
    cell_mask, cell_rows, for_each_bcc_cell, for_each_bit, mark_active, mask_tail, plane_cell_rows, popcount,
    rank_prefix, uniform_block, Bits, RankedMask, RankedRef,
};
use super::families::{X, Y, Z};
use super::fill::{fill_planes, prefetch_cells, Counted, FillOut, RowTable, PREFETCH_ROWS};
use super::keyed::centre_in;
use super::stream::{fill_batch, Ctx, SlabRing, StreamStats};
use super::{for_each_chunk, reuse_words, reuse_zeroed, Passes, PointBox, Scratch};
use crate::cube::{Axis, CellPoint, EdgeKey, SegmentKey, VertexKey, FACE_CORNERS};
use crate::error::{Error, Result};
use crate::extract::tetrahedra::BccSolid;
use crate::extract::BodyCentredTables;
use crate::grid::Sample;
use crate::mesh::{MeshBuilder, MeshSink, OwnedBatch};
use crate::volume::{Iso, SampleSlabs};
use crate::walk::segment;
use crate::walk::{edge_crossing, edge_normal};
use crate::walk::{Progress, WalkStats};

/// Centre → corner c: family `CC + c`.
const CC: usize = 3;
/// Centre → centre across the lower face on axis a: family `CCL + a`.
const CCL: usize = 11;
/// Diagonal of boundary face f: family `BD + f`.
const BD: usize = 14;
/// Families a row numbers, in this order.
pub(super) const BCC_FAMILIES: usize = 20;

/// Counts of one row: crossings per family, and the triangles of the cell row starting at it.
#[derive(Clone, Copy, Default, Debug, bytemuck::Zeroable)]
pub(super) struct BccRow {
    pub(super) v: [u32; BCC_FAMILIES],
    pub(super) tris: u32,
}

impl BccRow {
    #[inline]
    fn vertices(&self) -> u32 {
        self.v.iter().sum()
    }
    /// The id of each family's first vertex, the row's first being `first`.
    #[inline]
    fn family_bases(&self, first: u32) -> [u32; BCC_FAMILIES] {
        let mut at = first;
        self.v.map(|n| {
            let base = at;
            at += n;
            base
        })
    }
}

impl Counted for BccRow {
    #[inline]
    fn sums(&self) -> [u64; 3] {
        [self.vertices() as u64, self.tris as u64, 0]
    }
}

/// Row counts and each row's first vertex and triangle (no quads).
pub(super) type BccTable = RowTable<BccRow>;

/// Rows of a cell's ranked masks, relative to its cell row A = (j, k).
#[derive(Clone, Copy)]
enum Src {
    A,
    B,
    C,
    E,
    /// (j − 1, k)
    Below,
    /// (j, k − 1)
    Under,
}

/// Mask slots of a cell row: `(family, row)`.
const SLOT_SOURCE: [(usize, Src); SLOTS] = {
    use Src::*;
    let mut t = [(0usize, A); SLOTS];
    t[0] = (X, A);
    t[1] = (X, B);
    t[2] = (X, C);
    t[3] = (X, E);
    t[4] = (Y, A);
    t[5] = (Y, C);
    t[6] = (Z, A);
    t[7] = (Z, B);
    let mut c = 0;
    while c < 8 {
        t[8 + c] = (CC + c, A);
        c += 1;
    }
    // The lower y neighbour's corners 2, 3, 6, 7 and the lower z neighbour's 4, 5, 6, 7.
    let y = [2, 3, 6, 7];
    let mut q = 0;
    while q < 4 {
        t[16 + q] = (CC + y[q], Below);
        t[20 + q] = (CC + 4 + q, Under);
        q += 1;
    }
    let mut a = 0;
    while a < 3 {
        t[24 + a] = (CCL + a, A);
        a += 1;
    }
    let mut f = 0;
    while f < 6 {
        t[27 + f] = (BD + f, A);
        f += 1;
    }
    t
};
const SLOTS: usize = 33;
/// The slots of each source row (`Src as usize`) as `(slot, family)`, in slot order, and their
/// count: the fill sets a cell row's slots source by source, without a branch on each slot's.
const SLOTS_OF: [([(u8, u8); SLOTS], usize); 6] = {
    let mut t = [([(0u8, 0u8); SLOTS], 0usize); 6];
    let mut slot = 0;
    while slot < SLOTS {
        let (f, src) = SLOT_SOURCE[slot];
        let s = src as usize;
        t[s].0[t[s].1] = (slot as u8, f as u8);
        t[s].1 += 1;
        slot += 1;
    }
    t
};

/// The `(slot, family)` pairs of source row `src`.
#[inline(always)]
fn slots_of(src: Src) -> &'static [(u8, u8)] {
    let (list, n) = &SLOTS_OF[src as usize];
    &list[..*n]
}

/// The slots of the x-edges of rows C and E: row E of cell row j is row C of j + 1.
const X_OF_C: usize = 2;
const X_OF_E: usize = 3;
const _: () = assert!(
    SLOT_SOURCE[X_OF_C].0 == X
        && matches!(SLOT_SOURCE[X_OF_C].1, Src::C)
        && SLOT_SOURCE[X_OF_E].0 == X
        && matches!(SLOT_SOURCE[X_OF_E].1, Src::E)
);

/// For each numbered segment (`BCC_SEGMENTS` in extract/tetrahedra.rs): its mask slot and the
/// offset of its owner from the cell's i.
const SEGMENT_SLOT: [(u8, i8); 41] = {
    let mut t = [(0u8, 0i8); 41];
    let mut e = 0;
    while e < 12 {
        let (lo, hi) = ((e & 1) as u8, ((e >> 1) & 1) as u8);
        t[e] = match e / 4 {
            0 => (lo + 2 * hi, 0),
            1 => (4 + hi, lo as i8),
            _ => (6 + hi, lo as i8),
        };
        e += 1;
    }
    let mut c = 0;
    while c < 8 {
        t[12 + c] = (8 + c as u8, 0);
        c += 1;
    }
    let mut a = 0;
    while a < 3 {
        let mut q = 0;
        while q < 4 {
            // Corner c of the face (c without bit a is q), the neighbour's corner n = c | 1 << a.
            let low = q & ((1 << a) - 1);
            let c = low | (q >> a) << (a + 1);
            let n = c | 1 << a;
            t[20 + 4 * a + q] = match a {
                0 => (8 + n as u8, -1),
                1 => (16 + [0, 0, 0, 1, 0, 0, 2, 3][n] as u8, 0),
                _ => (20 + (n - 4) as u8, 0),
            };
            q += 1;
        }
        a += 1;
    }
    let mut a = 0;
    while a < 3 {
        t[32 + a] = (24 + a as u8, 0);
        a += 1;
    }
    let mut f = 0;
    while f < 6 {
        t[35 + f] = (27 + f as u8, 0);
        f += 1;
    }
    // Every slot is a mask slot (`Emit::program` indexes the masks with it unchecked).
    let mut n = 0;
    while n < t.len() {
        assert!((t[n].0 as usize) < SLOTS);
        n += 1;
    }
    t
};

/// The solids of [`BodyCentredTables`] with their segments named as this walker finds their
/// vertices: each distinct crossed segment once, as `slot << 2 | (offset + 1)` ([`SEGMENT_SLOT`]),
/// and the triangles as positions in that list. Besides each octahedron and pyramid, one merged
/// program per cell away from the lattice's faces (by the 12-bit index of
/// [`BodyCentredTables::interior`]): the triangles of its three lower octahedra in their order,
/// each shared segment ranked once (one lookup per cell instead of three solids).
struct SolidPrograms {
    /// Per program: its first segment, its first triangle, their counts.
    spans: Vec<(u32, u32, u8, u8)>,
    segments: Vec<u8>,
    /// The triangles in each orientation: as the solids wind them, and reversed (`[a, c, b]`),
    /// so the fill picks one table per walk instead of a select per triangle.
    triangles: [Vec<[u8; 3]>; 2],
}

/// Cell indices of [`BodyCentredTables::interior`].
const INTERIOR: usize = 4096;

impl SolidPrograms {
    /// The merged program of an interior cell with index `x`.
    const fn interior(x: usize) -> usize {
        x
    }
    /// The program of octahedron `pattern` around a lower face on axis `a`.
    const fn octahedron(a: usize, pattern: usize) -> usize {
        INTERIOR + 64 * a + pattern
    }
    /// The program of pyramid `pattern` on face `f`.
    const fn pyramid(f: usize, pattern: usize) -> usize {
        INTERIOR + 3 * 64 + 32 * f + pattern
    }

    /// The programs, built once.
    fn get() -> &'static Self {
        static PROGRAMS: std::sync::OnceLock<SolidPrograms> = std::sync::OnceLock::new();
        PROGRAMS.get_or_init(|| {
            let t = BodyCentredTables::get();
            let mut p = SolidPrograms { spans: Vec::new(), segments: Vec::new(), triangles: [Vec::new(), Vec::new()] };
            let octahedron = |a: usize, x: usize| &t.octahedra[a][BodyCentredTables::octahedron_pattern(x, a)];
            for x in 0..INTERIOR {
                p.push(&[0, 1, 2].map(|a| octahedron(a, x)));
            }
            for solids in &t.octahedra {
                solids.iter().for_each(|s| p.push(&[s]));
            }
            for solids in &t.pyramids {
                solids.iter().for_each(|s| p.push(&[s]));
            }
            p.triangles[1] = p.triangles[0].iter().map(|&[a, b, c]| [a, c, b]).collect();
            p
        })
    }

    /// Appends the program of `solids`' triangles, in order.
    fn push(&mut self, solids: &[&BccSolid]) {
        let (seg, tri) = (self.segments.len(), self.triangles[0].len());
        // Each numbered segment's position in the program (`u8::MAX`: not yet named).
        let mut position = [u8::MAX; SEGMENT_SLOT.len()];
        for s in solids {
            for t in &s.triangles[..s.triangle_count as usize] {
                // A loop, not `array::map`: its closure stayed out of line (half of this setup's
                // instructions, paid once per process).
                let mut tri = [0u8; 3];
                for (at, &q) in tri.iter_mut().zip(t) {
                    let n = s.segments[q as usize] as usize;
                    if position[n] == u8::MAX {
                        position[n] = (self.segments.len() - seg) as u8;
                        let (slot, off) = SEGMENT_SLOT[n];
                        self.segments.push(slot << 2 | (off + 1) as u8);
                    }
                    *at = position[n];
                }
                self.triangles[0].push(tri);
            }
        }
        let (ns, nt) = (self.segments.len() - seg, self.triangles[0].len() - tri);
        assert!(ns < 64 && nt < 256, "a body-centred program has {ns} segments, {nt} triangles");
        self.spans.push((seg as u32, tri as u32, ns as u8, nt as u8));
    }

    /// Program `p`: its segments and triangles, reversed when `reverse`.
    #[inline(always)]
    fn program(&self, p: usize, reverse: bool) -> (&[u8], &[[u8; 3]]) {
        let (seg, tri, ns, nt) = self.spans[p];
        let (seg, tri) = (seg as usize, tri as usize);
        (&self.segments[seg..seg + ns as usize], &self.triangles[reverse as usize][tri..tri + nt as usize])
    }
}

/// What a cell row's triangles are written from: the programs, and each mask slot's ranked
/// crossings (a rank is the vertex id: the prefix counts start at the family's first id).
struct Emit<'a, 'm> {
    programs: &'a SolidPrograms,
    masks: &'a [RankedRef<'m>; SLOTS],
    reverse: bool,
}

impl Emit<'_, '_> {
    /// The triangles of program `p` for cell i of the row into `tris` from slot `t`; returns the
    /// next slot. Inlined, with the slot in a register: through a closure's captured counter it
    /// was reloaded and stored for every triangle (the stores into `tris` could alias it).
    #[inline(always)]
    fn program(&self, p: usize, i: usize, tris: &mut [MaybeUninit<[u32; 3]>], t: usize) -> usize {
        let (segments, triangles) = self.programs.program(p, self.reverse);
        if triangles.is_empty() {
            return t;
        }
        // One id per segment of the program (at most 63, `SolidPrograms::push`), left
        // uninitialised: a program's triangles name only its segments, set first.
        let mut ids = [MaybeUninit::<u32>::uninit(); 64];
        for (id, &s) in ids.iter_mut().zip(segments) {
            let slot = (s >> 2) as usize;
            let at = (i + (s & 3) as usize).wrapping_sub(1);
            // SAFETY: `slot` is a `SEGMENT_SLOT` slot, below SLOTS; `at` is a point of the row (i;
            // i + 1 for the edges on the cell's upper x; i − 1, taken only when i > 0, for the
            // x-lower octahedron's centre segments), so below nx ≤ 64 · words; the slot of a
            // crossed segment was set, its family being crossed in its row.
            id.write(unsafe { self.masks.get_unchecked(slot).rank_unchecked(at) });
        }
        // The slab's slots for these triangles, checked once per program.
        let end = t + triangles.len();
        for (out, tri) in tris[t..end].iter_mut().zip(triangles) {
            // SAFETY: a program's triangles name positions in its segment list (below 64,
            // `SolidPrograms::push`), each written above.
            out.write(tri.map(|s| unsafe { ids.get_unchecked(s as usize).assume_init() }));
        }
        end
    }
}

/// Bit `i` of a row, across words.
#[inline(always)]
fn bit(row: &[u64], i: usize) -> u64 {
    row[i / 64] >> (i % 64) & 1
}

/// Word `w` of the bits of a cell row's corner `c` (rows A, B, C, E from `rows`), aligned with
/// the cells (bit i = corner c of cell i).
#[inline(always)]
fn corner_word(rows: &[&[u64]; 4], c: u8, w: usize) -> u64 {
    let row = rows[((c >> 1) & 3) as usize];
    if c & 1 == 0 {
        row[w]
    } else {
        (row[w] >> 1) | if w + 1 < row.len() { row[w + 1] << 63 } else { 0 }
    }
}

/// Ranked masks of every family of every row of a plane: masks, prefix popcounts.
type Store = (Vec<u64>, Vec<u32>);

/// A thread's mask stores for [`Passes::bcc_fill_plane`], kept for its next plane: allocating and
/// zeroing ~1 MB per plane cost ~6 % of the walk's instructions. `last` holds the plane it filled
/// last, named by `of` (walk, plane): when that is the plane just below, the triangles read the
/// slots of the row under from it.
#[derive(Default)]
struct MaskStores {
    last: Store,
    spare: Store,
    of: Option<(u64, usize)>,
}

thread_local! {
    static MASK_STORE: Cell<MaskStores> =
        const { Cell::new(MaskStores { last: (Vec::new(), Vec::new()), spare: (Vec::new(), Vec::new()), of: None }) };
}

/// A number no other walk takes, naming its planes in the threads' mask stores.
pub(super) fn walk_id() -> u64 {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

/// The centre values of a cell layer's active cells, row by row, as PASS 1b computed them: the
/// fill takes its centres from here instead of from the samples again (a float centre is eight
/// loads and a chain of eight dependent additions). Inactive cells' centres, which only a
/// centre → centre segment next to an active cell needs, are computed when needed. At most
/// 4 bytes per active cell, a fraction of what the cell's triangles take.
#[derive(Default)]
pub(super) struct LayerCentres {
    values: Vec<f32>,
    /// Where each cell row's values start (one entry more than the layer's rows).
    starts: Vec<usize>,
}

impl LayerCentres {
    /// The bytes it holds.
    pub(super) fn capacity_bytes(&self) -> usize {
        self.values.capacity() * 4 + self.starts.capacity() * std::mem::size_of::<usize>()
    }

    /// The values of the active cells of cell row `j`, in cell order.
    #[inline]
    fn row(&self, j: usize) -> &[f32] {
        &self.values[self.starts[j]..self.starts[j + 1]]
    }
}

/// Bit planes k and k + 1 of `bits` (k again for the last plane, which has no cells).
fn layer_planes(bits: &Bits, k: usize, [ny, nz]: [usize; 2]) -> [&[u64]; 2] {
    let plane = |k: usize| {
        let at = (k * ny - bits.row0) * bits.words;
        &bits.data[at..at + ny * bits.words]
    };
    [plane(k), plane((k + 1).min(nz - 1))]
}

/// Sets `memo[i]` to the stored centre of every active cell i of a cell row (`active`, whose
/// values `values` are in cell order), and the other cells' to NaN (not yet computed).
#[inline(always)]
fn scatter_centres(memo: &mut [f32], active: &[u64], values: &[f32]) {
    memo.fill(f32::NAN);
    let mut at = 0;
    for_each_bit(active, |i| {
        memo[i] = values[at];
        at += 1;
    });
}

/// What a counted body-centred walk shares besides [`Passes`].
pub(super) struct Bcc<'a> {
    pub(super) t: &'a BodyCentredTables,
    /// Centre bits, one row per cell row (`k · ny + j`), laid out as [`Bits`].
    pub(super) centres: &'a Bits,
    /// Active cells ([`mark_active`]), laid out as `centres`.
    pub(super) active: &'a Bits,
    /// The active cells' centre values, per cell layer from the first layer `centres` holds.
    pub(super) values: &'a [LayerCentres],
    /// The walk's [`walk_id`].
    pub(super) walk: u64,
}

impl Bcc<'_> {
    /// The centre values of cell layer `k` of a lattice `ny` cell rows deep.
    #[inline]
    fn layer(&self, k: usize, ny: usize) -> &LayerCentres {
        &self.values[k - self.centres.row0 / ny]
    }
}

/// How the vertex loop names a vertex, for the walks that record keys: its key, or its edge or
/// segment relative to its cell (whose lattice index is given with it).
#[derive(Clone, Copy)]
enum Named<'a> {
    Key(&'a VertexKey),
    /// The cell's lattice edge on this axis.
    Edge(Axis),
    /// Centre → corner c.
    Corner(u8),
    /// Centre of the lower neighbour on axis a → centre.
    Lower(usize),
}

impl Named<'_> {
    /// The key, for cell `g` when it names a segment from the cell's centre.
    #[inline]
    fn key(self, g: [u32; 3]) -> VertexKey {
        let cd = g.map(|x| 2 * x + 1);
        VertexKey::Segment(match self {
            Named::Key(k) => return *k,
            Named::Edge(axis) => return VertexKey::Edge(EdgeKey { origin: g, axis }),
            Named::Corner(c) => {
                let kd = [0, 1, 2].map(|a| 2 * g[a] + 2 * (c as u32 >> a & 1));
                let (a, b) = if cd <= kd { (cd, kd) } else { (kd, cd) };
                SegmentKey { a, b }
            }
            Named::Lower(axis) => {
                let mut nd = cd;
                nd[axis] -= 2;
                SegmentKey { a: nd, b: cd }
            }
        })
    }
}

/// The centre value of cell i of the cell row starting at slab index `at` of slabs `s0`, `s1`
/// (`stride` apart on y), through `memo` (NaN: not yet computed).
#[inline(always)]
fn memo_centre<S: Sample>(memo: &mut [f32], [s0, s1]: [&[S]; 2], [at, stride]: [usize; 2], i: usize, iso: Iso) -> f32 {
    let v = memo[i];
    if v.is_nan() {
        let v = centre_in(s0, s1, at + i, at + stride + i, iso);
        memo[i] = v;
        v
    } else {
        v
    }
}

impl<V: SampleSlabs> Passes<'_, V, ()> {
    /// PASS 1b for cell layer `k` (box-local): the centre bits of its cell rows into `out`, their
    /// active cells into `active` (`ny` rows of `bits.words` each) and the active cells' centre
    /// values into `values`; returns its all-outside and all-inside cell counts.
    #[inline(always)]
    fn centres_in<const V3: bool>(
        &self,
        planes: [&[u64]; 2],
        k: usize,
        out: &mut [u64],
        active: &mut [u64],
        values: &mut LayerCentres,
    ) -> [u64; 2] {
        let [nx, ny, nz] = self.bx.dims;
        let words = planes[0].len() / ny;
        let mut cs = [0u64; 2];
        values.values.clear();
        values.starts.clear();
        values.starts.resize(ny + 1, 0);
        // The rows below write every word of theirs: the last row (and the last plane) has no cells.
        let cells_end = if k + 1 >= nz { 0 } else { (ny - 1) * words };
        out[cells_end..].fill(0);
        active[cells_end..].fill(0);
        if k + 1 >= nz {
            return cs;
        }
        let z = self.bx.lo[2] + k as u32;
        let (s0, s1) = (self.vol.slab(z), self.vol.slab(z + 1));
        let stride = self.bx.row_stride();
        for j in 0..ny - 1 {
            let rows = plane_cell_rows(planes, j, words);
            let active = &mut active[j * words..(j + 1) * words];
            let (outside, inside) = mark_active(rows, nx - 1, active);
            cs[0] += outside;
            cs[1] += inside;
            let at = self.bx.in_slab(0, j);
            let o = &mut out[j * words..(j + 1) * words];
            for w in 0..words {
                o[w] = rows[0][w] & !active[w];
            }
            values.starts[j] = values.values.len();
            for_each_bit(active, |i| {
                let v = centre_in(s0, s1, at + i, at + stride + i, self.iso);
                values.values.push(v);
                if v < 0.0 {
                    o[i / 64] |= 1 << (i % 64);
                }
            });
            mask_tail(o, nx - 1);
        }
        let end = values.values.len();
        values.starts[ny - 1..].fill(end);
        cs
    }

    /// The crossing on the segment from index-space point `p0` (offset value `d0`) to `p1` (`d1`),
    /// `p0` the end its `SegmentKey` names first: the world point, and the normal when the walk
    /// writes normals. Always inlined: the ends passed to a call went through memory, and their
    /// reload stalled on store forwarding.
    #[inline(always)]
    fn bcc_segment_vertex(&self, p0: [f64; 3], p1: [f64; 3], d0: f32, d1: f32) -> ([f32; 3], Option<[f32; 3]>) {
        let q = segment::point_between(self.vol, [p0, p1], d0, d1, self.iso);
        let n = self.normals.then(|| segment::normal_between(self.vol, [p0, p1], q, d0, self.iso));
        (segment::world_point(self.vol, q), n)
    }

    /// Word by word, the crossings of families X … CCL + 2 (all but the boundary-face diagonals)
    /// of row `r` = (j, k), which starts a cell row (j + 1 < ny, k + 1 < nz): `each(w, m)` with
    /// `m[f]` word w of [`bcc_mask`](Self::bcc_mask)'s family f (0 where it has none). The corner
    /// words are built once for the edges and the eight centre → corner families.
    #[inline(always)]
    fn bcc_row_words(
        &self,
        bits: &Bits,
        cb: &Bits,
        r: usize,
        [j, k]: [usize; 2],
        mut each: impl FnMut(usize, &[u64; BD]),
    ) {
        let [nx, ny, _] = self.bx.dims;
        let words = bits.words;
        let rows = cell_rows(bits, r, ny);
        let c = cb.row(r);
        let cy = if j > 0 { cb.row(r - 1) } else { c };
        let cz = if k > 0 { cb.row(r - ny) } else { c };
        // Every word but the last is whole, for the points and for the cells.
        let tail = (cell_mask(words - 1, nx - 1), cell_mask(words - 1, nx));
        let mut carry = 0;
        for w in 0..words {
            let (cm, pm) = if w + 1 < words { (!0, !0) } else { tail };
            let mut corners = [0u64; 8];
            for (q, row) in rows.iter().enumerate() {
                let next = if w + 1 < words { row[w + 1] << 63 } else { 0 };
                corners[2 * q] = row[w];
                corners[2 * q + 1] = (row[w] >> 1) | next;
            }
            let cw = c[w];
            let mut m = [0u64; BD];
            m[X] = (corners[0] ^ corners[1]) & cm;
            m[Y] = (corners[0] ^ corners[2]) & pm;
            m[Z] = (corners[0] ^ corners[4]) & pm;
            for (q, &corner) in corners.iter().enumerate() {
                m[CC + q] = (cw ^ corner) & cm;
            }
            // Cell 0 has no lower x neighbour.
            let first = if w == 0 { !1 } else { !0 };
            m[CCL] = (cw ^ (cw << 1 | carry)) & cm & first;
            carry = cw >> 63;
            m[CCL + 1] = (cw ^ cy[w]) & cm;
            m[CCL + 2] = (cw ^ cz[w]) & cm;
            each(w, &m);
        }
    }

    /// Whether cell row (j, k) has cells on box face `face` (`2 · axis + upper`): all of them do
    /// on x (one cell each), on y and z the first or last cell row of the axis.
    #[inline]
    fn bcc_on_face(&self, face: usize, [j, k]: [usize; 2]) -> bool {
        let [_, ny, nz] = self.bx.dims;
        let (at, last) = match face / 2 {
            0 => return true,
            1 => (j, ny - 2),
            _ => (k, nz - 2),
        };
        at == if face % 2 == 1 { last } else { 0 }
    }

    /// Family `f`'s crossings in row `r` = (j, k) into `out`; false when the row has none.
    #[inline]
    fn bcc_mask(&self, f: usize, bits: &Bits, cb: &Bits, r: usize, [j, k]: [usize; 2], out: &mut [u64]) -> bool {
        let [nx, ny, nz] = self.bx.dims;
        if f <= Z {
            return self.walked.mask(f, bits, r, [j, k], self.bx.dims, out);
        }
        if j + 1 >= ny || k + 1 >= nz {
            return false;
        }
        let words = bits.words;
        let cells = nx - 1;
        let c = cb.row(r);
        match f {
            _ if f < CCL => {
                let rows = cell_rows(bits, r, ny);
                let corner = (f - CC) as u8;
                for w in 0..words {
                    out[w] = c[w] ^ corner_word(&rows, corner, w);
                }
            }
            _ if f == CCL => {
                for w in 0..words {
                    let carry = if w > 0 { c[w - 1] >> 63 } else { 0 };
                    out[w] = c[w] ^ (c[w] << 1 | carry);
                }
                out[0] &= !1;
            }
            _ if f == CCL + 1 || f == CCL + 2 => {
                if (f == CCL + 1 && j == 0) || (f == CCL + 2 && k == 0) {
                    return false;
                }
                let d = if f == CCL + 1 { cb.row(r - 1) } else { cb.row(r - ny) };
                for w in 0..words {
                    out[w] = c[w] ^ d[w];
                }
            }
            _ => {
                let face = f - BD;
                let (axis, upper) = (face / 2, face % 2 == 1);
                if !self.bcc_on_face(face, [j, k]) {
                    return false;
                }
                let rows = cell_rows(bits, r, ny);
                let fc = FACE_CORNERS[face];
                if axis == 0 {
                    // One cell of the row has this face on the boundary.
                    let i = if upper { nx - 2 } else { 0 };
                    let corner = |c: u8| bit(rows[((c >> 1) & 3) as usize], i + (c & 1) as usize);
                    out.fill(0);
                    out[i / 64] = (corner(fc[0]) ^ corner(fc[2])) << (i % 64);
                    return true;
                }
                for w in 0..words {
                    out[w] = corner_word(&rows, fc[0], w) ^ corner_word(&rows, fc[2], w);
                }
            }
        }
        mask_tail(out, cells);
        true
    }

    /// The triangles of box cell (i, j, k) on a face of the box or next to one, whose case and
    /// centre bits are `x` (as [`for_each_bcc_cell`] gives them); interior cells read
    /// `BodyCentredTables::interior` instead.
    #[inline(always)]
    fn bcc_cell_count(&self, t: &BodyCentredTables, x: usize, [i, j, k]: [usize; 3]) -> u32 {
        let [nx, ny, nz] = self.bx.dims;
        let (case, centre) = (x & 255, x >> 8 & 1);
        let l = [i, j, k];
        let last = [nx - 2, ny - 2, nz - 2];
        let mut n = 0;
        for f in 0..6 {
            let a = f / 2;
            let corners = t.face_case[f][case] as usize;
            let boundary = if f % 2 == 0 { l[a] == 0 } else { l[a] == last[a] };
            if boundary {
                n += t.pyramids[f][centre | corners << 1].triangle_count as u32;
            } else if f % 2 == 0 {
                n += t.octahedra[a][BodyCentredTables::octahedron_pattern(x, a)].triangle_count as u32;
            }
        }
        n
    }

    /// Cells of cell row `r` = (j, k) that can have triangles: the active ones and those just
    /// above an active one on some axis (their octahedra hold its centre), into `visit`.
    fn bcc_visit(&self, active: &Bits, r: usize, [j, k]: [usize; 2], visit: &mut [u64]) {
        let [nx, ny, _] = self.bx.dims;
        let here = active.row(r);
        // A missing neighbour row reads as this row (its cells are in `visit` anyway).
        let below = if j > 0 { active.row(r - 1) } else { here };
        let under = if k > 0 { active.row(r - ny) } else { here };
        let mut carry = 0;
        for (w, ((v, &h), (&y, &z))) in visit.iter_mut().zip(here).zip(below.iter().zip(under)).enumerate() {
            *v = (h | h << 1 | carry | y | z) & cell_mask(w, nx - 1);
            carry = h >> 63;
        }
    }

    /// PASS 2 for the rows of plane `k` into `out` (`zeroed`: as for `count_plane`).
    #[inline(always)]
    fn count_plane_in<const V3: bool>(&self, b: &Bcc<'_>, bits: &Bits, k: usize, out: &mut [BccRow], zeroed: bool) {
        let [nx, ny, nz] = self.bx.dims;
        let words = bits.words;
        let mut mask = vec![0u64; words];
        let mut visit = vec![0u64; words];
        let dims = self.bx.dims;
        // Whether the points of cell row (j, k) and those of the next rows on y and z are all on
        // one side (the row on the lattice's last y or z plane: its points and the next ones):
        // for a cell row, whether it has no active cell (neighbouring cells share corners).
        let uniform = |r: usize, [j, k]: [usize; 2]| {
            if dims[0] > 1 && j + 1 < ny && k + 1 < nz {
                b.active.row(r).iter().all(|&w| w == 0).then(|| (bits.row(r)[0] & 1) as u8)
            } else {
                uniform_block(bits, r, [j, k], dims)
            }
        };
        let mut below = None;
        for (j, c) in out.iter_mut().enumerate() {
            let r = k * ny + j;
            // A row whose cell row and the cell rows below it on y and z are uniform (all on one
            // side, so are their centres) crosses no segment and has no triangle.
            let here = uniform(r, [j, k]);
            let skip = here.is_some() && (j == 0 || below == here) && (k == 0 || uniform(r - ny, [j, k - 1]) == here);
            below = here;
            if skip {
                if !zeroed {
                    *c = BccRow::default();
                }
                continue;
            }
            *c = BccRow::default();
            // Rows on the last y or z plane start edges only.
            let cell_row = j + 1 < ny && k + 1 < nz;
            if cell_row {
                self.bcc_row_words(bits, b.centres, r, [j, k], |_, m| {
                    for (v, m) in c.v.iter_mut().zip(m) {
                        *v += m.count_ones();
                    }
                });
            }
            for f in if cell_row { BD..BCC_FAMILIES } else { 0..CC } {
                if cell_row && !self.bcc_on_face(f - BD, [j, k]) {
                    continue;
                }
                if self.bcc_mask(f, bits, b.centres, r, [j, k], &mut mask) {
                    c.v[f] = popcount(&mask);
                }
            }
            if !cell_row {
                continue;
            }
            self.bcc_visit(b.active, r, [j, k], &mut visit);
            let rows = cell_rows(bits, r, ny);
            let cr = b.centres.row(r);
            let cy = if j > 0 { b.centres.row(r - 1) } else { cr };
            let cz = if k > 0 { b.centres.row(r - ny) } else { cr };
            let mut tris = 0;
            let inner_row = j > 0 && k > 0 && j + 2 < ny && k + 2 < nz;
            for_each_bcc_cell(&rows, [cr, cy, cz], &visit, |i, x| {
                tris += if inner_row && i > 0 && i + 2 < nx {
                    b.t.interior[x & 4095] as u32
                } else {
                    self.bcc_cell_count(b.t, x, [i, j, k])
                };
            });
            c.tris = tris;
        }
    }

    /// PASS 4 for box plane `k`: the vertices of its rows, then the triangles of its cell rows.
    ///
    /// # Panics
    /// When the counts and the fill disagree (an internal error).
    #[inline(always)]
    fn fill_plane_in<O: FillOut, const V3: bool>(
        &self,
        b: &Bcc<'_>,
        bits: &Bits,
        table: &BccTable,
        k: usize,
        out: &mut O,
    ) {
        let [out_vertices, out_triangles, _] = out.sizes();
        let bx = &self.bx;
        let [nx, ny, nz] = bx.dims;
        let words = bits.words;
        let z = bx.lo[2] + k as u32;
        let s0 = self.vol.slab(z);
        let s1 = if k + 1 < nz { self.vol.slab(z + 1) } else { s0 };
        let plane = table.plane_base(k);
        let stride = bx.row_stride();
        let offset = |a: V::Sample| self.iso.offset(a.to_f64());
        // Ranked crossing masks of every family of every row of the plane (those of a family
        // not crossed in its row are left unset: no triangle names them). The vertices walk
        // them, and the triangles of the plane's cell rows find in them all their slots but
        // those of rows C, E and `Under` (7 of 33; `Under` too when this thread filled plane
        // k − 1 last). The thread's spare store, grown if need be: every entry read is written
        // first, so it is not cleared.
        let row_words = BCC_FAMILIES * words;
        let MaskStores { last: under, spare: (mut store, mut store_before), of } = MASK_STORE.take();
        let under_kept = k > 0 && of == Some((b.walk, k - 1));
        let keep = |store, store_before, under| {
            MASK_STORE.set(MaskStores { last: (store, store_before), spare: under, of: Some((b.walk, k)) })
        };
        store.resize(ny * row_words, 0);
        store_before.resize(ny * row_words, 0);
        let mut out_v = 0usize;
        // Centre values of the current cell row and of the one before it on y, computed once
        // (NaN: not yet); `cur_j` is the row `cur` belongs to.
        let mut cur = vec![f32::NAN; nx];
        let mut prev = vec![f32::NAN; nx];
        let mut cur_j = None;
        // The centres of cell row (j, k − 1), for the centre → centre segments on z (NaN: not
        // yet); `below_j` is the row it belongs to.
        let mut below = vec![f32::NAN; nx];
        let mut below_j = None;
        // The slab below (for the centres of cell layer k − 1).
        let sm = if k > 0 { self.vol.slab(z - 1) } else { s0 };
        // The centre of cell i of the cell row starting at slab index `at` in slabs k, k + 1,
        // through `memo` (NaN: not yet).
        let cached = |memo: &mut [f32], at: usize, i: usize| memo_centre(memo, [s0, s1], [at, stride], i, self.iso);
        // The samples of the active cells of cell row j: rows j + 1 of slabs k and k + 1 are
        // new to it (row j's were read by the row before), prefetched PREFETCH_ROWS rows ahead.
        let fetch = |j: usize| {
            if j + 1 < ny && k + 1 < nz {
                let at = bx.in_slab(0, j + 1);
                prefetch_cells(b.active.row(k * ny + j), [&s0[at..at + nx], &s1[at..at + nx]]);
            }
        };
        (0..PREFETCH_ROWS.min(ny)).for_each(fetch);
        for j in 0..ny {
            fetch(j + PREFETCH_ROWS);
            let r = k * ny + j;
            let c = table.count(r);
            assert_eq!(plane[0] + out_v as u64, table.first_vertex(r) as u64, "internal: row {r} starts off its count");
            if c.vertices() == 0 {
                continue;
            }
            let cell_row = j + 1 < ny && k + 1 < nz;
            if j > 0 && cur_j == Some(j - 1) {
                std::mem::swap(&mut cur, &mut prev);
            } else if j > 0 && k + 1 < nz {
                scatter_centres(&mut prev, b.active.row(r - 1), b.layer(k, ny).row(j - 1));
            } else {
                prev.fill(f32::NAN);
            }
            if cell_row {
                scatter_centres(&mut cur, b.active.row(r), b.layer(k, ny).row(j));
            } else {
                cur.fill(f32::NAN);
            }
            cur_j = Some(j);
            let at = bx.in_slab(0, j);
            // Keys are built only when recorded (most walks record none), from what names them:
            // moving keys by value through these closures stalled on store forwarding (about 15 %
            // of the fill's wall time), and so did taking the address of the segment's ends.
            let mut push = |(p, n): ([f32; 3], Option<[f32; 3]>), i: usize, named: Named<'_>| {
                self.put_vertex(out, out_v, plane[0], p, n, || named.key(bx.global([i, j, k])));
                out_v += 1;
            };
            // Index-space points of the row: the centre of cell i, and its corner o (the values
            // `SegmentKey::ends` gives, exactly).
            let [gx, gy, gz] = bx.global([0, j, k]).map(|x| x as f64);
            let centre = |i: usize| [gx + i as f64 + 0.5, gy + 0.5, gz + 0.5];
            let corner = |i: usize, o: [usize; 3]| [gx + (i + o[0]) as f64, gy + o[1] as f64, gz + o[2] as f64];
            // The masks of all families but the boundary diagonals at once (rows starting a cell
            // row), the others one by one.
            if cell_row {
                let row = &mut store[j * row_words..(j + 1) * row_words];
                self.bcc_row_words(bits, b.centres, r, [j, k], |w, m| {
                    for (f, &m) in m.iter().enumerate() {
                        row[f * words + w] = m;
                    }
                });
            }
            let first = c.family_bases(table.first_vertex(r));
            for f in 0..BCC_FAMILIES {
                let at_f = (j * BCC_FAMILIES + f) * words..(j * BCC_FAMILIES + f + 1) * words;
                let mask = &mut store[at_f.clone()];
                if c.v[f] == 0 || !((cell_row && f < BD) || self.bcc_mask(f, bits, b.centres, r, [j, k], mask)) {
                    continue;
                }
                rank_prefix(mask, &mut store_before[at_f], first[f]);
                let mask = &*mask;
                let sample = |i: usize, o: [usize; 3]| {
                    let s = if o[2] == 0 { s0 } else { s1 };
                    offset(s[at + o[1] * stride + i + o[0]])
                };
                match f {
                    // Lattice edges (as `Walked::segment` names them, without its match per vertex).
                    _ if f <= Z => {
                        let axis = match f {
                            X => Axis::X,
                            Y => Axis::Y,
                            _ => Axis::Z,
                        };
                        let u = axis.unit().map(|x| x as usize);
                        for_each_bit(mask, |i| {
                            let e = EdgeKey { origin: bx.global([i, j, k]), axis };
                            let (d0, d1) = (sample(i, [0; 3]), sample(i, u));
                            let (p, t) = edge_crossing(self.vol, e, d0, d1, self.iso);
                            push(
                                (p, self.normals.then(|| edge_normal(self.vol, e, t, d0, self.iso))),
                                i,
                                Named::Edge(axis),
                            );
                        });
                    }
                    // Centre → corner c (`SegmentKey`'s order: the end with the lower doubled
                    // coordinates first, here decided on x).
                    _ if f < CCL => {
                        let corner_c = f - CC;
                        let o = [corner_c & 1, corner_c >> 1 & 1, corner_c >> 2];
                        let named = Named::Corner(corner_c as u8);
                        // One loop per order (a branch on it inside was mispredicted at every
                        // change of family); the centres are in `cur` (above).
                        if o[0] == 1 {
                            for_each_bit(mask, |i| {
                                let v = self.bcc_segment_vertex(centre(i), corner(i, o), cur[i], sample(i, o));
                                push(v, i, named);
                            });
                        } else {
                            for_each_bit(mask, |i| {
                                let v = self.bcc_segment_vertex(corner(i, o), centre(i), sample(i, o), cur[i]);
                                push(v, i, named);
                            });
                        }
                    }
                    // Centre of the lower neighbour on axis a → centre (the neighbour's end first).
                    _ if f < BD => {
                        let axis = f - CCL;
                        if axis == 2 && below_j != Some(j) {
                            scatter_centres(&mut below, b.active.row(r - ny), b.layer(k - 1, ny).row(j));
                            below_j = Some(j);
                        }
                        // The step to the lower centre, subtracted on every axis (x − 0 = x): an
                        // index into the point went through memory and stalled on its reload.
                        let step = [0, 1, 2].map(|a| if a == axis { 1.0 } else { 0.0 });
                        for_each_bit(mask, |i| {
                            let vn = match axis {
                                0 => cached(&mut cur, at, i - 1),
                                1 => cached(&mut prev, at - stride, i),
                                _ => memo_centre(&mut below, [sm, s0], [at, stride], i, self.iso),
                            };
                            let vc = cached(&mut cur, at, i);
                            let pc = centre(i);
                            let pn = [0, 1, 2].map(|a| pc[a] - step[a]);
                            push(self.bcc_segment_vertex(pn, pc, vn, vc), i, Named::Lower(axis));
                        });
                    }
                    // Diagonal of a boundary face (rare: the generic route).
                    _ => {
                        let fc = FACE_CORNERS[f - BD];
                        for_each_bit(mask, |i| {
                            let value = |p: CellPoint| match p {
                                CellPoint::Corner(c) => {
                                    sample(i, [(c & 1) as usize, (c >> 1 & 1) as usize, (c >> 2) as usize])
                                }
                                _ => unreachable!("face diagonals join corners"),
                            };
                            let (key, d0, d1) = segment::segment_ends(
                                bx.global([i, j, k]),
                                CellPoint::Corner(fc[0]),
                                CellPoint::Corner(fc[2]),
                                value,
                            );
                            let (p0, p1) = key.ends();
                            push(self.bcc_segment_vertex(p0, p1, d0, d1), i, Named::Key(&VertexKey::Segment(key)));
                        });
                    }
                }
            }
        }
        assert_eq!(out_v, out_vertices, "internal: slab {k} vertices off their count");
        if k + 1 >= nz {
            assert_eq!(out_triangles, 0, "internal: triangles counted past the last layer");
            keep(store, store_before, under);
            return;
        }
        // Triangles of the cell rows of layer k: slots of rows A, B and `Below` from the store,
        // `Under` from the last plane's when kept, the others into `own`; row C's x-edges are the
        // last cell row's row E's when it was j − 1.
        let mut own: [RankedMask; SLOTS] = std::array::from_fn(|_| RankedMask::new(words));
        let mut visit = vec![0u64; words];
        let mut t_out = 0usize;
        let programs = SolidPrograms::get();
        let last = [nx - 2, ny - 2, nz - 2];
        let mut last_row = None;
        for j in 0..ny - 1 {
            let r = k * ny + j;
            if table.count(r).tris == 0 {
                continue;
            }
            let carried = last_row.is_some_and(|l| l + 1 == j);
            if carried {
                own.swap(X_OF_C, X_OF_E);
            }
            last_row = Some(j);
            let mut own_slots = |src: Src, row: usize, jk: [usize; 2]| {
                let count = table.count(row);
                let first = count.family_bases(table.first_vertex(row));
                for &(slot, f) in slots_of(src) {
                    let (slot, f) = (slot as usize, f as usize);
                    if !(carried && slot == X_OF_C) && count.v[f] != 0 {
                        let m = &mut own[slot];
                        self.bcc_mask(f, bits, b.centres, row, jk, &mut m.mask);
                        m.rank_prefix(first[f]);
                    }
                }
            };
            own_slots(Src::C, r + ny, [j, k + 1]);
            own_slots(Src::E, r + ny + 1, [j + 1, k + 1]);
            if k > 0 && !under_kept {
                own_slots(Src::Under, r - ny, [j, k - 1]);
            }
            let mut masks = [RankedRef::new(&[], &[]); SLOTS];
            // Every slot of a source row that exists, crossed in its row or not: a family not
            // crossed in its row names no segment of these cells, so its stale mask is never read.
            // (`None`: the row's masks are in `own`.)
            let here = Some((&store[..], &store_before[..]));
            let from = [
                (Src::A, here, j),
                (Src::B, here, j + 1),
                (Src::C, None, j),
                (Src::E, None, j),
                (Src::Below, here, j.wrapping_sub(1)),
                (Src::Under, if under_kept { Some((&under.0[..], &under.1[..])) } else { None }, j),
            ];
            let exists = [true, true, true, true, j > 0, k > 0];
            for ((src, masks_of, j_row), _) in from.into_iter().zip(exists).filter(|&(_, e)| e) {
                for &(slot, f) in slots_of(src) {
                    let (slot, f) = (slot as usize, f as usize);
                    masks[slot] = match masks_of {
                        Some((m, before)) => {
                            let at = (j_row * BCC_FAMILIES + f) * words..(j_row * BCC_FAMILIES + f + 1) * words;
                            RankedRef::new(&m[at.clone()], &before[at])
                        }
                        None => own[slot].as_ref(),
                    };
                }
            }
            self.bcc_visit(b.active, r, [j, k], &mut visit);
            let rows = cell_rows(bits, r, ny);
            // Centre rows of this cell row and of those below it on y and z (when they exist).
            let cr = b.centres.row(r);
            let cy = if j > 0 { b.centres.row(r - 1) } else { cr };
            let cz = if k > 0 { b.centres.row(r - ny) } else { cr };
            // Cell rows away from the lattice's y and z faces: cells away from all faces have just
            // the octahedra of their lower faces.
            let inner_row = j > 0 && k > 0 && j + 2 < ny && k + 2 < nz;
            let cell = Emit { programs, masks: &masks, reverse: self.reverse };
            let tris = out.triangles();
            for_each_bcc_cell(&rows, [cr, cy, cz], &visit, |i, x| {
                if inner_row && i > 0 && i + 2 < nx {
                    t_out = cell.program(SolidPrograms::interior(x & (INTERIOR - 1)), i, tris, t_out);
                    return;
                }
                let (case, centre) = (x & 255, x >> 8 & 1);
                let l = [i, j, k];
                for f in 0..6 {
                    let a = f / 2;
                    let corners = b.t.face_case[f][case] as usize;
                    let boundary = if f % 2 == 0 { l[a] == 0 } else { l[a] == last[a] };
                    if boundary {
                        t_out = cell.program(SolidPrograms::pyramid(f, centre | corners << 1), i, tris, t_out);
                    } else if f % 2 == 0 {
                        let p = SolidPrograms::octahedron(a, BodyCentredTables::octahedron_pattern(x, a));
                        t_out = cell.program(p, i, tris, t_out);
                    }
                }
            });
        }
        assert_eq!(t_out, out_triangles, "internal: slab {k} triangles off their count");
        keep(store, store_before, under);
    }
}

/// Whether this CPU runs the passes' x86-64-v3 copies: AVX2, BMI1, BMI2 and LZCNT (every x86-64
/// CPU since about 2015). The build's baseline is x86-64-v2 (`.cargo/config.toml`); the bit loops
/// gain `shlx`, `bzhi`, `blsr` and `tzcnt`, and the word loops wider vectors. No FMA: the same
/// arithmetic, so the same mesh bit for bit.
#[inline]
fn v3() -> bool {
    #[cfg(test)]
    if BASELINE_ONLY.load(Ordering::Relaxed) {
        return false;
    }
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        has!("avx2") && has!("bmi1") && has!("bmi2") && has!("lzcnt")
    }
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// While set, [`v3`] says no: tests run the baseline copies on CPUs that have the other. Both copies
/// make the same mesh, so walks of other tests running meanwhile are unaffected.
#[cfg(test)]
pub(super) static BASELINE_ONLY: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// The passes, each run as its x86-64-v3 copy where the CPU has it ([`v3`]), else as built. Each
/// copy is its own instance of the pass's body (`V3`), so the closures inside are too: with one
/// call site each they are inlined (shared by both copies, the fill's stayed out of line and ran
/// 1.03–1.31× slower).
impl<V: SampleSlabs> Passes<'_, V, ()> {
    /// PASS 1b ([`centres_in`](Self::centres_in)).
    pub(super) fn bcc_centres(
        &self,
        planes: [&[u64]; 2],
        k: usize,
        out: &mut [u64],
        active: &mut [u64],
        values: &mut LayerCentres,
    ) -> [u64; 2] {
        #[cfg(target_arch = "x86_64")]
        if v3() {
            // SAFETY: the CPU has the copy's features (`v3`).
            return unsafe { self.centres_v3(planes, k, out, active, values) };
        }
        self.centres_in::<false>(planes, k, out, active, values)
    }

    /// PASS 2 ([`count_plane_in`](Self::count_plane_in)).
    pub(super) fn bcc_count_plane(&self, b: &Bcc<'_>, bits: &Bits, k: usize, out: &mut [BccRow], zeroed: bool) {
        #[cfg(target_arch = "x86_64")]
        if v3() {
            // SAFETY: as above.
            return unsafe { self.count_plane_v3(b, bits, k, out, zeroed) };
        }
        self.count_plane_in::<false>(b, bits, k, out, zeroed)
    }

    /// PASS 4 ([`fill_plane_in`](Self::fill_plane_in)).
    pub(super) fn bcc_fill_plane<O: FillOut>(&self, b: &Bcc<'_>, bits: &Bits, table: &BccTable, k: usize, out: &mut O) {
        #[cfg(target_arch = "x86_64")]
        if v3() {
            // SAFETY: as above.
            return unsafe { self.fill_plane_v3(b, bits, table, k, out) };
        }
        self.fill_plane_in::<O, false>(b, bits, table, k, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,bmi2,lzcnt")]
    fn centres_v3(
        &self,
        planes: [&[u64]; 2],
        k: usize,
        out: &mut [u64],
        active: &mut [u64],
        values: &mut LayerCentres,
    ) -> [u64; 2] {
        self.centres_in::<true>(planes, k, out, active, values)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,bmi2,lzcnt")]
    fn count_plane_v3(&self, b: &Bcc<'_>, bits: &Bits, k: usize, out: &mut [BccRow], zeroed: bool) {
        self.count_plane_in::<true>(b, bits, k, out, zeroed)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,bmi2,lzcnt")]
    fn fill_plane_v3<O: FillOut>(&self, b: &Bcc<'_>, bits: &Bits, table: &BccTable, k: usize, out: &mut O) {
        self.fill_plane_in::<O, true>(b, bits, table, k, out)
    }
}

/// Whether a walk of `range` on `vol` can take the counted body-centred path.
pub(super) fn applies<V: SampleSlabs>(vol: &V, bx: &PointBox, range: &crate::cube::CellRange) -> bool {
    let all = crate::cube::CellRange::all(vol.lattice().dims());
    *range == all && bx.lo == [0; 3] && vol.centres_from_samples() && vol.bounded_by_corners()
}

impl<V: SampleSlabs + Sync> Passes<'_, V, ()> {
    /// PASS 1b–4 of the counted body-centred walk of the whole lattice (see the module doc).
    pub(super) fn bcc_counted(
        &self,
        t: &BodyCentredTables,
        bits: &mut Bits,
        out: &mut MeshBuilder,
        progress: Option<&dyn Progress>,
        scratch: &mut Scratch,
    ) -> Result<WalkStats> {
        let [_, ny, nz] = self.bx.dims;
        let words = bits.words;
        let plane = ny * words;
        let mut centres = Bits { words, row0: 0, data: reuse_words(&mut scratch.centres, ny * nz * words) };
        let mut active = Bits { words, row0: 0, data: reuse_words(&mut scratch.active, ny * nz * words) };
        let mut values = std::mem::take(&mut scratch.bcc_values);
        values.resize_with(nz, LayerCentres::default);
        // PASS 1 and 1b together, in groups of GROUP planes: each group classifies its planes (and
        // the next group's first again, into a buffer of its own) and takes each layer's centres
        // right after classifying the plane above it, while both slabs of samples are in cache.
        // As two passes, the centres read most of slab k + 1 from memory a second time, on lines
        // the hardware could not guess (5 % of mt-bcc's time on noise 512³, BENCHMARKS §6.21).
        const GROUP: usize = 8;
        let tasks: Vec<_> = bits
            .data
            .chunks_mut(GROUP * plane)
            .zip(centres.data.chunks_mut(GROUP * plane))
            .zip(active.data.chunks_mut(GROUP * plane))
            .zip(values.chunks_mut(GROUP))
            .enumerate()
            .map(|(g, (((b, c), a), v))| (g * GROUP, b, c, a, v))
            .collect();
        let per_group = super::map_tasks(tasks, &|(k0, b, c, a, v)| {
            let classify = |k: usize, out: &mut [u64]| {
                super::classify::classify_plane(self.vol, &self.bx, self.bx.lo[2] + k as u32, self.iso, out)
            };
            let mut next = Vec::new();
            classify(k0, &mut b[..plane]);
            let mut cs = Vec::with_capacity(v.len());
            for (n, v) in v.iter_mut().enumerate() {
                let (k, at) = (k0 + n, n * plane);
                let (here, above) = b.split_at_mut(at + plane);
                let here = &here[at..];
                // The last plane has no cells above it (its layer has none).
                let above: &[u64] = match above.get_mut(..plane) {
                    _ if k + 1 >= nz => here,
                    Some(above) => {
                        classify(k + 1, above);
                        above
                    }
                    None => {
                        next.resize(plane, 0);
                        classify(k + 1, &mut next);
                        &next
                    }
                };
                cs.push(self.bcc_centres([here, above], k, &mut c[at..at + plane], &mut a[at..at + plane], v));
            }
            cs
        });
        let cell_stats = per_group.concat();
        let bits = &*bits;
        let stats = WalkStats {
            cells: self.range.num_cells(),
            cells_outside: cell_stats.iter().map(|c| c[0]).sum(),
            cells_inside: cell_stats.iter().map(|c| c[1]).sum(),
        };
        let b = Bcc { t, centres: &centres, active: &active, values: &values, walk: walk_id() };
        // PASS 2: count (every row's count is set: written from zero, or left zero when fresh).
        let (mut counts, zeroed) = reuse_zeroed(&mut scratch.bcc_counts, ny * nz);
        for_each_chunk(&mut counts, ny, &|k, plane| self.bcc_count_plane(&b, bits, k, plane, zeroed));
        // PASS 3: prefix sums.
        let table = BccTable::prefix(counts, ny, std::mem::take(&mut scratch.first))?;
        // PASS 4: fill, one task per slab, each owning its slots of the exactly allocated output.
        // SAFETY: `bcc_fill_plane` returns only after writing every slot of its slab (asserted
        // row by row and per slab).
        let (mesh, keys) = unsafe {
            fill_planes(&table, ny, self.normals, progress, &|k, slab| self.bcc_fill_plane(&b, bits, &table, k, slab))
        };
        out.set_assembled(mesh, keys);
        (scratch.bcc_counts, scratch.first) = table.into_parts();
        (scratch.centres, scratch.active, scratch.bcc_values) = (centres.data, active.data, values);
        Ok(stats)
    }
}

/// Reads and classifies plane `k` of a stream into the bit window.
type LoadPlane<'a, S> = dyn FnMut(usize, &mut SlabRing<S>, &mut Bits) -> Result<()> + 'a;

impl Ctx<'_, ()> {
    /// The counted body-centred walk on a window sliding up a stream: bits of planes k − 1 … k + 2,
    /// centre bits and row counts of k − 1 … k + 1 (the triangles of layer k name the centre
    /// segments of layer k − 1); `bits` holds planes 0, 1, 2 on entry, `load(k, …)` reads and
    /// classifies plane k into the bit window. Each slab's vertices and triangles go to `sink`
    /// in the order of the in-memory walk.
    ///
    /// # Errors
    /// The source's or the sink's, [`Error::Limit`] past `u32` vertex indices.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn bcc_stream<S: Sample>(
        &self,
        t: &BodyCentredTables,
        ring: &mut SlabRing<S>,
        bits: &mut Bits,
        load: &mut LoadPlane<'_, S>,
        sink: &mut dyn MeshSink,
        progress: Option<&dyn Progress>,
        out: &mut StreamStats,
    ) -> Result<()> {
        let [_, ny, nz] = self.bx.dims;
        let words = bits.words;
        let plane = ny * words;
        bits.data.resize(4 * plane, 0);
        let mut centres = Bits { words, row0: 0, data: vec![0u64; 3 * plane] };
        let mut active = Bits { words, row0: 0, data: vec![0u64; 3 * plane] };
        let mut table = BccTable::window(3, ny);
        let mut values: [LayerCentres; 3] = Default::default();
        let walk = walk_id();
        let add = |cs: [u64; 2], out: &mut StreamStats| {
            out.walk.cells_outside += cs[0];
            out.walk.cells_inside += cs[1];
        };
        let cs = self.on(ring).bcc_centres(
            layer_planes(bits, 0, [ny, nz]),
            0,
            &mut centres.data[..plane],
            &mut active.data[..plane],
            &mut values[0],
        );
        add(cs, out);
        {
            let b = Bcc { t, centres: &centres, active: &active, values: &values, walk };
            self.on(ring).bcc_count_plane(&b, bits, 0, &mut table.counts[..ny], false);
        }
        let mut start = [0u64; 3];
        let mut batch = OwnedBatch::default();
        for k in 0..nz {
            // The windows hold planes p0 … (bits: p0 + 3, the others p0 + 2).
            let p0 = k.saturating_sub(1);
            let next = (k + 1 - p0) * ny;
            if k + 1 < nz {
                let at = next * words;
                let cs = self.on(ring).bcc_centres(
                    layer_planes(bits, k + 1, [ny, nz]),
                    k + 1,
                    &mut centres.data[at..at + plane],
                    &mut active.data[at..at + plane],
                    &mut values[next / ny],
                );
                add(cs, out);
                let b = Bcc { t, centres: &centres, active: &active, values: &values, walk };
                self.on(ring).bcc_count_plane(&b, bits, k + 1, &mut table.counts[next..next + ny], false);
            } else {
                table.counts[next..next + ny].fill(BccRow::default());
            }
            table.restart(p0 * ny, start)?;
            let [dv, dt, _] = table.plane_sizes(k, ny);
            let nv = if self.normals { dv } else { 0 };
            let b = Bcc { t, centres: &centres, active: &active, values: &values, walk };
            // SAFETY: `bcc_fill_plane` returns only after writing every slot of its slab
            // (asserted row by row and per slab).
            unsafe {
                fill_batch(&mut batch, [dv, nv, dt, 0], |slab| self.on(ring).bcc_fill_plane(&b, bits, &table, k, slab))
            };
            sink.push_owned(&mut batch).map_err(Error::External)?;
            out.vertices += dv as u64;
            out.triangles += dt as u64;
            if k >= 1 {
                // Slide the windows up one plane.
                start = table.plane_base(k);
                table.counts.copy_within(ny.., 0);
                bits.data.copy_within(plane.., 0);
                bits.row0 += ny;
                centres.data.copy_within(plane.., 0);
                centres.row0 += ny;
                active.data.copy_within(plane.., 0);
                active.row0 += ny;
                values.rotate_left(1);
            }
            if k + 3 < nz {
                load(k + 3, ring, bits)?;
            }
            if let Some(p) = progress {
                p.advance(k as u64 + 1, nz as u64);
                if p.cancelled() {
                    return Err(crate::Error::Cancelled);
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Program `at`'s triangles, each as its three segments' codes.
    fn expanded(p: &SolidPrograms, at: usize) -> Vec<[u8; 3]> {
        let (segments, triangles) = p.program(at, false);
        triangles.iter().map(|t| t.map(|q| segments[q as usize])).collect()
    }

    /// A solid's triangles through [`SEGMENT_SLOT`], as the programs code them.
    fn coded(s: &BccSolid) -> Vec<[u8; 3]> {
        let code = |n: u8| {
            let (slot, off) = SEGMENT_SLOT[n as usize];
            slot << 2 | (off + 1) as u8
        };
        s.triangles[..s.triangle_count as usize].iter().map(|t| t.map(|q| code(s.segments[q as usize]))).collect()
    }

    #[test]
    fn programs_are_the_tabulated_solids_and_interior_cells_their_three_octahedra() {
        let (p, t) = (SolidPrograms::get(), BodyCentredTables::get());
        for (a, solids) in t.octahedra.iter().enumerate() {
            for (pattern, s) in solids.iter().enumerate() {
                assert_eq!(expanded(p, SolidPrograms::octahedron(a, pattern)), coded(s), "octahedron {a} {pattern}");
            }
        }
        for (f, solids) in t.pyramids.iter().enumerate() {
            for (pattern, s) in solids.iter().enumerate() {
                assert_eq!(expanded(p, SolidPrograms::pyramid(f, pattern)), coded(s), "pyramid {f} {pattern}");
            }
        }
        for x in 0..INTERIOR {
            let three: Vec<[u8; 3]> = (0..3)
                .flat_map(|a| expanded(p, SolidPrograms::octahedron(a, BodyCentredTables::octahedron_pattern(x, a))))
                .collect();
            assert_eq!(expanded(p, SolidPrograms::interior(x)), three, "cell index {x}");
            assert_eq!(three.len(), t.interior[x] as usize, "cell index {x}");
            let (segments, _) = p.program(SolidPrograms::interior(x), false);
            let mut distinct = segments.to_vec();
            distinct.sort_unstable();
            distinct.dedup();
            assert_eq!(distinct.len(), segments.len(), "cell index {x} names a segment twice");
        }
    }
}
