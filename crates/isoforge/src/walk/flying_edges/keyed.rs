//! Extractors whose output is not known before processing: fixed groups of cell layers walked in
//! parallel, each into its own mesh with the keys of the vertices it shares, stitched by key.
//!
//! ```text
//!   group g: cell layers k0 .. k1   (layers per group fixed by the lattice's size, never by the
//!                                    thread count, so the output is the same for every count:
//!                                    about GROUPS groups, at least MIN_LAYERS layers each)
//!   plane k0 is shared with group g − 1, plane k1 with group g + 1: vertices there are made by
//!   both and kept once, where they first occur (walk::stitch)
//! ```

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

use super::bits::{case_at, cell_rows, for_each_case, mark_active, Bits};
use super::{map_tasks, Cells, Passes, PointBox};
use crate::cube::CellRange;
use crate::error::Result;
use crate::extract::Extractor;
use crate::grid::Sample;
use crate::mesh::{KeyRecord, MeshBuilder, Normals};
use crate::volume::{Iso, SampleSlabs};
use crate::walk::cached::{CachedCell, LayerCaches};
use crate::walk::stitch::{stitch_parts, KeyedMesh};
use crate::walk::{wants_cell, Progress, WalkStats};

/// Groups of cell layers: about this many, whatever the thread count (enough to balance a few
/// threads; each shared plane is walked twice and stitched, so not more).
const GROUPS: u32 = 32;
/// Fewest cell layers in a group.
const MIN_LAYERS: u32 = 8;

impl<X: Extractor + Sync> Passes<'_, Cells<'_>, X> {
    /// Walks the range in layer groups and stitches their meshes into `out`.
    pub(super) fn keyed(
        &self,
        bits: &Bits,
        out: &mut MeshBuilder,
        progress: Option<&dyn Progress>,
    ) -> Result<WalkStats> {
        let r = self.range;
        let layers = r.hi[2] - r.lo[2];
        let per = layers.div_ceil(GROUPS).max(MIN_LAYERS);
        let groups: Vec<CellRange> =
            (r.lo[2]..r.hi[2]).step_by(per as usize).map(|k0| r.layers(k0, k0 + per)).collect();
        let done = AtomicU64::new(0);
        let total = groups.len() as u64;
        let normals = if self.normals { Normals::Gradient } else { Normals::None };
        // Caches go back to a pool after a group and serve the next one without reallocation
        // (their slots carry a generation; nothing a group writes is seen by another).
        let pool = Mutex::new(Vec::<LayerCaches>::new());
        let parts = map_tasks(groups, &|g| {
            // Parts keep the keys stitching needs, or all of them when the walk asks for all.
            let record = if self.record == KeyRecord::All { KeyRecord::All } else { KeyRecord::Boundary(g) };
            let mut b = MeshBuilder::new(normals).with_keys(record);
            b.set_reverse_winding(self.reverse);
            let mut caches = pool.lock().ok().and_then(|mut p| p.pop()).unwrap_or_default();
            let stats = self.walk_group(bits, &g, &mut caches, &mut b);
            if let Ok(mut p) = pool.lock() {
                p.push(caches);
            }
            if let Some(p) = progress {
                p.advance(done.fetch_add(1, Ordering::Relaxed) + 1, total);
            }
            Ok::<_, crate::Error>((KeyedMesh::from_builder(b)?, stats))
        });
        let (stitched, stats) = stitch_parts(parts)?;
        let keys = stitched.keys.into_iter().filter(|(_, k)| self.records(k)).collect();
        out.set_assembled(stitched.mesh, keys);
        Ok(stats)
    }

    /// Walks the cells of group `g` (and, for placing extractors, places the cells just before
    /// it) into `out`.
    pub(super) fn walk_group(
        &self,
        bits: &Bits,
        g: &CellRange,
        caches: &mut LayerCaches,
        out: &mut MeshBuilder,
    ) -> WalkStats {
        let bx = &self.bx;
        let places = X::PLACES_VERTICES;
        let first_k = if places { g.lo[2].saturating_sub(1).max(bx.lo[2]) } else { g.lo[2] };
        caches.reset([bx.lo[0], bx.lo[1]], bx.dims[0], bx.dims[1], first_k, places);
        let mut stats = WalkStats::default();
        for gk in first_k..g.hi[2] {
            stats.add(self.walk_layer(bits, gk, gk >= g.lo[2], caches, out));
            caches.advance(places);
        }
        stats
    }

