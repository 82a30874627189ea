//! PLY writer: binary little-endian (default) or ASCII; normals as nx, ny, nz when present.

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use isoforge::mesh::Mesh;

use crate::atomic::TempFile;
use crate::attributes::MeshData;
use crate::error::{Error, Result};
use crate::Batch;

/// Writes `mesh` as PLY.
pub fn write_ply(w: &mut dyn Write, mesh: &Mesh, ascii: bool) -> io::Result<()> {
    write_ply_with(w, mesh, &MeshData::default(), ascii)
}

/// Writes `mesh` as PLY with extra vertex properties: `red green blue` (uchar) for colours, then
/// one `float NAME` per scalar attribute.
pub fn write_ply_with(w: &mut dyn Write, mesh: &Mesh, data: &MeshData, ascii: bool) -> io::Result<()> {
    if !data.fits(mesh) {
        return Err(io::Error::other("vertex data does not have one entry per vertex"));
    }
    let normals = !mesh.normals.is_empty();
    let format = if ascii { "ascii" } else { "binary_little_endian" };
    write!(w, "ply\nformat {format} 1.0\ncomment isoforge {}\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
        env!("CARGO_PKG_VERSION"), mesh.positions.len())?;
    if normals {
        w.write_all(b"property float nx\nproperty float ny\nproperty float nz\n")?;
    }
    if data.colors.is_some() {
        w.write_all(b"property uchar red\nproperty uchar green\nproperty uchar blue\n")?;
    }
    for (name, _) in &data.scalars {
        let name: String = name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '_' { c } else { '_' }).collect();
        writeln!(w, "property float {name}")?;
    }
    write!(w, "element face {}\nproperty list uchar int vertex_indices\n", mesh.triangles.len())?;
    if data.triangle_labels.is_some() {
        w.write_all(b"property int label\n")?;
    }
    w.write_all(b"end_header\n")?;
    if ascii {
        for (i, p) in mesh.positions.iter().enumerate() {
            write!(w, "{} {} {}", p[0], p[1], p[2])?;
            if normals {
                let n = mesh.normals[i];
                write!(w, " {} {} {}", n[0], n[1], n[2])?;
            }
            if let Some(c) = &data.colors {
                write!(w, " {} {} {}", c[i][0], c[i][1], c[i][2])?;
            }
            for (_, v) in &data.scalars {
                write!(w, " {}", v[i])?;
            }
            w.write_all(b"\n")?;
        }
        for (k, t) in mesh.triangles.iter().enumerate() {
            match &data.triangle_labels {
                Some(l) => writeln!(w, "3 {} {} {} {}", t[0], t[1], t[2], l[k])?,
                None => writeln!(w, "3 {} {} {}", t[0], t[1], t[2])?,
            }
        }
    } else {
        let mut buf = Vec::with_capacity(1 << 16);
        for (i, p) in mesh.positions.iter().enumerate() {
            for c in p {
                buf.extend_from_slice(&c.to_le_bytes());
            }
            if normals {
                for c in mesh.normals[i] {
                    buf.extend_from_slice(&c.to_le_bytes());
                }
            }
            if let Some(c) = &data.colors {
                buf.extend_from_slice(&c[i]);
            }
            for (_, v) in &data.scalars {
                buf.extend_from_slice(&v[i].to_le_bytes());
            }
            if buf.len() >= 1 << 16 {
                w.write_all(&buf)?;
                buf.clear();
            }
        }
        for (k, t) in mesh.triangles.iter().enumerate() {
            buf.push(3);
            for v in t {
                buf.extend_from_slice(&(*v as i32).to_le_bytes());
            }
            if let Some(l) = &data.triangle_labels {
                buf.extend_from_slice(&l[k].to_le_bytes());
            }
            if buf.len() >= 1 << 16 {
                w.write_all(&buf)?;
                buf.clear();
            }
        }
        w.write_all(&buf)?;
    }
    Ok(())
}

/// Width the streamed header reserves for each count, so the counts can be written at the end.
const COUNT_WIDTH: usize = 20;

/// A binary PLY written as the mesh is produced ([`isoforge::mesh::MeshSink`]): vertices go to the
/// output's temporary file, triangles to an anonymous scratch file beside it;
/// [`PlyStream::finish`] appends the triangles and writes the counts into the header's reserved
/// space. Nothing appears at the path before the batch commits (or, for
/// [`PlyStream::create`], before `finish`); a stream dropped unfinished leaves nothing.
pub struct PlyStream<'a> {
    batch: Owner<'a>,
    path: PathBuf,
    main: Option<io::BufWriter<TempFile>>,
    tris: io::BufWriter<TempFile>,
    normals: bool,
    vertices: u64,
    triangles: u64,
}

enum Owner<'a> {
    Own(Batch),
    Shared(&'a Batch),
}

impl Owner<'_> {
    fn batch(&self) -> &Batch {
        match self {
            Owner::Own(b) => b,
            Owner::Shared(b) => b,
        }
    }
}

