//! Lines of the text mesh formats (OBJ, OFF, ASCII PLY), formatted in parallel pieces and written
//! in order (the formatting, Rust's shortest float printing, is most of their cost), in memory or
//! as the mesh is produced ([`TextStream`]).

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use isoforge::mesh::{Mesh, MeshBatch};
use rayon::prelude::*;

use super::stream::{append_scratch, scratch};
use crate::atomic::TempFile;
use crate::error::{Error, Result};
use crate::Batch;

/// Lines formatted per piece (pieces of one window are formatted in parallel, then written in
/// order).
pub(super) const LINES_PER_PIECE: usize = 1 << 14;
/// Pieces formatted at once: bounds the memory of the formatted text (a few MB).
pub(super) const PIECES_PER_WINDOW: usize = 8;

/// Writes the lines `format` makes of `items`, formatted in parallel pieces and written in order;
/// `format` also gets the index of its piece's first item.
pub(super) fn write_lines<T: Sync>(
    w: &mut dyn Write,
    items: &[T],
    format: impl Fn(&mut Vec<u8>, &[T], usize) + Sync,
) -> io::Result<()> {
    for (window, chunk) in items.chunks(LINES_PER_PIECE * PIECES_PER_WINDOW).enumerate() {
        let start = window * LINES_PER_PIECE * PIECES_PER_WINDOW;
        let pieces: Vec<Vec<u8>> = chunk
            .par_chunks(LINES_PER_PIECE)
            .enumerate()
            .map(|(i, piece)| {
                let mut buf = Vec::with_capacity(piece.len() * 32);
                format(&mut buf, piece, start + i * LINES_PER_PIECE);
                buf
            })
            .collect();
        for p in pieces {
            w.write_all(&p)?;
        }
    }
    Ok(())
}

/// Appends `N i j k …` lines, 0-based indices (OFF and ASCII PLY faces).
#[cfg(any(feature = "off", feature = "ply"))]
pub(super) fn face_lines<const N: usize>(buf: &mut Vec<u8>, faces: &[[u32; N]]) {
    let mut num = itoa::Buffer::new();
    for f in faces {
        buf.extend_from_slice(num.format(N).as_bytes());
        for &v in f {
            buf.push(b' ');
            buf.extend_from_slice(num.format(v).as_bytes());
        }
        buf.push(b'\n');
    }
}

/// A text format a [`TextStream`] writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TextFormat {
    /// OBJ: a comment line, `v` lines, `vn` lines, 1-based `f` lines.
    #[cfg(feature = "obj")]
    Obj,
    /// OFF: the counts, vertex lines, `3 …` and `4 …` face lines.
    #[cfg(feature = "off")]
    Off,
    /// ASCII PLY: the header with the counts, vertex lines (normals inline), face lines.
    #[cfg(feature = "ply")]
    PlyAscii,
}

impl TextFormat {
    /// The file's start, given the counts.
    fn header(self, vertices: u64, faces: u64, normals: bool) -> io::Result<String> {
        let _ = (vertices, faces, normals);
        #[cfg(feature = "ply")]
        let count = |n: u64| {
            usize::try_from(n).map_err(|_| io::Error::other("more vertices or faces than this machine can count"))
        };
        Ok(match self {
            #[cfg(feature = "obj")]
            TextFormat::Obj => super::obj::header(),
            #[cfg(feature = "off")]
            TextFormat::Off => super::off::header(vertices, faces, false),
            #[cfg(feature = "ply")]
            TextFormat::PlyAscii => {
                super::ply::header(count(vertices)?, count(faces)?, normals, &crate::MeshData::default(), true)
            }
        })
    }

    /// Vertex lines for `points` (from vertex `at` of the held ones; `normals` all held normals).
    fn vertex_lines(self, buf: &mut Vec<u8>, points: &[[f32; 3]], normals: &[[f32; 3]], at: usize) {
        let _ = (normals, at);
        match self {
            #[cfg(feature = "obj")]
            TextFormat::Obj => super::obj::vertex_lines(buf, "v", points, None),
            #[cfg(feature = "off")]
            TextFormat::Off => super::off::vertex_lines(buf, points, None, 0),
            #[cfg(feature = "ply")]
            TextFormat::PlyAscii => {
                super::ply::ascii_vertex_lines(buf, points, normals, &crate::MeshData::default(), at)
            }
        }
    }

