//! Sparse grids made for an iso: only the blocks of 8³ points near the surface are sampled and
//! stored ([`SparseGrid::from_dense`], [`SparseGrid::from_field`]).

use crate::cube::CellRange;
use crate::error::{Error, Result};
use crate::grid::sparse::{copy_block, SparseNode, LEAF, NODE_POINTS, SURFACE_MARGIN};
use crate::grid::{BlockBounds, DenseGrid, Sample, SparseGrid};

use super::{Inside, Iso, Volume};

impl<S: Sample> SparseGrid<S> {
    /// A sparse copy of `grid` for the iso `iso`: every block of 8³ points whose points within
    /// [`SURFACE_MARGIN`] are not all on one side becomes a leaf, the others a tile of their side's
    /// extreme sample (a tile never changes a cell's side). The background is the outside extreme.
    /// Blocks are judged from [`BlockBounds`] of the points around them.
    pub fn from_dense(grid: &DenseGrid<S>, iso: Iso) -> Self {
        Self::from_dense_band(grid, iso, SURFACE_MARGIN)
    }

    /// [`from_dense`](SparseGrid::from_dense) keeping as leaves the blocks within `band` points of
    /// a crossed cell (`band` below [`SURFACE_MARGIN`] counts as [`SURFACE_MARGIN`]: a walk must
    /// read leaf samples only). A wider band keeps more of the field around the surface (for
    /// offsets, gradients or a later iso near this one).
    pub fn from_dense_band(grid: &DenseGrid<S>, iso: Iso, band: u32) -> Self {
        let band = band.max(SURFACE_MARGIN);
        let dims = grid.lattice().dims();
        let bounds = BlockBounds::of(grid);
        let inside = |v: f64| iso.exact_offset(v) < 0.0;
        let (inside_value, outside_value) = match (grid.value_range(), iso.inside) {
            (Some(r), Inside::Below) => (S::from_f64(r.min), S::from_f64(r.max)),
            (Some(r), Inside::Above) => (S::from_f64(r.max), S::from_f64(r.min)),
            (None, _) => (S::from_f64(0.0), S::from_f64(0.0)),
        };
        let node = |coord: [u32; 3]| {
            SparseNode::blocks(coord, dims, outside_value, &mut |o: [u32; 3], out: &mut [S]| {
                let lo = o.map(|v| v.saturating_sub(band));
                let hi = [0, 1, 2].map(|a| (o[a] + LEAF - 1).saturating_add(band).min(dims[a] - 1));
                let [min, max] = bounds.of_points(lo, hi);
                match (inside(min) || inside(max), !inside(min) || !inside(max)) {
                    (true, true) => {
                        copy_block(o, dims, out, |p| grid.get(p));
                        None
                    }
                    (true, false) => Some(inside_value),
                    _ => Some(outside_value),
                }
            })
        };
        Self::build(grid.lattice().clone(), outside_value, &node)
    }
}

