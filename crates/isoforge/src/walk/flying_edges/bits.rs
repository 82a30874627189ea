//! Bit rows: one bit per point (set = inside), 64 per word, and the word tricks the passes share —
//! crossings along a row, active cells of a cell row, and a crossing's rank in its row (its
//! vertex id's offset).

use super::families::{FX, FY, FZ, MAIN, X, Y, Z};
use super::fill::RowTable;
use crate::cube::{CELL_SEGMENTS, MAIN_DIAGONAL};

/// Bit rows of a box of points, `words` u64 per row, for rows `row0 ..` (row index
/// `k · ny + j`, box-local). The whole box in memory, a 3-slab window when streaming.
pub(super) struct Bits {
    pub(super) words: usize,
    pub(super) row0: usize,
    pub(super) data: Vec<u64>,
}

impl Bits {
    #[inline]
    pub(super) fn row(&self, r: usize) -> &[u64] {
        let r = r - self.row0;
        &self.data[r * self.words..(r + 1) * self.words]
    }
}

/// Clears bits at and past `len`.
#[inline]
pub(super) fn mask_tail(words: &mut [u64], len: usize) {
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
pub(super) fn popcount(words: &[u64]) -> u32 {
    words.iter().map(|w| w.count_ones()).sum()
}

/// Mask of the valid cells (bits < `cells`) in word `w`.
#[inline]
pub(super) fn cell_mask(w: usize, cells: usize) -> u64 {
    let lo = w * 64;
    if lo + 64 <= cells {
        !0
    } else if lo >= cells {
        0
    } else {
        (1u64 << (cells - lo)) - 1
    }
}

#[inline(always)]
pub(super) fn for_each_bit(words: &[u64], mut f: impl FnMut(usize)) {
    for (w, &word) in words.iter().enumerate() {
        let mut m = word;
        while m != 0 {
            let b = m.trailing_zeros() as usize;
            f(w * 64 + b);
            m &= m - 1;
        }
    }
}

/// The case of cell i from rows A = (j, k), B = (j+1, k), C = (j, k+1), E = (j+1, k+1):
/// corner c = x + 2y + 4z (see cube/mod.rs).
#[inline(always)]
pub(super) fn case_at(rows: &[&[u64]; 4], i: usize) -> u8 {
    let (w, b) = (i / 64, i % 64);
    let mut case = 0u8;
    for (q, row) in rows.iter().enumerate() {
        // Bits i and i + 1 of the row, possibly straddling two words.
        let pair = if b < 63 { row[w] >> b } else { (row[w] >> 63) | (row[w + 1] << 1) };
        case |= ((pair & 3) as u8) << (2 * q);
    }
    case
}

/// The four bit rows of cell row `r` = (j, k) of a box `ny` rows deep: A, B, C, E as in [`case_at`].
#[inline]
pub(super) fn cell_rows(bits: &Bits, r: usize, ny: usize) -> [&[u64]; 4] {
    [bits.row(r), bits.row(r + 1), bits.row(r + ny), bits.row(r + ny + 1)]
}

/// The four bit rows of cell row j between bit planes `planes` (k and k + 1): A, B, C, E.
#[inline(always)]
pub(super) fn plane_cell_rows<'a>([p, q]: [&'a [u64]; 2], j: usize, words: usize) -> [&'a [u64]; 4] {
    let row = |p: &'a [u64], j: usize| &p[j * words..(j + 1) * words];
    [row(p, j), row(p, j + 1), row(q, j), row(q, j + 1)]
}

