use super::cached::{CachedCell, LayerCaches};
use super::{range_of, wants_cell, Progress, WalkStats, Walker};
use crate::cube::{case_of, CellRange};
use crate::error::Result;
use crate::extract::Extractor;
use crate::mesh::MeshBuilder;
use crate::volume::{Iso, Volume};

/// Walks z-slab by z-slab keeping O(nx·ny) state: the values of slabs k and k + 1, and the vertex
/// caches of the planes around cell layer k (`LayerCaches`). Every value is read once and
/// every vertex is created once, by the first cell that asks for it. Serial; any [`Volume`].
///
/// A walk covers a [`CellRange`] (the whole lattice unless given one). Extractors that place
/// vertices also get the cells just before the range on each axis placed (not processed), so
/// polygons can refer to them. Boxes of 8 × 8 cells whose [`Volume::value_bounds`] lie on one
/// side of the iso are skipped.
#[derive(Default)]
pub struct SlabWalker<'p> {
    below: Vec<f32>,
    above: Vec<f32>,
    caches: LayerCaches,
    range: Option<CellRange>,
    progress: Option<&'p dyn Progress>,
}

/// Cells per side of the boxes tested against [`Volume::value_bounds`].
const SKIP_TILE: u32 = 8;

impl<'p> SlabWalker<'p> {
    /// A walker with empty caches (sized on the first walk, then reused).
    pub fn new() -> Self {
        SlabWalker::default()
    }

    /// Walks only the cells of `range` (global lattice indices).
    pub fn with_range(mut self, range: CellRange) -> Self {
        self.range = Some(range);
        self
    }

    /// Reports progress once per slab.
    pub fn with_progress(mut self, progress: &'p dyn Progress) -> Self {
        self.progress = Some(progress);
        self
    }
}

impl<V: Volume + ?Sized> Walker<V> for SlabWalker<'_> {
    fn walk<X: Extractor + Sync>(&mut self, vol: &V, iso: Iso, x: &X, out: &mut MeshBuilder) -> Result<WalkStats> {
        let lattice = vol.lattice();
        let dims = lattice.dims();
        let range = range_of(self.range, dims);
        let mut stats = WalkStats::default();
        if range.is_empty() {
            return Ok(stats);
        }
        out.set_reverse_winding(lattice.is_mirrored());
        let places = X::PLACES_VERTICES;
        // Cells walked: the range, and for placing extractors the layer before it on each axis.
        let first = if places { range.lo.map(|v| v.saturating_sub(1)) } else { range.lo };
        let [nx, ny, _] = dims.map(|d| d as usize);
        let (w, h) = ((range.hi[0] - first[0] + 1) as usize, (range.hi[1] - first[1] + 1) as usize);
        self.caches.reset([first[0], first[1]], w, h, first[2], places);
        for buf in [&mut self.below, &mut self.above] {
            buf.clear();
            buf.resize(nx * ny, 0.0);
        }
        vol.fill_slab(first[2], iso, &mut self.below);
        let uniform_too = x.visits_uniform_cells();
        let layers = range.hi[2] - first[2];
        for k in first[2]..range.hi[2] {
            vol.fill_slab(k + 1, iso, &mut self.above);
            let layer_in_range = k >= range.lo[2];
            for tj in (first[1]..range.hi[1]).step_by(SKIP_TILE as usize) {
                for ti in (first[0]..range.hi[0]).step_by(SKIP_TILE as usize) {
                    let (i1, j1) = ((ti + SKIP_TILE).min(range.hi[0]), (tj + SKIP_TILE).min(range.hi[1]));
                    // Body-centred extractors also read the centres across the lower faces.
                    let grow = u32::from(uniform_too);
                    let lo = [ti.saturating_sub(grow), tj.saturating_sub(grow), k.saturating_sub(grow)];
                    let hi =
                        [(i1 + grow).min(dims[0] - 1), (j1 + grow).min(dims[1] - 1), (k + 1 + grow).min(dims[2] - 1)];
                    if let Some((min, max)) = vol.value_bounds(lo, hi, iso) {
                        if max < 0.0 || min >= 0.0 {
                            if layer_in_range {
                                let tile = CellRange {
                                    lo: [ti.max(range.lo[0]), tj.max(range.lo[1]), k],
                                    hi: [i1, j1, k + 1],
                                };
                                let n = tile.num_cells();
                                stats.cells += n;
                                if max < 0.0 {
                                    stats.cells_inside += n;
                                } else {
                                    stats.cells_outside += n;
                                }
                            }
                            continue;
                        }
                    }
                    for j in tj..j1 {
                        let (r0, r1) = (j as usize * nx, (j as usize + 1) * nx);
                        let (b0, b1) = (&self.below[r0..r0 + nx], &self.below[r1..r1 + nx]);
                        let (a0, a1) = (&self.above[r0..r0 + nx], &self.above[r1..r1 + nx]);
                        for i in ti..i1 {
                            let i = i as usize;
                            let d = [b0[i], b0[i + 1], b1[i], b1[i + 1], a0[i], a0[i + 1], a1[i], a1[i + 1]];
                            let case = case_of(&d);
                            let ijk = [i as u32, j, k];
                            let in_range = layer_in_range && j >= range.lo[1] && ijk[0] >= range.lo[0];
                            if in_range {
                                stats.cells += 1;
                                match case {
                                    0 => stats.cells_outside += 1,
                                    255 => stats.cells_inside += 1,
                                    _ => {}
                                }
                            }
                            if !wants_cell(x, case) {
                                continue;
                            }
                            let mut cell = CachedCell::new(ijk, d, case, vol, iso, &mut self.caches, out);
                            if places {
                                x.place(&mut cell);
                            }
                            if in_range {
                                x.process(&mut cell);
                            }
                        }
                    }
                }
            }
            // The top slab becomes the bottom one.
            std::mem::swap(&mut self.below, &mut self.above);
            self.caches.advance(places);
            if let Some(p) = self.progress {
                p.advance((k - first[2]) as u64 + 1, layers as u64);
            }
        }
        Ok(stats)
    }
}
