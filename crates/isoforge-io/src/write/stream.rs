//! Writing a mesh as it is produced: [`MeshStream`] picks the streaming writer of a format, and
//! the pieces those writers share (the window of recent positions, scratch files appended at the
//! end, batch checks and errors).

use std::path::Path;

use crate::error::Result;
use crate::{Batch, MeshFormat};

/// The positions of the last batches of a streamed mesh, for writers that need a polygon's
/// corners: a batch's polygons use vertices of the batch before, their own and the next
/// ([`isoforge::mesh::MeshSink`]), so after the polygons of batch k − 1 are written (batch k has
/// arrived), those of batch k − 1 and later are kept.
#[derive(Default)]
pub(crate) struct PositionWindow {
    /// Positions of vertices `base..end`.
    positions: Vec<[f32; 3]>,
    base: u64,
    /// First vertex of the batch before the last one pushed, and of the last one.
    starts: [u64; 2],
    end: u64,
}

impl PositionWindow {
    /// Adds a batch's positions.
    pub(crate) fn push(&mut self, positions: &[[f32; 3]]) {
        self.positions.extend_from_slice(positions);
        self.starts = [self.starts[1], self.end];
        self.end += positions.len() as u64;
    }

    /// Lets go of the batches before the one before the last (call after writing the polygons
    /// of the batch before the last).
    pub(crate) fn release(&mut self) {
        let keep = self.starts[0];
        self.positions.drain(..(keep - self.base) as usize);
        self.base = keep;
    }

    /// The position of vertex `v`, if held.
    pub(crate) fn get(&self, v: u32) -> Option<[f32; 3]> {
        self.positions.get(usize::try_from((v as u64).checked_sub(self.base)?).ok()?).copied()
    }

    /// Vertices pushed so far.
    pub(crate) fn vertices(&self) -> u64 {
        self.end
    }

    /// Appends `quads` split as [`isoforge::mesh::Mesh::split_quad`] splits them to `out`.
    ///
    /// # Errors
    /// A corner the window does not hold.
    pub(crate) fn split_quads(&self, quads: &[[u32; 4]], out: &mut Vec<[u32; 3]>) -> std::io::Result<()> {
        for &q in quads {
            let p = q.map(|v| self.get(v));
            let [Some(a), Some(b), Some(c), Some(d)] = p else {
                return Err(missing_vertex(&q, &p));
            };
            out.extend(isoforge::mesh::split_quad(q, [a, b, c, d]));
        }
        Ok(())
    }
}

/// The scratch file in `part`, created beside `path` when first needed.
pub(crate) fn scratch<'p>(
    part: &'p mut Option<std::io::BufWriter<crate::atomic::TempFile>>,
    path: &Path,
) -> std::io::Result<&'p mut std::io::BufWriter<crate::atomic::TempFile>> {
    match part {
        Some(w) => Ok(w),
        None => Ok(part.insert(std::io::BufWriter::with_capacity(1 << 20, crate::atomic::TempFile::create(path)?))),
    }
}

/// Appends the scratch files in `parts` (in order, those created) to `main` at its position,
/// leaving it at the end; returns the bytes appended.
pub(crate) fn append_scratch(
    main: &mut crate::atomic::TempFile,
    parts: &mut [Option<std::io::BufWriter<crate::atomic::TempFile>>],
) -> std::io::Result<u64> {
    use std::io::{Seek, SeekFrom, Write};
    let mut files = Vec::new();
    for p in parts.iter_mut().flatten() {
        p.flush()?;
        let f = p.get_mut().file_mut();
        let len = f.metadata()?.len();
        files.push((&*f, len));
    }
    let total: u64 = files.iter().map(|(_, n)| n).sum();
    let at = main.file_mut().stream_position()?;
    super::copy::copy_span(&files, main.file_mut(), at, 0..total)?;
    main.file_mut().seek(SeekFrom::Start(at + total))?;
    Ok(total)
}

/// The error for the first of a polygon's `corners` that a writer does not hold (`got`: the
/// positions looked up).
pub(crate) fn missing_vertex(corners: &[u32], got: &[Option<[f32; 3]>]) -> std::io::Error {
    let v = corners.iter().zip(got).find(|(_, p)| p.is_none()).map_or(corners[0], |(v, _)| *v);
    std::io::Error::other(format!("a polygon refers to vertex {v}, which the mesh does not hold here"))
}

/// A stream's error as a [`isoforge::mesh::MeshSink`] reports it: the file, then the reason.
pub(crate) fn sink_error(path: &Path, e: &std::io::Error) -> isoforge::mesh::ExternalError {
    format!("{}: {}", path.display(), crate::error::os_reason(e)).into()
}

/// Checks a batch given to a stream: the stream is not finished, and the batch has one normal
/// per vertex when the stream writes normals (none otherwise).
pub(crate) fn check_batch(finished: bool, normals: bool, batch: &isoforge::mesh::MeshBatch<'_>) -> std::io::Result<()> {
    if finished {
        return Err(std::io::Error::other("the stream is finished"));
    }
    let want = if normals { batch.positions.len() } else { 0 };
    if batch.normals.len() != want {
        return Err(std::io::Error::other(format!(
            "{} normals for {} vertices given to a stream {} normals",
            batch.normals.len(),
            batch.positions.len(),
            if normals { "with" } else { "without" }
        )));
    }
    Ok(())
}

