//! Mesh checks: watertightness, manifoldness, orientation, Euler characteristic and genus; and
//! exact [`self_intersections`]; the [`hausdorff`] distance between two meshes.
//!
//! In: a [`Mesh`](crate::mesh::Mesh), or its batches as out-of-core extraction streams them
//! ([`StreamCheck`]). Out: a [`MeshReport`] whose findings name the elements.

mod check;
mod hausdorff;
mod intersect;
mod stream;

pub use check::{
    check, check_with, check_with_progress, defect_edges, edge_key, CheckOptions, ComponentReport, EdgeFinding,
    Findings, Guarantee, MeshReport,
};
pub use hausdorff::{hausdorff, Hausdorff};
pub use intersect::self_intersections;
pub(crate) use intersect::{improper, keep_axis};
pub use stream::StreamCheck;
