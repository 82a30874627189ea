//! Samples the caller owns in any layout: element strides per axis, of either sign (a numpy
//! array in C or Fortran order, a view taking every other plane, a reversed axis, a broadcast).

use super::SlabSource;
use crate::error::{Error, Result};
use crate::grid::{value_range_of, AnyGrid, DenseGrid, Lattice, Sample, ValueRange};
use crate::mesh::ExternalError;

/// Borrowed samples on a lattice, the sample of point `(x, y, z)` at index
/// `first + x·sx + y·sy + z·sz` of `samples` (strides in elements, any sign, 0 for a broadcast
/// axis). Walked in place when the layout is the library's own (x fastest, packed:
/// [`contiguous`](StridedSamples::contiguous)); otherwise read slab by slab
/// ([`slabs`](StridedSamples::slabs)), never copied whole.
#[derive(Debug, Clone)]
pub struct StridedSamples<'a, S> {
    samples: &'a [S],
    first: usize,
    strides: [isize; 3],
    lattice: Lattice,
}

impl<'a, S: Sample> StridedSamples<'a, S> {
    /// Wraps `samples` with point `(0, 0, 0)` at index `first` and `strides` (elements) along x,
    /// y and z.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] naming the index when a point of the lattice falls outside
    /// `samples`.
    pub fn new(lattice: Lattice, samples: &'a [S], first: usize, strides: [isize; 3]) -> Result<Self> {
        let dims = lattice.dims();
        // The lowest and highest index any point reaches, in i128 (no overflow for any input).
        let (mut lo, mut hi) = (first as i128, first as i128);
        for a in 0..3 {
            let reach = i128::from(dims[a].saturating_sub(1)) * strides[a] as i128;
            lo += reach.min(0);
            hi += reach.max(0);
        }
        if lo < 0 || hi >= samples.len() as i128 {
            return Err(Error::InvalidInput(format!(
                "strides {strides:?} from index {first} reach indices {lo}..={hi} of {} samples for a lattice of {dims:?} \
                 points",
                samples.len()
            )));
        }
        Ok(StridedSamples { samples, first, strides, lattice })
    }

    /// The lattice.
    pub fn lattice(&self) -> &Lattice {
        &self.lattice
    }