impl SparseGrid<f32> {
    /// A sparse sampling of `vol` (a field on its lattice) for `iso`, which samples only where the
    /// surface may pass. With a bound `lipschitz` = L on how fast the values change (|f(p) −
    /// f(q)| ≤ L·|p − q| in world units; 1 for a true signed distance), a box of points whose
    /// centre lies farther from the iso than L × its half diagonal grown by [`SURFACE_MARGIN`]
    /// points holds no crossing within the margin, and becomes a tile of its side without being
    /// sampled: nodes of 128³ points first, then their blocks of 8³. Without a bound every point is
    /// sampled, node by node with a ring of one block around it, and a block is a leaf when its
    /// points within the margin are not all on one side: memory still grows with the surface,
    /// time with the lattice, and no component of the sampled surface can be missed.
    ///
    /// Samples are the values (`vol.value_at` at `Iso::below(0)`); tiles hold `iso` ∓ `width`
    /// on their side (`width`: L × a leaf's half diagonal, or 1 without a bound), as a
    /// narrow-band level set's background. A bound that is too small misses surfaces: it is the
    /// caller's promise.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when `lipschitz` is not finite and above 0, or `iso` not finite.
    pub fn from_field(vol: &(dyn Volume + Sync), iso: Iso, lipschitz: Option<f64>) -> Result<Self> {
        if let Some(l) = lipschitz {
            if !(l.is_finite() && l > 0.0) {
                return Err(Error::InvalidInput(format!("lipschitz bound {l}: must be a finite number above 0")));
            }
        }
        if !iso.value.is_finite() {
            return Err(Error::InvalidInput(format!("iso {}: must be a finite number", iso.value)));
        }
        let lattice = vol.lattice().clone();
        let dims = lattice.dims();
        let spacing = lattice.spacing();
        let sample = |p: [u32; 3]| vol.value_at(p.map(f64::from), Iso::below(0.0));
        let offset = |p: [f64; 3]| vol.value_at(p, iso) as f64;
        // A leaf's half diagonal grown by the margin, in world units.
        let leaf_reach = (0..3)
            .map(|a| ((LEAF - 1) as f64 / 2.0 + SURFACE_MARGIN as f64) * spacing[a])
            .map(|h| h * h)
            .sum::<f64>()
            .sqrt();
        let width = lipschitz.map_or(1.0, |l| l * leaf_reach);
        let side = |inside: bool| -> f32 {
            let below = (iso.inside == Inside::Below) == inside;
            (if below { iso.value - width } else { iso.value + width }) as f32
        };
        let (inside_value, outside_value) = (side(true), side(false));
        if inside_value.to_f64() == outside_value.to_f64() || !inside_value.is_finite() || !outside_value.is_finite() {
            return Err(Error::InvalidInput(format!(
                "iso {} with a band of {width}: tile values are not distinct in f32",
                iso.value
            )));
        }
        // The field's own bounds over a box, when it has them (interval arithmetic), then the
        // Lipschitz bound.
        let bounded = lipschitz.is_some() || vol.value_bounds([0; 3], dims.map(|d| d - 1), iso).is_some();
        let grid = match bounded.then(|| lipschitz.unwrap_or(f64::INFINITY)) {
            Some(l) => {
                // The side of all points of the box lo .. hi, or `None` when the bound cannot
                // tell (then split `depth` more times): uniform when the centre lies farther from
                // the iso than L × the half diagonal.
                fn side(
                    lo: [u32; 3],
                    hi: [u32; 3],
                    depth: u32,
                    test: &dyn Fn([u32; 3], [u32; 3]) -> Option<bool>,
                ) -> Option<bool> {
                    if let Some(s) = test(lo, hi) {
                        return Some(s);
                    }
                    if depth == 0 || (0..3).all(|a| hi[a] - lo[a] <= 1) {
                        return None;
                    }
                    let mid = [0, 1, 2].map(|a| lo[a] + (hi[a] - lo[a]).div_ceil(2));
                    let mut found = None;
                    for c in 0..8u32 {
                        let (mut l, mut h) = (lo, hi);
                        for a in 0..3 {
                            if c >> a & 1 == 0 {
                                h[a] = mid[a];
                            } else {
                                l[a] = mid[a];
                            }
                        }
                        if (0..3).any(|a| l[a] >= h[a]) {
                            continue;
                        }
                        match (side(l, h, depth - 1, test), found) {
                            (None, _) => return None,
                            (Some(s), Some(f)) if s != f => return None,
                            (s, _) => found = s,
                        }
                    }
                    found
                }
                let test = |lo: [u32; 3], hi: [u32; 3]| -> Option<bool> {
                    if let Some((min, max)) = vol.value_bounds(lo, hi.map(|v| v - 1), iso) {
                        if min >= 0.0 || max < 0.0 {
                            return Some(max < 0.0);
                        }
                    }
                    if !l.is_finite() {
                        return None;
                    }
                    let half = [0, 1, 2].map(|a| (hi[a] - lo[a] - 1) as f64 / 2.0);
                    let r = (0..3).map(|a| (half[a] * spacing[a]).powi(2)).sum::<f64>().sqrt();
                    let v = offset([0, 1, 2].map(|a| lo[a] as f64 + half[a]));
                    (v.abs() > l * r).then_some(v < 0.0)
                };
                let value = |inside: bool| if inside { inside_value } else { outside_value };
                // A box of points grown by the margin, clamped to the lattice.
                let grown = |o: [u32; 3], n: u32| {
                    let lo = o.map(|v| v.saturating_sub(SURFACE_MARGIN));
                    let hi = [0, 1, 2].map(|a| (o[a] + n + SURFACE_MARGIN).min(dims[a]));
                    (lo, hi)
                };
                let node = |coord: [u32; 3]| {
                    let (lo, hi) = grown(coord.map(|c| c * NODE_POINTS), NODE_POINTS);
                    if let Some(s) = side(lo, hi, 3, &test) {
                        return SparseNode::tile(value(s));
                    }
                    SparseNode::blocks(coord, dims, outside_value, &mut |o: [u32; 3], out: &mut [f32]| {
                        let (lo, hi) = grown(o, LEAF);
                        side(lo, hi, 2, &test).map(value).or_else(|| {
                            copy_block(o, dims, out, sample);
                            None
                        })
                    })
                };
                Self::build(lattice, outside_value, &node)
            }
            None => {
                // The node and a ring of one block, sampled once into a box; each block judged
                // from the box's points within the margin.
                let node = |coord: [u32; 3]| {
                    let base = coord.map(|c| c * NODE_POINTS);
                    let lo = base.map(|v| v.saturating_sub(LEAF));
                    let hi = [0, 1, 2].map(|a| (base[a] + NODE_POINTS + LEAF).min(dims[a]));
                    let d = [0, 1, 2].map(|a| (hi[a] - lo[a]) as usize);
                    let mut values = vec![0.0f32; d[0] * d[1] * d[2]];
                    for z in lo[2]..hi[2] {
                        for y in lo[1]..hi[1] {
                            let at = ((z - lo[2]) as usize * d[1] + (y - lo[1]) as usize) * d[0];
                            for x in lo[0]..hi[0] {
                                values[at + (x - lo[0]) as usize] = sample([x, y, z]);
                            }
                        }
                    }
                    let get = |p: [u32; 3]| {
                        values[((p[2] - lo[2]) as usize * d[1] + (p[1] - lo[1]) as usize) * d[0]
                            + (p[0] - lo[0]) as usize]
                    };
                    let inside = |v: f32| iso.exact_offset(v as f64) < 0.0;
                    SparseNode::blocks(coord, dims, outside_value, &mut |o: [u32; 3], out: &mut [f32]| {
                        let blo = o.map(|v| v.saturating_sub(SURFACE_MARGIN));
                        let bhi = [0, 1, 2].map(|a| (o[a] + LEAF + SURFACE_MARGIN).min(dims[a]));
                        let (mut any_in, mut any_out) = (false, false);
                        for z in blo[2]..bhi[2] {
                            for y in blo[1]..bhi[1] {
                                for x in blo[0]..bhi[0] {
                                    if inside(get([x, y, z])) {
                                        any_in = true;
                                    } else {
                                        any_out = true;
                                    }
                                }
                            }
                        }
                        match (any_in, any_out) {
                            (true, true) => {
                                copy_block(o, dims, out, get);
                                None
                            }
                            (true, false) => Some(inside_value),
                            _ => Some(outside_value),
                        }
                    })
                };
                Self::build(lattice, outside_value, &node)
            }
        };
        Ok(grid)
    }
}

