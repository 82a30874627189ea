//! File formats, recognised by extension.

use std::path::{Path, PathBuf};

/// A volume file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum VolumeFormat {
    /// Headerless samples (`.raw`, or anything with `--dims`).
    Raw,
    /// NRRD (`.nrrd`, `.nhdr`).
    Nrrd,
    /// NIfTI-1 (`.nii`, `.nii.gz`, `.hdr`).
    Nifti,
    /// MetaImage (`.mha`, `.mhd`).
    MetaImage,
    /// MRC2014 / CCP4 map (`.mrc`, `.map`, `.ccp4`, `.mrcs`).
    Mrc,
    /// VTK legacy structured points (`.vtk`).
    VtkLegacy,
    /// VTK XML image data (`.vti`).
    Vti,
    /// PNG image (`.png`): one slice.
    Png,
    /// TIFF image or multi-page stack (`.tif`, `.tiff`).
    Tiff,
}

/// A mesh file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum MeshFormat {
    /// PLY; written binary little-endian.
    Ply,
    /// PLY written as ASCII.
    PlyAscii,
    /// Wavefront OBJ.
    Obj,
    /// glTF 2.0 binary (`.glb`).
    Glb,
    /// glTF 2.0 JSON with an external `.bin` buffer (`.gltf`).
    Gltf,
    /// STL written as ASCII.
    StlAscii,
    /// STL; written binary.
    Stl,
    /// OFF.
    Off,
}

fn lower_name(path: &Path) -> String {
    path.file_name().map(|n| n.to_string_lossy().to_ascii_lowercase()).unwrap_or_default()
}

impl VolumeFormat {
    /// The format a path's extension names, if any.
    pub fn from_path(path: &Path) -> Option<Self> {
        let n = lower_name(path);
        Some(if n.ends_with(".nrrd") || n.ends_with(".nhdr") {
            VolumeFormat::Nrrd
        } else if n.ends_with(".nii") || n.ends_with(".nii.gz") || n.ends_with(".hdr") {
            VolumeFormat::Nifti
        } else if n.ends_with(".mha") || n.ends_with(".mhd") {
            VolumeFormat::MetaImage
        } else if n.ends_with(".mrc") || n.ends_with(".map") || n.ends_with(".ccp4") || n.ends_with(".mrcs") {
            VolumeFormat::Mrc
        } else if n.ends_with(".vtk") {
            VolumeFormat::VtkLegacy
        } else if n.ends_with(".vti") {
            VolumeFormat::Vti
        } else if n.ends_with(".png") {
            VolumeFormat::Png
        } else if n.ends_with(".tif") || n.ends_with(".tiff") {
            VolumeFormat::Tiff
        } else if n.ends_with(".raw") {
            VolumeFormat::Raw
        } else {
            return None;
        })
    }

    /// Display name.
    pub fn name(self) -> &'static str {
        match self {
            VolumeFormat::Raw => "raw",
            VolumeFormat::Nrrd => "NRRD",
            VolumeFormat::Nifti => "NIfTI-1",
            VolumeFormat::MetaImage => "MetaImage",
            VolumeFormat::Mrc => "MRC",
            VolumeFormat::VtkLegacy => "VTK legacy",
            VolumeFormat::Vti => "VTK image data (XML)",
            VolumeFormat::Png => "PNG",
            VolumeFormat::Tiff => "TIFF",
        }
    }
}

impl MeshFormat {
    /// The format a path's extension names, if any.
    pub fn from_path(path: &Path) -> Option<Self> {
        let n = lower_name(path);
        let ext = n.rsplit_once('.').map(|(_, e)| e)?;
        Some(match ext {
            "ply" => MeshFormat::Ply,
            "obj" => MeshFormat::Obj,
            "glb" => MeshFormat::Glb,
            "gltf" => MeshFormat::Gltf,
            "stl" => MeshFormat::Stl,
            "off" => MeshFormat::Off,
            _ => return None,
        })
    }

    /// The files a write of this format to `path` produces: `path`, and for `.gltf` the buffer
    /// [`MeshFormat::gltf_buffer`] beside it.
    pub fn files(self, path: &Path) -> Vec<PathBuf> {
        self.outputs(path, "").into_iter().map(|(p, _)| p).collect()
    }

    /// [`MeshFormat::files`], each with how messages name it when the output is named `role`
    /// (`-o`, and "the buffer of -o" for a glTF buffer).
    pub fn outputs(self, path: &Path, role: &str) -> Vec<(PathBuf, String)> {
        match self {
            MeshFormat::Gltf => {
                vec![(path.to_path_buf(), role.to_string()), (Self::gltf_buffer(path), format!("the buffer of {role}"))]
            }
            _ => vec![(path.to_path_buf(), role.to_string())],
        }
    }

    /// The binary buffer written beside a `.gltf` file: the same stem with `.bin`.
    pub fn gltf_buffer(path: &Path) -> PathBuf {
        path.with_extension("bin")
    }

    /// Display name.
    pub fn name(self) -> &'static str {
        match self {
            MeshFormat::Ply => "PLY",
            MeshFormat::PlyAscii => "PLY (ASCII)",
            MeshFormat::Obj => "OBJ",
            MeshFormat::Stl => "STL",
            MeshFormat::StlAscii => "STL (ASCII)",
            MeshFormat::Off => "OFF",
            MeshFormat::Glb => "glTF (binary)",
            MeshFormat::Gltf => "glTF",
        }
    }
}
