//! Mesh checks: watertightness, manifoldness, orientation, Euler characteristic and genus.
//!
//! In: a [`Mesh`](crate::mesh::Mesh). Out: a [`MeshReport`] whose findings name the elements.

mod check;

pub use check::{check, check_with, CheckOptions, ComponentReport, EdgeFinding, Findings, Guarantee, MeshReport};
