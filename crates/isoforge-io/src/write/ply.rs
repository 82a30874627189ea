//! PLY writer: binary little-endian (default) or ASCII; normals as nx, ny, nz when present.

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use isoforge::mesh::Mesh;

use super::copy::copy_span;
use super::text::{face_lines, write_lines};
use crate::atomic::TempFile;
use crate::attributes::MeshData;
use crate::error::{Error, Result};
use crate::Batch;

/// Writes `mesh` as PLY.
pub fn write_ply(w: &mut dyn Write, mesh: &Mesh, ascii: bool) -> io::Result<()> {
    write_ply_with(w, mesh, &MeshData::default(), ascii)
}

/// The header of a PLY file: `faces` triangles and quads as one `face` element.
pub(super) fn header(vertices: usize, faces: usize, normals: bool, data: &MeshData, ascii: bool) -> String {
    use std::fmt::Write as _;
    let format = if ascii { "ascii" } else { "binary_little_endian" };
    let mut h = format!(
        "ply\nformat {format} 1.0\ncomment isoforge {}\nelement vertex {vertices}\nproperty float x\nproperty float y\nproperty float z\n",
        env!("CARGO_PKG_VERSION")
    );
    if normals {
        h.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    if data.colors.is_some() {
        h.push_str("property uchar red\nproperty uchar green\nproperty uchar blue\n");
    }
    for (name, _) in &data.scalars {
        let name: String = name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '_' { c } else { '_' }).collect();
        let _ = writeln!(h, "property float {name}");
    }
    let _ = write!(h, "element face {faces}\nproperty list uchar int vertex_indices\n");
    if data.triangle_labels.is_some() {
        h.push_str("property int label\n");
    }
    h.push_str("end_header\n");
    h
}

/// Appends ASCII vertex lines for `points`, which start at vertex `at`: position, then the
/// vertex's normal (`normals[at..]`, when not empty), colour and scalars from `data`.
pub(super) fn ascii_vertex_lines(
    buf: &mut Vec<u8>,
    points: &[[f32; 3]],
    normals: &[[f32; 3]],
    data: &MeshData,
    at: usize,
) {
    for (j, p) in points.iter().enumerate() {
        let i = at + j;
        // Lines into a Vec cannot fail.
        let _ = write!(buf, "{} {} {}", p[0], p[1], p[2]);
        if let Some(n) = normals.get(i) {
            let _ = write!(buf, " {} {} {}", n[0], n[1], n[2]);
        }
        if let Some(c) = &data.colors {
            let _ = write!(buf, " {} {} {}", c[i][0], c[i][1], c[i][2]);
        }
        for (_, v) in &data.scalars {
            let _ = write!(buf, " {}", v[i]);
        }
        buf.push(b'\n');
    }
}

/// Faces packed per write (13 bytes a triangle, 17 a quad).
const FACES_PER_WRITE: usize = 1 << 16;