/// When row `r` = (j, k) and its neighbours (j+1, k), (j, k+1), (j+1, k+1) (those that exist in
/// a box of `dims` points) are all entirely outside (0) or all entirely inside (1), that class:
/// the row starts no crossed edge and its cell row has no active cell.
#[inline]
pub(super) fn uniform_block(bits: &Bits, r: usize, [j, k]: [usize; 2], dims: [usize; 3]) -> Option<u8> {
    let [nx, ny, nz] = dims;
    let a = bits.row(r);
    let class = if a[0] & 1 == 1 { 1u8 } else { 0 };
    let same = |row: &[u64]| row.iter().enumerate().all(|(w, &x)| x == if class == 1 { cell_mask(w, nx) } else { 0 });
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

/// Per-row crossing masks with prefix popcounts, for vertex ranks.
pub(super) struct RankedMask {
    pub(super) mask: Vec<u64>,
    before: Vec<u32>,
}

impl RankedMask {
    pub(super) fn new(words: usize) -> Self {
        RankedMask { mask: vec![0; words], before: vec![0; words] }
    }
    /// Recomputes the prefix popcounts after `mask` changed, from `first` (see [`rank_prefix`]).
    pub(super) fn rank_prefix(&mut self, first: u32) {
        rank_prefix(&self.mask, &mut self.before, first);
    }
    /// The mask and its prefix popcounts, as [`RankedRef`].
    #[inline]
    pub(super) fn as_ref(&self) -> RankedRef<'_> {
        RankedRef { mask: &self.mask, before: &self.before }
    }
}

/// The prefix popcounts of `mask` into `before` (the set bits in the words before each), from
/// `first`: with the id of the mask's first vertex there, a bit's rank is its vertex's id.
#[inline]
pub(super) fn rank_prefix(mask: &[u64], before: &mut [u32], first: u32) {
    let mut acc = first;
    for (b, m) in before.iter_mut().zip(mask) {
        *b = acc;
        acc += m.count_ones();
    }
}

/// A crossing mask and its prefix popcounts (see [`rank_prefix`]), borrowed from a
/// [`RankedMask`] or a store of many.
#[derive(Clone, Copy)]
pub(super) struct RankedRef<'a> {
    mask: &'a [u64],
    before: &'a [u32],
}

impl<'a> RankedRef<'a> {
    /// `mask` with prefix popcounts `before` (of the same length).
    #[inline]
    pub(super) fn new(mask: &'a [u64], before: &'a [u32]) -> Self {
        assert_eq!(mask.len(), before.len(), "a ranked mask has one prefix per word");
        RankedRef { mask, before }
    }
    /// Number of set bits below bit `i`, plus the `first` of [`rank_prefix`], without bounds
    /// checks (the inner loop of the counted fills; checked in debug builds).
    ///
    /// # Safety
    /// `i` must lie in the mask: `i < 64 · words`.
    #[inline(always)]
    pub(super) unsafe fn rank_unchecked(&self, i: usize) -> u32 {
        let (w, b) = (i / 64, i % 64);
        debug_assert!(w < self.mask.len());
        // SAFETY: `new` and `RankedMask` give `mask` and `before` the same length, and `w` is
        // below it by the caller's promise.
        unsafe { self.before.get_unchecked(w) + (self.mask.get_unchecked(w) & ((1u64 << b) - 1)).count_ones() }
    }
}

/// Calls `f(i, case)` for every set bit `i` of `active`, in order, with cell i's case as
/// [`case_at`] gives it for cell row `rows`: the word's eight corner bit words are built once
/// ([`WordPairs`]) and each active cell's case read from them (`case_at` per cell was 12 % of a
/// dense extraction's instructions).
#[inline(always)]
pub(super) fn for_each_case(rows: &[&[u64]; 4], active: &[u64], mut f: impl FnMut(usize, u8)) {
    for_each_cell_bits(active, |w| rows.map(|row| corner_pair(row, w)), |i, x| f(i, x as u8));
}

/// Calls `f(i, x)` for every set bit `i` of `active`, in order, where bit q of `x` is bit i of
/// word q of the 2N words `words(w)` gives for i's word w (corner words, centre words…), built
/// once per word.
#[inline(always)]
pub(super) fn for_each_cell_bits<const N: usize>(
    active: &[u64],
    words: impl Fn(usize) -> [[u64; 2]; N],
    mut f: impl FnMut(usize, u32),
) {
    for (w, &word) in active.iter().enumerate() {
        if word == 0 {
            continue;
        }
        let pairs = WordPairs::new(words(w));
        let mut m = word;
        while m != 0 {
            let b = m.trailing_zeros() as usize;
            f(w * 64 + b, pairs.bits(b));
            m &= m - 1;
        }
    }
}

