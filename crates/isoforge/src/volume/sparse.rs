//! Sparse grids made for an iso: only the blocks of 8³ points near the surface are sampled and
//! stored ([`SparseGrid::from_dense`], [`SparseGrid::from_field`]).

use crate::cube::CellRange;
use crate::error::{Error, Result};
use crate::grid::sparse::{copy_block, in_leaf, SparseNode, LEAF, LEAF_SAMPLES, NODE, NODE_POINTS, SURFACE_MARGIN};
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
    /// surface may pass. A block of 8³ points becomes a leaf exactly when its points within
    /// [`SURFACE_MARGIN`] are not all on one side (as [`from_dense`](SparseGrid::from_dense)
    /// judges), a tile of its side otherwise.
    ///
    /// Which points are sampled: with a bound — the field's interval bounds
    /// ([`Volume::value_bounds`], a field's `Field::bounds`) or `lipschitz` = L on how fast the
    /// values change (|f(p) − f(q)| ≤ L·|p − q| in world units; 1 for a true signed distance: a box
    /// whose centre lies farther from the iso than L × its half diagonal is on one side) — a node of
    /// 128³ points grown by the margin that the bound proves on one side is a tile and nothing of
    /// it is sampled; in the other nodes each block (and each ring block's layers within the margin)
    /// is proven on a side by the bound, or sampled, once, in one [`Volume::fill_values`] call. A
    /// loose bound then costs samples, not memory: the blocks it cannot decide are decided by their
    /// samples, and stored only where those straddle the iso. Without a bound every point is
    /// sampled (time grows with the lattice, memory still with the surface).
    ///
    /// No component of the sampled surface can be missed: a crossed cell's corners lie within the
    /// margin of every block a walk reads around it, and each of those corners' sides is known
    /// exactly — proven by the bound (which decides only blocks that hold no crossing) or read from
    /// its sample — so those blocks straddle and are leaves: the bound decides empty blocks, the
    /// samples only decide among the others.
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
        // Lipschitz bound: the side of all points of a box, or `None` when they cannot tell.
        let has_bounds = vol.value_bounds([0; 3], dims.map(|d| d - 1), iso).is_some();
        let bounded = lipschitz.is_some() || has_bounds;
        let test = |lo: [u32; 3], hi: [u32; 3]| -> Option<bool> {
            // The Lipschitz bound first (one value), then the interval bounds.
            if let Some(l) = lipschitz {
                let half = [0, 1, 2].map(|a| (hi[a] - lo[a] - 1) as f64 / 2.0);
                let r = (0..3).map(|a| (half[a] * spacing[a]).powi(2)).sum::<f64>().sqrt();
                let v = offset([0, 1, 2].map(|a| lo[a] as f64 + half[a]));
                if v.abs() > l * r {
                    return Some(v < 0.0);
                }
            }
            match has_bounds.then(|| vol.value_bounds(lo, hi.map(|v| v - 1), iso)).flatten() {
                Some((min, max)) if min >= 0.0 || max < 0.0 => Some(max < 0.0),
                _ => None,
            }
        };
        let test: Option<SideTest<'_>> = bounded.then_some(&test);
        let value = |inside: bool| if inside { inside_value } else { outside_value };
        let node = |coord: [u32; 3]| {
            let base = coord.map(|c| c * NODE_POINTS);
            if let Some(test) = test {
                // The whole node and its margin proven on one side: a tile, nothing sampled.
                let lo = base.map(|v| v.saturating_sub(SURFACE_MARGIN));
                let hi = [0, 1, 2].map(|a| (base[a] + NODE_POINTS + SURFACE_MARGIN).min(dims[a]));
                if let Some(s) = bound_side(lo, hi, 3, test) {
                    return SparseNode::tile(value(s));
                }
            }
            NODE_SCRATCH.with(|scratch| {
                let scratch = &mut *scratch.borrow_mut();
                scratch.status.clear();
                scratch.status.resize(BOX_BLOCKS.pow(3), UNKNOWN);
                scratch.pool.clear();
                let mut judge = Judge { vol, iso, dims, base, test, fill: outside_value, scratch };
                SparseNode::blocks(coord, dims, outside_value, &mut |o: [u32; 3], out: &mut [f32]| {
                    judge.block(o, out).map(value)
                })
            })
        };
        Ok(Self::build(lattice, outside_value, &node))
    }
}

