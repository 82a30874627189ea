//! Binary STL writer (facet normals from the triangle's winding), in memory or as the mesh is
//! produced ([`StlStream`]). STL holds triangles only: a mesh's quads are written split along
//! their shorter diagonal ([`Mesh::all_triangles`]), after its triangles.

use std::io::{self, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use isoforge::mesh::{Mesh, MeshBatch};
use rayon::prelude::*;

use super::stream::{append_scratch, missing_vertex, scratch, PositionWindow};
use crate::atomic::TempFile;
use crate::error::{Error, Result};
use crate::Batch;

/// Bytes of one binary facet: normal, three corners (12 little-endian floats), attribute count.
const FACET: usize = 50;

/// Facets packed per write: 1.6 MB, above the buffered writer's capacity, so the packed bytes go
/// straight to the file instead of being copied once more.
const FACETS_PER_WRITE: usize = 1 << 15;

/// The unit normal of triangle `a b c` from its winding (zero when degenerate).
fn facet_normal([a, b, c]: [[f32; 3]; 3]) -> [f32; 3] {
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if len > 0.0 {
        n.map(|x| x / len)
    } else {
        n
    }
}

/// The 80-byte header and the facet count.
fn header(facets: u64) -> io::Result<[u8; 84]> {
    let n = u32::try_from(facets).map_err(|_| io::Error::other("more triangles than binary STL can count"))?;
    let mut h = [0u8; 84];
    let tag = format!("isoforge {} binary STL", env!("CARGO_PKG_VERSION"));
    h[..tag.len()].copy_from_slice(tag.as_bytes());
    h[80..].copy_from_slice(&n.to_le_bytes());
    Ok(h)
}

/// The first and last lines of an ASCII STL.
const SOLID: &str = "solid isoforge\n";
const END_SOLID: &str = "endsolid isoforge\n";

/// Appends the facets of `triangles` to `buf`, corners from `corner`: as text (`ascii`), or as
/// fixed-size binary records written in place.
fn pack_facets(
    buf: &mut Vec<u8>,
    triangles: &[[u32; 3]],
    corner: impl Fn(u32) -> Option<[f32; 3]> + Sync,
    ascii: bool,
) -> io::Result<()> {
    if ascii {
        // Text formatting is most of the cost: pieces formatted in parallel, appended in order.
        let pieces: Vec<io::Result<Vec<u8>>> = triangles
            .par_chunks(1 << 12)
            .map(|piece| {
                let mut text = Vec::with_capacity(piece.len() * 256);
                for t in piece {
                    let p = [corner(t[0]), corner(t[1]), corner(t[2])];
                    let [Some(a), Some(b), Some(c)] = p else {
                        return Err(missing_vertex(t, &p));
                    };
                    let n = facet_normal([a, b, c]);
                    writeln!(text, "  facet normal {} {} {}\n    outer loop", n[0], n[1], n[2])?;
                    for q in [a, b, c] {
                        writeln!(text, "      vertex {} {} {}", q[0], q[1], q[2])?;
                    }
                    text.extend_from_slice(b"    endloop\n  endfacet\n");
                }
                Ok(text)
            })
            .collect();
        for p in pieces {
            buf.extend_from_slice(&p?);
        }
        return Ok(());
    }
    let at = buf.len();
    buf.resize(at + triangles.len() * FACET, 0);
    for (r, t) in buf[at..].chunks_exact_mut(FACET).zip(triangles) {
        let p = [corner(t[0]), corner(t[1]), corner(t[2])];
        let [Some(a), Some(b), Some(c)] = p else {
            return Err(missing_vertex(t, &p));
        };
        let floats = [facet_normal([a, b, c]), a, b, c];
        for (f, x) in r[..48].chunks_exact_mut(4).zip(floats.as_flattened()) {
            f.copy_from_slice(&x.to_le_bytes());
        }
        r[48..].fill(0);
    }
    Ok(())
}

/// Writes the facets of `triangles` in pieces of [`FACETS_PER_WRITE`], packed through `buf`.
fn write_facets(
    w: &mut dyn Write,
    triangles: &[[u32; 3]],
    corner: impl Fn(u32) -> Option<[f32; 3]> + Copy + Sync,
    ascii: bool,
    buf: &mut Vec<u8>,
) -> io::Result<()> {
    for chunk in triangles.chunks(FACETS_PER_WRITE) {
        buf.clear();
        pack_facets(buf, chunk, corner, ascii)?;
        w.write_all(buf)?;
    }
    Ok(())
}

/// Writes `mesh` as binary STL.
pub fn write_stl(w: &mut dyn Write, mesh: &Mesh) -> io::Result<()> {
    w.write_all(&header(mesh.num_split_triangles() as u64)?)?;
    write_all_facets(w, mesh, false)
}

/// Writes `mesh` as ASCII STL (`solid … endsolid`), facet normals from the winding.
pub fn write_stl_ascii(w: &mut dyn Write, mesh: &Mesh) -> io::Result<()> {
    w.write_all(SOLID.as_bytes())?;
    write_all_facets(w, mesh, true)?;
    w.write_all(END_SOLID.as_bytes())
}

/// The facets of `mesh`: its triangles, then its quads split.
fn write_all_facets(w: &mut dyn Write, mesh: &Mesh, ascii: bool) -> io::Result<()> {
    let corner = |v: u32| mesh.positions.get(v as usize).copied();
    let mut buf = Vec::with_capacity(FACET * FACETS_PER_WRITE);
    write_facets(w, &mesh.triangles, corner, ascii, &mut buf)?;
    for quads in mesh.quads.chunks(FACETS_PER_WRITE / 2) {
        let split: Vec<[u32; 3]> = quads.iter().flat_map(|&q| mesh.split_quad(q)).collect();
        write_facets(w, &split, corner, ascii, &mut buf)?;
    }
    Ok(())
}

/// An STL (binary or ASCII) written as the mesh is produced ([`isoforge::mesh::MeshSink`]), in memory
/// bounded by a few batches: the positions of the batches its polygons may still refer to (the
/// one before, their own and the next, as the sink's contract allows), and their polygons until
/// the next batch arrives. Triangles go straight into the output's temporary file, quads' halves
/// into a scratch file appended at the end, and the count is patched into the header last; the
/// bytes are exactly [`write_stl`]'s for the same mesh. Nothing appears at the path before the
/// batch commits; a stream dropped unfinished leaves nothing.
pub struct StlStream<'a> {
    batch: &'a Batch,
    path: PathBuf,
    main: Option<TempFile>,
    /// Text facets between `solid` and `endsolid` lines, or binary ones after a counted header.
    ascii: bool,
    /// Facets of split quads (created at the first quad).
    quads: Option<io::BufWriter<TempFile>>,
    window: PositionWindow,
    /// The last batch's polygons, written when the next batch (whose vertices they may use)
    /// arrives.
    pending_triangles: Vec<[u32; 3]>,
    pending_quads: Vec<[u32; 4]>,
    /// Reused packing buffers.
    buf: Vec<u8>,
    split: Vec<[u32; 3]>,
    facets: u64,
}

