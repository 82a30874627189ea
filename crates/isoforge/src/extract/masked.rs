//! A mask on any extractor: cells are processed iff all eight corners are in the mask.

use super::{Counting, Extractor};
use crate::extract::Cell;

/// Which lattice points are in the mask: one flag per point, x fastest.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PointMask {
    dims: [u32; 3],
    inside: Vec<bool>,
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
        Ok(PointMask { dims, inside })
    }

    /// Whether point `ijk` is in the mask.
    #[inline]
    pub fn contains(&self, [i, j, k]: [u32; 3]) -> bool {
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
    /// Whether the eight corners of cell `ijk` are in the mask.
    #[inline]
    fn keeps(&self, [i, j, k]: [u32; 3]) -> bool {
        (0..8u32).all(|c| self.mask.contains([i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1)]))
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