/// A bound's verdict on the points of a box `lo .. hi`: their side, or `None` when it cannot tell.
type SideTest<'a> = &'a (dyn Fn([u32; 3], [u32; 3]) -> Option<bool> + Sync);

/// Blocks per edge of the box [`Judge`] keeps a status for: a node's 16 and a ring of one.
const BOX_BLOCKS: usize = (NODE + 2) as usize;
/// A box block's status before it is needed.
const UNKNOWN: u32 = u32::MAX;
/// A box block whose points the bound proves inside.
const PROVEN_INSIDE: u32 = u32::MAX - 1;
/// A box block whose points the bound proves outside.
const PROVEN_OUTSIDE: u32 = u32::MAX - 2;

/// What [`Judge`] reuses from node to node on a thread (no fresh pages per node).
#[derive(Default)]
struct NodeScratch {
    /// Per block of the node's box: [`UNKNOWN`], proven on a side, or its slot in `pool`.
    status: Vec<u32>,
    /// Sampled blocks, [`LEAF_SAMPLES`] each (8³ layout, x fastest).
    pool: Vec<f32>,
    /// One box of values as [`Volume::fill_values`] writes them.
    rows: Vec<f32>,
}

thread_local! {
    static NODE_SCRATCH: std::cell::RefCell<NodeScratch> = std::cell::RefCell::new(NodeScratch::default());
}

/// The side of all points of the box `lo .. hi` (half-open) by the bound `test`, or `None` when
/// it cannot tell even after splitting the box `depth` more times.
fn bound_side(
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
        match (bound_side(l, h, depth - 1, test), found) {
            (None, _) => return None,
            (Some(s), Some(f)) if s != f => return None,
            (s, _) => found = s,
        }
    }
    found
}

/// Decides the blocks of one node of [`SparseGrid::from_field`]: a block is a leaf exactly when
/// its points within [`SURFACE_MARGIN`] are not all on one side. Each block of the node and of a
/// ring of one block around it is, once and only when a judgement needs it, either proven on one
/// side by the bound (never sampled) or sampled where judgements read it (the whole block inside
/// the node, the margin's layers in the ring).
struct Judge<'a> {
    vol: &'a (dyn Volume + Sync),
    iso: Iso,
    dims: [u32; 3],
    /// The node's first point.
    base: [u32; 3],
    test: Option<SideTest<'a>>,
    /// The value of points past the lattice in a leaf.
    fill: f32,
    scratch: &'a mut NodeScratch,
}