/// Word `w` of corners x and x + 1 of a row's cells: bit b of the pair is point 64w + b and the
/// one after it.
#[inline(always)]
fn corner_pair(row: &[u64], w: usize) -> [u64; 2] {
    let next = if w + 1 < row.len() { row[w + 1] << 63 } else { 0 };
    [row[w], (row[w] >> 1) | next]
}

/// [`for_each_cell_bits`] for the cells of a body-centred cell row (`rows` A, B, C, E, centre
/// rows `[cr, cy, cz]` of it and of the cell rows below it on y and z): `x` = the case (bits
/// 0–7), the cell's centre (8), the centres of its lower neighbours on x, y, z (9, 10, 11; cell
/// 0's x neighbour reads 0), the index of `BodyCentredTables::interior`.
#[inline(always)]
pub(super) fn for_each_bcc_cell(
    rows: &[&[u64]; 4],
    [cr, cy, cz]: [&[u64]; 3],
    active: &[u64],
    mut f: impl FnMut(usize, usize),
) {
    let words = |w: usize| {
        let [a, b, c, e] = rows.map(|row| corner_pair(row, w));
        let before = if w > 0 { cr[w - 1] >> 63 } else { 0 };
        [a, b, c, e, [cr[w], cr[w] << 1 | before], [cy[w], cz[w]]]
    };
    for_each_cell_bits(active, words, |i, x| f(i, x as usize));
}

/// Bit words in pairs, bit b of all of them read at once. On x86-64 each pair shares a 128-bit
/// register, so reading is one shift and one sign-bit mask per pair.
struct WordPairs<const N: usize> {
    #[cfg(target_arch = "x86_64")]
    pairs: [std::arch::x86_64::__m128i; N],
    #[cfg(not(target_arch = "x86_64"))]
    pairs: [[u64; 2]; N],
}

impl<const N: usize> WordPairs<N> {
    #[inline(always)]
    fn new(pairs: [[u64; 2]; N]) -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::_mm_set_epi64x;
            // SAFETY: SSE2 is part of x86-64.
            let pairs = pairs.map(|[x0, x1]| unsafe { _mm_set_epi64x(x1 as i64, x0 as i64) });
            WordPairs { pairs }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            WordPairs { pairs }
        }
    }

    /// Bit b of word q at bit q.
    #[inline(always)]
    fn bits(&self, b: usize) -> u32 {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_castsi128_pd, _mm_cvtsi64_si128, _mm_movemask_pd, _mm_sll_epi64};
            // SAFETY: SSE2 is part of x86-64. Bit b of each lane moves to its sign bit.
            unsafe {
                let by = _mm_cvtsi64_si128((63 - b) as i64);
                let mut x = 0;
                for (q, &pair) in self.pairs.iter().enumerate() {
                    x |= (_mm_movemask_pd(_mm_castsi128_pd(_mm_sll_epi64(pair, by))) as u32) << (2 * q);
                }
                x
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let bit = |x: u64| ((x >> b) & 1) as u32;
            (0..N).fold(0, |x, q| x | bit(self.pairs[q][0]) << (2 * q) | bit(self.pairs[q][1]) << (2 * q + 1))
        }
    }
}

/// Marks the active cells of cell row `rows` (A, B, C, E) in `active` (cells `< cells`); returns
/// the all-outside and all-inside cell counts.
///
/// A cell is inactive iff its 8 corners agree: both of its columns are uniform (the four rows
/// agree at i and at i + 1) and row A agrees between i and i + 1.
pub(super) fn mark_active(rows: [&[u64]; 4], cells: usize, active: &mut [u64]) -> (u64, u64) {
    let [a, b, c, e] = rows;
    let words = a.len();
    let column = |w: usize| (a[w] ^ b[w]) | (a[w] ^ c[w]) | (a[w] ^ e[w]);
    let (mut outside, mut inside) = (0u64, 0u64);
    // One pass, each word's column carried to the next.
    let mut d = column(0);
    for w in 0..words {
        let (next_d, next_a) = if w + 1 < words { (column(w + 1), a[w + 1]) } else { (0, 0) };
        let cm = cell_mask(w, cells);
        let act = (d | (d >> 1) | (next_d << 63) | (a[w] ^ ((a[w] >> 1) | (next_a << 63)))) & cm;
        active[w] = act;
        let idle = !act & cm;
        inside += (idle & a[w]).count_ones() as u64;
        outside += (idle & !a[w]).count_ones() as u64;
        d = next_d;
    }
    (outside, inside)
}