    /// The samples as one packed slice, x fastest (what [`GridVolume::borrowed`](super::GridVolume::borrowed)
    /// walks in place), when that is their layout.
    pub fn contiguous(&self) -> Option<&'a [S]> {
        let [nx, ny, nz] = self.lattice.dims().map(|d| d as usize);
        let n = nx * ny * nz;
        // Strides along axes of one point never matter.
        let packed = [1, nx, nx * ny];
        let same = (0..3).all(|a| self.lattice.dims()[a] < 2 || self.strides[a] == packed[a] as isize);
        same.then(|| &self.samples[self.first..self.first + n])
    }

    /// The memory of a packed layout with its axes permuted or reversed (Fortran order, a
    /// reversed axis): exactly the lattice's samples, in memory order; None for other layouts.
    fn permuted_memory(&self) -> Option<&'a [S]> {
        let dims = self.lattice.dims();
        let mut axes: Vec<(usize, usize)> =
            (0..3).filter(|&a| dims[a] > 1).map(|a| (self.strides[a].unsigned_abs(), dims[a] as usize)).collect();
        axes.sort_unstable();
        let mut packed = 1;
        for (stride, d) in axes {
            if stride != packed {
                return None;
            }
            packed *= d;
        }
        let reach: isize = (0..3).map(|a| ((dims[a] as isize - 1) * self.strides[a]).min(0)).sum();
        let lowest = (self.first as isize + reach) as usize;
        Some(&self.samples[lowest..lowest + packed])
    }

    /// The sample at point `p`.
    #[inline]
    pub fn get(&self, p: [u32; 3]) -> S {
        let i = self.first as isize + (0..3).map(|a| p[a] as isize * self.strides[a]).sum::<isize>();
        self.samples[i as usize]
    }

    /// A copy in a grid (for the walks that need the whole grid in the library's layout).
    ///
    /// # Errors
    /// As [`DenseGrid::new`].
    pub fn to_grid(&self) -> Result<DenseGrid<S>> {
        let [nx, ny, nz] = self.lattice.dims().map(|d| d as usize);
        let mut data = vec![S::from_f64(0.0); nx * ny * nz];
        self.gather(0, &mut data);
        DenseGrid::new(self.lattice.clone(), data)
    }

    /// The smallest and largest sample (NaN skipped; None when all are NaN), read slab by slab
    /// unless packed.
    pub fn value_range(&self) -> Option<ValueRange> {
        if let Some(memory) = self.contiguous().or_else(|| self.permuted_memory()) {
            return value_range_of(memory);
        }
        let [nx, ny, nz] = self.lattice.dims().map(|d| d as usize);
        let block = self.block();
        let mut slabs = vec![S::from_f64(0.0); block * nx * ny];
        let mut range: Option<ValueRange> = None;
        for k in (0..nz).step_by(block) {
            let some = &mut slabs[..block.min(nz - k) * nx * ny];
            self.gather(k, some);
            if let Some(r) = value_range_of(some) {
                range = Some(range.map_or(r, |a| ValueRange { min: a.min.min(r.min), max: a.max.max(r.max) }));
            }
        }
        range
    }

    /// The samples z-slab by z-slab, x fastest: a [`SlabSource`] for the streamed walk.
    pub fn slabs(&self) -> StridedSlabs<'a, S> {
        StridedSlabs { src: self.clone(), next: 0, block: self.block(), held: Vec::new(), held_from: 0, held_count: 0 }
    }

    /// Slabs gathered at once: where z is the fastest axis in memory (Fortran order), one cache
    /// line holds several slabs' samples, so as many slabs as a line holds; else one.
    fn block(&self) -> usize {
        let [sx, sy, sz] = self.strides.map(isize::unsigned_abs);
        let nz = self.lattice.dims()[2] as usize;
        if sz < sx.min(sy) && sz > 0 {
            (64 / std::mem::size_of::<S>()).clamp(1, nz.max(1))
        } else {
            1
        }
    }
}

/// A [`StridedSamples`]' slabs in order ([`StridedSamples::slabs`]), each gathered from the
/// caller's memory when asked for; a few slabs are held at a time when z is the fastest axis in
/// memory.
#[derive(Debug)]
pub struct StridedSlabs<'a, S> {
    src: StridedSamples<'a, S>,
    /// The next slab handed out.
    next: usize,
    /// Slabs gathered at once.
    block: usize,
    /// `held_count` slabs from `held_from` on, one after the other.
    held: Vec<S>,
    held_from: usize,
    held_count: usize,
}

impl<S: Sample> StridedSamples<'_, S> {
    /// Slabs `from`, `from + 1`, … (as many as `out` holds whole slabs) into `out`, x fastest.
    fn gather(&self, from: usize, out: &mut [S]) {
        let [nx, ny, _] = self.lattice.dims().map(|d| d as usize);
        let n = nx * ny;
        let count = out.len().checked_div(n).unwrap_or(0);
        let [sx, sy, sz] = self.strides;
        let base = self.first as isize + from as isize * sz;
        // The inner loop along the smaller stride of x and y.
        let x_inner = sx.unsigned_abs() <= sy.unsigned_abs();
        let (outer, inner, so, si) = if x_inner { (ny, nx, sy, sx) } else { (nx, ny, sx, sy) };
        for o in 0..outer {
            for i in 0..inner {
                let at = if x_inner { o * nx + i } else { i * nx + o };
                let p = base + o as isize * so + i as isize * si;
                for b in 0..count {
                    out[b * n + at] = self.samples[(p + b as isize * sz) as usize];
                }
            }
        }
    }
}