impl Judge<'_> {
    /// The status of the block at `b` (see [`NodeScratch::status`]), deciding it when unknown.
    fn status(&mut self, b: [u32; 3]) -> u32 {
        let i = [0, 1, 2].map(|a| (b[a] / LEAF + 1 - self.base[a] / LEAF) as usize);
        let at = (i[2] * BOX_BLOCKS + i[1]) * BOX_BLOCKS + i[0];
        if self.scratch.status[at] != UNKNOWN {
            return self.scratch.status[at];
        }
        // The points of the block judgements of this node read: within the margin of the node.
        let lo = [0, 1, 2].map(|a| b[a].max(self.base[a].saturating_sub(SURFACE_MARGIN)));
        let hi = [0, 1, 2].map(|a| (b[a] + LEAF).min(self.base[a] + NODE_POINTS + SURFACE_MARGIN).min(self.dims[a]));
        let proven = self.test.and_then(|t| bound_side(lo, hi, 2, t));
        let st = match proven {
            Some(true) => PROVEN_INSIDE,
            Some(false) => PROVEN_OUTSIDE,
            None => {
                let slot = self.scratch.pool.len() / LEAF_SAMPLES;
                self.scratch.pool.resize(self.scratch.pool.len() + LEAF_SAMPLES, self.fill);
                let NodeScratch { pool, rows, .. } = &mut *self.scratch;
                sample_block(self.vol, b, lo, hi, &mut pool[slot * LEAF_SAMPLES..], rows);
                slot as u32
            }
        };
        self.scratch.status[at] = st;
        st
    }

    /// The block at `o` (inside the node): `Some(side)` when its points within the margin are
    /// all on one side, else `None` after writing its samples into `out`.
    fn block(&mut self, o: [u32; 3], out: &mut [f32]) -> Option<bool> {
        let glo = o.map(|v| v.saturating_sub(SURFACE_MARGIN));
        let ghi = [0, 1, 2].map(|a| (o[a] + LEAF + SURFACE_MARGIN).min(self.dims[a]));
        let (mut any_in, mut any_out) = (false, false);
        let first = glo.map(|v| v / LEAF * LEAF);
        'scan: for bz in (first[2]..ghi[2]).step_by(LEAF as usize) {
            for by in (first[1]..ghi[1]).step_by(LEAF as usize) {
                for bx in (first[0]..ghi[0]).step_by(LEAF as usize) {
                    let b = [bx, by, bz];
                    match self.status(b) {
                        PROVEN_INSIDE => any_in = true,
                        PROVEN_OUTSIDE => any_out = true,
                        slot => {
                            let s = [0, 1, 2].map(|a| b[a].max(glo[a]));
                            let e = [0, 1, 2].map(|a| (b[a] + LEAF).min(ghi[a]));
                            let values = &self.scratch.pool[slot as usize * LEAF_SAMPLES..][..LEAF_SAMPLES];
                            for z in s[2]..e[2] {
                                for y in s[1]..e[1] {
                                    let at = in_leaf([s[0], y, z]);
                                    for &v in &values[at..at + (e[0] - s[0]) as usize] {
                                        if self.iso.exact_offset(v as f64) < 0.0 {
                                            any_in = true;
                                        } else {
                                            any_out = true;
                                        }
                                    }
                                }
                            }
                        }
                    }
                    if any_in && any_out {
                        break 'scan;
                    }
                }
            }
        }
        if !(any_in && any_out) {
            return Some(any_in);
        }
        match self.status(o) {
            PROVEN_INSIDE | PROVEN_OUTSIDE => {
                // Proven on one side itself, beside a crossing: its samples are needed all the same.
                let hi = [0, 1, 2].map(|a| (o[a] + LEAF).min(self.dims[a]));
                sample_block(self.vol, o, o, hi, out, &mut self.scratch.rows);
            }
            slot => out.copy_from_slice(&self.scratch.pool[slot as usize * LEAF_SAMPLES..][..LEAF_SAMPLES]),
        }
        None
    }
}

/// The values of the points `lo .. hi` of the block at `b` into `out` (the block's 8³ layout),
/// through one [`Volume::fill_values`] call.
fn sample_block(
    vol: &(dyn Volume + Sync),
    b: [u32; 3],
    lo: [u32; 3],
    hi: [u32; 3],
    out: &mut [f32],
    rows: &mut Vec<f32>,
) {
    let d = [0, 1, 2].map(|a| (hi[a] - lo[a]) as usize);
    rows.resize(d[0] * d[1] * d[2], 0.0);
    vol.fill_values(lo, hi, Iso::below(0.0), rows);
    for (r, row) in rows.chunks_exact(d[0]).enumerate() {
        let (y, z) = (lo[1] + (r % d[1]) as u32, lo[2] + (r / d[1]) as u32);
        let at = in_leaf([lo[0] - b[0], y - b[1], z - b[2]]);
        out[at..at + d[0]].copy_from_slice(row);
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
    /// The box's samples copied leaf row by leaf row ([`SparseGrid::fill_box`]), then offset.
    fn fill_values(&self, lo: [u32; 3], hi: [u32; 3], iso: Iso, out: &mut [f32]) {
        let mut rows = Vec::new();
        self.grid.fill_box(lo, hi, &mut rows);
        for (o, v) in out.iter_mut().zip(rows) {
            *o = iso.offset(v.to_f64());
        }
    }
    fn gradient_at(&self, p: [f64; 3]) -> crate::math::Vec3 {
        super::point_gradient_at(self.grid.lattice(), p, &|q| self.at(q))
    }
    fn bounded_by_corners(&self) -> bool {
        true
    }
}
