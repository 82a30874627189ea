//! Data: the sampling [`Lattice`], sample types ([`Sample`], [`DType`]), dense grids, sparse grids
//! and signed octrees ([`SignedOctree`], PolyMender's SOG).
//!
//! Nothing here depends on other modules; volumes, walkers and readers build on it.

mod blocks;
mod dense;
mod histogram;
mod lattice;
pub mod octree;
mod region;
mod resample;
mod sample;
pub mod sparse;

pub use blocks::BlockBounds;
pub use dense::{value_range_of, AnyGrid, DenseGrid, NonFinite, ValueRange};
pub use histogram::Histogram;
pub use lattice::{Lattice, WorldSpace, IDENTITY};
pub use octree::{OctreeLeaf, OctreeNode, SignedOctree};
pub(crate) use resample::blend;
pub use resample::{downsample_mean, upsample_trilinear};
pub use sample::{as_bytes, as_bytes_mut, first_non_finite, DType, Sample, Threshold};
pub use sparse::{AnySparse, SparseGrid, SparseNode, SparseStats, SparseTile};
