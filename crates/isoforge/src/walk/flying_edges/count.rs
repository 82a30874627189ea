//! PASS 2: every row → its crossed segments of each family (popcounts of XORed bit rows); every
//! cell row → the polygons and placed vertices of its active cells (the extractor's counts).

use super::bits::{cell_rows, count_edges_and_mark, for_each_case, mark_active, popcount, uniform_block, Bits};
use super::families::FAMILIES;
use super::{Cells, Passes};
use crate::extract::{CellCounts, Decision, Extractor};

/// Counts of one row (its segments' crossings, by family) and of the cell row starting at it
/// (its cells' output). Only `u32`s: zero bytes are its default, so fresh tables come zeroed
/// from the allocator (`bytemuck::zeroed_vec`).
#[derive(Clone, Copy, Default, Debug, bytemuck::Zeroable)]
pub(super) struct RowCount {
    /// Crossings per family (see `families.rs`), numbered in this order.
    pub(super) v: [u32; FAMILIES],
    /// Vertices the cells of this cell row place.
    pub(super) placed: u32,
    pub(super) tris: u32,
    pub(super) quads: u32,
}

impl RowCount {
    /// Vertices numbered in this row: its crossings', then its cells' placed ones.
    #[inline]
    pub(super) fn vertices(&self) -> u32 {
        self.v.iter().sum::<u32>() + self.placed
    }

    /// Crossings numbered before family `f`'s in this row.
    #[inline(always)]
    pub(super) fn before(&self, f: usize) -> u32 {
        self.v[..f].iter().sum()
    }
}

/// The extractor's counts per case and parity, `None` where the values decide.
pub(super) struct CaseCounts([[Option<CellCounts>; 2]; 256]);

impl CaseCounts {
    /// The counts of the cases the extractor tabulates.
    pub(super) fn of<X: Extractor>(x: &X) -> Self {
        CaseCounts(std::array::from_fn(|c| {
            [false, true].map(|odd| {
                x.case_triangles(c as u8, odd).map(|t| CellCounts { triangles: t.len() as u16, ..Default::default() })
            })
        }))
    }
}

impl<X: Extractor> Passes<'_, Cells<'_>, X> {
    /// PASS 2 for the rows of point plane `k` (box-local) into `out`; returns the all-outside and
    /// all-inside cell counts of cell layer `k`. The decisions of the cells counted from their
    /// values go to `decisions`, in walk order, for the fill (`Extractor::process_decided`).
    /// `zeroed`: `out` holds zeros no one has written ([`reuse_zeroed`](super::reuse_zeroed)'s
    /// fresh pages); rows without crossings are then left alone (see there).
    pub(super) fn count_plane(
        &self,
        bits: &Bits,
        k: usize,
        out: &mut [RowCount],
        decisions: &mut Vec<Decision>,
        zeroed: bool,
    ) -> [u64; 2] {
        decisions.clear();
        let bx = &self.bx;
        let [nx, ny, nz] = bx.dims;
        let mut cs = [0u64; 2];
        let mut mask = vec![0u64; bits.words];
        let mut active = vec![0u64; bits.words];
        for (j, c) in out.iter_mut().enumerate() {
            let r = k * ny + j;
            let cells_here = j + 1 < ny && k + 1 < nz;
            if let Some(class) = uniform_block(bits, r, [j, k], bx.dims) {
                // No crossing in or out of this row and its cell row: only cell counts.
                if !zeroed {
                    *c = RowCount::default();
                }
                if cells_here {
                    cs[class as usize] += (nx - 1) as u64;
                }
                continue;
            }
            *c = RowCount::default();
            let rows = if cells_here && self.walked.edges_only() {
                // Axis edges only, and the row has all three: counts and active cells in one pass.
                let rows = cell_rows(bits, r, ny);
                let (v, outside, inside) = count_edges_and_mark(rows, nx, &mut active);
                c.v[..3].copy_from_slice(&v);
                cs[0] += outside;
                cs[1] += inside;
                rows
            } else {
                for f in 0..FAMILIES {
                    if self.walked.has(f) && self.walked.mask(f, bits, r, [j, k], bx.dims, &mut mask) {
                        c.v[f] = popcount(&mask);
                    }
                }
                if !cells_here {
                    continue;
                }
                let rows = cell_rows(bits, r, ny);
                let (outside, inside) = mark_active(rows, nx - 1, &mut active);
                cs[0] += outside;
                cs[1] += inside;
                rows
            };
            let parity = self.walked.parity0 + j + k;
            let first_decision = decisions.len();
            for_each_case(&rows, &active, |i, case| {
                let n = match self.table.0[case as usize][(parity + i) % 2] {
                    Some(n) => n,
                    None => {
                        let l = [i, j, k];
                        let (n, decision) = self.x.counts(case, bx.global(l), || self.vol.cell_values(bx, self.iso, l));
                        decisions.push(decision);
                        n
                    }
                };
                c.tris += n.triangles as u32;
                c.quads += n.quads as u32;
                c.placed += n.placed as u32;
            });
            if c.tris == 0 && c.quads == 0 && c.placed == 0 {
                // The fill skips a cell row without output, so it must not see its decisions.
                decisions.truncate(first_decision);
            }
        }
        cs
    }
}
