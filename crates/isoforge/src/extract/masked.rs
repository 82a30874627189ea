//! A mask on any extractor: cells are processed iff all eight corners are in the mask (or, for a
//! mask made of cell flags, iff the cell's flag is set).

use super::{Counting, Extractor};
use crate::extract::Cell;

/// Which lattice points are in the mask: one flag per point, x fastest (or, made by
/// [`PointMask::of_cells`], one flag per cell).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PointMask {
    dims: [u32; 3],
    inside: Vec<bool>,
    per_cell: bool,
}

impl PointMask {
    /// A mask from one flag per point of a lattice with `dims`.
    ///
    /// # Errors
    /// [`Error::InvalidInput`](crate::Error::InvalidInput) when the flag count is not the point count.
    pub fn new(dims: [u32; 3], inside: Vec<bool>) -> crate::Result<Self> {
        let n = dims.iter().map(|&d| d as usize).product::<usize>();
        if inside.len() != n {
            return Err(crate::Error::InvalidInput(format!(
                "mask has {} points, the lattice {dims:?} has {n}",
                inside.len()
            )));
        }
        Ok(PointMask { dims, inside, per_cell: false })
    }

    /// A mask of the cells of a lattice with point `dims`: one flag per cell (`dims − 1` per
    /// axis, x fastest); a cell is processed iff its flag is set (scikit-image's `mask=`).
    ///
    /// # Errors
    /// [`Error::InvalidInput`](crate::Error::InvalidInput) when the flag count is not the cell count.
    pub fn of_cells(dims: [u32; 3], cells: Vec<bool>) -> crate::Result<Self> {
        let n = dims.iter().map(|&d| d.saturating_sub(1) as usize).product::<usize>();
        if cells.len() != n {
            return Err(crate::Error::InvalidInput(format!(
                "cell mask has {} cells, the lattice {dims:?} has {n}",
                cells.len()
            )));
        }
        Ok(PointMask { dims, inside: cells, per_cell: true })
    }

    /// Whether cell `ijk` (its lowest corner) is kept: all eight corners in the mask, or its
    /// own flag for a mask of cells.
    #[inline]
    pub fn keeps_cell(&self, [i, j, k]: [u32; 3]) -> bool {
        if self.per_cell {
            let [nx, ny, _] = self.dims.map(|d| d.saturating_sub(1) as usize);
            return self.inside[(k as usize * ny + j as usize) * nx + i as usize];
        }
        (0..8u32).all(|c| self.contains([i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1)]))
    }

    /// Whether point `ijk` is in the mask (for a mask of cells: whether `ijk` is a kept cell).
    #[inline]
    pub fn contains(&self, [i, j, k]: [u32; 3]) -> bool {
        if self.per_cell {
            return [i, j, k].iter().zip(self.dims).all(|(&x, d)| x + 1 < d) && self.keeps_cell([i, j, k]);
        }
        let [nx, ny, _] = self.dims.map(|d| d as usize);
        self.inside[(k as usize * ny + j as usize) * nx + i as usize]
    }

    /// The lattice dims the mask was made for.
    pub fn dims(&self) -> [u32; 3] {
        self.dims
    }
}

/// `X` restricted to the cells whose eight corners are in `mask` (surfaces end, open, at the
/// mask's boundary; combine with an outside border of the volume to close them).
#[derive(Debug)]
pub struct Masked<'m, X> {
    /// The extractor.
    pub inner: X,
    /// The mask, on the walked lattice.
    pub mask: &'m PointMask,
}

impl<X> Masked<'_, X> {
    /// Whether cell `ijk` is kept by the mask.
    #[inline]
    fn keeps(&self, ijk: [u32; 3]) -> bool {
        self.mask.keeps_cell(ijk)
    }
}

impl<X: Extractor> Extractor for Masked<'_, X> {
    const PLACES_VERTICES: bool = X::PLACES_VERTICES;

    // Not counted: a counted walk makes every crossed edge's vertex up front, and masked-out
    // cells would leave theirs unused (walkers that create vertices on request make none).
    const COUNTING: Counting = Counting::Unknown;

    #[inline]
    fn place<C: Cell>(&self, cell: &mut C) {
        if self.keeps(cell.ijk()) {
            self.inner.place(cell);
        }
    }

    #[inline]
    fn process<C: Cell>(&self, cell: &mut C) {
        if self.keeps(cell.ijk()) {
            self.inner.process(cell);
        }
    }

    fn visits_uniform_cells(&self) -> bool {
        self.inner.visits_uniform_cells()
    }
}

#[cfg(test)]
mod tests {
    use super::PointMask;

    #[test]
    fn cell_masks_keep_exactly_the_flagged_cells() {
        // 3 x 2 x 2 points: 2 x 1 x 1 cells; only cell [1, 0, 0] flagged.
        let m = PointMask::of_cells([3, 2, 2], vec![false, true]).unwrap();
        assert!(!m.keeps_cell([0, 0, 0]));
        assert!(m.keeps_cell([1, 0, 0]));
        let e = PointMask::of_cells([3, 2, 2], vec![true; 3]).unwrap_err().to_string();
        assert!(e.contains("3 cells") && e.contains("has 2"), "{e}");
        // A point mask keeps a cell iff its eight corners are in: point [0, 0, 0] out drops cell 0.
        let mut flags = vec![true; 12];
        flags[0] = false;
        let p = PointMask::new([3, 2, 2], flags).unwrap();
        assert!(!p.keeps_cell([0, 0, 0]));
        assert!(p.keeps_cell([1, 0, 0]));
    }
}
