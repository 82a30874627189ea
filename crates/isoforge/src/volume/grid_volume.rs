use super::{linear_crossing, Iso, Volume};
use crate::extract::cube::EdgeKey;
use crate::grid::{DenseGrid, Lattice, Sample};
use crate::math::Vec3;

/// A dense grid seen as a volume: crossings by linear interpolation (exact for the trilinear
/// interpolant on an edge), gradients by central differences at the edge's two points,
/// interpolated (one-sided at the lattice faces).
#[derive(Debug, Clone, Copy)]
pub struct GridVolume<'g, S> {
    grid: &'g DenseGrid<S>,
}

impl<'g, S: Sample> GridVolume<'g, S> {
    /// Wraps a grid.
    pub fn new(grid: &'g DenseGrid<S>) -> Self {
        GridVolume { grid }
    }
}

/// The index-space central-difference gradient at lattice point `p` (one-sided at the lattice
/// faces), reading values through `get`.
#[inline]
pub fn point_gradient(dims: [u32; 3], p: [u32; 3], get: &impl Fn([u32; 3]) -> f64) -> [f64; 3] {
    let mut g = [0.0; 3];
    for a in 0..3 {
        if dims[a] < 2 {
            continue;
        }
        let (mut lo, mut hi) = (p, p);
        let mut span = 2.0;
        if p[a] == 0 {
            span = 1.0;
        } else {
            lo[a] -= 1;
        }
        if p[a] + 1 == dims[a] {
            span -= 1.0;
        } else {
            hi[a] += 1;
        }
        g[a] = (get(hi) - get(lo)) / span;
    }
    g
}

/// The world gradient at parameter `t` on edge `e`: the end points' central differences,
/// interpolated. Shared by every grid-backed volume so their normals agree bit for bit.
#[inline]
pub fn edge_gradient(lattice: &Lattice, e: EdgeKey, t: f32, get: &impl Fn([u32; 3]) -> f64) -> Vec3 {
    let dims = lattice.dims();
    let g0 = point_gradient(dims, e.origin, get);
    let g1 = point_gradient(dims, e.end(), get);
    let t = t as f64;
    let g = [0, 1, 2].map(|a| g0[a] + (g1[a] - g0[a]) * t);
    let w = lattice.gradient_to_world(g);
    Vec3::new(w[0] as f32, w[1] as f32, w[2] as f32)
}

/// The trilinear interpolant of a grid-backed volume at index point `p` (clamped to the lattice).
#[inline]
pub fn trilinear_value(dims: [u32; 3], p: [f64; 3], get: &impl Fn([u32; 3]) -> f64) -> f64 {
    crate::grid::blend(dims, p, |q| [get(q)])[0]
}

/// The world gradient at index point `p`: the corners' central differences, blended
/// trilinearly (on lattice edges this equals [`edge_gradient`] up to rounding).
#[inline]
pub fn point_gradient_at(lattice: &Lattice, p: [f64; 3], get: &impl Fn([u32; 3]) -> f64) -> Vec3 {
    let dims = lattice.dims();
    let g = crate::grid::blend(dims, p, |q| point_gradient(dims, q, get));
    let w = lattice.gradient_to_world(g);
    Vec3::new(w[0] as f32, w[1] as f32, w[2] as f32)
}

impl<S: Sample> Volume for GridVolume<'_, S> {
    #[inline]
    fn lattice(&self) -> &Lattice {
        self.grid.lattice()
    }

    fn fill_slab(&self, k: u32, iso: Iso, out: &mut [f32]) {
        let n = self.grid.lattice().slab_len();
        let start = k as usize * n;
        let src = &self.grid.data()[start..start + n];
        for (o, &v) in out.iter_mut().zip(src) {
            *o = iso.offset(v.to_f64());
        }
    }

    #[inline]
    fn crossing(&self, _e: EdgeKey, d0: f32, d1: f32, _iso: Iso) -> f32 {
        linear_crossing(d0, d1)
    }

    fn gradient(&self, e: EdgeKey, t: f32) -> Vec3 {
        edge_gradient(self.grid.lattice(), e, t, &|p| self.grid.get(p).to_f64())
    }

    fn value_at(&self, p: [f64; 3], iso: Iso) -> f32 {
        iso.offset(trilinear_value(self.grid.lattice().dims(), p, &|q| self.grid.get(q).to_f64()))
    }

    fn gradient_at(&self, p: [f64; 3]) -> Vec3 {
        point_gradient_at(self.grid.lattice(), p, &|q| self.grid.get(q).to_f64())
    }
}
