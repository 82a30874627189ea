//! Region operations on dense grids: crop to an index box, pad with a border, replace the
//! geometry. They keep the sample type and put the result where the source was in world space.

use super::{AnyGrid, DenseGrid, Lattice, Sample};
use crate::error::{Error, Result};

impl<S: Sample> DenseGrid<S> {
    /// The samples in the half-open index box `lo..hi` (per axis), with a lattice whose origin is
    /// the world position of `lo` (same spacing and direction).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when the box is empty or leaves the lattice.
    pub fn crop(&self, lo: [u32; 3], hi: [u32; 3]) -> Result<Self> {
        let dims = self.lattice().dims();
        for a in 0..3 {
            if lo[a] >= hi[a] || hi[a] > dims[a] {
                return Err(Error::InvalidInput(format!(
                    "region {lo:?}..{hi:?}: axis {a} must satisfy lo < hi <= {} (the lattice has {dims:?} points)",
                    dims[a]
                )));
            }
        }
        let size = [0, 1, 2].map(|a| hi[a] - lo[a]);
        let origin = self.lattice().to_world(lo.map(f64::from));
        let lattice = Lattice::with_geometry(size, self.lattice().spacing(), origin)?
            .with_direction(self.lattice().direction())?;
        let mut data = Vec::with_capacity(lattice.num_points() as usize);
        for k in lo[2]..hi[2] {
            for j in lo[1]..hi[1] {
                let start = self.lattice().linear([lo[0], j, k]);
                data.extend_from_slice(&self.data()[start..start + size[0] as usize]);
            }
        }
        DenseGrid::new(lattice, data)
    }

    /// The grid inside a border of `width` points of `value` on every side; the lattice grows by
    /// `2 · width` points per axis and its origin moves `width` steps back along each axis.
    ///
    /// # Errors
    /// [`Error::Limit`] when the padded lattice is too large.
    pub fn pad(&self, width: u32, value: S) -> Result<Self> {
        let l = self.lattice();
        let dims = l.dims();
        let size = dims.map(|d| d.saturating_add(2 * width));
        let origin = l.to_world([-(width as f64); 3]);
        let lattice =
            Lattice::with_geometry(size, l.spacing(), origin)?.with_direction(l.direction())?.with_space(l.space());
        let mut data = vec![value; lattice.num_points() as usize];
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                let src = l.linear([0, j, k]);
                let dst = lattice.linear([width, j + width, k + width]);
                data[dst..dst + dims[0] as usize].copy_from_slice(&self.data()[src..src + dims[0] as usize]);
            }
        }
        DenseGrid::new(lattice, data)
    }

    /// The same samples on another lattice with the same dims (e.g. unit spacing for index-space
    /// output).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when the dims differ.
    pub fn with_lattice(self, lattice: Lattice) -> Result<Self> {
        if lattice.dims() != self.lattice().dims() {
            return Err(Error::InvalidInput(format!(
                "lattice dims {:?} differ from the grid's {:?}",
                lattice.dims(),
                self.lattice().dims()
            )));
        }
        let (_, data) = self.into_parts();
        DenseGrid::new(lattice, data)
    }
}

impl AnyGrid {
    /// [`DenseGrid::crop`] for any sample type.
    ///
    /// # Errors
    /// As [`DenseGrid::crop`].
    pub fn crop(&self, lo: [u32; 3], hi: [u32; 3]) -> Result<AnyGrid> {
        crate::with_grid!(self, g => g.crop(lo, hi).map(AnyGrid::from))
    }

    /// [`DenseGrid::pad`] with the sample nearest to `value` (saturating at the type's range).
    ///
    /// # Errors
    /// As [`DenseGrid::pad`].
    pub fn pad(&self, width: u32, value: f64) -> Result<AnyGrid> {
        crate::with_grid!(self, g => g.pad(width, Sample::from_f64(value)).map(AnyGrid::from))
    }

