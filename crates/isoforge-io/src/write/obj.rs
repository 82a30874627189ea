//! OBJ writer: `v`, `vn` when normals exist, and 1-based `f` (with `//n` references): triangles,
//! then quads. In memory (lines formatted in parallel pieces) or as the mesh is produced
//! ([`ObjStream`]).

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use isoforge::mesh::{Mesh, MeshBatch};

use super::stream::{append_scratch, scratch};
use super::text::{write_lines, LINES_PER_PIECE, PIECES_PER_WINDOW};
use crate::atomic::TempFile;
use crate::attributes::MeshData;
use crate::error::{Error, Result};
use crate::Batch;

/// The first line.
fn header() -> String {
    format!("# isoforge {}\n", env!("CARGO_PKG_VERSION"))
}

/// Appends `TAG x y z` lines (`TAG x y z r g b` with colours, as fractions of 255), the floats
/// as Rust prints them (shortest round trip).
fn vertex_lines(buf: &mut Vec<u8>, tag: &str, points: &[[f32; 3]], colors: Option<&[[u8; 3]]>) {
    for (i, p) in points.iter().enumerate() {
        // Writing into a Vec cannot fail.
        let _ = match colors {
            Some(c) => {
                let [r, g, b] = c[i].map(|x| x as f32 / 255.0);
                writeln!(buf, "{tag} {} {} {} {r} {g} {b}", p[0], p[1], p[2])
            }
            None => writeln!(buf, "{tag} {} {} {}", p[0], p[1], p[2]),
        };
    }
}

/// Appends `f` lines for polygons of `N` corners, vertex `v` written as `v + base_v + 1`, and
/// `//n` references `v + base_n + 1` when `with_n`.
fn face_lines<const N: usize>(buf: &mut Vec<u8>, faces: &[[u32; N]], base_v: u64, base_n: u64, with_n: bool) {
    let mut num = itoa::Buffer::new();
    for f in faces {
        buf.push(b'f');
        for &v in f {
            buf.push(b' ');
            buf.extend_from_slice(num.format(v as u64 + base_v + 1).as_bytes());
            if with_n {
                buf.extend_from_slice(b"//");
                buf.extend_from_slice(num.format(v as u64 + base_n + 1).as_bytes());
            }
        }
        buf.push(b'\n');
    }
}

/// Writes `mesh` as OBJ.
pub fn write_obj(w: &mut dyn Write, mesh: &Mesh) -> io::Result<()> {
    write_obj_with(w, mesh, &MeshData::default())
}

/// Writes `mesh` as OBJ with vertex colours (`v x y z r g b`, the common extension read by
/// MeshLab, Blender and trimesh). Scalar attributes have no OBJ form and are not written.
pub fn write_obj_with(w: &mut dyn Write, mesh: &Mesh, data: &MeshData) -> io::Result<()> {
    w.write_all(header().as_bytes())?;
    write_object(w, mesh, data, 0, 0)
}

/// One mesh's `v`, `vn` and `f` lines, indices offset by the vertices and normals written before.
fn write_object(w: &mut dyn Write, mesh: &Mesh, data: &MeshData, base_v: usize, base_n: usize) -> io::Result<()> {
    if !data.fits(mesh) {
        return Err(io::Error::other("mesh data does not have one entry per vertex"));
    }
    let colors = data.colors.as_deref();
    write_lines(w, &mesh.positions, |buf, p, at| vertex_lines(buf, "v", p, colors.map(|c| &c[at..at + p.len()])))?;
    write_lines(w, &mesh.normals, |buf, n, _| vertex_lines(buf, "vn", n, None))?;
    let (bv, bn, with_n) = (base_v as u64, base_n as u64, !mesh.normals.is_empty());
    write_lines(w, &mesh.triangles, |buf, t, _| face_lines(buf, t, bv, bn, with_n))?;
    write_lines(w, &mesh.quads, |buf, q, _| face_lines(buf, q, bv, bn, with_n))
}

/// Writes several meshes into one OBJ, each an object (`o NAME`) with its own vertices
/// (colours as in [`write_obj_with`]); indices continue across objects as OBJ requires.
pub fn write_obj_objects(w: &mut dyn Write, meshes: &[crate::attributes::NamedMesh]) -> io::Result<()> {
    w.write_all(header().as_bytes())?;
    let (mut base_v, mut base_n) = (0usize, 0usize);
    for m in meshes {
        let name: String = m.name.chars().map(|c| if c.is_whitespace() { '_' } else { c }).collect();
        writeln!(w, "o {name}")?;
        write_object(w, m.mesh, m.data, base_v, base_n)?;
        base_v += m.mesh.positions.len();
        base_n += m.mesh.normals.len();
    }
    Ok(())
}

