//! ② Walker: owns the traversal order and the caches; hands one [`Cell`] at a time to an extractor.
//!
//! In: a [`Volume`], an [`Iso`], a [`CellRange`] (global lattice indices; the whole lattice by
//! default). Out: vertices and polygons in a [`MeshBuilder`] (or, streamed, a [`MeshSink`](crate::mesh::MeshSink)).
//!
//! | walker | volumes | traversal | parallel |
//! |---|---|---|---|
//! | [`FlyingEdgesWalker`] | sampled grids ([`SampleSlabs`]), streamed slabs, materialised fields | bit rows; count → prefix sums → fill, or per-slab meshes stitched by key | yes, identical output for every thread count |
//! | [`SlabWalker`] | any [`Volume`] | cell by cell, slab by slab, O(nx·ny) memory | no |
//! | [`ReferenceWalker`] | any [`Volume`] | recomputes everything (tests) | no |
//!
//! Every walker creates each vertex once per walk, with its [`VertexKey`]: walks of cell ranges
//! that tile the lattice [`stitch`] by key into the whole-lattice mesh.

mod cached;
pub mod flying_edges;
mod follow;
mod ranges;
mod reference;
pub(crate) mod segment;
mod slab;
mod stitch;

pub use flying_edges::{FlyingEdgesWalker, StreamStats};
pub use follow::{FollowStats, Follower};
pub use ranges::{walk_ranges, BoxSamples};
pub(crate) use reference::walk_cells;
pub use reference::ReferenceWalker;
pub use slab::SlabWalker;
pub use stitch::{stitch, stitch_keyed, KeyedMesh};

use crate::cube::{CellRange, CubeEdge, EdgeKey, VertexKey};
use crate::error::Result;
use crate::extract::Extractor;
use crate::mesh::{MeshBuilder, VertexId};
use crate::volume::{Iso, Volume};

#[doc(inline)]
pub use crate::extract::{Cell, Hermite};
#[doc(inline)]
pub use crate::volume::SampleSlabs;

/// A traversal strategy over the volumes of type `V` it can walk: visits the cells of its range
/// and lets an extractor process the active ones.
pub trait Walker<V: ?Sized> {
    /// Walks the range (the whole lattice unless the walker was given one).
    ///
    /// # Errors
    /// [`Error::Limit`](crate::Error::Limit) when the mesh outgrows `u32` indices.
    fn walk<X: Extractor + Sync>(&mut self, vol: &V, iso: Iso, x: &X, out: &mut MeshBuilder) -> Result<WalkStats>;
}

/// Counts gathered during a walk.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct WalkStats {
    /// Cells visited (the range's cells).
    pub cells: u64,
    /// Cells whose corners are all outside (case 0).
    pub cells_outside: u64,
    /// Cells whose corners are all inside (case 255).
    pub cells_inside: u64,
}

impl WalkStats {
    /// Cells crossed by the surface.
    pub fn active_cells(&self) -> u64 {
        self.cells - self.cells_outside - self.cells_inside
    }

    /// Why a walk produced nothing: every cell outside, or every cell inside (`None` otherwise).
    pub fn uniform_side(&self) -> Option<&'static str> {
        if self.cells == 0 {
            None
        } else if self.cells_outside == self.cells {
            Some("outside")
        } else if self.cells_inside == self.cells {
            Some("inside")
        } else {
            None
        }
    }

    fn add(&mut self, o: WalkStats) {
        self.cells += o.cells;
        self.cells_outside += o.cells_outside;
        self.cells_inside += o.cells_inside;
    }
}

/// Reports progress of long walks (one call per slab or task), and lets the caller cancel them.
pub trait Progress: Sync {
    /// `done` of `total` units of work are finished.
    fn advance(&self, done: u64, total: u64);

    /// Whether the caller wants the walk stopped. The in-memory Flying Edges walk asks once per
    /// plane task before its fill (classification, counting) and then returns
    /// [`Error::Cancelled`](crate::Error::Cancelled); the fill, once started, runs to its end.
    fn cancelled(&self) -> bool {
        false
    }
}

/// Whether `progress` asks for the walk to stop.
#[inline]
pub(crate) fn is_cancelled(progress: Option<&dyn Progress>) -> bool {
    progress.is_some_and(|p| p.cancelled())
}

/// The crossing on lattice edge `key` (offset values `d0` at its origin, `d1` at its end): its
/// world position and its parameter `t` from the origin. Shared by every walker so all agree bit
/// for bit. Always inlined: out of line, the point's array `map` went out of line too, and its
/// stores then stalled the wide load of the world transform (+25 % on a dense MC extraction).
#[inline(always)]
pub fn edge_crossing<V: Volume + ?Sized>(vol: &V, key: EdgeKey, d0: f32, d1: f32, iso: Iso) -> ([f32; 3], f32) {
    let t = vol.crossing(key, d0, d1, iso);
    let w = vol.lattice().to_world(key.point_at(t as f64));
    ([w[0] as f32, w[1] as f32, w[2] as f32], t)
}

