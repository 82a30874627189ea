//! glTF 2.0 writer: `.glb` (one binary file) or `.gltf` + `.bin`. One mesh and node per
//! [`NamedMesh`]: POSITION (with its bounds), NORMAL when present, COLOR_0 (normalised unsigned
//! bytes) and `_NAME` float attributes from [`MeshData`](crate::MeshData), u32 indices, triangles. Units are the
//! mesh's (millimetres for medical volumes; glTF viewers assume metres, so scale in the viewer).

use std::io::{self, Write};

use std::path::{Path, PathBuf};

use isoforge::mesh::{Mesh, MeshBatch};

use super::stream::{append_scratch, scratch, PositionWindow};
use crate::atomic::TempFile;
use crate::attributes::NamedMesh;
use crate::error::{Error, Result};
use crate::{Batch, MeshFormat};

/// The name of the mesh and node of a file with one mesh.
pub const SINGLE_MESH: &str = "isosurface";

/// What fills one buffer view: read from the meshes as the buffer is written, never copied whole.
enum Source<'m> {
    /// Little-endian floats, three a vertex.
    Vec3(&'m [[f32; 3]]),
    /// Normals made unit (glTF requires it): a zero normal (flat field) becomes +z.
    UnitNormals(&'m [[f32; 3]]),
    /// Colours as VEC4 of unsigned bytes (alpha 255), which keeps every element 4-byte aligned.
    Colors(&'m [[u8; 3]]),
    /// Little-endian floats, one a vertex.
    Scalars(&'m [f32]),
    /// u32 indices of the triangles, then of the quads split (`Mesh::split_quad`).
    Indices(&'m Mesh),
    /// u32 indices of triangles.
    Triangles(&'m [[u32; 3]]),
}

/// Elements packed per write.
const PER_WRITE: usize = 1 << 15;

impl Source<'_> {
    fn byte_len(&self) -> usize {
        match self {
            Source::Vec3(v) | Source::UnitNormals(v) => 12 * v.len(),
            Source::Colors(c) => 4 * c.len(),
            Source::Scalars(s) => 4 * s.len(),
            Source::Indices(m) => 12 * m.num_split_triangles(),
            Source::Triangles(t) => 12 * t.len(),
        }
    }

    /// Writes the view's bytes, packed through `buf`.
    fn write(&self, w: &mut dyn Write, buf: &mut Vec<u8>) -> io::Result<()> {
        fn put<T>(
            w: &mut dyn Write,
            buf: &mut Vec<u8>,
            items: &[T],
            bytes: impl Fn(&T, &mut Vec<u8>),
        ) -> io::Result<()> {
            for chunk in items.chunks(PER_WRITE) {
                buf.clear();
                chunk.iter().for_each(|x| bytes(x, buf));
                w.write_all(buf)?;
            }
            Ok(())
        }
        let floats = |v: &[f32], buf: &mut Vec<u8>| v.iter().for_each(|x| buf.extend_from_slice(&x.to_le_bytes()));
        let ints = |v: &[u32], buf: &mut Vec<u8>| v.iter().for_each(|x| buf.extend_from_slice(&x.to_le_bytes()));
        match self {
            Source::Vec3(v) => put(w, buf, v, |p, buf| floats(p, buf)),
            Source::UnitNormals(v) => put(w, buf, v, |n, buf| {
                let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                floats(&if l > 0.0 { n.map(|x| x / l) } else { [0.0, 0.0, 1.0] }, buf)
            }),
            Source::Colors(c) => put(w, buf, c, |c, buf| buf.extend_from_slice(&[c[0], c[1], c[2], 255])),
            Source::Scalars(s) => put(w, buf, s, |x, buf| buf.extend_from_slice(&x.to_le_bytes())),
            Source::Indices(m) => {
                Source::Triangles(&m.triangles).write(w, buf)?;
                put(w, buf, &m.quads, |&q, buf| m.split_quad(q).iter().for_each(|t| ints(t, buf)))
            }
            Source::Triangles(t) => put(w, buf, t, |t, buf| ints(t, buf)),
        }
    }
}

/// The buffer's views (each starting on a 4-byte boundary) and its length, and the JSON document
/// for `meshes`; `uri` names the external buffer (`None` for .glb, whose buffer follows the JSON).
struct Layout<'m> {
    views: Vec<(usize, Source<'m>)>,
    bin_len: usize,
    json: String,
}

/// What the JSON says of one mesh: taken from a mesh in memory, or gathered by a stream.
struct Summary<'a> {
    name: &'a str,
    vertices: usize,
    /// Smallest and largest coordinates of the positions.
    bounds: [[f32; 3]; 2],
    normals: bool,
    colors: bool,
    scalars: Vec<&'a str>,
    /// Triangles, quads split.
    triangles: usize,
    max_index: u32,
}

impl<'a> Summary<'a> {
    fn of(m: &NamedMesh<'a>, k: usize) -> io::Result<Self> {
        let mesh = m.mesh;
        if !m.data.fits(mesh) || !(mesh.normals.is_empty() || mesh.normals.len() == mesh.positions.len()) {
            return Err(empty_or_misfit(k, m.name));
        }
        let mut bounds = [[f32::INFINITY; 3], [f32::NEG_INFINITY; 3]];
        grow_bounds(&mut bounds, &mesh.positions);
        Ok(Summary {
            name: m.name,
            vertices: mesh.positions.len(),
            bounds,
            normals: !mesh.normals.is_empty(),
            colors: m.data.colors.is_some(),
            scalars: m.data.scalars.iter().map(|(n, _)| n.as_str()).collect(),
            triangles: mesh.num_split_triangles(),
            // The split triangles use all four corners of their quad.
            max_index: mesh.triangles.iter().flatten().chain(mesh.quads.iter().flatten()).max().copied().unwrap_or(0),
        })
    }
}

fn empty_or_misfit(k: usize, name: &str) -> io::Error {
    io::Error::other(format!("mesh {k} ({name}): empty, or vertex data of the wrong length"))
}

/// Widens `bounds` (smallest, largest) to take `positions`.
fn grow_bounds(bounds: &mut [[f32; 3]; 2], positions: &[[f32; 3]]) {
    for p in positions {
        for a in 0..3 {
            bounds[0][a] = bounds[0][a].min(p[a]);
            bounds[1][a] = bounds[1][a].max(p[a]);
        }
    }
}

/// The JSON document for `meshes` and the buffer views' offsets (each on a 4-byte boundary) and
/// lengths, in the order the buffer holds them (per mesh: positions, normals, colours, scalars,
/// indices), and the buffer's length; `uri` names the external buffer (`None` for .glb, whose
/// buffer follows the JSON).
fn document(meshes: &[Summary], uri: Option<&str>) -> io::Result<Document> {
    let (mut views, mut accessors, mut gmeshes, mut nodes) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut spans = Vec::new();
    let mut bin_len = 0usize;
    let mut view = |len: usize, target: u32| -> usize {
        bin_len = bin_len.next_multiple_of(4);
        views.push(format!(r#"{{"buffer":0,"byteOffset":{bin_len},"byteLength":{len},"target":{target}}}"#));
        spans.push((bin_len, len));
        bin_len += len;
        views.len() - 1
    };
    for (k, m) in meshes.iter().enumerate() {
        let n = m.vertices;
        if n == 0 {
            return Err(empty_or_misfit(k, m.name));
        }
        let [lo, hi] = m.bounds;
        let mut attrs = Vec::new();
        let v = view(12 * n, 34962);
        accessors.push(format!(
            r#"{{"bufferView":{v},"componentType":5126,"count":{n},"type":"VEC3","min":[{},{},{}],"max":[{},{},{}]}}"#,
            lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]
        ));
        attrs.push(format!(r#""POSITION":{}"#, accessors.len() - 1));
        if m.normals {
            let v = view(12 * n, 34962);
            accessors.push(format!(r#"{{"bufferView":{v},"componentType":5126,"count":{n},"type":"VEC3"}}"#));
            attrs.push(format!(r#""NORMAL":{}"#, accessors.len() - 1));
        }
        if m.colors {
            let v = view(4 * n, 34962);
            accessors.push(format!(
                r#"{{"bufferView":{v},"componentType":5121,"normalized":true,"count":{n},"type":"VEC4"}}"#
            ));
            attrs.push(format!(r#""COLOR_0":{}"#, accessors.len() - 1));
        }
        for name in &m.scalars {
            let v = view(4 * n, 34962);
            accessors.push(format!(r#"{{"bufferView":{v},"componentType":5126,"count":{n},"type":"SCALAR"}}"#));
            attrs.push(format!(r#""_{}":{}"#, json_name(name).to_ascii_uppercase(), accessors.len() - 1));
        }
        // glTF primitives here are triangle lists: quads are split (`Mesh::all_triangles`).
        let v = view(12 * m.triangles, 34963);
        accessors.push(format!(
            r#"{{"bufferView":{v},"componentType":5125,"count":{},"type":"SCALAR","min":[0],"max":[{}]}}"#,
            m.triangles * 3,
            m.max_index
        ));
        gmeshes.push(format!(
            r#"{{"name":"{}","primitives":[{{"attributes":{{{}}},"indices":{},"mode":4}}]}}"#,
            json_name(m.name),
            attrs.join(","),
            accessors.len() - 1
        ));
        nodes.push(format!(r#"{{"name":"{}","mesh":{k}}}"#, json_name(m.name)));
    }
    let bin_len = bin_len.next_multiple_of(4);
    let uri = uri.map(|u| format!(r#","uri":"{}""#, json_name(u))).unwrap_or_default();
    let scene_nodes: Vec<String> = (0..nodes.len()).map(|k| k.to_string()).collect();
    let json = format!(
        r#"{{"asset":{{"version":"2.0","generator":"isoforge {}"}},"scene":0,"scenes":[{{"nodes":[{}]}}],"nodes":[{}],"meshes":[{}],"accessors":[{}],"bufferViews":[{}],"buffers":[{{"byteLength":{bin_len}{uri}}}]}}"#,
        env!("CARGO_PKG_VERSION"),
        scene_nodes.join(","),
        nodes.join(","),
        gmeshes.join(","),
        accessors.join(","),
        views.join(",")
    );
    Ok(Document { json, spans, bin_len })
}

/// What [`document`] lays out: the JSON, each view's offset and length, the buffer's length.
struct Document {
    json: String,
    spans: Vec<(usize, usize)>,
    bin_len: usize,
}

/// Lays out `meshes` (no bytes copied).
fn layout<'m>(meshes: &[NamedMesh<'m>], uri: Option<&str>) -> io::Result<Layout<'m>> {
    let summaries = meshes.iter().enumerate().map(|(k, m)| Summary::of(m, k)).collect::<io::Result<Vec<_>>>()?;
    let Document { json, spans, bin_len } = document(&summaries, uri)?;
    let mut sources = Vec::new();
    for m in meshes {
        let mesh: &'m Mesh = m.mesh;
        sources.push(Source::Vec3(&mesh.positions));
        if !mesh.normals.is_empty() {
            sources.push(Source::UnitNormals(&mesh.normals));
        }
        if let Some(c) = &m.data.colors {
            sources.push(Source::Colors(c));
        }
        sources.extend(m.data.scalars.iter().map(|(_, v)| Source::Scalars(v)));
        sources.push(Source::Indices(mesh));
    }
    debug_assert!(spans.iter().zip(&sources).all(|(s, src)| s.1 == src.byte_len()));
    let views = spans.into_iter().map(|(at, _)| at).zip(sources).collect();
    Ok(Layout { views, bin_len, json })
}

impl Layout<'_> {
    /// Writes the buffer: each view at its offset, zeros between and after to 4-byte boundaries.
    fn write_bin(&self, w: &mut dyn Write) -> io::Result<()> {
        let (mut at, mut buf) = (0, Vec::with_capacity(12 * PER_WRITE));
        for (offset, source) in &self.views {
            w.write_all(&[0; 3][..offset - at])?;
            source.write(w, &mut buf)?;
            at = offset + source.byte_len();
        }
        w.write_all(&[0; 3][..self.bin_len - at])
    }
}

/// The `uri` a `.gltf` gives its buffer file `bin` (beside it: the file name).
pub(crate) fn buffer_uri(bin: &Path) -> String {
    bin.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
}

/// A string safe inside JSON quotes (names come from file names and iso values).
fn json_name(s: &str) -> String {
    s.chars().map(|c| if c == '"' || c == '\\' || c.is_control() { '_' } else { c }).collect()
}

/// The start of a `.glb` up to its buffer's bytes: file header, JSON chunk, buffer chunk header.
fn glb_head(json: &str, bin_len: usize) -> io::Result<Vec<u8>> {
    let mut json = json.as_bytes().to_vec();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + 8 + bin_len;
    let total = u32::try_from(total).map_err(|_| io::Error::other("the mesh exceeds the 4 GiB of a .glb file"))?;
    let mut head = Vec::with_capacity(28 + json.len());
    head.extend_from_slice(b"glTF");
    head.extend_from_slice(&2u32.to_le_bytes());
    head.extend_from_slice(&total.to_le_bytes());
    head.extend_from_slice(&(json.len() as u32).to_le_bytes());
    head.extend_from_slice(b"JSON");
    head.extend_from_slice(&json);
    head.extend_from_slice(&(bin_len as u32).to_le_bytes());
    head.extend_from_slice(b"BIN\0");
    Ok(head)
}

/// Writes a binary glTF (`.glb`).
pub fn write_glb(w: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    let layout = layout(meshes, None)?;
    w.write_all(&glb_head(&layout.json, layout.bin_len)?)?;
    layout.write_bin(w)
}

/// The JSON of a `.gltf` whose buffer is the file `bin_uri` (written with [`write_gltf_bin`]).
pub fn write_gltf_json(w: &mut dyn Write, meshes: &[NamedMesh], bin_uri: &str) -> io::Result<()> {
    w.write_all(layout(meshes, Some(bin_uri))?.json.as_bytes())
}

/// The binary buffer of a `.gltf` + `.bin` pair.
pub fn write_gltf_bin(w: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    layout(meshes, None)?.write_bin(w)
}

/// A glTF file of one mesh ([`SINGLE_MESH`]) written as the mesh is produced
/// ([`isoforge::mesh::MeshSink`]): a `.glb`, or a `.gltf` with its `.bin` buffer beside it
/// ([`MeshFormat::gltf_buffer`]). Positions, unit normals, triangles' and quads' halves' indices
/// go to four scratch files while the bounds and counts are gathered; [`GltfStream::finish`]
/// writes the JSON (after the `.glb` header, or as the `.gltf`) and appends the scratch files to
/// the `.glb` or writes them as the `.bin`. The bytes are exactly [`write_glb`]'s, or
/// [`write_gltf_json`]'s and [`write_gltf_bin`]'s, for the same mesh. Nothing appears before the
/// batch commits; a stream dropped unfinished leaves nothing.
pub struct GltfStream<'a> {
    batch: &'a Batch,
    path: PathBuf,
    main: Option<TempFile>,
    /// A `.gltf`'s buffer: its path and file (`None` for a `.glb`).
    bin: Option<(PathBuf, TempFile)>,
    /// Positions, unit normals, triangles' indices, quads' halves' indices (created when first
    /// needed).
    parts: [Option<io::BufWriter<TempFile>>; 4],
    /// Positions of the batches the pending quads may use.
    window: PositionWindow,
    /// The last batch's quads, split when the next batch (whose vertices they may use) arrives.
    pending_quads: Vec<[u32; 4]>,
    split: Vec<[u32; 3]>,
    normals: bool,
    bounds: [[f32; 3]; 2],
    triangles: usize,
    max_index: u32,
    buf: Vec<u8>,
}

impl<'a> GltfStream<'a> {
    /// Starts writing `path` (with normals when `normals`) as an output of `batch` (reserved
    /// there first if needed, a `.gltf` with its buffer as [`Batch::reserve_mesh`] does); the
    /// batch's commit moves it into place. `format`: [`MeshFormat::Glb`], or [`MeshFormat::Gltf`]
    /// and its `.bin`.
    ///
    /// # Errors
    /// As [`Batch::reserve_mesh`].
    pub fn create_in(batch: &'a Batch, path: &Path, format: MeshFormat, normals: bool) -> Result<Self> {
        let bin = match format {
            MeshFormat::Glb => None,
            MeshFormat::Gltf => {
                let bin = batch.reserve_gltf_buffer(path)?;
                let file = batch.take_empty(&bin)?;
                Some((bin, file))
            }
            f => return Err(Error::InvalidInput(format!("internal: {} is not glTF", f.name()))),
        };
        let main = batch.take_empty(path)?;
        Ok(GltfStream {
            batch,
            path: path.to_path_buf(),
            main: Some(main),
            bin,
            parts: [None, None, None, None],
            window: PositionWindow::default(),
            pending_quads: Vec::new(),
            split: Vec::new(),
            normals,
            bounds: [[f32::INFINITY; 3], [f32::NEG_INFINITY; 3]],
            triangles: 0,
            max_index: 0,
            buf: Vec::new(),
        })
    }

    /// Appends a batch (its quads are split when the next batch or
    /// [`finish`](GltfStream::finish) comes).
    ///
    /// # Errors
    /// Writing fails, `normals` does not match the stream, or a quad of the previous batch
    /// refers to a vertex beyond this one.
    pub fn push(&mut self, batch: MeshBatch<'_>) -> io::Result<()> {
        super::stream::check_batch(self.main.is_none(), self.normals, &batch)?;
        let MeshBatch { positions, normals, triangles, quads } = batch;
        self.window.push(positions);
        grow_bounds(&mut self.bounds, positions);
        let corners = triangles.iter().flatten().chain(quads.iter().flatten());
        self.max_index = corners.copied().fold(self.max_index, u32::max);
        let path = &self.path;
        let [pos, nrm, tri, _] = &mut self.parts;
        Source::Vec3(positions).write(scratch(pos, path)?, &mut self.buf)?;
        if !normals.is_empty() {
            Source::UnitNormals(normals).write(scratch(nrm, path)?, &mut self.buf)?;
        }
        if !triangles.is_empty() {
            Source::Triangles(triangles).write(scratch(tri, path)?, &mut self.buf)?;
        }
        self.split_pending()?;
        self.window.release();
        self.pending_quads.extend_from_slice(quads);
        self.triangles += triangles.len() + 2 * quads.len();
        // The .glb's 32-bit length, checked as it grows (the JSON of one mesh is under 4 KiB).
        let vertex_bytes = if self.normals { 24 } else { 12 };
        let bytes = 28 + 4096 + vertex_bytes * self.window.vertices() + 12 * self.triangles as u64;
        if self.bin.is_none() && bytes > u32::MAX as u64 {
            return Err(io::Error::other("the mesh exceeds the 4 GiB of a .glb file"));
        }
        Ok(())
    }

    /// Splits the pending quads and writes their halves' indices.
    fn split_pending(&mut self) -> io::Result<()> {
        if self.pending_quads.is_empty() {
            return Ok(());
        }
        self.split.clear();
        self.window.split_quads(&self.pending_quads, &mut self.split)?;
        self.pending_quads.clear();
        Source::Triangles(&self.split).write(scratch(&mut self.parts[3], &self.path)?, &mut self.buf)
    }

    /// Writes the header and JSON, appends the buffer's parts; then hands the file back to its
    /// batch. Returns the vertex and triangle counts.
    ///
    /// # Errors
    /// [`Error::Io`] naming the path when writing fails or the mesh is empty (nothing is left
    /// behind).
    pub fn finish(mut self) -> Result<(u64, u64)> {
        let written = self.split_pending().and_then(|()| self.assemble());
        written.map_err(|source| Error::Io { path: self.path.clone(), source })?;
        // Only a complete file goes back to the batch (a failed one is dropped, and the batch
        // then refuses to commit the output it never got).
        if let Some(main) = self.main.take() {
            self.batch.put(&self.path, main);
        }
        if let Some((bin, file)) = self.bin.take() {
            self.batch.put(&bin, file);
        }
        Ok((self.window.vertices(), self.triangles as u64))
    }

    /// The JSON and the buffer's parts: into the output after the `.glb` header, or as the
    /// `.gltf` and its `.bin`.
    fn assemble(&mut self) -> io::Result<()> {
        let summary = Summary {
            name: SINGLE_MESH,
            vertices: usize::try_from(self.window.vertices()).map_err(|_| io::Error::other("too many vertices"))?,
            bounds: self.bounds,
            normals: self.normals,
            colors: false,
            scalars: Vec::new(),
            triangles: self.triangles,
            max_index: self.max_index,
        };
        let uri = self.bin.as_ref().map(|(bin, _)| buffer_uri(bin));
        let Document { json, bin_len, .. } = document(&[summary], uri.as_deref())?;
        let main = self.main.as_mut().ok_or_else(|| io::Error::other("the stream is finished"))?;
        let total = match &mut self.bin {
            None => {
                main.write_all(&glb_head(&json, bin_len)?)?;
                append_scratch(main, &mut self.parts)?
            }
            Some((_, bin)) => {
                main.write_all(json.as_bytes())?;
                append_scratch(bin, &mut self.parts)?
            }
        };
        if total != bin_len as u64 {
            return Err(io::Error::other(format!("internal: the buffer holds {total} bytes, not {bin_len}")));
        }
        Ok(())
    }
}

impl isoforge::mesh::MeshSink for GltfStream<'_> {
    fn push(&mut self, batch: MeshBatch<'_>) -> std::result::Result<(), isoforge::mesh::ExternalError> {
        GltfStream::push(self, batch).map_err(|e| super::stream::sink_error(&self.path, &e))
    }
}