/// [`mark_active`] fused with the edge counts of row A (cells `nx - 1`, points `nx`): marks the
/// active cells of cell row `rows` in `active` and returns the crossed x-, y- and z-edges
/// starting in row A (the popcounts of [`Walked::mask`] for `X`, `Y`, `Z`) and the all-outside
/// and all-inside cell counts, in one pass over the four rows' words.
pub(super) fn count_edges_and_mark(rows: [&[u64]; 4], nx: usize, active: &mut [u64]) -> ([u32; 3], u64, u64) {
    let [a, b, c, e] = rows;
    let words = a.len();
    let cells = nx - 1;
    let column = |w: usize| (a[w] ^ b[w]) | (a[w] ^ c[w]) | (a[w] ^ e[w]);
    let (mut v, mut outside, mut inside) = ([0u32; 3], 0u64, 0u64);
    let mut d = column(0);
    for w in 0..words {
        let (next_d, next_a) = if w + 1 < words { (column(w + 1), a[w + 1]) } else { (0, 0) };
        let (cm, pm) = (cell_mask(w, cells), cell_mask(w, nx));
        let x = (a[w] ^ ((a[w] >> 1) | (next_a << 63))) & cm;
        v[0] += x.count_ones();
        v[1] += ((a[w] ^ b[w]) & pm).count_ones();
        v[2] += ((a[w] ^ c[w]) & pm).count_ones();
        let act = (d | (d >> 1) | (next_d << 63) | x) & cm;
        active[w] = act;
        let idle = !act & cm;
        inside += (idle & a[w]).count_ones() as u64;
        outside += (idle & !a[w]).count_ones() as u64;
        d = next_d;
    }
    (v, outside, inside)
}

/// For each cell segment (edges 0–11, face diagonals 12–17, the main diagonal 18): the mask
/// slot holding its row's crossings (see [`SLOT_SOURCE`]) and the offset of its row point from the
/// cell's i.
pub(super) const SEGMENT_SLOT: [(u8, u8); CELL_SEGMENTS] = {
    let mut t = [(0u8, 0u8); CELL_SEGMENTS];
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
    // Face f = 2 · axis + side: its diagonal belongs to the face's first point.
    t[12] = (12, 0); // x-min: FX of row A at i
    t[13] = (12, 1); // x-max: FX of row A at i + 1
    t[14] = (10, 0); // y-min: FY of row A
    t[15] = (11, 0); // y-max: FY of row B
    t[16] = (8, 0); // z-min: FZ of row A
    t[17] = (9, 0); // z-max: FZ of row C
    t[MAIN_DIAGONAL as usize] = (13, 0);
    t
};

/// The slots of the axis edges (0–7), all a walk of edges only numbers.
const EDGE_SLOTS: usize = 8;

/// The id of the first crossing of each slot (see [`SLOT_SOURCE`]) of cell row `r` (`ny` rows a
/// plane): its row's first vertex and the row's crossings of the families before.
#[inline]
pub(super) fn slot_bases(table: &RowTable, r: usize, ny: usize) -> [u32; SLOTS] {
    let rows = [r, r + 1, r + ny, r + ny + 1];
    std::array::from_fn(|slot| {
        let (f, q) = SLOT_SOURCE[slot];
        table.first_vertex(rows[q]) + table.count(rows[q]).before(f)
    })
}

