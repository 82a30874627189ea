use super::{DType, Lattice, Sample};
use crate::error::{Error, Result};

/// Samples stored densely on a lattice, x fastest, in their own type `S`.
#[derive(Debug, Clone, PartialEq)]
pub struct DenseGrid<S> {
    lattice: Lattice,
    data: Vec<S>,
}

/// The first non-finite sample of a grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NonFinite {
    /// Its lattice point.
    pub ijk: [u32; 3],
    /// Its value (NaN or ±inf).
    pub value: f64,
}

/// The smallest and largest sample of a grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValueRange {
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
}

impl<S: Sample> DenseGrid<S> {
    /// Wraps samples (x fastest) on a lattice.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when `data.len()` is not the lattice's point count.
    pub fn new(lattice: Lattice, data: Vec<S>) -> Result<Self> {
        if data.len() as u64 != lattice.num_points() {
            return Err(Error::InvalidInput(format!(
                "grid of {:?} points needs {} samples, got {}",
                lattice.dims(),
                lattice.num_points(),
                data.len()
            )));
        }
        Ok(DenseGrid { lattice, data })
    }

    /// A grid filled by `f(ijk)`.
    pub fn from_fn(lattice: Lattice, mut f: impl FnMut([u32; 3]) -> S) -> Self {
        let n = lattice.num_points() as usize;
        let data = (0..n).map(|lin| f(lattice.ijk(lin))).collect();
        DenseGrid { lattice, data }
    }

    /// The lattice and the samples, taken apart without copying.
    #[inline]
    pub fn into_parts(self) -> (Lattice, Vec<S>) {
        (self.lattice, self.data)
    }

    /// The sampling lattice.
    #[inline]
    pub fn lattice(&self) -> &Lattice {
        &self.lattice
    }

    /// All samples, x fastest.
    #[inline]
    pub fn data(&self) -> &[S] {
        &self.data
    }

    /// Mutable samples, x fastest.
    #[inline]
    pub fn data_mut(&mut self) -> &mut [S] {
        &mut self.data
    }

    /// The sample at `ijk`.
    ///
    /// # Panics
    /// When `ijk` is outside the lattice.
    #[inline]
    pub fn get(&self, ijk: [u32; 3]) -> S {
        self.data[self.lattice.linear(ijk)]
    }

    /// Replaces the lattice geometry (spacing, origin) keeping dims.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when `lattice` has other dims.
    pub fn set_lattice(&mut self, lattice: Lattice) -> Result<()> {
        if lattice.dims() != self.lattice.dims() {
            return Err(Error::InvalidInput(format!(
                "new lattice dims {:?} differ from the grid's {:?}",
                lattice.dims(),
                self.lattice.dims()
            )));
        }
        self.lattice = lattice;
        Ok(())
    }

    /// The first sample that is NaN or infinite, if any.
    pub fn first_non_finite(&self) -> Option<NonFinite> {
        let lin = super::sample::first_non_finite(&self.data)?;
        Some(NonFinite { ijk: self.lattice.ijk(lin), value: self.data[lin].to_f64() })
    }

    /// Smallest and largest sample (NaN samples are skipped; `None` when all are NaN).
    pub fn value_range(&self) -> Option<ValueRange> {
        value_range_of(&self.data)
    }

    /// Consumes the grid, returning its samples.
    pub fn into_data(self) -> Vec<S> {
        self.data
    }
}

/// The smallest and largest of `data` (NaN skipped; None when there is no other value).
pub fn value_range_of<S: Sample>(data: &[S]) -> Option<ValueRange> {
    // Lanes of running bounds in the sample's own type (exact: `to_f64` is monotonic and
    // exact), so the loop vectorises; a NaN never compares less or greater, so it is skipped.
    const LANES: usize = 16;
    let first = data.iter().position(|v| !v.to_f64().is_nan())?;
    let rest = &data[first..];
    let (mut lo, mut hi) = ([rest[0]; LANES], [rest[0]; LANES]);
    let mut chunks = rest.chunks_exact(LANES);
    for c in &mut chunks {
        for l in 0..LANES {
            let v = c[l];
            lo[l] = if v < lo[l] { v } else { lo[l] };
            hi[l] = if v > hi[l] { v } else { hi[l] };
        }
    }
    for &v in chunks.remainder() {
        lo[0] = if v < lo[0] { v } else { lo[0] };
        hi[0] = if v > hi[0] { v } else { hi[0] };
    }
    let min = lo.iter().map(|v| v.to_f64()).fold(f64::INFINITY, f64::min);
    let max = hi.iter().map(|v| v.to_f64()).fold(f64::NEG_INFINITY, f64::max);
    Some(ValueRange { min, max })
}

