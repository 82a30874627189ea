//! File formats for isoforge: volumes in, meshes in and out.
//!
//! Every reader opens regular files only and reads no further than the sizes it planned for,
//! checks header-declared sizes against [`Limits`] before allocating, rejects non-finite samples
//! naming the first one, and returns an [`Error`] naming the file, the field and the value
//! instead of panicking on bad bytes. Every writer goes through a [`Batch`]: outputs are checked
//! and created before any work, and appear whole, all together, or not at all.
#![warn(missing_docs)]
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used))]
// The readers share their helpers (headers, decoding, streams); a build with only some of the
// format features leaves the others' unused.
#![cfg_attr(
    not(all(
        feature = "raw",
        feature = "nrrd",
        feature = "nifti",
        feature = "metaimage",
        feature = "mrc",
        feature = "vtk",
        feature = "png",
        feature = "tiff",
        feature = "dicom"
    )),
    allow(dead_code)
)]

mod atomic;
pub mod attributes;
pub mod error;
mod file;
pub mod format;
pub mod limits;
mod memory;
pub mod read;
#[cfg(feature = "png")]
pub mod render;
pub mod write;

use std::path::{Path, PathBuf};

pub use atomic::{install_signal_cleanup, refuse_overwrite, same_file, write_atomic, Batch};
pub use attributes::{MeshData, NamedMesh};
pub use error::{Error, Result};
pub use format::{MeshFormat, VolumeFormat};
pub use limits::Limits;
pub use memory::keep_freed_memory;
#[cfg(feature = "raw")]
pub use read::raw::RawSpec;
#[cfg(feature = "sog")]
pub use read::skt::read_skt;
#[cfg(feature = "sog")]
pub use read::sog::read_sog;
#[cfg(feature = "vdb")]
pub use read::sparse::{dense_region, read_sparse, SparseFile};
pub use read::stream::VolumeReader;
#[cfg(feature = "tiff")]
pub use read::tiff::{read_tiff_rgb, RgbVolume};
#[cfg(feature = "vdb")]
pub use write::vdb::{GridClass, VdbWriteOptions};

use isoforge::grid::AnyGrid;
use isoforge::mesh::Mesh;

/// Reads a volume, choosing the reader by extension (raw files need [`read::raw::read_raw`]).
///
/// # Errors
/// [`Error::Unsupported`] for an unknown extension or a raw file; otherwise the reader's errors.
pub fn read_volume(path: &Path, limits: &Limits) -> Result<AnyGrid> {
    open_volume(path, limits)?.read_grid(limits)
}

/// Opens a volume (header parsed, samples not read yet), choosing the reader by extension. Its
/// size is checked against `limits`; pass `Limits::new(u64::MAX)` to stream it slab by slab.
///
/// # Errors
/// As [`read_volume`], for the header.
pub fn open_volume(path: &Path, limits: &Limits) -> Result<VolumeReader> {
    let _ = limits; // unused when no volume reader is compiled in
    if let Err(source) = std::fs::metadata(path) {
        return Err(Error::Io { path: path.to_path_buf(), source });
    }
    let unsupported = |detail: &str| Err(Error::Unsupported { path: path.to_path_buf(), detail: detail.to_string() });
    if path.is_dir() {
        // Image slices (PNG, TIFF) make a numbered stack; anything else is a DICOM series.
        #[cfg(any(feature = "png", feature = "tiff"))]
        {
            let images: Vec<std::path::PathBuf> = std::fs::read_dir(path)
                .map_err(|e| Error::Io { path: path.to_path_buf(), source: e })?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.is_file() && read::stack::is_image(p))
                .collect();
            if !images.is_empty() {
                return read::stack::open_image_stack(path, images, limits);
            }
        }
        #[cfg(feature = "dicom")]
        return read::dicom::open_dicom_dir(path, limits);
        #[cfg(not(feature = "dicom"))]
        return unsupported("a folder is read as a DICOM series, and DICOM support is not compiled in");
    }
    match VolumeFormat::from_path(path) {
        #[cfg(feature = "nrrd")]
        Some(VolumeFormat::Nrrd) => read::nrrd::open_nrrd(path, limits),
        #[cfg(feature = "nifti")]
        Some(VolumeFormat::Nifti) => read::nifti::open_nifti(path, limits),
        #[cfg(feature = "metaimage")]
        Some(VolumeFormat::MetaImage) => read::metaimage::open_metaimage(path, limits),
        #[cfg(feature = "mrc")]
        Some(VolumeFormat::Mrc) => read::mrc::open_mrc(path, limits),
        #[cfg(feature = "vtk")]
        Some(VolumeFormat::VtkLegacy) => read::vtk::open_vtk(path, limits),
        #[cfg(feature = "vtk")]
        Some(VolumeFormat::Vti) => read::vti::open_vti(path, limits),
        #[cfg(feature = "png")]
        Some(VolumeFormat::Png) => read::png::open_png(path, limits),
        #[cfg(feature = "tiff")]
        Some(VolumeFormat::Tiff) => read::tiff::open_tiff(path, limits),
        #[cfg(feature = "sog")]
        Some(VolumeFormat::Sog) => {
            let tree = read::sog::read_sog(path, limits)?;
            read::sog::sign_grid(path, &tree, limits)
        }
        Some(VolumeFormat::Raw) => unsupported("raw volumes need their layout: pass --dims X,Y,Z and --dtype"),
        Some(VolumeFormat::Vdb) => unsupported("an OpenVDB file is sparse: read it with read_sparse"),
        #[allow(unreachable_patterns)]
        Some(f) => unsupported(&format!("{} support is not compiled in", f.name())),
        None => unsupported(
            "unknown volume format (expected .nrrd, .nhdr, .nii, .nii.gz, .mha, .mhd, .mrc, .map, .ccp4, .vtk, .vti, .png, .tif, .tiff, .sog, or .raw with --dims/--dtype)",
        ),
    }
}

