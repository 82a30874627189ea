//! Per-block bounds of a grid's samples, so walkers can skip what the surface cannot cross.

use super::{DenseGrid, Sample};

/// The smallest and largest sample of every block of cells of a grid.
///
/// Block `b` holds the cells `B·b .. B·(b + 1)` on each axis (B = [`BlockBounds::CELLS`]) and
/// its bounds cover all their corner points `B·b ..= B·(b + 1)`, so neighbouring blocks share a
/// layer of points. Computed once (one pass over the samples, in parallel) and reused for every
/// iso value — the viewer re-extracts the same volume at many.
#[derive(Debug, Clone, PartialEq)]
pub struct BlockBounds {
    blocks: [u32; 3],
    bounds: Vec<[f64; 2]>,
}

impl BlockBounds {
    /// Cells per block edge.
    pub const CELLS: u32 = 8;

    /// The bounds of every block of `grid`.
    pub fn of<S: Sample>(grid: &DenseGrid<S>) -> Self {
        let dims = grid.lattice().dims();
        let b = Self::CELLS;
        let blocks = dims.map(|d| d.saturating_sub(1).div_ceil(b).max(1));
        let [bx, by, bz] = blocks.map(|x| x as usize);
        let [nx, ny, nz] = dims.map(|x| x as usize);
        let data = grid.data();
        let layer = |kb: usize| -> Vec<[f64; 2]> {
            let mut out = vec![[f64::INFINITY, f64::NEG_INFINITY]; bx * by];
            let (k0, k1) = (kb * b as usize, ((kb + 1) * b as usize).min(nz - 1));
            for k in k0..=k1 {
                for j in 0..ny {
                    let row = &data[(k * ny + j) * nx..(k * ny + j + 1) * nx];
                    // The blocks this row's points belong to along y (a point on a block
                    // boundary belongs to both).
                    let own = j / b as usize;
                    let jb_lo = if j % b as usize == 0 && j > 0 { own - 1 } else { own };
                    let jb_hi = own.min(by - 1);
                    for ib in 0..bx {
                        let (i0, i1) = (ib * b as usize, ((ib + 1) * b as usize).min(nx - 1));
                        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
                        for v in &row[i0..=i1] {
                            let v = v.to_f64();
                            lo = lo.min(v);
                            hi = hi.max(v);
                        }
                        for jb in jb_lo..=jb_hi {
                            let o = &mut out[jb * bx + ib];
                            o[0] = o[0].min(lo);
                            o[1] = o[1].max(hi);
                        }
                    }
                }
            }
            out
        };
        #[cfg(feature = "parallel")]
        let layers: Vec<Vec<[f64; 2]>> = {
            use rayon::prelude::*;
            (0..bz).into_par_iter().map(layer).collect()
        };
        #[cfg(not(feature = "parallel"))]
        let layers: Vec<Vec<[f64; 2]>> = (0..bz).map(layer).collect();
        BlockBounds { blocks, bounds: layers.concat() }
    }

    /// Blocks per axis.
    pub fn blocks(&self) -> [u32; 3] {
        self.blocks
    }

    /// The bounds `[min, max]` of block `b`.
    #[inline]
    pub fn block(&self, b: [u32; 3]) -> [f64; 2] {
        let [bx, by, _] = self.blocks.map(|x| x as usize);
        self.bounds[(b[2] as usize * by + b[1] as usize) * bx + b[0] as usize]
    }

    /// The bounds of the points `lo ..= hi` (a superset's: the blocks covering them).
    pub fn of_points(&self, lo: [u32; 3], hi: [u32; 3]) -> [f64; 2] {
        let b = Self::CELLS;
        // Point p lies in block p / B (and in block p / B − 1 when on a boundary, whose bounds
        // hold it too); the blocks covering lo ..= hi are lo / B ..= (hi − 1) / B, clamped.
        let blo = [0, 1, 2].map(|a| (lo[a] / b).min(self.blocks[a] - 1));
        let bhi = [0, 1, 2].map(|a| (hi[a].saturating_sub(1) / b).clamp(blo[a], self.blocks[a] - 1));
        let mut out = [f64::INFINITY, f64::NEG_INFINITY];
        for z in blo[2]..=bhi[2] {
            for y in blo[1]..=bhi[1] {
                for x in blo[0]..=bhi[0] {
                    let [l, h] = self.block([x, y, z]);
                    out = [out[0].min(l), out[1].max(h)];
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Lattice;

    #[test]
    fn block_bounds_hold_every_point_of_their_cells() {
        let g = DenseGrid::from_fn(Lattice::new([19, 10, 17]).unwrap(), |p| {
            ((p[0] * 7 + p[1] * 13 + p[2] * 29) % 31) as i16 - 15
        });
        let bb = BlockBounds::of(&g);
        assert_eq!(bb.blocks(), [3, 2, 2]);
        for z in 0..2 {
            for y in 0..2 {
                for x in 0..3 {
                    let [lo, hi] = bb.block([x, y, z]);
                    let (mut want_lo, mut want_hi) = (f64::INFINITY, f64::NEG_INFINITY);
                    for k in 8 * z..=(8 * z + 8).min(16) {
                        for j in 8 * y..=(8 * y + 8).min(9) {
                            for i in 8 * x..=(8 * x + 8).min(18) {
                                let v = g.get([i, j, k]) as f64;
                                want_lo = want_lo.min(v);
                                want_hi = want_hi.max(v);
                            }
                        }
                    }
                    assert_eq!([lo, hi], [want_lo, want_hi], "block {x} {y} {z}");
                }
            }
        }
        let [lo, hi] = bb.of_points([0, 0, 0], [18, 9, 16]);
        assert_eq!((lo, hi), (-15.0, 15.0));
    }
}
