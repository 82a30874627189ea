//! Mesh writers: PLY (binary or ASCII), OBJ, STL (binary or ASCII), OFF, glTF; contour writers (SVG, GeoJSON,
//! CSV); sparse grids as OpenVDB files ([`vdb`]), signed octrees as SOG files (`sog`), TopoMender's skeletons (`skt`). All go through [`write_atomic`](crate::write_atomic): a failed write leaves no file.

pub mod contour;
mod copy;
pub mod gltf;
#[cfg(feature = "obj")]
pub mod obj;
#[cfg(feature = "off")]
pub mod off;
#[cfg(feature = "ply")]
pub mod ply;
#[cfg(feature = "sog")]
pub mod skt;
#[cfg(feature = "sog")]
pub mod sog;
#[cfg(feature = "stl")]
pub mod stl;
mod stream;
#[cfg(any(feature = "obj", feature = "off", feature = "ply"))]
mod text;
#[cfg(feature = "vdb")]
pub mod vdb;
#[cfg(all(feature = "nrrd", feature = "nifti"))]
pub mod volume;

pub use stream::MeshStream;