/// Reads a mesh, choosing the reader by extension.
///
/// # Errors
/// [`Error::Unsupported`] for an unknown extension; otherwise the reader's errors.
pub fn read_mesh(path: &Path, limits: &Limits) -> Result<Mesh> {
    let _ = limits; // unused when no mesh reader is compiled in
    if let Err(source) = std::fs::metadata(path) {
        return Err(Error::Io { path: path.to_path_buf(), source });
    }
    match MeshFormat::from_path(path) {
        #[cfg(feature = "ply")]
        Some(MeshFormat::Ply | MeshFormat::PlyAscii) => read::ply::read_ply(path, limits),
        #[cfg(feature = "obj")]
        Some(MeshFormat::Obj) => read::obj::read_obj(path, limits),
        #[cfg(feature = "stl")]
        Some(MeshFormat::Stl) => read::stl::read_stl(path, limits),
        #[cfg(feature = "off")]
        Some(MeshFormat::Off) => read::off::read_off(path, limits),
        _ => Err(Error::Unsupported {
            path: path.to_path_buf(),
            detail: "unknown mesh format (expected .ply, .obj, .stl or .off)".into(),
        }),
    }
}

/// The files reading the volume at `path` opens: the file itself and its detached data (NRRD
/// `data file`, MetaImage `ElementDataFile`, the `.img` beside a NIfTI `.hdr`), or every file of
/// a folder (a DICOM series or numbered slices). An output must be none of them
/// ([`Batch::refuse_inputs`]). A header that cannot be parsed contributes its own path only;
/// reading it reports the problem.
pub fn input_files(path: &Path) -> Vec<PathBuf> {
    let mut files = vec![path.to_path_buf()];
    if path.is_dir() {
        if let Ok(entries) = std::fs::read_dir(path) {
            files.extend(entries.filter_map(|e| e.ok().map(|e| e.path())).filter(|p| p.is_file()));
        }
        return files;
    }
    let detached = match VolumeFormat::from_path(path) {
        #[cfg(feature = "nrrd")]
        Some(VolumeFormat::Nrrd) => read::nrrd::data_file(path),
        #[cfg(feature = "metaimage")]
        Some(VolumeFormat::MetaImage) => read::metaimage::data_file(path),
        Some(VolumeFormat::Nifti) if path.to_string_lossy().to_ascii_lowercase().ends_with(".hdr") => {
            Some(path.with_extension("img"))
        }
        _ => None,
    };
    files.extend(detached);
    files
}

/// Writes a volume, choosing the format by extension: `.nrrd` (gzip-encoded), `.nii`, `.nii.gz`.
/// Atomic: a failed write leaves no file.
///
/// # Errors
/// As [`Batch::write_volume`] and [`Batch::commit`].
#[cfg(all(feature = "nrrd", feature = "nifti"))]
pub fn write_volume(path: &Path, grid: &AnyGrid) -> Result<()> {
    let batch = Batch::new();
    batch.write_volume(path, grid)?;
    batch.commit()
}