    /// The trilinear interpolant at world point `w`, and whether `w` lies inside the lattice's box
    /// (outside points take the value at the nearest point of the box).
    pub fn value_at_world(&self, w: [f64; 3]) -> (f64, bool) {
        let l = self.lattice();
        let p = l.to_index(w);
        let dims = l.dims();
        let tol = 1e-6;
        let inside = (0..3).all(|a| p[a] >= -tol && p[a] <= (dims[a] - 1) as f64 + tol);
        let v = crate::with_grid!(self, g => super::blend(dims, p, |q| [g.get(q).to_f64()])[0]);
        (v, inside)
    }

    /// The same samples placed with `spacing` and `origin` where given (images carry no
    /// geometry: unset, they keep spacing 1 and origin 0); the direction is reset to the identity.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when the spacing is not positive and finite or the origin not finite.
    pub fn placed(self, spacing: Option<[f64; 3]>, origin: Option<[f64; 3]>) -> Result<AnyGrid> {
        if spacing.is_none() && origin.is_none() {
            return Ok(self);
        }
        let l = self.lattice();
        let lattice = Lattice::with_geometry(l.dims(), spacing.unwrap_or(l.spacing()), origin.unwrap_or(l.origin()))?;
        self.with_lattice(lattice)
    }

    /// [`DenseGrid::with_lattice`] for any sample type.
    ///
    /// # Errors
    /// As [`DenseGrid::with_lattice`].
    pub fn with_lattice(self, lattice: Lattice) -> Result<AnyGrid> {
        crate::with_grid!(self, g => g.with_lattice(lattice).map(AnyGrid::from))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> DenseGrid<u16> {
        let l = Lattice::with_geometry([4, 3, 2], [0.5, 1.0, 2.0], [10.0, 20.0, 30.0]).unwrap();
        DenseGrid::from_fn(l, |[i, j, k]| (i + 10 * j + 100 * k) as u16)
    }

    #[test]
    fn crop_keeps_values_and_world_positions() {
        let g = grid();
        let c = g.crop([1, 1, 0], [3, 3, 2]).unwrap();
        assert_eq!(c.lattice().dims(), [2, 2, 2]);
        assert_eq!(c.get([0, 0, 0]), g.get([1, 1, 0]));
        assert_eq!(c.get([1, 1, 1]), g.get([2, 2, 1]));
        assert_eq!(c.lattice().to_world([1.0, 1.0, 1.0]), g.lattice().to_world([2.0, 2.0, 1.0]));
        assert!(g.crop([0, 0, 0], [5, 1, 1]).is_err());
        assert!(g.crop([2, 0, 0], [2, 1, 1]).is_err());
    }

    #[test]
    fn placing_sets_spacing_and_origin_where_given() {
        let g: AnyGrid = grid().into();
        let p = g.clone().placed(Some([0.5, 2.0, 1.0]), None).unwrap();
        assert_eq!((p.lattice().spacing(), p.lattice().origin()), ([0.5, 2.0, 1.0], g.lattice().origin()));
        let p = g.clone().placed(None, Some([1.0, -2.0, 3.0])).unwrap();
        assert_eq!((p.lattice().spacing(), p.lattice().origin()), (g.lattice().spacing(), [1.0, -2.0, 3.0]));
        assert_eq!(p.values_f64().collect::<Vec<_>>(), g.values_f64().collect::<Vec<_>>());
        assert!(g.placed(Some([0.0, 1.0, 1.0]), None).is_err());
    }

    #[test]
    fn pad_surrounds_with_the_value() {
        let g = grid();
        let p = g.pad(1, 999).unwrap();
        assert_eq!(p.lattice().dims(), [6, 5, 4]);
        assert_eq!(p.get([0, 0, 0]), 999);
        assert_eq!(p.get([5, 4, 3]), 999);
        assert_eq!(p.get([1, 1, 1]), g.get([0, 0, 0]));
        assert_eq!(p.get([4, 3, 2]), g.get([3, 2, 1]));
        assert_eq!(p.lattice().to_world([1.0, 1.0, 1.0]), g.lattice().to_world([0.0; 3]));
    }
}
