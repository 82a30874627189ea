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

/// Binary PLY files end their vertex block on a multiple of this many bytes (the header is
/// padded with blank `comment` lines): the streamed writer then writes the faces in place and
/// inserts the header and vertices in front of them at the end (`FALLOC_FL_INSERT_RANGE`
/// shifts whole filesystem blocks), rather than copying the larger face block.
pub const VERTEX_BLOCK_END: u64 = 4096;

/// The header of a PLY file: `faces` triangles and quads as one `face` element. A binary
/// header is padded so that it and the vertex block end on [`VERTEX_BLOCK_END`].
fn header(vertices: usize, faces: usize, normals: bool, data: &MeshData, ascii: bool) -> String {
    use std::fmt::Write as _;
    let format = if ascii { "ascii" } else { "binary_little_endian" };
    let head = format!("ply\nformat {format} 1.0\ncomment isoforge {}\n", env!("CARGO_PKG_VERSION"));
    let mut h = format!("element vertex {vertices}\nproperty float x\nproperty float y\nproperty float z\n");
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
    if ascii {
        return head + &h;
    }
    let stride = 12 * (1 + normals as u64) + 3 * data.colors.is_some() as u64 + 4 * data.scalars.len() as u64;
    let end = (head.len() + h.len()) as u64 + vertices as u64 * stride;
    head + &padding(end) + &h
}