/// A mesh file written as the mesh is produced, batch by batch, in memory bounded by a few
/// batches: the formats whose streamed bytes are exactly the in-memory writer's (binary PLY,
/// STL, glTF (`.glb`, or `.gltf` + `.bin`), and the text formats OBJ, OFF and ASCII PLY).
// One per output file: its variants' sizes do not matter (and depend on the format features).
#[allow(clippy::large_enum_variant)]
pub enum MeshStream<'a> {
    /// Binary PLY ([`super::ply::PlyStream`]).
    #[cfg(feature = "ply")]
    Ply(super::ply::PlyStream<'a>),
    /// STL, binary or ASCII ([`super::stl::StlStream`]).
    #[cfg(feature = "stl")]
    Stl(super::stl::StlStream<'a>),
    /// OBJ, OFF or ASCII PLY (`TextStream`).
    #[cfg(any(feature = "obj", feature = "off", feature = "ply"))]
    Text(super::text::TextStream<'a>),
    /// glTF, a `.glb` or a `.gltf` and its `.bin` ([`super::gltf::GltfStream`]).
    Gltf(super::gltf::GltfStream<'a>),
}

impl<'a> MeshStream<'a> {
    /// Whether `format` can be written as a stream.
    pub fn streams(format: MeshFormat) -> bool {
        (cfg!(feature = "ply") && format == MeshFormat::Ply)
            || (cfg!(feature = "stl") && matches!(format, MeshFormat::Stl | MeshFormat::StlAscii))
            || (cfg!(feature = "obj") && format == MeshFormat::Obj)
            || (cfg!(feature = "off") && format == MeshFormat::Off)
            || (cfg!(feature = "ply") && format == MeshFormat::PlyAscii)
            || matches!(format, MeshFormat::Glb | MeshFormat::Gltf)
    }

    /// Starts writing `path` in `format` (with vertex normals when `normals` and the format has
    /// room for them) as an output of `batch`; `None` when the format cannot be streamed.
    ///
    /// # Errors
    /// As [`Batch::reserve`].
    pub fn create_in(batch: &'a Batch, path: &Path, format: MeshFormat, normals: bool) -> Result<Option<Self>> {
        Ok(match format {
            #[cfg(feature = "ply")]
            MeshFormat::Ply => Some(MeshStream::Ply(super::ply::PlyStream::create_in(batch, path, normals)?)),
            #[cfg(feature = "stl")]
            MeshFormat::Stl => Some(MeshStream::Stl(super::stl::StlStream::create_in(batch, path, false)?)),
            #[cfg(feature = "stl")]
            MeshFormat::StlAscii => Some(MeshStream::Stl(super::stl::StlStream::create_in(batch, path, true)?)),
            #[cfg(feature = "obj")]
            MeshFormat::Obj => Some(MeshStream::text(batch, path, super::text::TextFormat::Obj, normals)?),
            #[cfg(feature = "off")]
            MeshFormat::Off => Some(MeshStream::text(batch, path, super::text::TextFormat::Off, normals)?),
            #[cfg(feature = "ply")]
            MeshFormat::PlyAscii => Some(MeshStream::text(batch, path, super::text::TextFormat::PlyAscii, normals)?),
            MeshFormat::Glb | MeshFormat::Gltf => {
                Some(MeshStream::Gltf(super::gltf::GltfStream::create_in(batch, path, format, normals)?))
            }
            #[allow(unreachable_patterns)] // every format, with all format features on
            _ => None,
        })
    }

    #[cfg(any(feature = "obj", feature = "off", feature = "ply"))]
    fn text(batch: &'a Batch, path: &Path, format: super::text::TextFormat, normals: bool) -> Result<Self> {
        Ok(MeshStream::Text(super::text::TextStream::create_in(batch, path, format, normals)?))
    }

    /// Completes the file (see each stream's `finish`); returns the vertex and polygon counts
    /// written (STL and glTF: triangles, quads counted twice).
    ///
    /// # Errors
    /// [`crate::Error::Io`] naming the path when writing fails.
    pub fn finish(self) -> Result<(u64, u64)> {
        match self {
            #[cfg(feature = "ply")]
            MeshStream::Ply(s) => s.finish(),
            #[cfg(feature = "stl")]
            MeshStream::Stl(s) => s.finish(),
            #[cfg(any(feature = "obj", feature = "off", feature = "ply"))]
            MeshStream::Text(s) => s.finish(),
            MeshStream::Gltf(s) => s.finish(),
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
            #[cfg(any(feature = "obj", feature = "off", feature = "ply"))]
            MeshStream::Text(s) => isoforge::mesh::MeshSink::push(s, batch),
            MeshStream::Gltf(s) => isoforge::mesh::MeshSink::push(s, batch),
        }
    }
}