    /// Walks cell layer `gk` (global) with active cells found from the bits; its cells are
    /// processed when `process` is set (otherwise only placed: the layer before a group).
    pub(super) fn walk_layer(
        &self,
        bits: &Bits,
        gk: u32,
        process: bool,
        caches: &mut LayerCaches,
        out: &mut MeshBuilder,
    ) -> WalkStats {
        let bx = &self.bx;
        let [nx, ny, _] = bx.dims;
        let places = X::PLACES_VERTICES;
        let uniform_too = self.x.visits_uniform_cells();
        // Extractors that sample cell centres (those that visit uniform cells) read each visited
        // cell's and its lower neighbours' centres: from the samples when the volume allows.
        let centres = uniform_too && self.vol.centres_from_samples();
        let mut stats = WalkStats::default();
        let mut active = vec![0u64; bits.words];
        let k = (gk - bx.lo[2]) as usize;
        // Extractors that sample off the lattice need every cell whose octahedra (or the like)
        // can hold a crossing. On a volume bounded by its corners that is a cell crossed by the
        // surface or one just above such a cell on some axis. The cells below must be known: a
        // layer below missing from the bits (streaming) or lying outside the box (a chunk's first
        // layer, row or column) makes every cell there a candidate.
        let below_known = if k == 0 { bx.lo[2] == 0 } else { bits.row0 <= (k - 1) * ny };
        let neighbours = uniform_too && self.vol.bounded_by_corners() && below_known;
        let mut visit = vec![0u64; bits.words];
        let mut below = vec![0u64; bits.words];
        let mut before = vec![0u64; bits.words];
        // Box-local first cell of the range (the box starts one cell early for placing extractors).
        let lo = [0, 1, 2].map(|a| (self.range.lo[a] - bx.lo[a]) as usize);
        for j in 0..ny - 1 {
            let r = k * ny + j;
            let rows = cell_rows(bits, r, ny);
            let (mut outside, mut inside) = mark_active(rows, nx - 1, &mut active);
            let row_in = process && j >= lo[1];
            if row_in {
                // Cells before the range on x (placing extractors' halo) are not counted.
                for i in 0..lo[0] {
                    if active[i / 64] >> (i % 64) & 1 == 0 {
                        if rows[0][i / 64] >> (i % 64) & 1 == 1 {
                            inside -= 1;
                        } else {
                            outside -= 1;
                        }
                    }
                }
                stats.add(WalkStats { cells: (nx - 1 - lo[0]) as u64, cells_outside: outside, cells_inside: inside });
            }
            let mut visit_cell = |i: usize, case: u8| {
                if !wants_cell(self.x, case) {
                    return;
                }
                let l = [i, j, k];
                if centres {
                    self.keep_centres(l, caches);
                }
                let d = self.vol.cell_values(bx, self.iso, l);
                let mut cell = CachedCell::new(bx.global(l), d, case, self.vol, self.iso, caches, out);
                if places {
                    self.x.place(&mut cell);
                }
                if row_in && i >= lo[0] {
                    self.x.process(&mut cell);
                }
            };
            if neighbours {
                // Active cells, and those above an active one along x, y or z.
                let words = active.len();
                for w in 0..words {
                    let carry = if w > 0 { active[w - 1] >> 63 } else { 0 };
                    visit[w] = active[w] | (active[w] << 1) | carry;
                }
                visit[0] |= u64::from(bx.lo[0] > 0);
                if j == 0 && bx.lo[1] > 0 {
                    visit.fill(!0);
                } else if j > 0 {
                    mark_active(cell_rows(bits, r - 1, ny), nx - 1, &mut before);
                    visit.iter_mut().zip(&before).for_each(|(v, b)| *v |= b);
                }
                if k > 0 {
                    mark_active(cell_rows(bits, r - ny, ny), nx - 1, &mut below);
                    visit.iter_mut().zip(&below).for_each(|(v, b)| *v |= b);
                }
                super::bits::mask_tail(&mut visit, nx - 1);
                for_each_case(&rows, &visit, &mut visit_cell);
            } else if uniform_too {
                for i in 0..nx - 1 {
                    visit_cell(i, case_at(&rows, i));
                }
            } else {
                for_each_case(&rows, &active, &mut visit_cell);
            }
        }
        stats
    }

    /// Keeps in `caches` the centre values of box cell `l` and of the box cells below it on each
    /// axis (what the body-centred split reads), computed from the samples.
    #[inline]
    fn keep_centres(&self, l: [usize; 3], caches: &mut LayerCaches) {
        let bx = &self.bx;
        caches.keep_centre(bx.global(l), || self.vol.centre_value(bx, self.iso, l));
        for a in 0..3 {
            if l[a] > 0 {
                let mut n = l;
                n[a] -= 1;
                caches.keep_centre(bx.global(n), || self.vol.centre_value(bx, self.iso, n));
            }
        }
    }
}