/// Writes a sparse grid to `path` atomically as an OpenVDB file; see [`Batch::write_sparse`].
///
/// # Errors
/// As [`Batch::write_sparse`] and [`Batch::commit`].
#[cfg(feature = "vdb")]
pub fn write_sparse<S: isoforge::grid::Sample>(
    path: &Path,
    grid: &isoforge::grid::SparseGrid<S>,
    opts: &VdbWriteOptions,
) -> Result<()> {
    let batch = Batch::new();
    batch.write_sparse(path, grid, opts)?;
    batch.commit()
}

/// Writes a signed octree to `path` atomically as a `.sog` file; see [`Batch::write_sog`].
///
/// # Errors
/// As [`Batch::write_sog`] and [`Batch::commit`].
#[cfg(feature = "sog")]
pub fn write_sog(path: &Path, tree: &isoforge::grid::SignedOctree) -> Result<()> {
    let batch = Batch::new();
    batch.write_sog(path, tree)?;
    batch.commit()
}

/// Writes `mesh` to `path` atomically in `format`.
///
/// # Errors
/// As [`Batch::write_mesh`] and [`Batch::commit`].
pub fn write_mesh(path: &Path, mesh: &Mesh, format: MeshFormat) -> Result<()> {
    write_mesh_with(path, mesh, &MeshData::default(), format)
}

/// [`write_mesh`] with mesh data (colours and scalars where the format has room for them: PLY
/// and glTF both, OBJ and OFF (COFF) colours, PLY triangle labels; STL positions only).
///
/// # Errors
/// As [`Batch::write_mesh`] and [`Batch::commit`].
pub fn write_mesh_with(path: &Path, mesh: &Mesh, data: &MeshData, format: MeshFormat) -> Result<()> {
    let batch = Batch::new();
    batch.write_mesh(path, mesh, data, format)?;
    batch.commit()
}

/// Renders `mesh` into a PNG file (atomic); see [`render::render`].
///
/// # Errors
/// As [`Batch::write_render`] and [`Batch::commit`].
#[cfg(feature = "png")]
pub fn write_render(path: &Path, mesh: &Mesh, colors: Option<&[[u8; 3]]>, opts: &render::RenderOptions) -> Result<()> {
    let batch = Batch::new();
    batch.write_render(path, mesh, colors, opts)?;
    batch.commit()
}

/// Writes several meshes into one OBJ file, one object (`o NAME`) each. Atomic.
///
/// # Errors
/// As [`Batch::write_obj_objects`] and [`Batch::commit`].
#[cfg(feature = "obj")]
pub fn write_obj_objects(path: &Path, meshes: &[NamedMesh]) -> Result<()> {
    let batch = Batch::new();
    batch.write_obj_objects(path, meshes)?;
    batch.commit()
}

/// Writes several meshes into one glTF file (`binary`: .glb; else .gltf beside a .bin of the same
/// stem), one mesh and node each. Both files appear together or not at all.
///
/// # Errors
/// As [`Batch::write_gltf`] and [`Batch::commit`].
pub fn write_gltf(path: &Path, meshes: &[NamedMesh], binary: bool) -> Result<()> {
    let batch = Batch::new();
    batch.write_gltf(path, meshes, binary)?;
    batch.commit()
}

/// Whether the glTF JSON at `gltf` names `bin` as its buffer (`"uri": "NAME.bin"`), i.e. `bin`
/// belongs to it and may be replaced along with it.
fn gltf_owns_buffer(gltf: &Path, bin: &Path) -> bool {
    let Some(name) = bin.file_name().map(|n| n.to_string_lossy().into_owned()) else { return false };
    let ctx = error::Ctx::new(gltf, "glTF");
    file::read_all(ctx, gltf, 64 << 20).is_ok_and(|json| {
        let json = String::from_utf8_lossy(&json);
        json.contains("\"uri\"") && json.contains(&format!("\"{name}\""))
    })
}

/// Refuses a `.gltf` at `path` whose `.bin` buffer exists and is not its own (a previous run's).
fn check_gltf_buffer(path: &Path, role: &str) -> Result<()> {
    let bin = MeshFormat::gltf_buffer(path);
    if bin.exists() && !gltf_owns_buffer(path, &bin) {
        return Err(Error::InvalidInput(format!(
            "{}: {role} writes its buffer to {}, which exists and is not the buffer of {}; remove it or choose another name",
            path.display(),
            bin.display(),
            path.display()
        )));
    }
    Ok(())
}