/// Tiles per range of [`SparseGrid::active_ranges`] at most (along x): long enough that a walk's
/// setup is paid once for much work, short enough to spread over threads.
const RUN_TILES: u32 = 4;

impl<S: Sample> SparseGrid<S> {
    /// The cell ranges a walk at `iso` must visit to make every polygon of the grid's surface:
    /// the blocks of 8³ cells whose corners are not all on one side (judged from the bounds of
    /// the leaves and tiles their corners lie in) and, with `uniform_too` (extractors that sample
    /// off the lattice: [`Extractor::visits_uniform_cells`](crate::extract::Extractor::visits_uniform_cells)),
    /// the blocks just above them on each axis; joined in runs along x, sorted (z, y, x).
    ///
    /// A cell block can be crossed only where a leaf is among its corners' blocks, or where two
    /// tiles of opposite sides meet (files may hold that: a fog volume's tiles of 1 beside the
    /// background 0): both kinds are candidates, kept when their corners' bounds straddle the iso.
    pub fn active_ranges(&self, iso: Iso, uniform_too: bool) -> Vec<CellRange> {
        self.active_ranges_in(iso, uniform_too, Self::TILE_BLOCKS)
    }

    /// Blocks per edge of the tiles [`active_ranges`](SparseGrid::active_ranges) walks active
    /// blocks in: walking the idle cells of a tile of 64³ cells costs less than the setup of
    /// walks of its active blocks alone (sphere 1024³: 1.0 s with tiles of one block, 0.6 s with
    /// these; docs/BENCHMARKS.md §8).
    pub const TILE_BLOCKS: u32 = 8;

