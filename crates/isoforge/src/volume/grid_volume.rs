use super::{exact_crossing, linear_crossing, offsets_are_faithful, Iso, SampleSlabs, Volume};
use crate::cube::EdgeKey;
use crate::error::{Error, Result};
use crate::grid::{BlockBounds, DenseGrid, Lattice, Sample};
use crate::math::Vec3;

/// A dense grid seen as a volume: crossings by linear interpolation (exact for the trilinear
/// interpolant on an edge), gradients by central differences at the edge's two points,
/// interpolated (one-sided at the lattice faces).
///
/// Usually the grid is the whole lattice ([`new`](GridVolume::new)); a *window* is a chunk of a
/// larger lattice (its points from a global offset, [`window`](GridVolume::window)), walked
/// over a cell range in global indices exactly as the whole lattice would be.
#[derive(Debug, Clone)]
pub struct GridVolume<'g, S> {
    /// The samples, x fastest: a grid's, or caller memory ([`borrowed`](GridVolume::borrowed)).
    samples: &'g [S],
    /// Points per axis of `samples`.
    dims: [u32; 3],
    /// The lattice walked (the grid's own, or the global one of a window).
    lattice: Lattice,
    /// Global index of the grid's first point.
    offset: [u32; 3],
    bounds: Option<&'g BlockBounds>,
}

impl<'g, S: Sample> GridVolume<'g, S> {
    /// Wraps a grid.
    pub fn new(grid: &'g DenseGrid<S>) -> Self {
        GridVolume {
            samples: grid.data(),
            dims: grid.lattice().dims(),
            lattice: grid.lattice().clone(),
            offset: [0; 3],
            bounds: None,
        }
    }

    /// Wraps samples the caller owns (x fastest, then y, then z: a C-ordered `(nz, ny, nx)`
    /// array) on `lattice`, without copying them.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when there are not exactly as many samples as lattice points.
    pub fn borrowed(lattice: Lattice, samples: &'g [S]) -> Result<Self> {
        if samples.len() as u64 != lattice.num_points() {
            return Err(Error::InvalidInput(format!(
                "{} samples for a lattice of {:?} points",
                samples.len(),
                lattice.dims()
            )));
        }
        Ok(GridVolume { samples, dims: lattice.dims(), lattice, offset: [0; 3], bounds: None })
    }

    /// A chunk of the lattice `global`: `grid` holds its points from global index `offset` on
    /// (its own lattice's geometry is ignored). Walks of a cell range read its points and one
    /// more on every side ([`CellRange::halo_points`](crate::cube::CellRange::halo_points)), so
    /// the window must hold them.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when the window does not fit in `global`.
    pub fn window(grid: &'g DenseGrid<S>, offset: [u32; 3], global: Lattice) -> Result<Self> {
        let (d, g) = (grid.lattice().dims(), global.dims());
        if (0..3).any(|a| offset[a] as u64 + d[a] as u64 > g[a] as u64) {
            return Err(Error::InvalidInput(format!(
                "window of {d:?} points at {offset:?} does not fit a lattice of {g:?} points"
            )));
        }
        Ok(GridVolume { samples: grid.data(), dims: d, lattice: global, offset, bounds: None })
    }

    /// Lets walkers skip blocks whose sample bounds exclude the iso (computed once by
    /// [`BlockBounds::of`] on the same grid, and reused for any iso).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when `bounds` were computed for a grid of other dims.
    pub fn with_block_bounds(mut self, bounds: &'g BlockBounds) -> Result<Self> {
        let want = self.dims.map(|d| d.saturating_sub(1).div_ceil(BlockBounds::CELLS).max(1));
        if bounds.blocks() != want {
            return Err(Error::InvalidInput(format!(
                "block bounds of {:?} blocks do not match a grid of {:?} points",
                bounds.blocks(),
                self.dims
            )));
        }
        self.bounds = Some(bounds);
        Ok(self)
    }

