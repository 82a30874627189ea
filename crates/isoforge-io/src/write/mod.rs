//! Mesh writers: PLY (binary or ASCII), OBJ, STL (binary or ASCII), OFF; contour writers (SVG, GeoJSON,
//! CSV). All go through [`write_atomic`](crate::write_atomic): a failed write leaves no file.

pub mod contour;
mod copy;
pub mod gltf;
#[cfg(feature = "obj")]
pub mod obj;
#[cfg(feature = "off")]
pub mod off;
#[cfg(feature = "ply")]
pub mod ply;
#[cfg(feature = "stl")]
pub mod stl;
mod text;
#[cfg(all(feature = "nrrd", feature = "nifti"))]
pub mod volume;

use std::path::Path;

use crate::error::Result;
use crate::{Batch, MeshFormat};

/// A mesh file written as the mesh is produced, batch by batch, in memory bounded by a few
/// batches: the formats whose streamed bytes are exactly the in-memory writer's (binary PLY,
/// binary STL and OBJ).
pub enum MeshStream<'a> {
    /// Binary PLY ([`ply::PlyStream`]).
    #[cfg(feature = "ply")]
    Ply(ply::PlyStream<'a>),
    /// Binary STL ([`stl::StlStream`]).
    #[cfg(feature = "stl")]
    Stl(stl::StlStream<'a>),
    /// OBJ ([`obj::ObjStream`]).
    #[cfg(feature = "obj")]
    Obj(obj::ObjStream<'a>),
}

impl<'a> MeshStream<'a> {
    /// Whether `format` can be written as a stream.
    pub fn streams(format: MeshFormat) -> bool {
        (cfg!(feature = "ply") && format == MeshFormat::Ply)
            || (cfg!(feature = "stl") && format == MeshFormat::Stl)
            || (cfg!(feature = "obj") && format == MeshFormat::Obj)
    }

    /// Starts writing `path` in `format` (with vertex normals when `normals` and the format has
    /// room for them) as an output of `batch`; `None` when the format cannot be streamed.
    ///
    /// # Errors
    /// As [`Batch::reserve`].
    pub fn create_in(batch: &'a Batch, path: &Path, format: MeshFormat, normals: bool) -> Result<Option<Self>> {
        let _ = (batch, path, normals);
        Ok(match format {
            #[cfg(feature = "ply")]
            MeshFormat::Ply => Some(MeshStream::Ply(ply::PlyStream::create_in(batch, path, normals)?)),
            #[cfg(feature = "stl")]
            MeshFormat::Stl => Some(MeshStream::Stl(stl::StlStream::create_in(batch, path)?)),
            #[cfg(feature = "obj")]
            MeshFormat::Obj => Some(MeshStream::Obj(obj::ObjStream::create_in(batch, path, normals)?)),
            _ => None,
        })
    }

    /// Completes the file (see each stream's `finish`); returns the vertex and polygon counts
    /// written (STL: facets, quads counted twice).
    ///
    /// # Errors
    /// [`crate::Error::Io`] naming the path when writing fails.
    pub fn finish(self) -> Result<(u64, u64)> {
        match self {
            #[cfg(feature = "ply")]
            MeshStream::Ply(s) => s.finish(),
            #[cfg(feature = "stl")]
            MeshStream::Stl(s) => s.finish(),
            #[cfg(feature = "obj")]
            MeshStream::Obj(s) => s.finish(),
        }
    }
}

impl isoforge::mesh::MeshSink for MeshStream<'_> {
    fn push(&mut self, batch: isoforge::mesh::MeshBatch<'_>) -> std::result::Result<(), isoforge::mesh::ExternalError> {
        match self {
            #[cfg(feature = "ply")]
            MeshStream::Ply(s) => isoforge::mesh::MeshSink::push(s, batch),
            #[cfg(feature = "stl")]
            MeshStream::Stl(s) => isoforge::mesh::MeshSink::push(s, batch),
            #[cfg(feature = "obj")]
            MeshStream::Obj(s) => isoforge::mesh::MeshSink::push(s, batch),
        }
    }
}