/// A dense grid of any sample type: the runtime choice, matched once at the top of a pipeline.
///
/// Exhaustive on purpose: [`with_grid!`](crate::with_grid) matches every variant, in any crate.
#[derive(Debug, Clone, PartialEq)]
pub enum AnyGrid {
    /// `u8` samples.
    U8(DenseGrid<u8>),
    /// `i8` samples.
    I8(DenseGrid<i8>),
    /// `u16` samples.
    U16(DenseGrid<u16>),
    /// `i16` samples.
    I16(DenseGrid<i16>),
    /// `u32` samples.
    U32(DenseGrid<u32>),
    /// `i32` samples.
    I32(DenseGrid<i32>),
    /// `f32` samples.
    F32(DenseGrid<f32>),
    /// `f64` samples.
    F64(DenseGrid<f64>),
}

/// Calls `$body` with `$g` bound to the typed grid inside an [`AnyGrid`].
#[macro_export]
macro_rules! with_grid {
    ($any:expr, $g:ident => $body:expr) => {
        match $any {
            $crate::grid::AnyGrid::U8($g) => $body,
            $crate::grid::AnyGrid::I8($g) => $body,
            $crate::grid::AnyGrid::U16($g) => $body,
            $crate::grid::AnyGrid::I16($g) => $body,
            $crate::grid::AnyGrid::U32($g) => $body,
            $crate::grid::AnyGrid::I32($g) => $body,
            $crate::grid::AnyGrid::F32($g) => $body,
            $crate::grid::AnyGrid::F64($g) => $body,
        }
    };
}

/// Calls `$body` with `$s` bound to the Rust sample type of a [`DType`](crate::grid::DType)
/// (f64 for any type added later): a runtime type matched once, then generic code.
#[macro_export]
macro_rules! with_dtype {
    ($dtype:expr, $s:ident => $body:expr) => {{
        #[allow(unreachable_patterns)]
        match $dtype {
            $crate::grid::DType::U8 => {
                type $s = u8;
                $body
            }
            $crate::grid::DType::I8 => {
                type $s = i8;
                $body
            }
            $crate::grid::DType::U16 => {
                type $s = u16;
                $body
            }
            $crate::grid::DType::I16 => {
                type $s = i16;
                $body
            }
            $crate::grid::DType::U32 => {
                type $s = u32;
                $body
            }
            $crate::grid::DType::I32 => {
                type $s = i32;
                $body
            }
            $crate::grid::DType::F32 => {
                type $s = f32;
                $body
            }
            _ => {
                type $s = f64;
                $body
            }
        }
    }};
}

macro_rules! any_from {
    ($t:ty, $v:ident) => {
        impl From<DenseGrid<$t>> for AnyGrid {
            fn from(g: DenseGrid<$t>) -> Self {
                AnyGrid::$v(g)
            }
        }
    };
}
any_from!(u8, U8);
any_from!(i8, I8);
any_from!(u16, U16);
any_from!(i16, I16);
any_from!(u32, U32);
any_from!(i32, I32);
any_from!(f32, F32);
any_from!(f64, F64);

impl AnyGrid {
    /// The sampling lattice.
    pub fn lattice(&self) -> &Lattice {
        with_grid!(self, g => g.lattice())
    }

    /// The sample type.
    pub fn dtype(&self) -> DType {
        fn d<S: Sample>(_: &DenseGrid<S>) -> DType {
            S::DTYPE
        }
        with_grid!(self, g => d(g))
    }

