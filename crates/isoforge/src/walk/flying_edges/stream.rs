//! The walker over a [`SlabSource`]: the same passes on a window sliding up the volume.
//!
//! ```text
//!   samples  ring of 5 slabs: k − 2, k − 1 (gradients, also at body-centred vertices of the
//!            layer below), k, k + 1, k + 2 (the next plane's counts)
//!   bits     planes k, k + 1, k + 2
//!   counts   planes k, k + 1 (their running sums continue from the first vertex of plane k)
//!   step k   count plane k + 1 → fill plane k → hand its batch to the sink → slide, read k + 3
//! ```
//! Extractors without counts walk the window layer by layer with the same caches as a
//! [`SlabWalker`](crate::walk::SlabWalker), handing each layer's new vertices and polygons on.

use super::bits::Bits;
use super::count::CaseCounts;
use super::families::Walked;
use super::fill::{RowTable, SlabSlots};
use super::{classify, Cells, FlyingEdgesWalker, Passes, Paths, PointBox};
use crate::cube::{CellRange, EdgeKey};
use crate::error::{Error, Result};
use crate::extract::Extractor;
use crate::grid::{Lattice, Sample};
use crate::mesh::{ExternalError, KeyRecord, MeshBuilder, MeshSink, Normals, OwnedBatch};
use crate::volume::{Iso, SampleSlabs, SlabSource, Volume};
use crate::walk::cached::LayerCaches;
use crate::walk::WalkStats;

/// Counts of a streamed walk.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StreamStats {
    /// Cell counts, as for an in-memory walk.
    pub walk: WalkStats,
    /// Vertices pushed.
    pub vertices: u64,
    /// Triangles pushed.
    pub triangles: u64,
    /// Quads pushed.
    pub quads: u64,
}

/// Slabs in a streamed volume's window.
const RING: usize = 5;

/// Five consecutive slabs k − 2 … k + 2 of a streamed volume, slab k in slot k mod 5; indices
/// are global, so crossings and normals are computed exactly as on the whole grid.
pub(super) struct SlabRing<S> {
    slabs: [Vec<S>; RING],
    slab_len: usize,
    lattice: Lattice,
}

impl<S: Sample> SlabRing<S> {
    #[inline(always)]
    fn get(&self, p: [u32; 3]) -> f64 {
        let [nx, _, _] = self.lattice.dims();
        self.slabs[p[2] as usize % RING][p[1] as usize * nx as usize + p[0] as usize].to_f64()
    }
}

impl<S: Sample> Volume for SlabRing<S> {
    fn lattice(&self) -> &Lattice {
        &self.lattice
    }
    fn fill_slab(&self, k: u32, iso: Iso, out: &mut [f32]) {
        for (o, v) in out.iter_mut().zip(&self.slabs[k as usize % RING]) {
            *o = iso.offset(v.to_f64());
        }
    }
    #[inline]
    fn crossing(&self, e: EdgeKey, d0: f32, d1: f32, iso: Iso) -> f32 {
        crate::volume::grid_crossing(e, d0, d1, iso, &|p| self.get(p))
    }
    #[inline]
    fn segment_crossing(&self, p0: [f64; 3], p1: [f64; 3], d0: f32, d1: f32, iso: Iso) -> f32 {
        crate::volume::grid_segment_crossing(self.lattice.dims(), [p0, p1], d0, d1, iso, &|p| self.get(p))
    }
    fn gradient(&self, e: EdgeKey, t: f32) -> glam::Vec3 {
        crate::volume::edge_gradient(&self.lattice, e, t, &|p| self.get(p))
    }
    fn value_at(&self, p: [f64; 3], iso: Iso) -> f32 {
        iso.offset(crate::volume::trilinear_value(self.lattice.dims(), p, &|q| self.get(q)))
    }
    fn gradient_at(&self, p: [f64; 3]) -> glam::Vec3 {
        crate::volume::point_gradient_at(&self.lattice, p, &|q| self.get(q))
    }
    fn bounded_by_corners(&self) -> bool {
        true
    }
}

impl<S: Sample> SampleSlabs for SlabRing<S> {
    type Sample = S;
    fn sample_box(&self) -> ([u32; 3], [u32; 3]) {
        ([0; 3], self.lattice.dims())
    }
    #[inline]
    fn slab(&self, k: u32) -> &[S] {
        &self.slabs[k as usize % RING][..self.slab_len]
    }
    fn centres_from_samples(&self) -> bool {
        true
    }
}

/// What the passes of a streamed walk share, but the window.
pub(super) struct Ctx<'a, X> {
    x: &'a X,
    iso: Iso,
    pub(super) bx: PointBox,
    table: &'a CaseCounts,
    walked: Walked,
    crossed: &'a [[u32; 2]; 256],
    range: CellRange,
    pub(super) normals: bool,
}

