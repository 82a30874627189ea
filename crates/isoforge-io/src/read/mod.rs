//! Readers: volumes (raw, NRRD, NIfTI-1, MetaImage, …), signed octrees (SOG), TopoMender's skeletons (SKT) and meshes (PLY, OBJ, STL, OFF).

pub(crate) mod decode;
#[cfg(feature = "dicom")]
pub mod dicom;
#[cfg(any(feature = "ply", feature = "obj", feature = "stl", feature = "off"))]
mod mesh_text;
#[cfg(feature = "metaimage")]
pub mod metaimage;
#[cfg(feature = "mrc")]
pub mod mrc;
#[cfg(feature = "nifti")]
pub mod nifti;
#[cfg(feature = "nrrd")]
pub mod nrrd;
#[cfg(feature = "obj")]
pub mod obj;
#[cfg(feature = "off")]
pub mod off;
#[cfg(feature = "ply")]
pub mod ply;
#[cfg(feature = "png")]
pub mod png;
#[cfg(feature = "raw")]
pub mod raw;
#[cfg(feature = "sog")]
pub mod skt;
#[cfg(feature = "sog")]
pub mod sog;
#[cfg(feature = "vdb")]
pub mod sparse;
#[cfg(any(feature = "png", feature = "tiff"))]
pub mod stack;
#[cfg(feature = "stl")]
pub mod stl;
pub mod stream;
#[cfg(feature = "tiff")]
pub mod tiff;
#[cfg(feature = "vdb")]
pub mod vdb;
#[cfg(feature = "vtk")]
pub mod vti;
#[cfg(feature = "vtk")]
pub mod vtk;
