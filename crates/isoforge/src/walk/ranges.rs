//! Many cell ranges of one lattice in one walk: each range walked by the [`FlyingEdgesWalker`] on a
//! window of its halo points, the ranges in parallel, their meshes stitched by vertex key in range
//! order. What sparse grids are walked with (a range per run of active leaf blocks), and any
//! volume that hands out boxes of samples ([`BoxSamples`]).
//!
//! ```text
//!   ranges    sorted (z, y, x), disjoint; each reads its halo points only (CellRange::halo_points)
//!   per range BoxSamples::fill_box → a window (GridVolume::window) → the walk of that range, with
//!             the keys of the vertices on its boundary (KeyRecord::Boundary)
//!   stitch    vertices with equal keys kept once, where they first occur (walk::stitch)
//! ```
//! The mesh has exactly the polygons and vertices a walk of the whole lattice makes in those cells
//! (`chunks_with_halos_stitch_into_the_whole_mesh`), numbered by range instead of by row.

use super::stitch::{stitch_parts, KeyedMesh};
use super::{FlyingEdgesWalker, WalkStats, Walker};
use crate::cube::CellRange;
use crate::error::Result;
use crate::extract::Extractor;
use crate::grid::{DenseGrid, Lattice, Sample, SparseGrid};
use crate::mesh::{KeyRecord, MeshBuilder, Normals};
use crate::volume::{GridVolume, Iso};

/// A volume whose samples come box by box (a sparse grid): what [`walk_ranges`] reads.
pub trait BoxSamples<S>: Sync {
    /// The lattice the samples are on.
    fn lattice(&self) -> &Lattice;
    /// The samples of the points `lo .. hi` (half-open, inside the lattice), x fastest, into
    /// `out` (resized).
    fn fill_box(&self, lo: [u32; 3], hi: [u32; 3], out: &mut Vec<S>);
}

impl<S: Sample> BoxSamples<S> for SparseGrid<S> {
    fn lattice(&self) -> &Lattice {
        SparseGrid::lattice(self)
    }
    fn fill_box(&self, lo: [u32; 3], hi: [u32; 3], out: &mut Vec<S>) {
        SparseGrid::fill_box(self, lo, hi, out)
    }
}

/// Walks `ranges` (disjoint cell ranges of `src`'s lattice, in the order their meshes are joined)
/// with `x` at `iso`, in parallel, and stitches their meshes; `record` says which vertices keep
/// their keys in the result (as for a whole walk). Returns the mesh with its keys, and the cell
/// counts of the ranges.
///
/// # Errors
/// As [`Walker::walk`] and [`stitch`](super::stitch).
pub fn walk_ranges<S: Sample, X: Extractor + Sync>(
    src: &dyn BoxSamples<S>,
    ranges: &[CellRange],
    iso: Iso,
    x: &X,
    normals: Normals,
    record: KeyRecord,
) -> Result<(KeyedMesh, WalkStats)> {
    let lattice = src.lattice();
    let dims = lattice.dims();
    let one = |range: &CellRange| -> Result<(KeyedMesh, WalkStats)> {
        let (lo, hi) = range.halo_points(dims);
        let mut samples = Vec::new();
        src.fill_box(lo, hi, &mut samples);
        let window = DenseGrid::new(Lattice::new([0, 1, 2].map(|a| hi[a] - lo[a]))?, samples)?;
        let vol = GridVolume::window(&window, lo, lattice.clone())?;
        let keep = if record == KeyRecord::All { KeyRecord::All } else { KeyRecord::Boundary(*range) };
        let mut out = MeshBuilder::new(normals).with_keys(keep);
        let stats = FlyingEdgesWalker::new().with_range(*range).walk(&vol, iso, x, &mut out)?;
        Ok((KeyedMesh::from_builder(out)?, stats))
    };
    let parts = super::flying_edges::map_tasks(ranges.iter().collect(), &one);
    let (mut stitched, stats) = stitch_parts(parts)?;
    stitched.keys.retain(|(_, k)| match record {
        KeyRecord::None => false,
        KeyRecord::All => true,
        KeyRecord::Boundary(r) => crate::mesh::touches_boundary(k, &r),
    });
    Ok((stitched, stats))
}