/// Writers that fill a [`Batch`]: nothing appears before [`Batch::commit`].
impl Batch {
    /// Reserves the files a mesh written to `path` in `format` produces ([`MeshFormat::files`]:
    /// a `.gltf` comes with a `.bin` buffer beside it). An existing `.bin` is replaced only when
    /// the existing `.gltf` names it as its buffer (a previous run); otherwise it belongs to
    /// something else and the write is refused.
    ///
    /// # Errors
    /// As [`Batch::reserve`]; [`Error::InvalidInput`] for an unrelated existing `.bin`.
    pub fn reserve_mesh(&self, path: &Path, format: MeshFormat, role: &str) -> Result<()> {
        if format == MeshFormat::Gltf {
            check_gltf_buffer(path, role)?;
        }
        for (file, file_role) in format.outputs(path, role) {
            self.reserve(&file, &file_role)?;
        }
        Ok(())
    }

    /// The `.bin` buffer of the `.gltf` at `path`, reserved with the `.gltf` when it is not yet
    /// (checked as [`Batch::reserve_mesh`] does).
    ///
    /// # Errors
    /// As [`Batch::reserve_mesh`].
    pub(crate) fn reserve_gltf_buffer(&self, path: &Path) -> Result<PathBuf> {
        let bin = MeshFormat::gltf_buffer(path);
        let reserved = self.paths();
        if reserved.contains(&bin) {
            return Ok(bin);
        }
        if reserved.iter().any(|p| p == path) {
            // The .gltf reserved alone: its buffer beside it, as `reserve_mesh` would have added.
            check_gltf_buffer(path, "the output")?;
            self.reserve(&bin, "the buffer of the output")?;
        } else {
            self.reserve_mesh(path, MeshFormat::Gltf, "the output")?;
        }
        Ok(bin)
    }

    /// Writes `mesh` (with `data`) to `path` in `format`.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when the data does not have one entry per vertex;
    /// [`Error::Unsupported`] when the format is not compiled in; as [`Batch::write`].
    pub fn write_mesh(&self, path: &Path, mesh: &Mesh, data: &MeshData, format: MeshFormat) -> Result<()> {
        if !data.fits(mesh) {
            return Err(Error::InvalidInput(format!("{}: vertex data does not match the mesh", path.display())));
        }
        match format {
            #[cfg(feature = "ply")]
            MeshFormat::Ply => self.write(path, |w| write::ply::write_ply_with(w, mesh, data, false)),
            #[cfg(feature = "ply")]
            MeshFormat::PlyAscii => self.write(path, |w| write::ply::write_ply_with(w, mesh, data, true)),
            #[cfg(feature = "obj")]
            MeshFormat::Obj => self.write(path, |w| write::obj::write_obj_with(w, mesh, data)),
            #[cfg(feature = "stl")]
            MeshFormat::Stl => self.write(path, |w| write::stl::write_stl(w, mesh)),
            #[cfg(feature = "stl")]
            MeshFormat::StlAscii => self.write(path, |w| write::stl::write_stl_ascii(w, mesh)),
            #[cfg(feature = "off")]
            MeshFormat::Off => self.write(path, |w| write::off::write_off_with(w, mesh, data)),
            MeshFormat::Glb | MeshFormat::Gltf => self.write_gltf(
                path,
                &[NamedMesh { name: write::gltf::SINGLE_MESH, mesh, data }],
                format == MeshFormat::Glb,
            ),
            #[allow(unreachable_patterns)]
            f => Err(Error::Unsupported {
                path: path.to_path_buf(),
                detail: format!("{} support is not compiled in", f.name()),
            }),
        }
    }

    /// Writes several meshes into one glTF file (`binary`: .glb; else .gltf and its .bin, see
    /// [`Batch::reserve_mesh`]), one mesh and node each.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for an empty mesh or an unrelated existing `.bin`; as [`Batch::write`].
    pub fn write_gltf(&self, path: &Path, meshes: &[NamedMesh], binary: bool) -> Result<()> {
        if let Some(m) = meshes.iter().find(|m| m.mesh.positions.is_empty() || !m.data.fits(m.mesh)) {
            return Err(Error::InvalidInput(format!(
                "{}: mesh {:?} is empty or its vertex data does not match",
                path.display(),
                m.name
            )));
        }
        if binary {
            return self.write(path, |w| write::gltf::write_glb(w, meshes));
        }
        let bin = self.reserve_gltf_buffer(path)?;
        let uri = write::gltf::buffer_uri(&bin);
        self.write(&bin, |w| write::gltf::write_gltf_bin(w, meshes))?;
        self.write(path, |w| write::gltf::write_gltf_json(w, meshes, &uri))
    }