/// The outward unit normal at parameter `t` on lattice edge `key` whose origin has offset value
/// `d0`: the normalised gradient, or the edge's world direction towards its outside end where the
/// gradient vanishes.
#[inline]
pub fn edge_normal<V: Volume + ?Sized>(vol: &V, key: EdgeKey, t: f32, d0: f32, iso: Iso) -> [f32; 3] {
    let n = (vol.gradient(key, t) * iso.sign()).normalize_or_zero();
    if n == glam::Vec3::ZERO {
        let dir = vol.lattice().direction()[key.axis.index()];
        let sign = if d0 < 0.0 { 1.0 } else { -1.0 };
        dir.map(|x| (x * sign) as f32)
    } else {
        n.to_array()
    }
}

/// Hermite data of lattice edge `key`, its cell coordinates in the frame of the cell whose
/// corner 0 is the edge's origin ([`Hermite::on_edge`] moves them to any other cell's edge).
#[inline]
pub fn edge_hermite<V: Volume + ?Sized>(vol: &V, key: EdgeKey, d0: f32, d1: f32, iso: Iso) -> Hermite {
    let (point, t) = edge_crossing(vol, key, d0, d1, iso);
    let normal = edge_normal(vol, key, t, d0, iso);
    let mut local = [0.0; 3];
    local[key.axis.index()] = t;
    Hermite { point, normal, local, local_normal: local_covector(vol.lattice(), normal), exact: vol.exact_gradients() }
}

/// A world normal `n` as a covector of cell (index) coordinates: `m_a = spacing_a · (direction_a ·
/// n)`, so `m · δ` is the world length along `n` of the index-space step `δ` (see [`Cell`]).
#[inline]
pub fn local_covector(lattice: &crate::grid::Lattice, n: [f32; 3]) -> [f32; 3] {
    let (dir, spacing) = (lattice.direction(), lattice.spacing());
    [0, 1, 2].map(|a| (spacing[a] * (0..3).map(|w| dir[a][w] * n[w] as f64).sum::<f64>()) as f32)
}

/// The crossing on edge `e` of cell `ijk` (offset values `d`) in the cell's frame.
#[inline]
pub(crate) fn cell_crossing<V: Volume + ?Sized>(
    vol: &V,
    ijk: [u32; 3],
    e: CubeEdge,
    d: &[f32; 8],
    iso: Iso,
) -> [f32; 3] {
    let [c0, c1] = e.corners();
    local_on_edge(e, vol.crossing(EdgeKey::of_cell(ijk, e), d[c0 as usize], d[c1 as usize], iso))
}

/// The point at parameter `t` on edge `e` in cell coordinates.
#[inline]
pub(crate) fn local_on_edge(e: CubeEdge, t: f32) -> [f32; 3] {
    let mut p = e.origin_offset().map(|x| x as f32);
    p[e.axis().index()] = t;
    p
}

/// Creates the vertex at the crossing on `key` in `out`, with its normal when `out` stores normals.
#[inline]
pub(crate) fn push_edge_vertex<V: Volume + ?Sized>(
    vol: &V,
    key: EdgeKey,
    d0: f32,
    d1: f32,
    iso: Iso,
    out: &mut MeshBuilder,
) -> VertexId {
    let (p, t) = edge_crossing(vol, key, d0, d1, iso);
    let n = if out.wants_normals() { edge_normal(vol, key, t, d0, iso) } else { [0.0; 3] };
    out.push_vertex(VertexKey::Edge(key), p, n)
}

/// Which cells of `range` a walker hands to `process`: those with a crossing, or every cell for
/// extractors that sample off the lattice ([`Extractor::visits_uniform_cells`]).
#[inline]
pub(crate) fn wants_cell<X: Extractor + ?Sized>(x: &X, case: u8) -> bool {
    (case != 0 && case != 255) || x.visits_uniform_cells()
}

/// The range a walker covers: the one it was given, clipped to the lattice, or all of it.
pub(crate) fn range_of(given: Option<CellRange>, dims: [u32; 3]) -> CellRange {
    match given {
        Some(r) => CellRange::clipped(r.lo, r.hi, dims),
        None => CellRange::all(dims),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Compile-time: walkers and volumes can move to worker threads (the parallel walker needs it).
    #[test]
    fn thread_safety_of_the_roles() {
        fn send<T: Send>() {}
        fn sync<T: Sync>() {}
        send::<SlabWalker<'static>>();
        send::<FlyingEdgesWalker<'static>>();
        send::<ReferenceWalker>();
        sync::<crate::volume::GridVolume<'static, f32>>();
        sync::<crate::volume::Sampled<crate::volume::sdf::Sphere>>();
        sync::<crate::mesh::MeshBuilder>();
    }
}