/// Positions (and normals, interleaved) as binary little-endian floats: one write of the cast
/// slice when there are no normals on a little-endian target, else packed through `buf`.
fn write_vertices(
    w: &mut dyn Write,
    positions: &[[f32; 3]],
    normals: &[[f32; 3]],
    buf: &mut Vec<u8>,
) -> io::Result<()> {
    if normals.is_empty() && cfg!(target_endian = "little") {
        return w.write_all(isoforge::grid::as_bytes(positions.as_flattened()));
    }
    let stride = if normals.is_empty() { 12 } else { 24 };
    for (i, chunk) in positions.chunks(FACES_PER_WRITE).enumerate() {
        buf.clear();
        buf.reserve(chunk.len() * stride);
        for (j, p) in chunk.iter().enumerate() {
            for c in p {
                buf.extend_from_slice(&c.to_le_bytes());
            }
            if let Some(n) = normals.get(i * FACES_PER_WRITE + j) {
                for c in n {
                    buf.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
        w.write_all(buf)?;
    }
    Ok(())
}

/// Polygons (`N` corners) as binary `uchar N, int × N` records, packed 64 Ki at a time into
/// `buf` (reused, so no whole-mesh staging).
fn write_faces<const N: usize>(w: &mut dyn Write, faces: &[[u32; N]], buf: &mut Vec<u8>) -> io::Result<()> {
    for chunk in faces.chunks(FACES_PER_WRITE) {
        buf.clear();
        pack_faces(buf, chunk);
        w.write_all(buf)?;
    }
    Ok(())
}

/// Appends polygons to `buf` as binary `uchar N, int × N` records (fixed-size records written in
/// place, no per-byte pushes).
fn pack_faces<const N: usize>(buf: &mut Vec<u8>, faces: &[[u32; N]]) {
    let record = 1 + 4 * N;
    let at = buf.len();
    buf.resize(at + faces.len() * record, 0);
    for (r, f) in buf[at..].chunks_exact_mut(record).zip(faces) {
        r[0] = N as u8;
        for (b, v) in r[1..].chunks_exact_mut(4).zip(f) {
            b.copy_from_slice(&(*v as i32).to_le_bytes());
        }
    }
}

/// Bytes of packed faces a [`PlyStream`] gathers before writing them (straight to the file,
/// past its buffered writer).
const FACE_BYTES_PER_WRITE: usize = 1 << 20;

/// Writes `mesh` as PLY with extra vertex properties: `red green blue` (uchar) for colours, then
/// one `float NAME` per scalar attribute. Triangles come first, then quads (4-gons), in one
/// `face` element; triangle labels need a mesh without quads.
pub fn write_ply_with(w: &mut dyn Write, mesh: &Mesh, data: &MeshData, ascii: bool) -> io::Result<()> {
    if !data.fits(mesh) {
        return Err(io::Error::other("vertex data does not have one entry per vertex"));
    }
    if data.triangle_labels.is_some() && !mesh.quads.is_empty() {
        return Err(io::Error::other("triangle labels on a mesh with quads (triangulate it first)"));
    }
    let normals = !mesh.normals.is_empty();
    let faces = mesh.triangles.len() + mesh.quads.len();
    w.write_all(header(mesh.positions.len(), faces, normals, data, ascii).as_bytes())?;
    if ascii {
        // Lines into a Vec cannot fail.
        write_lines(w, &mesh.positions, |buf, ps, at| ascii_vertex_lines(buf, ps, &mesh.normals, data, at))?;
        match &data.triangle_labels {
            Some(l) => write_lines(w, &mesh.triangles, |buf, ts, at| {
                for (j, t) in ts.iter().enumerate() {
                    let _ = writeln!(buf, "3 {} {} {} {}", t[0], t[1], t[2], l[at + j]);
                }
            })?,
            None => write_lines(w, &mesh.triangles, |buf, ts, _| face_lines(buf, ts))?,
        }
        return write_lines(w, &mesh.quads, |buf, qs, _| face_lines(buf, qs));
    }
    let mut buf = Vec::with_capacity(1 << 16);
    if data.colors.is_none() && data.scalars.is_empty() {
        write_vertices(w, &mesh.positions, &mesh.normals, &mut buf)?;
    } else {
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
        w.write_all(&buf)?;
    }
    match &data.triangle_labels {
        None => write_faces(w, &mesh.triangles, &mut buf)?,
        Some(l) => {
            buf.clear();
            for (t, l) in mesh.triangles.iter().zip(l) {
                buf.push(3);
                for v in t {
                    buf.extend_from_slice(&(*v as i32).to_le_bytes());
                }
                buf.extend_from_slice(&l.to_le_bytes());
                if buf.len() >= 1 << 16 {
                    w.write_all(&buf)?;
                    buf.clear();
                }
            }
            w.write_all(&buf)?;
        }
    }
    write_faces(w, &mesh.quads, &mut buf)
}

/// A binary PLY written as the mesh is produced ([`isoforge::mesh::MeshSink`]): vertices and
/// faces go to two anonymous scratch files beside the output (the counts, hence the header, are
/// known only at the end); [`PlyStream::finish`] writes the header into the output's temporary
/// file and appends both (`copy_file_range`: a copy inside the kernel, in two parallel halves).
/// The bytes are exactly [`write_ply`]'s for the same mesh. Nothing appears at the path before the
/// batch commits (or, for [`PlyStream::create`], before `finish`); a stream dropped unfinished
/// leaves nothing.
pub struct PlyStream<'a> {
    batch: Owner<'a>,
    path: PathBuf,
    main: Option<TempFile>,
    verts: io::BufWriter<TempFile>,
    faces: io::BufWriter<TempFile>,
    /// Reused packing buffer.
    buf: Vec<u8>,
    /// Faces packed but not yet written (written in pieces of [`FACE_BYTES_PER_WRITE`]).
    faces_packed: Vec<u8>,
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
        let main = batch.batch().take_empty(path)?;
        let verts = TempFile::create(path).map_err(io_err)?;
        let faces = TempFile::create(path).map_err(io_err)?;
        Ok(PlyStream {
            batch,
            path: path.to_path_buf(),
            main: Some(main),
            verts: io::BufWriter::with_capacity(1 << 20, verts),
            faces: io::BufWriter::with_capacity(1 << 20, faces),
            buf: Vec::new(),
            faces_packed: Vec::new(),
            normals,
            vertices: 0,
            triangles: 0,
        })
    }

    /// Appends vertices and polygons (triangles, then quads as 4-gons).
    ///
    /// # Errors
    /// Writing fails, or `normals` does not match the stream.
    pub fn push(&mut self, batch: isoforge::mesh::MeshBatch<'_>) -> io::Result<()> {
        super::stream::check_batch(self.main.is_none(), self.normals, &batch)?;
        let isoforge::mesh::MeshBatch { positions, normals, triangles, quads } = batch;
        write_vertices(&mut self.verts, positions, normals, &mut self.buf)?;
        // Faces are packed into one buffer across batches and written from it directly (the
        // buffered writer would copy them once more).
        pack_faces(&mut self.faces_packed, triangles);
        pack_faces(&mut self.faces_packed, quads);
        if self.faces_packed.len() >= FACE_BYTES_PER_WRITE {
            self.faces.write_all(&self.faces_packed)?;
            self.faces_packed.clear();
        }
        self.vertices += positions.len() as u64;
        self.triangles += (triangles.len() + quads.len()) as u64;
        Ok(())
    }

    /// Writes the header, appends the vertices and faces; then commits the file (a stream of its
    /// own) or hands it back to its batch. Returns the vertex and face counts.
    ///
    /// # Errors
    /// [`Error::Io`] naming the path when writing or committing fails (nothing is left behind).
    pub fn finish(mut self) -> Result<(u64, u64)> {
        use std::io::{Seek, SeekFrom};
        let path = self.path.clone();
        let io_err = |source| Error::Io { path: path.clone(), source };
        let mut main = self.main.take().ok_or_else(|| io_err(io::Error::other("the stream is finished")))?;
        let written = (|| {
            let too_many = || io::Error::other("more vertices or faces than this machine can count");
            let (v, f) = (
                usize::try_from(self.vertices).map_err(|_| too_many())?,
                usize::try_from(self.triangles).map_err(|_| too_many())?,
            );
            main.write_all(header(v, f, self.normals, &MeshData::default(), false).as_bytes())?;
            self.faces.write_all(&self.faces_packed)?;
            self.verts.flush()?;
            self.faces.flush()?;
            // Vertices after the header, faces after the vertices: both lengths are known, so
            // the body is copied as two equal halves at once (the walk is over; the second core
            // is free). Vertices ∥ faces was unbalanced: the faces are twice the vertices.
            let at = main.file_mut().stream_position()?;
            let (verts, faces) = (self.verts.get_mut().file_mut(), self.faces.get_mut().file_mut());
            let (vlen, flen) = (verts.metadata()?.len(), faces.metadata()?.len());
            let out: &std::fs::File = main.file_mut();
            let parts: [(&std::fs::File, u64); 2] = [(verts, vlen), (faces, flen)];
            let half = (vlen + flen) / 2;
            std::thread::scope(|s| {
                let tail = s.spawn(|| copy_span(&parts, out, at, half..vlen + flen));
                let head = copy_span(&parts, out, at, 0..half);
                head.and(tail.join().unwrap_or_else(|_| Err(io::Error::other("copying into the output panicked"))))
            })?;
            main.file_mut().seek(SeekFrom::Start(at + vlen + flen))?;
            Ok(())
        })();
        written.map_err(io_err)?;
        self.batch.batch().put(&path, main);
        if let Owner::Own(b) = std::mem::replace(&mut self.batch, Owner::Own(Batch::new())) {
            b.commit()?;
        }
        Ok((self.vertices, self.triangles))
    }
}

impl isoforge::mesh::MeshSink for PlyStream<'_> {
    fn push(&mut self, batch: isoforge::mesh::MeshBatch<'_>) -> Result<(), isoforge::mesh::ExternalError> {
        PlyStream::push(self, batch).map_err(|e| super::stream::sink_error(&self.path, &e))
    }
}