    /// Writes several meshes into one OBJ file, one object (`o NAME`) each.
    ///
    /// # Errors
    /// As [`Batch::write`].
    #[cfg(feature = "obj")]
    pub fn write_obj_objects(&self, path: &Path, meshes: &[NamedMesh]) -> Result<()> {
        self.write(path, |w| write::obj::write_obj_objects(w, meshes))
    }

    /// Renders `mesh` into a PNG file; see [`render::render`].
    ///
    /// # Errors
    /// As [`Batch::write`].
    #[cfg(feature = "png")]
    pub fn write_render(
        &self,
        path: &Path,
        mesh: &Mesh,
        colors: Option<&[[u8; 3]]>,
        opts: &render::RenderOptions,
    ) -> Result<()> {
        let img = render::render(mesh, colors, opts);
        let size = opts.size.map(|s| s.clamp(1, render::MAX_SIDE));
        self.write(path, |w| render::write_png(w, &img, size))
    }

    /// Writes a sparse grid as a one-grid OpenVDB file (see [`write::vdb`]).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] naming `path` when the grid or options cannot be written (checked
    /// before any byte: [`write::vdb::check_vdb`]); as [`Batch::write`].
    #[cfg(feature = "vdb")]
    pub fn write_sparse<S: isoforge::grid::Sample>(
        &self,
        path: &Path,
        grid: &isoforge::grid::SparseGrid<S>,
        opts: &VdbWriteOptions,
    ) -> Result<()> {
        write::vdb::check_vdb(grid, opts).map_err(|e| Error::InvalidInput(format!("{}: {e}", path.display())))?;
        self.write(path, |w| write::vdb::write_vdb(w, grid, opts))
    }

    /// Writes a signed octree as a PolyMender `.sog` file (see [`write::sog`]).
    ///
    /// # Errors
    /// As [`Batch::write`].
    #[cfg(feature = "sog")]
    pub fn write_sog(&self, path: &Path, tree: &isoforge::grid::SignedOctree) -> Result<()> {
        self.write(path, |w| write::sog::write_sog(w, tree))
    }

    /// Writes TopoMender's skeleton file (see [`write::skt`]) for a root cube of `2^depth` cells.
    ///
    /// # Errors
    /// As [`Batch::write`].
    #[cfg(feature = "sog")]
    pub fn write_skt(&self, path: &Path, records: &[isoforge::mend::SkeletonRecord], depth: u32) -> Result<()> {
        self.write(path, |w| write::skt::write_skt(w, records, depth))
    }

    /// Writes a volume, choosing the format by extension: `.nrrd` (gzip-encoded), `.nii`, `.nii.gz`.
    ///
    /// # Errors
    /// [`Error::Unsupported`] for another extension, or NIfTI-1 dims above 32767; as [`Batch::write`].
    #[cfg(all(feature = "nrrd", feature = "nifti"))]
    pub fn write_volume(&self, path: &Path, grid: &AnyGrid) -> Result<()> {
        let unsupported = |detail: String| Err(Error::Unsupported { path: path.to_path_buf(), detail });
        match VolumeFormat::from_path(path) {
            Some(VolumeFormat::Nrrd) => self.write(path, |w| write::volume::write_nrrd(w, grid, true)),
            Some(VolumeFormat::Nifti) => {
                let dims = grid.lattice().dims();
                if dims.iter().any(|&d| d > i16::MAX as u32) {
                    return unsupported(format!(
                        "dims {dims:?}: NIfTI-1 stores dims as 16-bit integers (at most 32767)"
                    ));
                }
                let name = path.to_string_lossy().to_ascii_lowercase();
                if name.ends_with(".hdr") {
                    return unsupported("write a single-file .nii or .nii.gz (not .hdr/.img pairs)".into());
                }
                self.write(path, |w| write::volume::write_nifti(w, grid, name.ends_with(".gz")))
            }
            _ => unsupported("volumes are written as .nrrd, .nii or .nii.gz".into()),
        }
    }
}
