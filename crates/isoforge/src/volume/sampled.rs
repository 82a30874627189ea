use super::{Field, Illinois, Iso, Oracle, Volume};
use crate::cube::EdgeKey;
use crate::grid::Lattice;
use crate::math::Vec3;

/// A continuous field sampled on a lattice: values are evaluated at the lattice points, crossings
/// are the field's own roots on each edge found by the oracle `O`, gradients are the field's.
#[derive(Debug, Clone)]
pub struct Sampled<F, O = Illinois> {
    field: F,
    lattice: Lattice,
    oracle: O,
}

impl<F: Field> Sampled<F> {
    /// Samples `field` on `lattice` with the default oracle ([`Illinois`]).
    pub fn new(field: F, lattice: Lattice) -> Self {
        Sampled { field, lattice, oracle: Illinois::default() }
    }
}

impl<F: Field, O: Oracle> Sampled<F, O> {
    /// Samples `field` on `lattice`, finding crossings with `oracle`.
    pub fn with_oracle(field: F, lattice: Lattice, oracle: O) -> Self {
        Sampled { field, lattice, oracle }
    }

    /// The field.
    pub fn field(&self) -> &F {
        &self.field
    }

    #[inline]
    fn world(&self, p: [f64; 3]) -> Vec3 {
        let w = self.lattice.to_world(p);
        Vec3::new(w[0] as f32, w[1] as f32, w[2] as f32)
    }
}

impl<F: Field, O: Oracle> Volume for Sampled<F, O> {
    #[inline]
    fn lattice(&self) -> &Lattice {
        &self.lattice
    }

    fn fill_slab(&self, k: u32, iso: Iso, out: &mut [f32]) {
        let [nx, _, _] = self.lattice.dims();
        for (lin, o) in out.iter_mut().enumerate() {
            let (i, j) = (lin % nx as usize, lin / nx as usize);
            let p = self.world([i as f64, j as f64, k as f64]);
            *o = iso.offset(self.field.value(p) as f64);
        }
    }

    fn crossing(&self, e: EdgeKey, d0: f32, d1: f32, iso: Iso) -> f32 {
        let p0 = self.world(e.point_at(0.0));
        let p1 = self.world(e.point_at(1.0));
        let g = |t: f32| iso.offset(self.field.value(p0.lerp(p1, t)) as f64);
        self.oracle.root(g, d0, d1)
    }

    fn gradient(&self, e: EdgeKey, t: f32) -> Vec3 {
        self.field.gradient(self.world(e.point_at(t as f64)))
    }

    fn value_at(&self, p: [f64; 3], iso: Iso) -> f32 {
        iso.offset(self.field.value(self.world(p)) as f64)
    }

    fn gradient_at(&self, p: [f64; 3]) -> Vec3 {
        self.field.gradient(self.world(p))
    }

    /// [`value_at`](Volume::value_at) of each point, in one loop the field's value inlines into.
    fn fill_values(&self, lo: [u32; 3], hi: [u32; 3], iso: Iso, out: &mut [f32]) {
        let mut at = 0;
        for z in lo[2]..hi[2] {
            for y in lo[1]..hi[1] {
                for (x, o) in (lo[0]..hi[0]).zip(&mut out[at..]) {
                    *o = iso.offset(self.field.value(self.world([x as f64, y as f64, z as f64])) as f64);
                }
                at += (hi[0] - lo[0]) as usize;
            }
        }
    }

    /// The field's [`Field::bounds`] over the world box around the index box's corners.
    fn value_bounds(&self, lo: [u32; 3], hi: [u32; 3], iso: Iso) -> Option<(f32, f32)> {
        if self.lattice.direction() == crate::grid::IDENTITY {
            // Axis-aligned: the world box is spanned by the two extreme corners.
            let (a, b) = (self.world(lo.map(f64::from)), self.world(hi.map(f64::from)));
            let (a, b) = self.field.bounds(a.min(b), a.max(b))?;
            let (a, b) = (iso.offset(a as f64), iso.offset(b as f64));
            return Some((a.min(b), a.max(b)));
        }
        let corners = (0..8u32).map(|c| {
            let p = [0, 1, 2].map(|a| if c >> a & 1 == 0 { lo[a] } else { hi[a] } as f64);
            self.world(p)
        });
        let (wlo, whi) = corners
            .fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(l, h), p| (l.min(p), h.max(p)));
        let (a, b) = self.field.bounds(wlo, whi)?;
        let (a, b) = (iso.offset(a as f64), iso.offset(b as f64));
        Some((a.min(b), a.max(b)))
    }

    fn segment_crossing(&self, p0: [f64; 3], p1: [f64; 3], d0: f32, d1: f32, iso: Iso) -> f32 {
        let (p0, p1) = (self.world(p0), self.world(p1));
        let g = |t: f32| iso.offset(self.field.value(p0.lerp(p1, t)) as f64);
        self.oracle.root(g, d0, d1)
    }
}