impl<'a> StlStream<'a> {
    /// Starts writing `path` as an output of `batch` (reserved there first if needed); the
    /// batch's commit moves it into place.
    ///
    /// # Errors
    /// As [`Batch::reserve`].
    pub fn create_in(batch: &'a Batch, path: &Path, ascii: bool) -> Result<Self> {
        let io_err = |source| Error::Io { path: path.to_path_buf(), source };
        let mut main = batch.take_empty(path)?;
        let start = || if ascii { Ok(SOLID.as_bytes().to_vec()) } else { header(0).map(|h| h.to_vec()) };
        start().and_then(|bytes| main.write_all(&bytes)).map_err(io_err)?;
        Ok(StlStream {
            batch,
            path: path.to_path_buf(),
            main: Some(main),
            ascii,
            quads: None,
            window: PositionWindow::default(),
            pending_triangles: Vec::new(),
            pending_quads: Vec::new(),
            buf: Vec::new(),
            split: Vec::new(),
            facets: 0,
        })
    }

    /// Appends a batch's vertices and polygons (written once the next batch or
    /// [`finish`](StlStream::finish) comes).
    ///
    /// # Errors
    /// Writing fails, a polygon of the previous batch refers to a vertex beyond this one, or
    /// the facets outgrow binary STL's 32-bit count.
    pub fn push(&mut self, batch: MeshBatch<'_>) -> io::Result<()> {
        if self.main.is_none() {
            return Err(io::Error::other("the stream is finished"));
        }
        self.window.push(batch.positions);
        self.write_pending()?;
        self.window.release();
        self.pending_triangles.extend_from_slice(batch.triangles);
        self.pending_quads.extend_from_slice(batch.quads);
        self.facets += (batch.triangles.len() + 2 * batch.quads.len()) as u64;
        if self.ascii {
            return Ok(());
        }
        header(self.facets).map(|_| ())
    }

    /// Writes the pending polygons' facets: triangles into the output, quads' halves aside.
    fn write_pending(&mut self) -> io::Result<()> {
        let window = &self.window;
        let corner = |v: u32| window.get(v);
        let main = self.main.as_mut().ok_or_else(|| io::Error::other("the stream is finished"))?;
        write_facets(main, &self.pending_triangles, corner, self.ascii, &mut self.buf)?;
        self.pending_triangles.clear();
        if !self.pending_quads.is_empty() {
            self.split.clear();
            window.split_quads(&self.pending_quads, &mut self.split)?;
            self.pending_quads.clear();
            write_facets(scratch(&mut self.quads, &self.path)?, &self.split, corner, self.ascii, &mut self.buf)?;
        }
        Ok(())
    }

    /// Writes the last polygons, appends the quads' facets and patches the count into the
    /// header (binary) or ends the solid (ASCII); then hands the file back to its batch. Returns the vertex and facet counts.
    ///
    /// # Errors
    /// [`Error::Io`] naming the path when writing fails (nothing is left behind).
    pub fn finish(mut self) -> Result<(u64, u64)> {
        let written = self.write_pending().and_then(|()| {
            let main = self.main.as_mut().ok_or_else(|| io::Error::other("the stream is finished"))?;
            append_scratch(main, std::slice::from_mut(&mut self.quads))?;
            if self.ascii {
                return main.write_all(END_SOLID.as_bytes());
            }
            let end = main.file_mut().stream_position()?;
            main.file_mut().seek(SeekFrom::Start(0))?;
            main.write_all(&header(self.facets)?)?;
            main.file_mut().seek(SeekFrom::Start(end)).map(|_| ())
        });
        written.map_err(|source| Error::Io { path: self.path.clone(), source })?;
        // Only a complete file goes back to the batch (a failed one is dropped, and the batch
        // then refuses to commit the output it never got).
        if let Some(main) = self.main.take() {
            self.batch.put(&self.path, main);
        }
        Ok((self.window.vertices(), self.facets))
    }
}

impl isoforge::mesh::MeshSink for StlStream<'_> {
    fn push(&mut self, batch: MeshBatch<'_>) -> Result<(), isoforge::mesh::ExternalError> {
        StlStream::push(self, batch).map_err(|e| super::stream::sink_error(&self.path, &e))
    }
}
