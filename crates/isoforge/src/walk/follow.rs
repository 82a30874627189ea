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

use std::collections::HashMap;
use std::hash::BuildHasherDefault;

use crate::cube::{CellRange, CORNER_OFFSETS};
use crate::math::KeyHasher;
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

/// Bits of a block's 9³ corner points (`x + 9 (y + 9 z)`), in words.
const SIGN_WORDS: usize = (9 * 9 * 9usize).div_ceil(64);

/// What the flood knows of one block of 8³ cells: the sides of its cells' 9³ corners (read in
/// one [`Volume::fill_values`] call when a cell of it is first asked about) and its cells found
/// so far (bit `x + 8 y` of word `z`).
struct Block {
    coord: [u32; 3],
    inside: [u64; SIGN_WORDS],
    found: [u64; 8],
}

/// The blocks of cells the flood has touched: dense bits per block, one hash lookup per block
/// change (the last block is remembered: a flood moves mostly within a block).
#[derive(Default)]
struct Blocks {
    index: HashMap<[u32; 3], u32, BuildHasherDefault<KeyHasher>>,
    blocks: Vec<Block>,
    last: Option<([u32; 3], u32)>,
    len: usize,
    values: Vec<f32>,
}

impl Blocks {
    /// The block of cell `c` (made, its corners' sides read, when new), and the cell's word
    /// (its z in the block) and bit (x + 8 y) in it.
    #[inline]
    fn at<V: Volume + ?Sized>(&mut self, c: [u32; 3], vol: &V, iso: Iso) -> (usize, usize, u64) {
        let b = c.map(|v| v >> 3);
        let (x, y, z) = (c[0] & 7, c[1] & 7, c[2] & 7);
        let (w, bit) = (z as usize, 1u64 << (x | y << 3));
        if let Some((lb, n)) = self.last {
            if lb == b {
                return (n as usize, w, bit);
            }
        }
        let n = match self.index.get(&b) {
            Some(&n) => n,
            None => {
                let dims = vol.lattice().dims();
                let lo = b.map(|v| v << 3);
                let hi = [0, 1, 2].map(|a| (lo[a] + 9).min(dims[a]));
                let d = [0, 1, 2].map(|a| (hi[a] - lo[a]) as usize);
                self.values.resize(d[0] * d[1] * d[2], 0.0);
                vol.fill_values(lo, hi, iso, &mut self.values);
                let mut inside = [0u64; SIGN_WORDS];
                let mut at = 0;
                for k in 0..d[2] {
                    for j in 0..d[1] {
                        for i in 0..d[0] {
                            let p = i + 9 * (j + 9 * k);
                            inside[p >> 6] |= u64::from(self.values[at] < 0.0) << (p & 63);
                            at += 1;
                        }
                    }
                }
                let n = self.blocks.len() as u32;
                self.blocks.push(Block { coord: b, inside, found: [0; 8] });
                self.index.insert(b, n);
                n
            }
        };
        self.last = Some((b, n));
        (n as usize, w, bit)
    }

    /// The sides (bit n set ⇔ corner n inside) of cell `c`'s corners.
    #[inline]
    fn case<V: Volume + ?Sized>(&mut self, c: [u32; 3], vol: &V, iso: Iso) -> u8 {
        let (n, _, _) = self.at(c, vol, iso);
        let inside = &self.blocks[n].inside;
        let l = c.map(|v| (v & 7) as usize);
        let mut case = 0u8;
        for (k, o) in CORNER_OFFSETS.iter().enumerate() {
            let p = (l[0] + o[0] as usize) + 9 * ((l[1] + o[1] as usize) + 9 * (l[2] + o[2] as usize));
            case |= ((inside[p >> 6] >> (p & 63)) as u8 & 1) << k;
        }
        case
    }

    fn contains<V: Volume + ?Sized>(&mut self, c: [u32; 3], vol: &V, iso: Iso) -> bool {
        let (n, w, bit) = self.at(c, vol, iso);
        self.blocks[n].found[w] & bit != 0
    }

    /// Adds `c`; whether it was new.
    fn insert<V: Volume + ?Sized>(&mut self, c: [u32; 3], vol: &V, iso: Iso) -> bool {
        let (n, w, bit) = self.at(c, vol, iso);
        let words = &mut self.blocks[n].found;
        let new = words[w] & bit == 0;
        words[w] |= bit;
        self.len += usize::from(new);
        new
    }