/// The vertex ids of a cell row's active cells, visited in order, from one running counter per
/// slot instead of ranks in crossing masks: every crossed segment of the row's slots belongs to
/// an active cell (an x-edge or a y-, z-face diagonal to its one cell; a y- or z-edge or an
/// x-face diagonal at point i to cells i − 1 and i, both active when it crosses), so skipping
/// idle cells skips no crossing, and a slot's next id grows only by the cells' own crossings.
/// This is Flying Edges' running edge count (Schroeder et al. 2015), kept to active cells. It
/// replaced per-segment ranks (masked popcounts): −17 % instructions and about −18 % wall time for MC
/// on gyroid 256³ (BENCHMARKS §6.11).
pub(super) struct SegmentRun {
    next: [u32; SLOTS],
}

/// Each cell segment's slot, and whether it sits at the cell's second point (i + 1) of its slot.
const SEGMENT_AT: [(usize, bool); CELL_SEGMENTS] = {
    let mut t = [(0, false); CELL_SEGMENTS];
    let mut e = 0;
    while e < CELL_SEGMENTS {
        t[e] = (SEGMENT_SLOT[e].0 as usize, SEGMENT_SLOT[e].1 == 1);
        e += 1;
    }
    t
};

/// The cell segment at the first point of each slot (for slots of one segment per cell, that
/// segment).
const SLOT_FIRST: [u32; SLOTS] = {
    let mut t = [0; SLOTS];
    let mut e = 0;
    while e < CELL_SEGMENTS {
        if !SEGMENT_AT[e].1 {
            t[SEGMENT_AT[e].0] = e as u32;
        }
        e += 1;
    }
    t
};

impl SegmentRun {
    /// Counters at the row's first crossing of each slot ([`slot_bases`]).
    #[inline]
    pub(super) fn new(bases: [u32; SLOTS]) -> Self {
        SegmentRun { next: bases }
    }

    /// The vertex ids of the first `N` segments (12: the edges; [`CELL_SEGMENTS`]: all) of the
    /// next active cell, whose crossed segments are the bits of `crossed` (all among the first
    /// `N`; the ids of segments it does not cross are meaningless), and steps past the cell.
    #[inline(always)]
    pub(super) fn cell<const N: usize>(&mut self, crossed: u32) -> [u32; N] {
        debug_assert!(crossed >> N == 0, "crossed segments past the first {N}: {crossed:#b}");
        // The slots the first N segments use: the axis edges', or all.
        let slots = if N <= 12 { EDGE_SLOTS } else { SLOTS };
        let mut first = [0u32; SLOTS];
        for s in 0..slots {
            first[s] = (crossed >> SLOT_FIRST[s]) & 1;
        }
        let ids = std::array::from_fn(|e| {
            let (slot, second) = SEGMENT_AT[e];
            self.next[slot] + if second { first[slot] } else { 0 }
        });
        for s in 0..slots {
            self.next[s] += first[s];
        }
        ids
    }
}

