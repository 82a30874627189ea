//! ② Walker: owns the traversal order and the caches; hands one [`Cell`] at a time to an extractor.
//!
//! In: a [`Volume`] and an [`Iso`]. Out: mesh vertices and triangles in a [`MeshBuilder`].
//! [`SlabWalker`] is the production walker (two value slabs, per-axis vertex-id slabs);
//! [`ReferenceWalker`] recomputes everything and joins vertices by [`EdgeKey`], for tests.

pub mod flying_edges;
mod reference;
pub mod segment;
mod slab;

pub use flying_edges::{
    flying_edges, flying_edges_streaming, CaseTable, ExternalError, MeshSink, SlabSource, StreamStats,
};
pub use reference::ReferenceWalker;
pub use segment::{CellPoint, SegmentKey};
pub use slab::SlabWalker;

use crate::error::Result;
use crate::extract::cube::{CubeEdge, EdgeKey};
use crate::extract::Extractor;
use crate::mesh::{MeshBuilder, VertexId};
use crate::volume::{Iso, Volume};

/// A walker's cursor on one cell. Extractors are generic over it and see nothing else.
pub trait Cell {
    /// Lattice index of the cell's corner 0.
    fn ijk(&self) -> [u32; 3];
    /// The eight corner values offset by iso (inside ⇔ < 0), in corner order.
    fn values(&self) -> &[f32; 8];
    /// Case index: bit `c` set ⇔ corner `c` inside.
    fn case(&self) -> u8;
    /// The mesh vertex at the crossing on edge `e`, created on first request and shared with
    /// every other cell touching the same lattice edge.
    ///
    /// The edge must cross (its corners differ in class).
    fn edge_vertex(&mut self, e: CubeEdge) -> VertexId;
    /// Emits a triangle (wound counter-clockwise seen from outside).
    fn push_triangle(&mut self, t: [VertexId; 3]);

    /// Whether the neighbouring cell across `face` (`2 · axis + side`) exists.
    fn has_neighbour(&self, face: u8) -> bool;
    /// The value offset by iso at a cell point: a corner's from [`values`](Cell::values), a
    /// centre's from [`Volume::value_at`] (computed once per cell).
    fn point_value(&mut self, p: CellPoint) -> f32;
    /// The mesh vertex where segment `a`–`b` crosses (their values differ in class), created on
    /// first request and shared with every cell that names the same lattice segment; axis edges
    /// give the same vertex as [`edge_vertex`](Cell::edge_vertex).
    fn segment_vertex(&mut self, a: CellPoint, b: CellPoint) -> VertexId;
    /// A new vertex private to this cell at cell coordinates `local` ∈ [0, 1]³ (never shared).
    fn interior_vertex(&mut self, local: [f32; 3]) -> VertexId;
}

/// A traversal strategy: visits every cell of `vol` and lets `x` process the active ones.
pub trait Walker {
    /// Walks the whole lattice.
    ///
    /// # Errors
    /// [`Error::Limit`](crate::Error::Limit) when the mesh outgrows `u32` indices.
    fn walk<V: Volume, X: Extractor>(
        &mut self,
        vol: &V,
        iso: Iso,
        x: &mut X,
        out: &mut MeshBuilder,
    ) -> Result<WalkStats>;
}

/// Counts gathered during a walk.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct WalkStats {
    /// Cells visited.
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
}

/// Reports progress of long walks (one call per slab).
pub trait Progress: Sync {
    /// `done` of `total` units of work are finished.
    fn advance(&self, done: u64, total: u64);
}

/// A vertex on a lattice edge: world position and unit normal (outward).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hermite {
    /// World position of the crossing.
    pub point: [f32; 3],
    /// Unit normal pointing from inside to outside.
    pub normal: [f32; 3],
}

/// Computes the crossing on `key` (offset values `d0` at its origin, `d1` at its end) and, when
/// `normals` is set, its outward normal. Shared by every walker so all agree bit for bit.
#[inline]
pub fn hermite<V: Volume + ?Sized>(vol: &V, key: EdgeKey, d0: f32, d1: f32, iso: Iso, normals: bool) -> Hermite {
    let s = iso.sign();
    let t = vol.crossing(key, d0, d1, iso);
    let w = vol.lattice().to_world(key.point_at(t as f64));
    let point = [w[0] as f32, w[1] as f32, w[2] as f32];
    if !normals {
        return Hermite { point, normal: [0.0; 3] };
    }
    let g = vol.gradient(key, t) * s;
    let n = g.normalize_or_zero();
    let normal = if n == glam::Vec3::ZERO {
        // Flat field: fall back to the edge's world direction, pointing to its outside end.
        let dir = vol.lattice().direction()[key.axis.index()];
        let sign = if d0 < 0.0 { 1.0 } else { -1.0 };
        dir.map(|x| (x * sign) as f32)
    } else {
        n.to_array()
    };
    Hermite { point, normal }
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
        send::<ReferenceWalker>();
        sync::<crate::volume::GridVolume<'static, f32>>();
        sync::<crate::volume::Sampled<crate::volume::sdf::Sphere>>();
        sync::<crate::mesh::MeshBuilder>();
    }
}