/// Blank `comment` lines (at most 72 bytes each) that bring `end` to a multiple of
/// [`VERTEX_BLOCK_END`]; a line takes at least 8 bytes (`comment` and its newline).
fn padding(end: u64) -> String {
    const LINE: usize = 64;
    let mut pad = ((VERTEX_BLOCK_END - end % VERTEX_BLOCK_END) % VERTEX_BLOCK_END) as usize;
    if (1..8).contains(&pad) {
        pad += VERTEX_BLOCK_END as usize;
    }
    let mut lines = vec![LINE; pad / LINE];
    match (pad % LINE, lines.last_mut()) {
        (0, _) => {}
        (r @ 8.., _) => lines.push(r),
        (r, Some(last)) => *last += r,
        (_, None) => unreachable!("a padding under 8 bytes is raised by a block"),
    }
    lines.iter().map(|&n| format!("comment{}\n", " ".repeat(n - 8))).collect()
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
        for q in &mesh.quads {
            writeln!(w, "4 {} {} {} {}", q[0], q[1], q[2], q[3])?;
        }
        return Ok(());
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

/// A binary PLY written as the mesh is produced ([`isoforge::mesh::MeshSink`]). The counts, hence
/// the header, are known only at the end. Where the filesystem shifts blocks in
/// (`FALLOC_FL_INSERT_RANGE`: ext4, XFS) the faces go straight into the output's temporary file and
/// [`PlyStream::finish`] inserts the header and the vertices (kept in a scratch file) in front of
/// them; elsewhere the faces go to a scratch file too and both are copied behind the header
/// (`copy_file_range`: a copy inside the kernel). The bytes are exactly [`write_ply`]'s for the
/// same mesh. Nothing appears at the path before the batch commits (or, for
/// [`PlyStream::create`], before `finish`); a stream dropped unfinished leaves nothing.
pub struct PlyStream<'a> {
    batch: Owner<'a>,
    path: PathBuf,
    /// The output's temporary file, or `None` when the faces are written into it in place (it is
    /// then `faces`' file).
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
        let mut main = batch.batch().take(path)?;
        main.reset().map_err(io_err)?;
        let verts = TempFile::create(path).map_err(io_err)?;
        let (main, faces) = if inserts_blocks(&mut main).map_err(io_err)? {
            (None, main)
        } else {
            (Some(main), TempFile::create(path).map_err(io_err)?)
        };
        Ok(PlyStream {
            batch,
            path: path.to_path_buf(),
            main,
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
        let isoforge::mesh::MeshBatch { positions, normals, triangles, quads } = batch;
        if self.normals == normals.is_empty() && !positions.is_empty() {
            return Err(io::Error::other("normals given to a stream created without them, or missing"));
        }
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

    /// Writes the header and the vertices in front of the faces (see [`PlyStream`]); then
    /// commits the file (a stream of its own) or hands it back to its batch. Returns the vertex
    /// and face counts.
    ///
    /// # Errors
    /// [`Error::Io`] naming the path when writing or committing fails (nothing is left behind).
    pub fn finish(self) -> Result<(u64, u64)> {
        use std::io::{Seek, SeekFrom};
        use std::os::unix::fs::FileExt;
        let PlyStream { batch, path, main, verts, mut faces, faces_packed, normals, vertices, triangles, .. } = self;
        let io_err = |source| Error::Io { path: path.clone(), source };
        let out = (|| {
            let too_many = || io::Error::other("more vertices or faces than this machine can count");
            let (v, f) = (
                usize::try_from(vertices).map_err(|_| too_many())?,
                usize::try_from(triangles).map_err(|_| too_many())?,
            );
            let head = header(v, f, normals, &MeshData::default(), false);
            faces.write_all(&faces_packed)?;
            let mut verts = verts.into_inner().map_err(io::IntoInnerError::into_error)?;
            let mut faces = faces.into_inner().map_err(io::IntoInnerError::into_error)?;
            let (h, vlen) = (head.len() as u64, verts.file_mut().metadata()?.len());
            let flen = faces.file_mut().metadata()?.len();
            let (mut out, scratch_faces) = match main {
                Some(main) => (main, Some(faces)),
                None => {
                    if flen > 0 {
                        insert_blocks(faces.file_mut(), h + vlen)?;
                    }
                    (faces, None)
                }
            };
            let (o, vf): (&std::fs::File, &std::fs::File) = (out.file_mut(), verts.file_mut());
            o.write_all_at(head.as_bytes(), 0)?;
            // The vertices in two halves and the scratch faces, at once (the walk is over: the
            // second core is free).
            let half = vlen / 2;
            std::thread::scope(|s| {
                let faces = scratch_faces.as_ref().map(|sf| {
                    let sf: &std::fs::File = sf.file();
                    s.spawn(move || copy_at(sf, 0, o, h + vlen, flen))
                });
                let first = s.spawn(|| copy_at(vf, 0, o, h, half));
                let rest = copy_at(vf, half, o, h + half, vlen - half);
                let joined = |j: std::thread::ScopedJoinHandle<'_, io::Result<()>>| {
                    j.join().unwrap_or_else(|_| Err(io::Error::other("copying into the output panicked")))
                };
                rest.and(joined(first)).and(faces.map_or(Ok(()), joined))
            })?;
            out.file_mut().seek(SeekFrom::Start(h + vlen + flen))?;
            Ok(out)
        })()
        .map_err(io_err)?;
        batch.batch().put(&path, out);
        if let Owner::Own(b) = batch {
            b.commit()?;
        }
        Ok((vertices, triangles))
    }
}

/// Whether `t`'s filesystem shifts whole blocks into a file (`FALLOC_FL_INSERT_RANGE` of
/// [`VERTEX_BLOCK_END`] bytes, tried on the empty file, which is emptied again). Never elsewhere
/// than Linux, nor with `ISOFORGE_PLY_COPY=1` (to exercise the copying path).
fn inserts_blocks(t: &mut TempFile) -> io::Result<bool> {
    if std::env::var_os("ISOFORGE_PLY_COPY").is_some_and(|v| v == "1") {
        return Ok(false);
    }
    #[cfg(target_os = "linux")]
    {
        t.file_mut().set_len(VERTEX_BLOCK_END)?;
        let ok = insert_blocks(t.file_mut(), VERTEX_BLOCK_END).is_ok();
        t.reset()?;
        Ok(ok)
    }
    #[cfg(not(target_os = "linux"))]
    Ok(false)
}

/// Shifts `f`'s contents `len` bytes further in (`len` a multiple of the filesystem block),
/// leaving a hole at the start.
#[cfg(target_os = "linux")]
fn insert_blocks(f: &std::fs::File, len: u64) -> io::Result<()> {
    use std::os::fd::AsRawFd;
    let len = libc::off_t::try_from(len).map_err(|_| io::Error::other("the vertex block is too long to insert"))?;
    // SAFETY: the descriptor is an open file borrowed for the call; no memory is passed.
    if unsafe { libc::fallocate(f.as_raw_fd(), libc::FALLOC_FL_INSERT_RANGE, 0, len) } == 0 {
        Ok(())
    } else {
        Err(io::Error::last_os_error())
    }
}

#[cfg(not(target_os = "linux"))]
fn insert_blocks(_: &std::fs::File, _: u64) -> io::Result<()> {
    Err(io::Error::from(io::ErrorKind::Unsupported))
}

/// Copies `len` bytes of `from` at `from_at` into `to` at `to_at` (neither file's position is
/// used or moved): in the kernel (`copy_file_range`) where it can, else through a buffer.
fn copy_at(from: &std::fs::File, from_at: u64, to: &std::fs::File, to_at: u64, len: u64) -> io::Result<()> {
    let mut done = 0u64;
    #[cfg(target_os = "linux")]
    {
        use std::os::fd::AsRawFd;
        while done < len {
            let (mut off_in, mut off_out) = ((from_at + done) as libc::loff_t, (to_at + done) as libc::loff_t);
            let want = usize::try_from(len - done).unwrap_or(usize::MAX).min(1 << 30);
            // SAFETY: both descriptors are open files borrowed for the call; the offsets are
            // locals the kernel updates; no memory of ours is read or written.
            let n =
                unsafe { libc::copy_file_range(from.as_raw_fd(), &mut off_in, to.as_raw_fd(), &mut off_out, want, 0) };
            if n > 0 {
                done += n as u64;
                continue;
            }
            if n == 0 {
                return Err(io::Error::new(io::ErrorKind::UnexpectedEof, "a scratch file ended early"));
            }
            let e = io::Error::last_os_error();
            match e.raw_os_error() {
                Some(libc::EINTR) => continue,
                // Not supported between these files: copy through a buffer below.
                Some(libc::ENOSYS | libc::EXDEV | libc::EINVAL | libc::EOPNOTSUPP | libc::EBADF) => break,
                _ => return Err(e),
            }
        }
    }
    use std::os::unix::fs::FileExt;
    let mut buf = vec![0u8; (1 << 20).min(len.saturating_sub(done)) as usize];
    while done < len {
        let n = buf.len().min((len - done) as usize);
        from.read_exact_at(&mut buf[..n], from_at + done)?;
        to.write_all_at(&buf[..n], to_at + done)?;
        done += n as u64;
    }
    Ok(())
}

impl isoforge::mesh::MeshSink for PlyStream<'_> {
    fn push(&mut self, batch: isoforge::mesh::MeshBatch<'_>) -> Result<(), isoforge::mesh::ExternalError> {
        PlyStream::push(self, batch).map_err(|e| {
            let msg = format!("{}: {}", self.path.display(), crate::error::os_reason(&e));
            msg.into()
        })
    }
}