    /// The cells found, sorted (z, y, x).
    fn sorted(&self) -> Vec<[u32; 3]> {
        let mut out = Vec::with_capacity(self.len);
        for block in &self.blocks {
            let b = block.coord;
            for (w, &word) in block.found.iter().enumerate() {
                let mut bits = word;
                while bits != 0 {
                    let xy = bits.trailing_zeros();
                    bits &= bits - 1;
                    out.push([b[0] << 3 | (xy & 7), b[1] << 3 | xy >> 3, b[2] << 3 | w as u32]);
                }
            }
        }
        out.sort_unstable_by_key(|c| (c[2], c[1], c[0]));
        out
    }
}

/// Flooding state: the crossed cells found so far.
pub struct Follower<'v, V: ?Sized> {
    vol: &'v V,
    iso: Iso,
    cells: [u32; 3],
    found: Blocks,
    stats: FollowStats,
}

impl<'v, V: Volume + ?Sized> Follower<'v, V> {
    /// A follower of the surface of `vol` at `iso`.
    pub fn new(vol: &'v V, iso: Iso) -> Self {
        let cells = vol.lattice().dims().map(|d| d.saturating_sub(1));
        Follower { vol, iso, cells, found: Blocks::default(), stats: FollowStats::default() }
    }

    /// The signs (bit c set ⇔ corner c inside) of cell `c`.
    fn case(&mut self, c: [u32; 3]) -> u8 {
        self.found.case(c, self.vol, self.iso)
    }

    fn contains(&mut self, c: [u32; 3]) -> bool {
        self.found.contains(c, self.vol, self.iso)
    }

    fn insert(&mut self, c: [u32; 3]) -> bool {
        self.found.insert(c, self.vol, self.iso)
    }

    /// Whether cell `c` is crossed, counted as examined.
    fn crossed(&mut self, c: [u32; 3]) -> bool {
        self.stats.examined += 1;
        !matches!(self.case(c), 0 | 255)
    }

    /// Floods from cell `seed` when it is crossed and not yet found.
    pub fn flood(&mut self, seed: [u32; 3]) {
        if (0..3).any(|a| seed[a] >= self.cells[a]) || self.contains(seed) || !self.crossed(seed) {
            return;
        }
        self.stats.floods += 1;
        self.insert(seed);
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
                    if self.insert(n) {
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
            if self.contains(cell) {
                return;
            }
            if self.crossed(cell) {
                self.flood(cell);
                return;
            }
        }
    }

    /// Floods from every crossed cell of `ranges` not yet found: with the ranges a min/max tree
    /// proves hold every crossing, every component is found. Each range's points are classified
    /// once (a sign per point), its cells from their corners' signs.
    pub fn flood_ranges(&mut self, ranges: &[CellRange]) {
        let (mut inside, mut values) = (Vec::new(), Vec::new());
        for r in ranges {
            let hi = [0, 1, 2].map(|a| r.hi[a].min(self.cells[a]));
            if (0..3).any(|a| r.lo[a] >= hi[a]) {
                continue;
            }
            // The range's points, x fastest: inside or not.
            let n = [0, 1, 2].map(|a| (hi[a] - r.lo[a] + 1) as usize);
            values.resize(n[0] * n[1] * n[2], 0.0);
            self.vol.fill_values(r.lo, hi.map(|v| v + 1), self.iso, &mut values);
            inside.clear();
            inside.extend(values.iter().map(|&v| v < 0.0));
            let at = |p: [usize; 3]| inside[p[0] + n[0] * (p[1] + n[1] * p[2])];
            for z in 0..n[2] - 1 {
                for y in 0..n[1] - 1 {
                    for x in 0..n[0] - 1 {
                        self.stats.examined += 1;
                        let first = at([x, y, z]);
                        let uniform = CORNER_OFFSETS
                            .iter()
                            .all(|o| at([x + o[0] as usize, y + o[1] as usize, z + o[2] as usize]) == first);
                        if !uniform {
                            // A crossed cell: a seed unless a flood already found it.
                            self.flood([x as u32 + r.lo[0], y as u32 + r.lo[1], z as u32 + r.lo[2]]);
                        }
                    }
                }
            }
        }
    }

    /// The crossed cells found, sorted (z, y, x), and what it took.
    pub fn finish(self) -> (Vec<[u32; 3]>, FollowStats) {
        (self.found.sorted(), self.stats)
    }
}