impl<S: Sample, T: Sample> SlabSource<T> for StridedSlabs<'_, S> {
    fn lattice(&self) -> &Lattice {
        &self.src.lattice
    }

    fn read_slab(&mut self, out: &mut [T]) -> std::result::Result<(), ExternalError> {
        let [nx, ny, nz] = self.src.lattice.dims().map(|d| d as usize);
        let (n, k) = (nx * ny, self.next);
        if out.len() != n {
            return Err(format!("a slab of {} samples asked for, slabs hold {n}", out.len()).into());
        }
        if k >= nz {
            return Err(format!("slab {k} asked for, the volume has {nz}").into());
        }
        if !(self.held_from..self.held_from + self.held_count).contains(&k) {
            let count = self.block.min(nz - k);
            self.held.resize(count * n, S::from_f64(0.0));
            self.src.gather(k, &mut self.held);
            (self.held_from, self.held_count) = (k, count);
        }
        let i = k - self.held_from;
        // The same type converts exactly (every sample type is exact in f64).
        for (o, v) in out.iter_mut().zip(&self.held[i * n..(i + 1) * n]) {
            *o = T::from_f64(v.to_f64());
        }
        self.next += 1;
        Ok(())
    }
}

/// [`StridedSamples`] of any sample type (an array whose type is known at run time).
#[derive(Debug, Clone)]
pub enum AnySamples<'a> {
    /// `u8` samples.
    U8(StridedSamples<'a, u8>),
    /// `i8` samples.
    I8(StridedSamples<'a, i8>),
    /// `u16` samples.
    U16(StridedSamples<'a, u16>),
    /// `i16` samples.
    I16(StridedSamples<'a, i16>),
    /// `u32` samples.
    U32(StridedSamples<'a, u32>),
    /// `i32` samples.
    I32(StridedSamples<'a, i32>),
    /// `f32` samples.
    F32(StridedSamples<'a, f32>),
    /// `f64` samples.
    F64(StridedSamples<'a, f64>),
}

/// Runs `$body` with `$s` bound to the [`StridedSamples`] inside an [`AnySamples`].
#[macro_export]
macro_rules! with_samples {
    ($samples:expr, $s:ident => $body:expr) => {{
        use $crate::volume::AnySamples as A;
        match $samples {
            A::U8($s) => $body,
            A::I8($s) => $body,
            A::U16($s) => $body,
            A::I16($s) => $body,
            A::U32($s) => $body,
            A::I32($s) => $body,
            A::F32($s) => $body,
            A::F64($s) => $body,
        }
    }};
}

impl AnySamples<'_> {
    /// The lattice.
    pub fn lattice(&self) -> &Lattice {
        crate::with_samples!(self, s => s.lattice())
    }

    /// See [`StridedSamples::value_range`].
    pub fn value_range(&self) -> Option<ValueRange> {
        crate::with_samples!(self, s => s.value_range())
    }

    /// A copy in a grid of the same sample type.
    ///
    /// # Errors
    /// As [`DenseGrid::new`].
    pub fn to_grid(&self) -> Result<AnyGrid> {
        Ok(match self {
            AnySamples::U8(s) => AnyGrid::U8(s.to_grid()?),
            AnySamples::I8(s) => AnyGrid::I8(s.to_grid()?),
            AnySamples::U16(s) => AnyGrid::U16(s.to_grid()?),
            AnySamples::I16(s) => AnyGrid::I16(s.to_grid()?),
            AnySamples::U32(s) => AnyGrid::U32(s.to_grid()?),
            AnySamples::I32(s) => AnyGrid::I32(s.to_grid()?),
            AnySamples::F32(s) => AnyGrid::F32(s.to_grid()?),
            AnySamples::F64(s) => AnyGrid::F64(s.to_grid()?),
        })
    }
}