/// The offset value at the centre of box-local cell `[i, j, k]`, from its corners' samples with
/// the arithmetic of the trilinear interpolant (`crate::grid::blend`: weight 1/8 each, summed in
/// `f64` in corner order): the bits `Volume::value_at` gives there for volumes whose
/// [`centres_from_samples`](SampleSlabs::centres_from_samples) holds.
#[inline]
pub(super) fn centre_value<V: SampleSlabs>(vol: &V, bx: &PointBox, iso: Iso, [i, j, k]: [usize; 3]) -> f32 {
    let z = bx.lo[2] + k as u32;
    centre_in(vol.slab(z), vol.slab(z + 1), bx.in_slab(i, j), bx.in_slab(i, j + 1), iso)
}

/// [`centre_value`] of the cell whose corners are samples `a`, `a + 1`, `b`, `b + 1` of slabs
/// `s0` (its lower z) and `s1`, for walkers that hold the slabs.
#[inline(always)]
pub(super) fn centre_in<S: Sample>(s0: &[S], s1: &[S], a: usize, b: usize, iso: Iso) -> f32 {
    let (a0, b0, a1, b1) = (&s0[a..a + 2], &s0[b..b + 2], &s1[a..a + 2], &s1[b..b + 2]);
    let v = [a0[0], a0[1], b0[0], b0[1], a1[0], a1[1], b1[0], b1[1]].map(|s| s.to_f64());
    let acc = if S::DTYPE.is_float() {
        v.iter().fold(0.0f64, |acc, &v| acc + 0.125 * v)
    } else {
        // Integers (at most 32 bits): every eighth and every partial sum is exact in f64, so
        // summing first, in any order, and scaling once gives the same bits.
        ((v[0] + v[1]) + (v[2] + v[3]) + ((v[4] + v[5]) + (v[6] + v[7]))) * 0.125
    };
    iso.offset(acc)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{DenseGrid, Lattice};
    use crate::volume::{GridVolume, Volume};

    /// Random samples of type `S` on `dims` points.
    fn grid<S: Sample>(dims: [u32; 3], f: impl Fn(u32) -> S) -> DenseGrid<S> {
        let mut h = 0x9e37_79b9_u32;
        DenseGrid::from_fn(Lattice::new(dims).unwrap(), |_| {
            h ^= h << 13;
            h ^= h >> 17;
            h ^= h << 5;
            f(h)
        })
    }

    /// `centre_value` gives `value_at`'s bits at every cell centre, on whole grids and windows.
    fn check<S: Sample>(g: &DenseGrid<S>, iso: Iso) {
        let dims = g.lattice().dims();
        let whole = GridVolume::new(g);
        // A window of the samples with points 1.. on each axis, in the same global lattice.
        let sub = DenseGrid::from_fn(Lattice::new(dims.map(|d| d - 1)).unwrap(), |p| g.get(p.map(|x| x + 1)));
        let window = GridVolume::window(&sub, [1; 3], g.lattice().clone()).unwrap();
        let mut checked = 0;
        for (vol, first) in [(&whole, [0u32; 3]), (&window, [1; 3])] {
            let cells = CellRange { lo: first, hi: dims.map(|d| d - 1) };
            let bx = PointBox::of(vol, first, &cells).unwrap();
            for k in 0..bx.dims[2] - 1 {
                for j in 0..bx.dims[1] - 1 {
                    for i in 0..bx.dims[0] - 1 {
                        let c = bx.global([i, j, k]);
                        let want = vol.value_at(c.map(|x| x as f64 + 0.5), iso);
                        let got = centre_value(vol, &bx, iso, [i, j, k]);
                        assert_eq!(got.to_bits(), want.to_bits(), "cell {c:?} from {first:?}");
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > 0);
    }

    #[test]
    fn centres_from_samples_are_those_of_value_at() {
        let floats = grid([7, 6, 5], |h| (h % 100_000) as f32 / 77.0 - 400.0);
        check(&floats, Iso::below(150.3));
        check(&floats, Iso::above(-3.0));
        let shorts = grid([6, 7, 5], |h| (h % 4096) as i16 - 1024);
        check(&shorts, Iso::below(988.37));
        check(&shorts, Iso::above(0.5));
        assert!(GridVolume::new(&floats).centres_from_samples());
    }
}