/// The crossings of a cell row, by slot: 0–3 x-edges of rows A, B, C, E; 4–5 y-edges of rows
/// A, C; 6–7 z-edges of rows A, B; then the face diagonals FZ of A and C, FY of A and B, FX of
/// A, and the main diagonals of A. Each slot's family and row (0 = A, 1 = B, 2 = C, 3 = E).
const SLOT_SOURCE: [(usize, usize); SLOTS] = [
    (X, 0),
    (X, 1),
    (X, 2),
    (X, 3),
    (Y, 0),
    (Y, 2),
    (Z, 0),
    (Z, 1),
    (FZ, 0),
    (FZ, 2),
    (FY, 0),
    (FY, 1),
    (FX, 0),
    (MAIN, 0),
];
const SLOTS: usize = 14;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::extract::Segments;
    use crate::walk::flying_edges::families::Walked;

    /// Cases read from a word's corner words are `case_at`'s, and mt-bcc's cell reads (case and
    /// centre bits at once) are the bits read one by one, on rows of 1–3 words with sparse, dense
    /// and full active masks.
    #[test]
    fn word_cases_are_case_at() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for words in 1..=3 {
            for density in [1u32, 3, 6] {
                let rows: Vec<Vec<u64>> = (0..4).map(|_| (0..words).map(|_| next()).collect()).collect();
                let rows = [&rows[0][..], &rows[1][..], &rows[2][..], &rows[3][..]];
                let cells = words * 64 - 1;
                // Sparse (AND of draws), medium, or every cell active.
                let mut active: Vec<u64> = (0..words)
                    .map(|_| match density {
                        1 => next() & next() & next(),
                        3 => next(),
                        _ => !0,
                    })
                    .collect();
                mask_tail(&mut active, cells);
                let mut seen = Vec::new();
                for_each_case(&rows, &active, |i, case| seen.push((i, case)));
                let mut want = Vec::new();
                for_each_bit(&active, |i| want.push((i, case_at(&rows, i))));
                assert_eq!(seen, want, "{words} words, density {density}");
                // mt-bcc's reads: the case, then the centre bits of the cell and of its lower
                // neighbours on x (none for cell 0), y and z.
                let centres: Vec<Vec<u64>> = (0..3).map(|_| (0..words).map(|_| next()).collect()).collect();
                let [cr, cy, cz] = [&centres[0][..], &centres[1][..], &centres[2][..]];
                let bit = |row: &[u64], i: usize| ((row[i / 64] >> (i % 64)) & 1) as usize;
                let mut seen = Vec::new();
                for_each_bcc_cell(&rows, [cr, cy, cz], &active, |i, x| seen.push((i, x)));
                let mut want = Vec::new();
                for_each_bit(&active, |i| {
                    let before = if i > 0 { bit(cr, i - 1) } else { 0 };
                    let x = case_at(&rows, i) as usize
                        | bit(cr, i) << 8
                        | before << 9
                        | bit(cy, i) << 10
                        | bit(cz, i) << 11;
                    want.push((i, x));
                });
                assert_eq!(seen, want, "bcc cells: {words} words, density {density}");
            }
        }
    }

    /// Running counters give every crossed segment of every active cell the id of its rank in
    /// its slot's crossing mask (`Walked::mask`, the masks the vertex pass numbers), for walks of
    /// edges only (MC), of alternating face diagonals (mt5, both parities) and of fixed ones with
    /// main diagonals (mt6), on random rows of 1–4 words, full and partial.
    #[test]
    fn segment_run_ids_are_the_ranks() {
        use crate::cube::Diagonals;
        let walks = [
            (Segments { diagonals: None, main_diagonal: false }, 0),
            (Segments { diagonals: Some(Diagonals::OddCorners), main_diagonal: false }, 0),
            (Segments { diagonals: Some(Diagonals::OddCorners), main_diagonal: false }, 1),
            (Segments { diagonals: Some(Diagonals::MinToMax), main_diagonal: true }, 0),
        ];
        let mut checked = [0usize; 3]; // edges, face diagonals, main diagonals
        for (segments, parity) in walks {
            let walked = Walked::new(segments, [parity, 0, 0]);
            let crossed = walked.crossed();
            for nx in [2usize, 5, 64, 65, 150, 192, 256] {
                let words = nx.div_ceil(64);
                let (ny, nz) = (4, 3);
                let mut data = rows(nx as u64 * 31 + parity as u64, ny * nz * words);
                for row in data.chunks_mut(words) {
                    mask_tail(row, nx);
                }
                let bits = Bits { words, row0: 0, data };
                let dims = [nx, ny, nz];
                let mut counts = vec![crate::walk::flying_edges::count::RowCount::default(); ny * nz];
                for (i, c) in counts.iter_mut().enumerate() {
                    c.v = std::array::from_fn(|f| (i * (f + 3) % 7) as u32);
                }
                let table = RowTable::prefix(counts, ny, Vec::new()).unwrap();
                let mut active = vec![0u64; words];
                let mut mask = vec![0u64; words];
                for k in 0..nz - 1 {
                    for j in 0..ny - 1 {
                        let r = k * ny + j;
                        let bases = slot_bases(&table, r, ny);
                        // Each slot's mask, as the vertex pass makes it.
                        let masks: Vec<Vec<u64>> = SLOT_SOURCE
                            .iter()
                            .map(|&(f, q)| {
                                let (row, jk) = [
                                    (r, [j, k]),
                                    (r + 1, [j + 1, k]),
                                    (r + ny, [j, k + 1]),
                                    (r + ny + 1, [j + 1, k + 1]),
                                ][q];
                                let ok = walked.has(f) && walked.mask(f, &bits, row, jk, dims, &mut mask);
                                if ok {
                                    mask.clone()
                                } else {
                                    vec![0; words]
                                }
                            })
                            .collect();
                        let rows = cell_rows(&bits, r, ny);
                        mark_active(rows, nx - 1, &mut active);
                        let mut run = SegmentRun::new(bases);
                        let parity = walked.parity0 + j + k;
                        for_each_case(&rows, &active, |i, case| {
                            let mut m = crossed[case as usize][(parity + i) % 2];
                            let ids: [u32; CELL_SEGMENTS] = run.cell(m);
                            while m != 0 {
                                let e = m.trailing_zeros() as usize;
                                let (slot, off) = SEGMENT_SLOT[e];
                                let at = i + off as usize;
                                let below =
                                    (0..at).filter(|&p| masks[slot as usize][p / 64] >> (p % 64) & 1 == 1).count();
                                assert!(
                                    masks[slot as usize][at / 64] >> (at % 64) & 1 == 1,
                                    "segment {e} not in its mask"
                                );
                                let want = bases[slot as usize] + below as u32;
                                assert_eq!(ids[e], want, "{segments:?} nx {nx} row {r} cell {i} segment {e}");
                                checked[(e >= 12) as usize + (e == MAIN_DIAGONAL as usize) as usize] += 1;
                                m &= m - 1;
                            }
                        });
                    }
                }
            }
        }
        assert!(checked.iter().all(|&n| n > 500), "crossed segments seen (edges, faces, main): {checked:?}");
    }

    /// A xorshift stream of words, biased towards runs (as bit rows of a surface are).
    fn rows(seed: u64, n: usize) -> Vec<u64> {
        let mut s = seed | 1;
        (0..n)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                if s.is_multiple_of(3) {
                    s
                } else if s % 3 == 1 {
                    !0
                } else {
                    0
                }
            })
            .collect()
    }

    /// The fused pass gives the counts and active cells of `Walked::mask` + `popcount` +
    /// `mark_active`, for rows of 1 to 3 words, full and partial.
    #[test]
    fn fused_edge_counts_equal_the_separate_passes() {
        let walked = Walked::new(Segments { diagonals: None, main_diagonal: false }, [0; 3]);
        for nx in [2usize, 5, 63, 64, 65, 127, 128, 150, 192] {
            let words = nx.div_ceil(64);
            let (ny, nz) = (3, 3);
            for seed in 1..40u64 {
                let mut data = rows(seed * 7919 + nx as u64, ny * nz * words);
                for row in data.chunks_mut(words) {
                    mask_tail(row, nx); // classify clears the bits past the row
                }
                let bits = Bits { words, row0: 0, data };
                let dims = [nx, ny, nz];
                let (j, k) = (seed as usize % 2, (seed as usize / 2) % 2);
                let r = k * ny + j;
                let rows = [bits.row(r), bits.row(r + 1), bits.row(r + ny), bits.row(r + ny + 1)];
                let mut mask = vec![0u64; words];
                let want: [u32; 3] = std::array::from_fn(|f| {
                    assert!(walked.mask(f, &bits, r, [j, k], dims, &mut mask));
                    popcount(&mask)
                });
                let mut active = vec![0u64; words];
                let (outside, inside) = mark_active(rows, nx - 1, &mut active);
                let mut fused = vec![!0u64; words];
                let got = count_edges_and_mark(rows, nx, &mut fused);
                assert_eq!(got, (want, outside, inside), "nx {nx} seed {seed}");
                assert_eq!(fused, active, "nx {nx} seed {seed}");
            }
        }
    }
}
