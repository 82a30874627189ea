//! Boxes of cells in global lattice indices: what a walker visits.

/// The cells `lo[a] ≤ ijk[a] < hi[a]` (half-open, global lattice indices; a cell is named by its
/// corner 0). A walk over a range creates exactly the triangles those cells create in a walk of
/// the whole lattice, and its vertices carry the same [`VertexKey`](super::VertexKey)s, so the
/// meshes of ranges that tile the lattice stitch by key into the whole-lattice mesh.
///
/// A range reads the points `lo ..= hi` (the corners of its cells) and, for gradients (central
/// differences), one point further on every side. Cells just before the range also matter to
/// dual methods (their placed vertices) and body-centred ones (their centres), whose normals read
/// one more point: a chunk of data for range `r` is the points `r.lo − 2 ..= r.hi + 1` clamped to
/// the lattice (its *halo*, see [`halo_points`](CellRange::halo_points)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct CellRange {
    /// First cell on each axis (inclusive).
    pub lo: [u32; 3],
    /// One past the last cell on each axis.
    pub hi: [u32; 3],
}

impl CellRange {
    /// Every cell of a lattice with `dims` points per axis (`dims − 1` cells each; empty when an
    /// axis has fewer than two points).
    pub fn all(dims: [u32; 3]) -> Self {
        CellRange { lo: [0; 3], hi: dims.map(|d| d.saturating_sub(1)) }
    }

    /// The cells `lo .. hi`, clipped to a lattice with `dims` points.
    pub fn clipped(lo: [u32; 3], hi: [u32; 3], dims: [u32; 3]) -> Self {
        let all = CellRange::all(dims);
        let lo = [0, 1, 2].map(|a| lo[a].min(all.hi[a]));
        let hi = [0, 1, 2].map(|a| hi[a].clamp(lo[a], all.hi[a]));
        CellRange { lo, hi }
    }

    /// Cells per axis.
    #[inline]
    pub fn dims(&self) -> [u32; 3] {
        [0, 1, 2].map(|a| self.hi[a].saturating_sub(self.lo[a]))
    }

    /// True when the range holds no cell.
    #[inline]
    pub fn is_empty(&self) -> bool {
        (0..3).any(|a| self.hi[a] <= self.lo[a])
    }

    /// Number of cells.
    pub fn num_cells(&self) -> u64 {
        self.dims().iter().map(|&d| d as u64).product()
    }

    /// Whether cell `ijk` is in the range.
    #[inline]
    pub fn contains(&self, ijk: [u32; 3]) -> bool {
        (0..3).all(|a| self.lo[a] <= ijk[a] && ijk[a] < self.hi[a])
    }

    /// The same range restricted to the cell layers `k0 .. k1` (clipped to the range).
    pub fn layers(&self, k0: u32, k1: u32) -> Self {
        let (k0, k1) = (k0.clamp(self.lo[2], self.hi[2]), k1.clamp(self.lo[2], self.hi[2]));
        CellRange { lo: [self.lo[0], self.lo[1], k0.min(k1)], hi: [self.hi[0], self.hi[1], k1] }
    }

    /// The points a chunk of data must hold to walk this range exactly as the whole lattice is
    /// walked, every method and gradient normals included: two points before the cells' corners
    /// and one after, clamped to a lattice with `dims` points. Returns `(first, one past last)`.
    pub fn halo_points(&self, dims: [u32; 3]) -> ([u32; 3], [u32; 3]) {
        let lo = self.lo.map(|x| x.saturating_sub(2));
        let hi = [0, 1, 2].map(|a| (self.hi[a] + 2).min(dims[a]));
        (lo, hi)
    }

    /// Tiles the range into boxes of at most `size` cells per axis, in z, y, x order.
    pub fn tiles(&self, size: [u32; 3]) -> Vec<CellRange> {
        let size = size.map(|s| s.max(1));
        let starts = |a: usize| (self.lo[a]..self.hi[a]).step_by(size[a] as usize).collect::<Vec<_>>();
        let mut out = Vec::new();
        for &z in &starts(2) {
            for &y in &starts(1) {
                for &x in &starts(0) {
                    let lo = [x, y, z];
                    let hi = [0, 1, 2].map(|a| (lo[a] + size[a]).min(self.hi[a]));
                    out.push(CellRange { lo, hi });
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_cover_the_range_once() {
        let r = CellRange::all([8, 7, 6]);
        assert_eq!(r.dims(), [7, 6, 5]);
        let tiles = r.tiles([3, 4, 5]);
        assert_eq!(tiles.len(), 3 * 2);
        assert_eq!(tiles.iter().map(|t| t.num_cells()).sum::<u64>(), r.num_cells());
        for k in 0..5 {
            for j in 0..6 {
                for i in 0..7 {
                    assert_eq!(tiles.iter().filter(|t| t.contains([i, j, k])).count(), 1);
                }
            }
        }
    }

    #[test]
    fn halo_and_clipping_stay_inside_the_lattice() {
        let dims = [10, 10, 10];
        let r = CellRange::clipped([2, 0, 7], [5, 3, 20], dims);
        assert_eq!(r, CellRange { lo: [2, 0, 7], hi: [5, 3, 9] });
        assert_eq!(r.halo_points(dims), ([0, 0, 5], [7, 5, 10]));
        assert!(CellRange::all([1, 5, 5]).is_empty());
        assert_eq!(r.layers(8, 100), CellRange { lo: [2, 0, 8], hi: [5, 3, 9] });
    }
}