fn stream_header(vertices: u64, triangles: u64, normals: bool) -> String {
    let mut h = format!(
        "ply\nformat binary_little_endian 1.0\ncomment isoforge {}\nelement vertex {:<w$}\nproperty float x\nproperty float y\nproperty float z\n",
        env!("CARGO_PKG_VERSION"),
        vertices,
        w = COUNT_WIDTH
    );
    if normals {
        h.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    h.push_str(&format!(
        "element face {:<w$}\nproperty list uchar int vertex_indices\nend_header\n",
        triangles,
        w = COUNT_WIDTH
    ));
    h
}

impl PlyStream<'static> {
    /// Starts writing `path` on its own (committed by [`PlyStream::finish`]).
    ///
    /// # Errors
    /// As [`Batch::reserve`].
    pub fn create(path: &Path, normals: bool) -> Result<Self> {
        let batch = Batch::new();
        batch.reserve(path, "the output")?;
        Self::start(Owner::Own(batch), path, normals)
    }
}

impl<'a> PlyStream<'a> {
    /// Starts writing `path` as an output of `batch` (reserved there first if needed); the
    /// batch's commit moves it into place.
    ///
    /// # Errors
    /// As [`Batch::reserve`].
    pub fn create_in(batch: &'a Batch, path: &Path, normals: bool) -> Result<Self> {
        Self::start(Owner::Shared(batch), path, normals)
    }

    fn start(batch: Owner<'a>, path: &Path, normals: bool) -> Result<Self> {
        let io_err = |source| Error::Io { path: path.to_path_buf(), source };
        let mut main = batch.batch().take(path)?;
        main.reset().map_err(io_err)?;
        let tris = TempFile::create(path).map_err(io_err)?;
        let mut s = PlyStream {
            batch,
            path: path.to_path_buf(),
            main: Some(io::BufWriter::with_capacity(1 << 20, main)),
            tris: io::BufWriter::with_capacity(1 << 20, tris),
            normals,
            vertices: 0,
            triangles: 0,
        };
        s.main_mut().and_then(|m| m.write_all(stream_header(0, 0, normals).as_bytes())).map_err(io_err)?;
        Ok(s)
    }

    fn main_mut(&mut self) -> io::Result<&mut io::BufWriter<TempFile>> {
        self.main.as_mut().ok_or_else(|| io::Error::other("the stream is finished"))
    }

    /// Appends vertices and polygons.
    ///
    /// # Errors
    /// Writing fails, or `normals` does not match the stream.
    pub fn push(&mut self, batch: isoforge::mesh::MeshBatch<'_>) -> io::Result<()> {
        let isoforge::mesh::MeshBatch { positions, normals, triangles, quads } = batch;
        if self.normals == normals.is_empty() && !positions.is_empty() {
            return Err(io::Error::other("normals given to a stream created without them, or missing"));
        }
        let mut buf = Vec::with_capacity(positions.len() * 24);
        for (i, p) in positions.iter().enumerate() {
            for c in p {
                buf.extend_from_slice(&c.to_le_bytes());
            }
            if self.normals {
                for c in normals[i] {
                    buf.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
        self.main_mut()?.write_all(&buf)?;
        buf.clear();
        for t in triangles {
            buf.push(3);
            for v in t {
                buf.extend_from_slice(&(*v as i32).to_le_bytes());
            }
        }
        for q in quads {
            buf.push(4);
            for v in q {
                buf.extend_from_slice(&(*v as i32).to_le_bytes());
            }
        }
        self.tris.write_all(&buf)?;
        self.vertices += positions.len() as u64;
        self.triangles += (triangles.len() + quads.len()) as u64;
        Ok(())
    }

    /// Appends the triangles and writes the counts; then commits the file (a stream of its own)
    /// or hands it back to its batch. Returns the vertex and triangle counts.
    ///
    /// # Errors
    /// [`Error::Io`] naming the path when writing or committing fails (nothing is left behind).
    pub fn finish(mut self) -> Result<(u64, u64)> {
        use std::io::{Seek, SeekFrom};
        let path = self.path.clone();
        let io_err = |source| Error::Io { path: path.clone(), source };
        let mut main = self.main.take().ok_or_else(|| io_err(io::Error::other("the stream is finished")))?;
        let mut file = (|| {
            self.tris.flush()?;
            let tris = self.tris.get_mut();
            tris.seek(SeekFrom::Start(0))?;
            io::copy(tris, &mut main)?;
            let mut file = main.into_inner().map_err(|e| e.into_error())?;
            file.seek(SeekFrom::Start(0))?;
            file.write_all(stream_header(self.vertices, self.triangles, self.normals).as_bytes())?;
            Ok(file)
        })()
        .map_err(io_err)?;
        file.seek(SeekFrom::End(0)).map_err(io_err)?;
        let batch = self.batch.batch();
        batch.put(&path, file);
        if let Owner::Own(b) = std::mem::replace(&mut self.batch, Owner::Own(Batch::new())) {
            b.commit()?;
        }
        Ok((self.vertices, self.triangles))
    }
}

impl isoforge::mesh::MeshSink for PlyStream<'_> {
    fn push(&mut self, batch: isoforge::mesh::MeshBatch<'_>) -> Result<(), isoforge::mesh::ExternalError> {
        PlyStream::push(self, batch).map_err(|e| {
            let msg = format!("{}: {}", self.path.display(), crate::error::os_reason(&e));
            msg.into()
        })
    }
}