impl<'a, X> Ctx<'a, X> {
    /// This context without its extractor (see `Passes::erased`).
    pub(super) fn erased(&self) -> Ctx<'a, ()> {
        Ctx {
            x: &(),
            iso: self.iso,
            bx: self.bx,
            table: self.table,
            walked: self.walked,
            crossed: self.crossed,
            range: self.range,
            normals: self.normals,
        }
    }

    /// The passes on the window `vol` (the ring by its type on the volume's side, as [`Cells`]
    /// on the extractor's).
    pub(super) fn on<'r, V: Volume + ?Sized>(&'r self, vol: &'r V) -> Passes<'r, V, X> {
        Passes {
            vol,
            x: self.x,
            iso: self.iso,
            bx: self.bx,
            table: self.table,
            walked: self.walked,
            crossed: self.crossed,
            range: self.range,
            reverse: vol.lattice().is_mirrored(),
            normals: self.normals,
            record: KeyRecord::None,
        }
    }
}

impl FlyingEdgesWalker<'_> {
    /// Walks a volume that arrives slab by slab, handing the mesh to `sink` as it is produced
    /// (one batch per slab), in O(nx·ny) memory. The vertices and polygons arrive in exactly the
    /// order an in-memory walk stores them, with the same values. The whole lattice is walked
    /// (a range given to the walker is not used here).
    ///
    /// # Errors
    /// [`Error::External`] from the source or the sink; [`Error::Limit`] past `u32` vertex indices.
    pub fn stream<S: Sample, X: Extractor + Sync>(
        &self,
        src: &mut dyn SlabSource<S>,
        iso: Iso,
        x: &X,
        normals: Normals,
        sink: &mut dyn MeshSink,
    ) -> Result<StreamStats> {
        let lattice = src.lattice().clone();
        let mut out = StreamStats::default();
        let range = CellRange::all(lattice.dims());
        if range.is_empty() {
            return Ok(out);
        }
        let [nx, ny, nz] = lattice.dims().map(|d| d as usize);
        let slab_len = nx * ny;
        let mut ring = SlabRing { slabs: std::array::from_fn(|_| vec![S::from_f64(0.0); slab_len]), slab_len, lattice };
        let bx = PointBox { lo: [0; 3], dims: [nx, ny, nz], s_lo: [0; 3], s_nx: nx };
        let words = bx.words();
        let mut bits = Bits { words, row0: 0, data: vec![0u64; 3 * ny * words] };
        let table = CaseCounts::of(x);
        let external = |e: ExternalError| Error::External(e);
        // Reads slab k into the ring and classifies it into the bit window.
        let load = |k: usize, ring: &mut SlabRing<S>, bits: &mut Bits, src: &mut dyn SlabSource<S>| -> Result<()> {
            src.take_slab(&mut ring.slabs[k % RING]).map_err(external)?;
            let at = (k * ny - bits.row0) * words;
            classify::classify_plane(&*ring, &bx, k as u32, iso, &mut bits.data[at..at + ny * words]);
            Ok(())
        };
        for k in 0..nz.min(3) {
            load(k, &mut ring, &mut bits, src)?;
        }
        let walked = Walked::new(x.segments(), bx.lo);
        let crossed = walked.crossed();
        let ctx =
            Ctx { x, iso, bx, table: &table, walked, crossed: &crossed, range, normals: normals == Normals::Gradient };
        let progress = self.progress;
        if let Some(t) = x.body_centred() {
            // One copy per sample type, whatever the extractor (mt-bcc's tables, not its `process`).
            let mut load = |k: usize, ring: &mut SlabRing<S>, bits: &mut Bits| load(k, ring, bits, &mut *src);
            ctx.erased().bcc_stream(t, &mut ring, &mut bits, &mut load, sink, progress, &mut out)?;
        } else if Paths::<X>::COUNTED {
            let mut rows = RowTable::window(2, ny);
            let mut start = [0u64; 3];
            // The count pass's decisions for slab k and for slab k + 1.
            let (mut decisions, mut next_decisions) = (Vec::new(), Vec::new());
            let cs = ctx.on(&ring as &Cells<'_>).count_plane(&bits, 0, &mut rows.counts[..ny], &mut decisions, false);
            out.walk.cells_outside += cs[0];
            out.walk.cells_inside += cs[1];
            // The batch's buffers: handed to the sink, which may give others back (no copy).
            let mut batch = OwnedBatch::default();
            for k in 0..nz {
                if k + 1 < nz {
                    let cs = ctx.on(&ring as &Cells<'_>).count_plane(
                        &bits,
                        k + 1,
                        &mut rows.counts[ny..],
                        &mut next_decisions,
                        false,
                    );
                    out.walk.cells_outside += cs[0];
                    out.walk.cells_inside += cs[1];
                } else {
                    rows.counts[ny..].fill(Default::default());
                    next_decisions.clear();
                }
                rows.restart(k * ny, start)?;
                // PASS 4 for slab k, into reused buffers sized from the counts, left
                // uninitialised: the fill writes every slot (asserted row by row).
                let [dv, dt, dq] = rows.plane_sizes(k, ny);
                let nv = if normals == Normals::Gradient { dv } else { 0 };
                // SAFETY: `fill_plane` returns only after writing every slot of its slab
                // (asserted row by row).
                unsafe {
                    fill_batch(&mut batch, [dv, nv, dt, dq], |slab| {
                        ctx.erased().on(&ring).fill_vertices(&bits, &rows, k, slab);
                        ctx.on(&ring as &Cells<'_>).fill_polygons(&bits, &rows, k, &decisions, slab)
                    })
                };
                sink.push_owned(&mut batch).map_err(external)?;
                out.vertices += dv as u64;
                out.triangles += dt as u64;
                out.quads += dq as u64;
                start = rows.plane_base(k + 1);
                // Slide the windows up one slab.
                rows.counts.copy_within(ny.., 0);
                std::mem::swap(&mut decisions, &mut next_decisions);
                bits.data.copy_within(ny * words.., 0);
                bits.row0 += ny;
                if k + 3 < nz {
                    load(k + 3, &mut ring, &mut bits, src)?;
                }
                if let Some(p) = progress {
                    p.advance(k as u64 + 1, nz as u64);
                    if p.cancelled() {
                        return Err(Error::Cancelled);
                    }
                }
            }
        } else {
            let mut caches = LayerCaches::default();
            caches.reset([0, 0], nx, ny, 0, X::PLACES_VERTICES);
            let mut b = MeshBuilder::new(normals);
            b.set_reverse_winding(ring.lattice.is_mirrored());
            for k in 0..nz - 1 {
                let s = ctx.on(&ring as &Cells<'_>).walk_layer(&bits, k as u32, true, &mut caches, &mut b);
                out.walk.cells_outside += s.cells_outside;
                out.walk.cells_inside += s.cells_inside;
                caches.advance(X::PLACES_VERTICES);
                let before = b.num_vertices();
                let (t, q) = b.polygon_counts();
                b.drain_into(sink).map_err(external)?;
                out.vertices = before;
                out.triangles += t as u64;
                out.quads += q as u64;
                // Slide: bits of plane k leave, slab k + 3 comes in.
                bits.data.copy_within(ny * words.., 0);
                bits.row0 += ny;
                if k + 3 < nz {
                    load(k + 3, &mut ring, &mut bits, src)?;
                }
                if let Some(p) = progress {
                    p.advance(k as u64 + 1, nz as u64 - 1);
                    if p.cancelled() {
                        return Err(Error::Cancelled);
                    }
                }
            }
            b.finish()?;
        }
        out.walk.cells = range.num_cells();
        Ok(out)
    }
}

/// The first `n` slots of `v`, emptied first: room the fill writes before `set_len`.
fn spare<T>(v: &mut Vec<T>, n: usize) -> &mut [std::mem::MaybeUninit<T>] {
    v.clear();
    v.reserve(n);
    &mut v.spare_capacity_mut()[..n]
}

/// PASS 4 of one streamed plane into `batch`'s reused buffers: their first `[v, nv, t, q]`
/// positions, normals, triangles and quads as uninitialised [`SlabSlots`] (no zeroing pass)
/// for `fill`, their lengths then committed.
///
/// # Safety
/// `fill` returns only after writing every slot of the [`SlabSlots`] it is given (the fills
/// assert it row by row and per plane, and panic otherwise).
pub(super) unsafe fn fill_batch(
    batch: &mut OwnedBatch,
    [v, nv, t, q]: [usize; 4],
    fill: impl FnOnce(&mut SlabSlots<'_>),
) {
    let mut slab = SlabSlots {
        positions: spare(&mut batch.positions, v),
        normals: spare(&mut batch.normals, nv),
        triangles: spare(&mut batch.triangles, t),
        quads: spare(&mut batch.quads, q),
        keys: Vec::new(),
    };
    fill(&mut slab);
    // SAFETY: `fill` returned, which (the caller's promise) it does only after writing every
    // slot of `slab`, the first v, nv, t and q of the buffers `spare` cleared and reserved; a
    // panic there propagates before this point.
    unsafe {
        batch.positions.set_len(v);
        batch.normals.set_len(nv);
        batch.triangles.set_len(t);
        batch.quads.set_len(q);
    }
}