    /// See [`DenseGrid::first_non_finite`].
    pub fn first_non_finite(&self) -> Option<NonFinite> {
        with_grid!(self, g => g.first_non_finite())
    }

    /// See [`DenseGrid::value_range`].
    pub fn value_range(&self) -> Option<ValueRange> {
        with_grid!(self, g => g.value_range())
    }

    /// See [`DenseGrid::set_lattice`].
    ///
    /// # Errors
    /// As [`DenseGrid::set_lattice`].
    pub fn set_lattice(&mut self, lattice: Lattice) -> Result<()> {
        with_grid!(self, g => g.set_lattice(lattice))
    }

    /// The sample at `ijk` as `f64`.
    ///
    /// # Panics
    /// When `ijk` is outside the lattice.
    pub fn get_f64(&self, ijk: [u32; 3]) -> f64 {
        with_grid!(self, g => g.get(ijk).to_f64())
    }

    /// Iterates over all samples as `f64`, x fastest.
    pub fn values_f64(&self) -> Box<dyn Iterator<Item = f64> + '_> {
        with_grid!(self, g => Box::new(g.data().iter().map(|v| v.to_f64())))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn range_and_non_finite() {
        let l = Lattice::new([2, 2, 2]).unwrap();
        let mut g = DenseGrid::from_fn(l, |p| (p[0] + 2 * p[1] + 4 * p[2]) as f32);
        assert_eq!(g.value_range(), Some(ValueRange { min: 0.0, max: 7.0 }));
        assert_eq!(g.first_non_finite(), None);
        g.data_mut()[5] = f32::NAN;
        let nf = g.first_non_finite().unwrap();
        assert_eq!(nf.ijk, [1, 0, 1]);
        assert!(nf.value.is_nan());
        assert!(DenseGrid::new(Lattice::new([2, 2, 2]).unwrap(), vec![0u8; 7]).is_err());
    }

    /// The blocked scans agree with a plain pass over the samples wherever the extremes and the
    /// non-finite samples sit: the first sample, inside a block, in the tail past the last block.
    #[test]
    fn blocked_scans_match_a_plain_pass() {
        let l = Lattice::new([23, 19, 3]).unwrap(); // 1311 samples: 5 blocks of 256 and a tail
        let n = l.num_points() as usize;
        let base = |i: usize| ((i * 7919) % 1000) as f32 * 0.5 - 200.0;
        let plain = |d: &[f32]| {
            let ok: Vec<f64> = d.iter().filter(|v| !v.is_nan()).map(|&v| v as f64).collect();
            let range = (!ok.is_empty()).then(|| ValueRange {
                min: ok.iter().copied().fold(f64::INFINITY, f64::min),
                max: ok.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            });
            (range, d.iter().position(|v| !v.is_finite()))
        };
        for at in [0, 1, 255, 256, 700, 1279, 1280, 1300, n - 1] {
            for special in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -1e30, 1e30] {
                let mut d: Vec<f32> = (0..n).map(base).collect();
                d[at] = special;
                if at > 3 {
                    d[3] = f32::NAN; // an earlier NaN wins the non-finite search
                }
                let g = DenseGrid::new(l.clone(), d.clone()).unwrap();
                let (range, first) = plain(&d);
                assert_eq!(g.value_range(), range, "special {special} at {at}");
                assert_eq!(g.first_non_finite().map(|nf| l.linear(nf.ijk)), first, "special {special} at {at}");
            }
        }
        let all_nan = DenseGrid::new(l.clone(), vec![f32::NAN; n]).unwrap();
        assert_eq!(all_nan.value_range(), None);
        assert_eq!(all_nan.first_non_finite().map(|nf| nf.ijk), Some([0, 0, 0]));
        let ints = DenseGrid::new(l.clone(), (0..n).map(|i| (i * 31 % 977) as u16).collect()).unwrap();
        assert_eq!(ints.value_range(), Some(ValueRange { min: 0.0, max: 976.0 }));
        assert_eq!(ints.first_non_finite().map(|nf| nf.ijk), None);
    }
}
