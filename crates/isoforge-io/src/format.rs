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
    /// OpenVDB (`.vdb`): a sparse grid, read by [`read_sparse`](crate::read_sparse).
    Vdb,
    /// PolyMender's signed octree grid (`.sog`): read as its signs, −1 inside and +1 outside, on
    /// the `(dim + 1)³` points of its root cube (the tree itself: [`read_sog`](crate::read_sog)).
    Sog,
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
    /// Every volume format, in the order help texts list them.
    pub const ALL: [VolumeFormat; 11] = [
        VolumeFormat::Nrrd,
        VolumeFormat::Nifti,
        VolumeFormat::MetaImage,
        VolumeFormat::Mrc,
        VolumeFormat::VtkLegacy,
        VolumeFormat::Vti,
        VolumeFormat::Png,
        VolumeFormat::Tiff,
        VolumeFormat::Vdb,
        VolumeFormat::Sog,
        VolumeFormat::Raw,
    ];

    /// The file-name endings that select the format (lower case, with the dot).
    pub fn extensions(self) -> &'static [&'static str] {
        match self {
            VolumeFormat::Raw => &[".raw"],
            VolumeFormat::Nrrd => &[".nrrd", ".nhdr"],
            VolumeFormat::Nifti => &[".nii", ".nii.gz", ".hdr"],
            VolumeFormat::MetaImage => &[".mha", ".mhd"],
            VolumeFormat::Mrc => &[".mrc", ".map", ".ccp4", ".mrcs"],
            VolumeFormat::VtkLegacy => &[".vtk"],
            VolumeFormat::Vti => &[".vti"],
            VolumeFormat::Png => &[".png"],
            VolumeFormat::Tiff => &[".tif", ".tiff"],
            VolumeFormat::Vdb => &[".vdb"],
            VolumeFormat::Sog => &[".sog"],
        }
    }

    /// The format a path's extension names, if any.
    pub fn from_path(path: &Path) -> Option<Self> {
        let n = lower_name(path);
        Self::ALL.into_iter().find(|f| f.extensions().iter().any(|e| n.ends_with(e)))
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
            VolumeFormat::Vdb => "OpenVDB (sparse: float and double grids)",
            VolumeFormat::Sog => "PolyMender signed octree (signs at iso 0)",
        }
    }
}

impl MeshFormat {
    /// The formats an extension selects (the ASCII variants are chosen by option), in the order
    /// help texts list them.
    pub const ALL: [MeshFormat; 6] =
        [MeshFormat::Ply, MeshFormat::Obj, MeshFormat::Stl, MeshFormat::Off, MeshFormat::Glb, MeshFormat::Gltf];

    /// The file extension that selects the format (lower case, without the dot); `None` for the
    /// ASCII variants.
    pub fn extension(self) -> Option<&'static str> {
        match self {
            MeshFormat::Ply => Some("ply"),
            MeshFormat::Obj => Some("obj"),
            MeshFormat::Stl => Some("stl"),
            MeshFormat::Off => Some("off"),
            MeshFormat::Glb => Some("glb"),
            MeshFormat::Gltf => Some("gltf"),
            MeshFormat::PlyAscii | MeshFormat::StlAscii => None,
        }
    }

    /// Whether [`read_mesh`](crate::read_mesh) reads the format (glTF is written only).
    pub fn is_readable(self) -> bool {
        !matches!(self, MeshFormat::Glb | MeshFormat::Gltf)
    }

    /// The format a path's extension names, if any.
    pub fn from_path(path: &Path) -> Option<Self> {
        let n = lower_name(path);
        let ext = n.rsplit_once('.').map(|(_, e)| e)?;
        Self::ALL.into_iter().find(|f| f.extension() == Some(ext))
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_extension_names_its_format() {
        for f in VolumeFormat::ALL {
            for e in f.extensions() {
                assert_eq!(VolumeFormat::from_path(Path::new(&format!("a/B{}", e.to_uppercase()))), Some(f), "{e}");
            }
        }
        for f in MeshFormat::ALL {
            let e = f.extension().unwrap();
            assert_eq!(MeshFormat::from_path(Path::new(&format!("m.{e}"))), Some(f));
        }
        assert_eq!(VolumeFormat::from_path(Path::new("x.gz")), None);
        assert_eq!(MeshFormat::from_path(Path::new("x.nrrd")), None);
    }
}