    /// [`active_ranges`](SparseGrid::active_ranges) with tiles of `tile_blocks`³ blocks (at least
    /// 1; the ranges are the same cells in other boxes, so the same mesh).
    pub fn active_ranges_in(&self, iso: Iso, uniform_too: bool, tile_blocks: u32) -> Vec<CellRange> {
        let dims = self.lattice().dims();
        let cells = dims.map(|d| d.saturating_sub(1));
        if cells.contains(&0) {
            return Vec::new();
        }
        let leaf_bounds = self.leaf_bounds();
        let bounds = |o: [u32; 3]| -> [f64; 2] {
            match self.block_at(o) {
                Ok(v) => [v.to_f64(); 2],
                Err(leaf) => leaf_bounds[leaf],
            }
        };
        // Candidates: every block of cells with a leaf among the blocks of its corners.
        let mut candidates: Vec<[u32; 3]> = Vec::with_capacity(self.num_leaves() * 8);
        for n in 0..self.num_leaves() {
            let o = self.leaf_origin(n);
            for d in 0..8u32 {
                let c = [0, 1, 2].map(|a| o[a].checked_sub(LEAF * (d >> a & 1)));
                if let [Some(x), Some(y), Some(z)] = c {
                    if x < cells[0] && y < cells[1] && z < cells[2] {
                        candidates.push([x, y, z]);
                    }
                }
            }
        }
        // And every block of cells between tiles of opposite sides.
        for o in self.tile_boundary_blocks(&|v: S| iso.exact_offset(v.to_f64()) < 0.0) {
            for d in 0..8u32 {
                let c = [0, 1, 2].map(|a| o[a].checked_sub(LEAF * (d >> a & 1)));
                if let [Some(x), Some(y), Some(z)] = c {
                    if x < cells[0] && y < cells[1] && z < cells[2] {
                        candidates.push([x, y, z]);
                    }
                }
            }
        }
        let order = |c: &[u32; 3]| (c[2], c[1], c[0]);
        candidates.sort_unstable_by_key(order);
        candidates.dedup();
        let crossed = |c: &[u32; 3]| {
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for d in 0..8u32 {
                let o = [0, 1, 2].map(|a| c[a] + LEAF * (d >> a & 1));
                if (0..3).any(|a| o[a] >= dims[a]) {
                    continue;
                }
                let [l, h] = bounds(o);
                let (l, h) = (iso.exact_offset(l), iso.exact_offset(h));
                lo = lo.min(l.min(h));
                hi = hi.max(l.max(h));
            }
            lo < 0.0 && hi >= 0.0
        };
        let mut active: Vec<[u32; 3]> = candidates.into_iter().filter(crossed).collect();
        if uniform_too {
            let above: Vec<[u32; 3]> = active
                .iter()
                .flat_map(|c| {
                    (0..3).map(move |a| {
                        let mut n = *c;
                        n[a] += LEAF;
                        n
                    })
                })
                .filter(|n| (0..3).all(|a| n[a] < cells[a]))
                .collect();
            active.extend(above);
            active.sort_unstable_by_key(order);
            active.dedup();
        }
        // Tiles of TILE_BLOCKS³ blocks holding an active block (walking a few idle cells costs less than
        // a walk's setup), then runs of tiles along x.
        let size = LEAF * tile_blocks.max(1);
        let mut tiles: Vec<[u32; 3]> = active.iter().map(|c| c.map(|v| v / size * size)).collect();
        tiles.dedup();
        tiles.sort_unstable_by_key(order);
        tiles.dedup();
        let mut ranges: Vec<CellRange> = Vec::new();
        for c in tiles {
            let hi = [0, 1, 2].map(|a| (c[a] + size).min(cells[a]));
            if let Some(last) = ranges.last_mut() {
                if last.lo[1] == c[1]
                    && last.lo[2] == c[2]
                    && last.hi[0] == c[0]
                    && c[0] - last.lo[0] < RUN_TILES * size
                {
                    last.hi[0] = hi[0];
                    continue;
                }
            }
            ranges.push(CellRange { lo: c, hi });
        }
        ranges
    }
}