    /// Face lines of polygons with `N` corners (`normals`: OBJ's `//n` references).
    fn face_lines<const N: usize>(self, buf: &mut Vec<u8>, faces: &[[u32; N]], normals: bool) {
        let _ = normals;
        match self {
            #[cfg(feature = "obj")]
            TextFormat::Obj => super::obj::face_lines(buf, faces, 0, 0, normals),
            #[cfg(any(feature = "off", feature = "ply"))]
            _ => face_lines(buf, faces),
        }
    }
}

/// An OBJ, OFF or ASCII PLY written as the mesh is produced ([`isoforge::mesh::MeshSink`]):
/// batches are gathered into windows whose lines are formatted in parallel pieces, vertex, normal,
/// triangle and quad lines going to four scratch files; [`TextStream::finish`] writes the header
/// (with the counts, for OFF and PLY) into the output's temporary file and appends them. The
/// bytes are exactly the in-memory writer's for the same mesh. Nothing appears at the path
/// before the batch commits; a stream dropped unfinished leaves nothing.
pub struct TextStream<'a> {
    batch: &'a Batch,
    path: PathBuf,
    format: TextFormat,
    main: Option<TempFile>,
    /// Vertex, normal (OBJ), triangle and quad lines (created when first needed).
    parts: [Option<io::BufWriter<TempFile>>; 4],
    normals: bool,
    /// Batches gathered since the last write.
    held: Mesh,
    vertices: u64,
    polygons: u64,
}

impl<'a> TextStream<'a> {
    /// Starts writing `path` in `format` (with normals when `normals`) as an output of `batch`
    /// (reserved there first if needed); the batch's commit moves it into place.
    ///
    /// # Errors
    /// As [`Batch::reserve`].
    pub fn create_in(batch: &'a Batch, path: &Path, format: TextFormat, normals: bool) -> Result<Self> {
        let main = batch.take_empty(path)?;
        Ok(TextStream {
            batch,
            path: path.to_path_buf(),
            format,
            main: Some(main),
            parts: [None, None, None, None],
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

    /// Writes the lines of the gathered batches into the scratch files.
    fn write_held(&mut self) -> io::Result<()> {
        let (held, n, f, path) = (&self.held, self.normals, self.format, &self.path);
        let [v, vn, tri, quad] = &mut self.parts;
        if !held.positions.is_empty() {
            write_lines(scratch(v, path)?, &held.positions, |buf, p, at| f.vertex_lines(buf, p, &held.normals, at))?;
        }
        // Only OBJ gives normals lines of their own (`vn`); PLY writes them on the vertex lines.
        #[cfg(feature = "obj")]
        if !held.normals.is_empty() && f == TextFormat::Obj {
            write_lines(scratch(vn, path)?, &held.normals, |buf, p, _| super::obj::vertex_lines(buf, "vn", p, None))?;
        }
        let _ = vn;
        if !held.triangles.is_empty() {
            write_lines(scratch(tri, path)?, &held.triangles, |buf, t, _| f.face_lines(buf, t, n))?;
        }
        if !held.quads.is_empty() {
            write_lines(scratch(quad, path)?, &held.quads, |buf, q, _| f.face_lines(buf, q, n))?;
        }
        self.held.clear();
        Ok(())
    }

    /// Writes the header, appends the lines; then hands the file back to its batch. Returns the
    /// vertex and polygon counts.
    ///
    /// # Errors
    /// [`Error::Io`] naming the path when writing fails (nothing is left behind).
    pub fn finish(mut self) -> Result<(u64, u64)> {
        let written = self.write_held().and_then(|()| {
            let main = self.main.as_mut().ok_or_else(|| io::Error::other("the stream is finished"))?;
            main.write_all(self.format.header(self.vertices, self.polygons, self.normals)?.as_bytes())?;
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

impl isoforge::mesh::MeshSink for TextStream<'_> {
    fn push(&mut self, batch: MeshBatch<'_>) -> std::result::Result<(), isoforge::mesh::ExternalError> {
        TextStream::push(self, batch).map_err(|e| super::stream::sink_error(&self.path, &e))
    }
}
