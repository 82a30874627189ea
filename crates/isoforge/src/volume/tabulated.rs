//! Any volume's values at one iso, stored as `f32` samples so the parallel walker can classify
//! them (fields, user volumes).

use super::{Iso, SampleSlabs, Volume};
use crate::cube::EdgeKey;
use crate::error::{Error, Result};
use crate::grid::Lattice;
use crate::math::Vec3;

/// The offset values of a volume at a fixed iso, tabulated once (in parallel over slabs), with
/// crossings, gradients and off-lattice values still asked of the volume itself (a field keeps
/// its exact root finding).
///
/// Walk it at [`Iso::below(0.0)`](Iso::below): its samples already are `iso.offset(value)` of the
/// tabulation iso (inside ⇔ < 0, exactly), and gradients are turned to point outward for that iso.
///
/// The volume is held as a trait object: one call per slab and per crossing goes through it, so
/// every field shares one compiled walk of its table instead of one per field type.
pub struct Tabulated<'v> {
    inner: &'v (dyn Volume + Sync),
    iso: Iso,
    samples: Vec<f32>,
}

impl<'v> Tabulated<'v> {
    /// Points up to which [`new`](Tabulated::new) tabulates (4 bytes each: 1 GiB).
    pub const MAX_POINTS: u64 = 1 << 28;

    /// Tabulates `inner` at `iso`.
    ///
    /// # Errors
    /// [`Error::Limit`] above [`MAX_POINTS`](Tabulated::MAX_POINTS).
    pub fn new(inner: &'v (dyn Volume + Sync), iso: Iso) -> Result<Self> {
        let lattice = inner.lattice();
        let points = lattice.num_points();
        if points > Self::MAX_POINTS {
            return Err(Error::Limit { what: "tabulated points", requested: points, allowed: Self::MAX_POINTS });
        }
        let n = lattice.slab_len();
        let mut samples = vec![0.0f32; points as usize];
        let fill = |(k, slab): (usize, &mut [f32])| inner.fill_slab(k as u32, iso, slab);
        #[cfg(feature = "parallel")]
        {
            use rayon::prelude::*;
            samples.par_chunks_mut(n.max(1)).enumerate().for_each(fill);
        }
        #[cfg(not(feature = "parallel"))]
        samples.chunks_mut(n.max(1)).enumerate().for_each(fill);
        Ok(Tabulated { inner, iso, samples })
    }
}

impl Volume for Tabulated<'_> {
    #[inline]
    fn lattice(&self) -> &Lattice {
        self.inner.lattice()
    }
    fn fill_slab(&self, k: u32, iso: Iso, out: &mut [f32]) {
        debug_assert_eq!(iso, Iso::below(0.0), "a tabulated volume is walked at Iso::below(0.0)");
        out.copy_from_slice(self.slab(k));
    }
    #[inline]
    fn crossing(&self, e: EdgeKey, d0: f32, d1: f32, _iso: Iso) -> f32 {
        self.inner.crossing(e, d0, d1, self.iso)
    }
    #[inline]
    fn gradient(&self, e: EdgeKey, t: f32) -> Vec3 {
        self.inner.gradient(e, t) * self.iso.sign()
    }
    fn value_at(&self, p: [f64; 3], _iso: Iso) -> f32 {
        self.inner.value_at(p, self.iso)
    }
    fn gradient_at(&self, p: [f64; 3]) -> Vec3 {
        self.inner.gradient_at(p) * self.iso.sign()
    }
    fn segment_crossing(&self, p0: [f64; 3], p1: [f64; 3], d0: f32, d1: f32, _iso: Iso) -> f32 {
        self.inner.segment_crossing(p0, p1, d0, d1, self.iso)
    }
    fn value_bounds(&self, lo: [u32; 3], hi: [u32; 3], _iso: Iso) -> Option<(f32, f32)> {
        self.inner.value_bounds(lo, hi, self.iso)
    }
    fn bounded_by_corners(&self) -> bool {
        self.inner.bounded_by_corners()
    }
}

impl SampleSlabs for Tabulated<'_> {
    type Sample = f32;
    fn sample_box(&self) -> ([u32; 3], [u32; 3]) {
        ([0; 3], self.inner.lattice().dims())
    }
    #[inline]
    fn slab(&self, k: u32) -> &[f32] {
        let n = self.inner.lattice().slab_len();
        &self.samples[k as usize * n..(k as usize + 1) * n]
    }
}