/// A sparse grid as a volume: values from its leaves and tiles, crossings and gradients by the
/// very routines of [`GridVolume`](super::GridVolume) (the same bits on the same samples), value
/// bounds from its leaves. What walkers that visit cells one by one read (surface following).
#[derive(Debug, Clone, Copy)]
pub struct SparseVolume<'g, S> {
    grid: &'g SparseGrid<S>,
}

impl<'g, S: Sample> SparseVolume<'g, S> {
    /// Wraps a sparse grid.
    pub fn new(grid: &'g SparseGrid<S>) -> Self {
        SparseVolume { grid }
    }

    #[inline]
    fn at(&self, p: [u32; 3]) -> f64 {
        self.grid.get(p).to_f64()
    }
}

impl<S: Sample> Volume for SparseVolume<'_, S> {
    #[inline]
    fn lattice(&self) -> &crate::grid::Lattice {
        self.grid.lattice()
    }
    fn fill_slab(&self, k: u32, iso: Iso, out: &mut [f32]) {
        let [nx, ny, _] = self.grid.lattice().dims();
        let mut row = Vec::new();
        self.grid.fill_box([0, 0, k], [nx, ny, k + 1], &mut row);
        for (o, v) in out.iter_mut().zip(row) {
            *o = iso.offset(v.to_f64());
        }
    }
    #[inline]
    fn crossing(&self, e: crate::cube::EdgeKey, d0: f32, d1: f32, iso: Iso) -> f32 {
        super::grid_crossing(e, d0, d1, iso, &|p| self.at(p))
    }
    fn segment_crossing(&self, p0: [f64; 3], p1: [f64; 3], d0: f32, d1: f32, iso: Iso) -> f32 {
        super::grid_segment_crossing(self.grid.lattice().dims(), [p0, p1], d0, d1, iso, &|p| self.at(p))
    }
    fn gradient(&self, e: crate::cube::EdgeKey, t: f32) -> crate::math::Vec3 {
        super::edge_gradient(self.grid.lattice(), e, t, &|p| self.at(p))
    }
    fn value_at(&self, p: [f64; 3], iso: Iso) -> f32 {
        iso.offset(super::trilinear_value(self.grid.lattice().dims(), p, &|q| self.at(q)))
    }
    #[inline]
    fn value_at_point(&self, p: [u32; 3], iso: Iso) -> f32 {
        iso.offset(self.at(p))
    }
    fn gradient_at(&self, p: [f64; 3]) -> crate::math::Vec3 {
        super::point_gradient_at(self.grid.lattice(), p, &|q| self.at(q))
    }
    fn bounded_by_corners(&self) -> bool {
        true
    }
}
