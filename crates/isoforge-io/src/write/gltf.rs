//! glTF 2.0 writer: `.glb` (one binary file) or `.gltf` + `.bin`. One mesh and node per
//! [`NamedMesh`]: POSITION (with its bounds), NORMAL when present, COLOR_0 (normalised unsigned
//! bytes) and `_NAME` float attributes from [`MeshData`], u32 indices, triangles. Units are the
//! mesh's (millimetres for medical volumes; glTF viewers assume metres, so scale in the viewer).

use std::io::{self, Write};

use isoforge::mesh::Mesh;

use crate::attributes::NamedMesh;

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
                put(w, buf, &m.triangles, |t, buf| ints(t, buf))?;
                put(w, buf, &m.quads, |&q, buf| m.split_quad(q).iter().for_each(|t| ints(t, buf)))
            }
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

/// Lays out `meshes` (no bytes copied).
fn layout<'m>(meshes: &[NamedMesh<'m>], uri: Option<&str>) -> io::Result<Layout<'m>> {
    let mut sources: Vec<(usize, Source<'m>)> = Vec::new();
    let (mut views, mut accessors, mut gmeshes, mut nodes) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut bin_len = 0usize;
    let mut view = |source: Source<'m>, target: u32| -> usize {
        bin_len = bin_len.next_multiple_of(4);
        let len = source.byte_len();
        views.push(format!(r#"{{"buffer":0,"byteOffset":{bin_len},"byteLength":{len},"target":{target}}}"#));
        sources.push((bin_len, source));
        bin_len += len;
        views.len() - 1
    };
    for (k, m) in meshes.iter().enumerate() {
        let mesh: &'m Mesh = m.mesh;
        let n = mesh.positions.len();
        if n == 0 || !m.data.fits(mesh) {
            return Err(io::Error::other(format!("mesh {k} ({}): empty, or vertex data of the wrong length", m.name)));
        }
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for p in &mesh.positions {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        let mut attrs = Vec::new();
        let v = view(Source::Vec3(&mesh.positions), 34962);
        accessors.push(format!(
            r#"{{"bufferView":{v},"componentType":5126,"count":{n},"type":"VEC3","min":[{},{},{}],"max":[{},{},{}]}}"#,
            lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]
        ));
        attrs.push(format!(r#""POSITION":{}"#, accessors.len() - 1));
        if !mesh.normals.is_empty() {
            let v = view(Source::UnitNormals(&mesh.normals), 34962);
            accessors.push(format!(r#"{{"bufferView":{v},"componentType":5126,"count":{n},"type":"VEC3"}}"#));
            attrs.push(format!(r#""NORMAL":{}"#, accessors.len() - 1));
        }
        if let Some(colors) = &m.data.colors {
            let v = view(Source::Colors(colors), 34962);
            accessors.push(format!(
                r#"{{"bufferView":{v},"componentType":5121,"normalized":true,"count":{n},"type":"VEC4"}}"#
            ));
            attrs.push(format!(r#""COLOR_0":{}"#, accessors.len() - 1));
        }
        for (name, values) in &m.data.scalars {
            let v = view(Source::Scalars(values), 34962);
            accessors.push(format!(r#"{{"bufferView":{v},"componentType":5126,"count":{n},"type":"SCALAR"}}"#));
            attrs.push(format!(r#""_{}":{}"#, json_name(name).to_ascii_uppercase(), accessors.len() - 1));
        }
        // glTF primitives here are triangle lists: quads are split (`Mesh::all_triangles`), and
        // the split triangles use all four corners of their quad.
        let v = view(Source::Indices(mesh), 34963);
        let max_index = mesh.triangles.iter().flatten().chain(mesh.quads.iter().flatten()).max().copied().unwrap_or(0);
        accessors.push(format!(
            r#"{{"bufferView":{v},"componentType":5125,"count":{},"type":"SCALAR","min":[0],"max":[{max_index}]}}"#,
            mesh.num_split_triangles() * 3
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
    Ok(Layout { views: sources, bin_len, json })
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

/// A string safe inside JSON quotes (names come from file names and iso values).
fn json_name(s: &str) -> String {
    s.chars().map(|c| if c == '"' || c == '\\' || c.is_control() { '_' } else { c }).collect()
}

/// Writes a binary glTF (`.glb`).
pub fn write_glb(w: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    let layout = layout(meshes, None)?;
    let mut json = layout.json.as_bytes().to_vec();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + 8 + layout.bin_len;
    let too_big = || io::Error::other("the mesh exceeds the 4 GiB of a .glb file");
    let total = u32::try_from(total).map_err(|_| too_big())?;
    w.write_all(b"glTF")?;
    w.write_all(&2u32.to_le_bytes())?;
    w.write_all(&total.to_le_bytes())?;
    w.write_all(&(json.len() as u32).to_le_bytes())?;
    w.write_all(b"JSON")?;
    w.write_all(&json)?;
    w.write_all(&(layout.bin_len as u32).to_le_bytes())?;
    w.write_all(b"BIN\0")?;
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
