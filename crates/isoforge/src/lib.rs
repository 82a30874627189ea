//! isoforge: turns volumes into meshes.
//!
//! ```text
//! file ─io::read─▶ DenseGrid | Field ─▶ Volume ─▶ Walker ─▶ Cell ─▶ Extractor ─▶ MeshBuilder ─▶ Mesh ─topo─▶ io::write ─▶ file
//! ```
//!
//! A [`Volume`](volume::Volume) knows the values and computes exact edge crossings; a
//! [`Walker`](walk::Walker) owns the traversal and caches values and vertices so each is computed
//! once; an [`Extractor`](extract::Extractor) turns one cell at a time into triangles. Inside ⇔
//! value < iso (ties outside) unless [`Inside::Above`](volume::Inside::Above) is asked for.
//!
//! ```
//! use isoforge::{grid::Lattice, math::Vec3, pipeline, topo, volume::{Iso, Sampled}};
//!
//! // Any closure is a field: a sphere of radius 0.8 sampled on [-1, 1]³.
//! let field = |p: Vec3| p.length() - 0.8;
//! let lattice = Lattice::spanning([32; 3], [-1.0; 3], [1.0; 3]).unwrap();
//! let volume = Sampled::new(field, lattice);
//! let out = pipeline::extract(&volume, Iso::below(0.0), &pipeline::Options::default()).unwrap();
//! let report = topo::check(&out.mesh);
//! assert!(report.is_watertight());
//! assert_eq!(report.genus(), Some(0));
//! assert!((report.volume - 4.0 / 3.0 * std::f64::consts::PI * 0.512).abs() < 0.05);
//! ```
#![warn(missing_docs)]

pub mod cube;
pub mod error;
pub mod extract;
pub mod grid;
pub mod math;
pub mod mend;
pub mod mesh;
pub mod pipeline;
pub mod topo;
pub mod volume;
pub mod voxelize;
pub mod walk;

pub use error::{Error, Result};
