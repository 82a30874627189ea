//! Surface following (the design documents' "marching" from a non-empty cell to its neighbours):
//! the cells a surface crosses, found by flooding from seed cells across the faces the surface
//! passes through, then walked one by one. Only crossed cells are visited; the rest of the lattice
//! is never read.
//!
//! ```text
//!   seed      a crossed cell: given, found by marching +x from a point, or found in the blocks a
//!             min/max tree proves may hold a crossing (every component has a cell there)
//!   flood     a crossed cell's face with corners on both sides is crossed by the surface, and the
//!             cell across it shares that face's crossed edge: it is crossed too (a bilinear face
//!             has no closed level curve inside it, so the surface leaves a cell only through such
//!             faces)
//!   walk      the cells found, sorted (z, y, x), by `walk_cells`: vertices joined by key
//! ```

use std::collections::HashSet;

use crate::cube::{CellRange, CORNER_OFFSETS};
use crate::volume::{Iso, Volume};

/// What a follow did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FollowStats {
    /// Cells the flood visited: every crossed cell of the components it reached, once.
    pub visited: u64,
    /// Cells classified while looking for seeds (the +x march from a point, the scan of blocks
    /// a tree says may be crossed), besides the visited ones.
    pub examined: u64,
    /// Floods started (at most one per component reached).
    pub floods: u64,
}

/// Flooding state: the crossed cells found so far.
pub struct Follower<'v, V: ?Sized> {
    vol: &'v V,
    iso: Iso,
    cells: [u32; 3],
    found: HashSet<[u32; 3]>,
    stats: FollowStats,
}

impl<'v, V: Volume + ?Sized> Follower<'v, V> {
    /// A follower of the surface of `vol` at `iso`.
    pub fn new(vol: &'v V, iso: Iso) -> Self {
        let cells = vol.lattice().dims().map(|d| d.saturating_sub(1));
        Follower { vol, iso, cells, found: HashSet::new(), stats: FollowStats::default() }
    }

    /// The signs (bit c set ⇔ corner c inside) of cell `c`.
    fn case(&self, c: [u32; 3]) -> u8 {
        let mut case = 0u8;
        for (n, o) in CORNER_OFFSETS.iter().enumerate() {
            let v = self.vol.value_at([0, 1, 2].map(|a| (c[a] + o[a]) as f64), self.iso);
            case |= u8::from(v < 0.0) << n;
        }
        case
    }

    /// Whether cell `c` is crossed, counted as examined.
    fn crossed(&mut self, c: [u32; 3]) -> bool {
        self.stats.examined += 1;
        !matches!(self.case(c), 0 | 255)
    }

    /// Floods from cell `seed` when it is crossed and not yet found.
    pub fn flood(&mut self, seed: [u32; 3]) {
        if (0..3).any(|a| seed[a] >= self.cells[a]) || self.found.contains(&seed) || !self.crossed(seed) {
            return;
        }
        self.stats.floods += 1;
        self.found.insert(seed);
        let mut stack = vec![seed];
        while let Some(c) = stack.pop() {
            self.stats.visited += 1;
            let case = self.case(c);
            for axis in 0..3 {
                for side in 0..2u32 {
                    // The face's four corners: those whose coordinate on `axis` is `side`.
                    let face = (0..8u8).filter(|&n| (n >> axis & 1) as u32 == side).map(|n| case >> n & 1);
                    let (mut inside, mut outside) = (false, false);
                    for s in face {
                        inside |= s == 1;
                        outside |= s == 0;
                    }
                    if !(inside && outside) {
                        continue;
                    }
                    let mut n = c;
                    if side == 0 {
                        let Some(v) = n[axis].checked_sub(1) else { continue };
                        n[axis] = v;
                    } else {
                        n[axis] += 1;
                        if n[axis] >= self.cells[axis] {
                            continue;
                        }
                    }
                    if self.found.insert(n) {
                        stack.push(n);
                    }
                }
            }
        }
    }

    /// Floods from the first crossed cell met marching along +x from the cell holding the world
    /// point `p` (a point inside an object finds its surface); nothing when none is met.
    pub fn flood_from_point(&mut self, p: [f64; 3]) {
        let idx = self.vol.lattice().to_index(p);
        if idx.iter().any(|v| !v.is_finite()) {
            return;
        }
        let c: [u32; 3] =
            [0, 1, 2].map(|a| (idx[a].floor().max(0.0) as u64).min(self.cells[a].saturating_sub(1) as u64) as u32);
        for x in c[0]..self.cells[0] {
            let cell = [x, c[1], c[2]];
            if self.found.contains(&cell) {
                return;
            }
            if self.crossed(cell) {
                self.flood(cell);
                return;
            }
        }
    }

    /// Floods from every crossed cell of `ranges` not yet found: with the ranges a min/max tree
    /// proves hold every crossing, every component is found.
    pub fn flood_ranges(&mut self, ranges: &[CellRange]) {
        for r in ranges {
            for z in r.lo[2]..r.hi[2] {
                for y in r.lo[1]..r.hi[1] {
                    for x in r.lo[0]..r.hi[0] {
                        let c = [x, y, z];
                        if !self.found.contains(&c) && self.crossed(c) {
                            self.flood(c);
                        }
                    }
                }
            }
        }
    }

    /// The crossed cells found, sorted (z, y, x), and what it took.
    pub fn finish(self) -> (Vec<[u32; 3]>, FollowStats) {
        let mut cells: Vec<[u32; 3]> = self.found.into_iter().collect();
        cells.sort_unstable_by_key(|c| (c[2], c[1], c[0]));
        (cells, self.stats)
    }
}