    /// The sample at global point `p`.
    #[inline]
    fn at(&self, p: [u32; 3]) -> f64 {
        let [x, y, z] = [0, 1, 2].map(|a| (p[a] - self.offset[a]) as usize);
        let [nx, ny, _] = self.dims.map(|d| d as usize);
        self.samples[(z * ny + y) * nx + x].to_f64()
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
    narrow_gradient(lattice.gradient_to_world(g))
}

/// A world gradient in `f32`: as it is, or, where its largest component lies outside [2⁻¹⁰⁰,
/// 2¹⁰⁰) (samples beyond `f32`'s range, whose gradient would overflow to infinity or vanish),
/// scaled by the power of two that brings it near 1: the direction is what walkers use (normals,
/// dual contouring's planes). Ordinary data never takes the scaled path: its gradients are
/// unchanged bit for bit.
#[inline]
fn narrow_gradient(w: [f64; 3]) -> Vec3 {
    const LO: f64 = 7.888609052210118e-31; // 2^-100
    const HI: f64 = 1.2676506002282294e30; // 2^100
    let largest = w.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if largest == 0.0 || (LO..HI).contains(&largest) || !largest.is_finite() {
        return Vec3::new(w[0] as f32, w[1] as f32, w[2] as f32);
    }
    scaled_gradient(w, largest)
}

#[cold]
fn scaled_gradient(w: [f64; 3], largest: f64) -> Vec3 {
    // 2^-e in two factors, each within f64's range for any finite `largest`.
    let e = largest.log2().floor() as i32;
    let (a, b) = (-e / 2, -e - -e / 2);
    let s = w.map(|x| (x * 2f64.powi(a) * 2f64.powi(b)) as f32);
    Vec3::new(s[0], s[1], s[2])
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
    narrow_gradient(lattice.gradient_to_world(g))
}

/// The crossing on lattice edge `e` of a grid-backed volume whose samples `get` reads: linear in
/// the offsets `d0`, `d1`, or in the samples' own unrounded offsets where the `f32` ones lost their
/// ratio (not [faithful](super::offsets_are_faithful): values beyond `f32`'s range, or both too
/// close to iso for it). Every walker calls this through [`Volume::crossing`], so all agree bit
/// for bit.
#[inline(always)]
pub fn grid_crossing(e: EdgeKey, d0: f32, d1: f32, iso: Iso, get: &impl Fn([u32; 3]) -> f64) -> f32 {
    if offsets_are_faithful(d0, d1) {
        linear_crossing(d0, d1)
    } else {
        samples_crossing(iso, [get(e.origin), get(e.end())])
    }
}

/// The crossing between two samples from their unrounded offsets: the rare path of
/// [`grid_crossing`] and [`grid_segment_crossing`], kept out of line so theirs stays small.
#[cold]
#[inline(never)]
fn samples_crossing(iso: Iso, [s0, s1]: [f64; 2]) -> f32 {
    exact_crossing(iso.exact_offset(s0), iso.exact_offset(s1))
}

/// [`grid_crossing`] for a segment `p0` → `p1` (index points: lattice points, cell centres), the
/// unrounded values of its ends being the trilinear interpolant's.
#[inline(always)]
pub fn grid_segment_crossing(
    dims: [u32; 3],
    [p0, p1]: [[f64; 3]; 2],
    d0: f32,
    d1: f32,
    iso: Iso,
    get: &impl Fn([u32; 3]) -> f64,
) -> f32 {
    if offsets_are_faithful(d0, d1) {
        linear_crossing(d0, d1)
    } else {
        samples_crossing(iso, [p0, p1].map(|p| trilinear_value(dims, p, get)))
    }
}

impl<S: Sample> Volume for GridVolume<'_, S> {
    #[inline]
    fn lattice(&self) -> &Lattice {
        &self.lattice
    }

    fn fill_slab(&self, k: u32, iso: Iso, out: &mut [f32]) {
        let [nx, ny, _] = self.lattice.dims().map(|d| d as usize);
        debug_assert_eq!(out.len(), nx * ny);
        if self.offset == [0; 3] && self.dims == self.lattice.dims() {
            for (o, &v) in out.iter_mut().zip(self.slab(k)) {
                *o = iso.offset(v.to_f64());
            }
            return;
        }
        // A window: the points it holds; the rest of the slab is never read by walks of ranges
        // the window serves, and is marked NaN so a misuse shows.
        out.fill(f32::NAN);
        let ([ox, oy, _], [wx, wy, _]) = self.sample_box();
        let slab = self.slab(k);
        for j in 0..wy as usize {
            let dst = &mut out[(oy as usize + j) * nx + ox as usize..][..wx as usize];
            for (o, &v) in dst.iter_mut().zip(&slab[j * wx as usize..(j + 1) * wx as usize]) {
                *o = iso.offset(v.to_f64());
            }
        }
    }

    #[inline]
    fn crossing(&self, e: EdgeKey, d0: f32, d1: f32, iso: Iso) -> f32 {
        grid_crossing(e, d0, d1, iso, &|p| self.at(p))
    }

    #[inline]
    fn segment_crossing(&self, p0: [f64; 3], p1: [f64; 3], d0: f32, d1: f32, iso: Iso) -> f32 {
        grid_segment_crossing(self.lattice.dims(), [p0, p1], d0, d1, iso, &|p| self.at(p))
    }

    fn gradient(&self, e: EdgeKey, t: f32) -> Vec3 {
        edge_gradient(&self.lattice, e, t, &|p| self.at(p))
    }

    fn value_at(&self, p: [f64; 3], iso: Iso) -> f32 {
        iso.offset(trilinear_value(self.lattice.dims(), p, &|q| self.at(q)))
    }
    #[inline]
    fn value_at_point(&self, p: [u32; 3], iso: Iso) -> f32 {
        iso.offset(self.at(p))
    }

    fn gradient_at(&self, p: [f64; 3]) -> Vec3 {
        point_gradient_at(&self.lattice, p, &|q| self.at(q))
    }

    fn bounded_by_corners(&self) -> bool {
        true
    }

    fn value_bounds(&self, lo: [u32; 3], hi: [u32; 3], iso: Iso) -> Option<(f32, f32)> {
        let b = self.bounds?;
        let local = |p: [u32; 3]| [0, 1, 2].map(|a| p[a].saturating_sub(self.offset[a]));
        let [l, h] = b.of_points(local(lo), local(hi));
        let (a, c) = (iso.offset(l), iso.offset(h));
        Some((a.min(c), a.max(c)))
    }
}

impl<S: Sample> SampleSlabs for GridVolume<'_, S> {
    type Sample = S;

    #[inline]
    fn sample_box(&self) -> ([u32; 3], [u32; 3]) {
        (self.offset, self.dims)
    }

    #[inline]
    fn slab(&self, k: u32) -> &[S] {
        let n = self.dims[0] as usize * self.dims[1] as usize;
        let k = (k - self.offset[2]) as usize;
        &self.samples[k * n..(k + 1) * n]
    }

    fn centres_from_samples(&self) -> bool {
        true
    }

    fn block_bounds(&self) -> Option<&BlockBounds> {
        self.bounds
    }
}