/// An OBJ written as the mesh is produced ([`isoforge::mesh::MeshSink`]): `v` lines go straight
/// into the output's temporary file, `vn`, triangle and quad lines into scratch files appended
/// at the end (OBJ numbers vertices globally, so no batch is kept). The bytes are exactly
/// [`write_obj`]'s for the same mesh. Nothing appears at the path before the batch commits; a
/// stream dropped unfinished leaves nothing.
pub struct ObjStream<'a> {
    batch: &'a Batch,
    path: PathBuf,
    main: Option<TempFile>,
    /// `vn`, triangle and quad lines (created when first needed).
    parts: [Option<io::BufWriter<TempFile>>; 3],
    normals: bool,
    /// Batches gathered since the last write.
    held: Mesh,
    vertices: u64,
    polygons: u64,
}

impl<'a> ObjStream<'a> {
    /// Starts writing `path` (with `vn` lines when `normals`) as an output of `batch` (reserved
    /// there first if needed); the batch's commit moves it into place.
    ///
    /// # Errors
    /// As [`Batch::reserve`].
    pub fn create_in(batch: &'a Batch, path: &Path, normals: bool) -> Result<Self> {
        let io_err = |source| Error::Io { path: path.to_path_buf(), source };
        let mut main = batch.take(path)?;
        main.reset().and_then(|()| main.write_all(header().as_bytes())).map_err(io_err)?;
        Ok(ObjStream {
            batch,
            path: path.to_path_buf(),
            main: Some(main),
            parts: [None, None, None],
            normals,
            held: Mesh::default(),
            vertices: 0,
            polygons: 0,
        })
    }

    /// Appends a batch's vertices (and normals) and polygons.
    ///
    /// # Errors
    /// Writing fails, or `normals` does not match the stream.
    pub fn push(&mut self, batch: MeshBatch<'_>) -> io::Result<()> {
        super::stream::check_batch(self.main.is_none(), self.normals, &batch)?;
        let MeshBatch { positions, normals, triangles, quads } = batch;
        // Batches (a slab's worth) are gathered into windows, whose lines are formatted in
        // parallel pieces.
        let held = &mut self.held;
        held.positions.extend_from_slice(positions);
        held.normals.extend_from_slice(normals);
        held.triangles.extend_from_slice(triangles);
        held.quads.extend_from_slice(quads);
        self.vertices += positions.len() as u64;
        self.polygons += (triangles.len() + quads.len()) as u64;
        if held.positions.len() + held.triangles.len() + held.quads.len() >= LINES_PER_PIECE * PIECES_PER_WINDOW {
            self.write_held()?;
        }
        Ok(())
    }

    /// Writes the lines of the gathered batches: `v` into the output, the others aside.
    fn write_held(&mut self) -> io::Result<()> {
        let main = self.main.as_mut().ok_or_else(|| io::Error::other("the stream is finished"))?;
        let (held, n) = (&self.held, self.normals);
        write_lines(main, &held.positions, |buf, p, _| vertex_lines(buf, "v", p, None))?;
        let [vn, tri, quad] = &mut self.parts;
        if !held.normals.is_empty() {
            write_lines(scratch(vn, &self.path)?, &held.normals, |buf, p, _| vertex_lines(buf, "vn", p, None))?;
        }
        if !held.triangles.is_empty() {
            write_lines(scratch(tri, &self.path)?, &held.triangles, |buf, t, _| face_lines(buf, t, 0, 0, n))?;
        }
        if !held.quads.is_empty() {
            write_lines(scratch(quad, &self.path)?, &held.quads, |buf, q, _| face_lines(buf, q, 0, 0, n))?;
        }
        self.held.clear();
        Ok(())
    }

    /// Appends the `vn`, triangle and quad lines; then hands the file back to its batch. Returns
    /// the vertex and polygon counts.
    ///
    /// # Errors
    /// [`Error::Io`] naming the path when writing fails (nothing is left behind).
    pub fn finish(mut self) -> Result<(u64, u64)> {
        let written = self.write_held().and_then(|()| {
            let main = self.main.as_mut().ok_or_else(|| io::Error::other("the stream is finished"))?;
            append_scratch(main, &mut self.parts).map(|_| ())
        });
        written.map_err(|source| Error::Io { path: self.path.clone(), source })?;
        // Only a complete file goes back to the batch (a failed one is dropped, and the batch
        // then refuses to commit the output it never got).
        if let Some(main) = self.main.take() {
            self.batch.put(&self.path, main);
        }
        Ok((self.vertices, self.polygons))
    }
}

impl isoforge::mesh::MeshSink for ObjStream<'_> {
    fn push(&mut self, batch: MeshBatch<'_>) -> std::result::Result<(), isoforge::mesh::ExternalError> {
        ObjStream::push(self, batch).map_err(|e| super::stream::sink_error(&self.path, &e))
    }
}
