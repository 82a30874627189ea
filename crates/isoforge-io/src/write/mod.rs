//! Mesh writers: PLY (binary or ASCII), OBJ, binary STL, OFF; contour writers (SVG, GeoJSON,
//! CSV). All go through [`write_atomic`](crate::write_atomic): a failed write leaves no file.

pub mod contour;
pub mod gltf;
#[cfg(feature = "obj")]
pub mod obj;
#[cfg(feature = "off")]
pub mod off;
#[cfg(feature = "ply")]
pub mod ply;
#[cfg(feature = "stl")]
pub mod stl;
#[cfg(all(feature = "nrrd", feature = "nifti"))]
pub mod volume;
