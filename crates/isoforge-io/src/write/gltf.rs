//! glTF 2.0 writer: `.glb` (one binary file) or `.gltf` + `.bin`. One mesh and node per
//! [`NamedMesh`]: POSITION (with its bounds), NORMAL when present, COLOR_0 (normalised unsigned
//! bytes) and `_NAME` float attributes from [`MeshData`], u32 indices, triangles. Units are the
//! mesh's (millimetres for medical volumes; glTF viewers assume metres, so scale in the viewer).

use std::io::{self, Write};

use crate::attributes::NamedMesh;

/// The binary buffer and the JSON document for `meshes`; `uri` names the external buffer
/// (`None` for .glb, whose buffer follows the JSON).
fn build(meshes: &[NamedMesh], uri: Option<&str>) -> io::Result<(Vec<u8>, String)> {
    let mut bin: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut gmeshes, mut nodes) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut view = |bin: &mut Vec<u8>, bytes: &[u8], target: u32| -> usize {
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        views.push(format!(
            r#"{{"buffer":0,"byteOffset":{},"byteLength":{},"target":{target}}}"#,
            bin.len(),
            bytes.len()
        ));
        bin.extend_from_slice(bytes);
        views.len() - 1
    };
    let f32s = |v: &mut dyn Iterator<Item = f32>| v.flat_map(f32::to_le_bytes).collect::<Vec<u8>>();
    for (k, m) in meshes.iter().enumerate() {
        let mesh = m.mesh;
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
        let v = view(&mut bin, &f32s(&mut mesh.positions.iter().flatten().copied()), 34962);
        accessors.push(format!(
            r#"{{"bufferView":{v},"componentType":5126,"count":{n},"type":"VEC3","min":[{},{},{}],"max":[{},{},{}]}}"#,
            lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]
        ));
        attrs.push(format!(r#""POSITION":{}"#, accessors.len() - 1));
        if !mesh.normals.is_empty() {
            // glTF requires unit normals: a zero normal (flat field) becomes +z.
            let unit = mesh.normals.iter().flat_map(|nv| {
                let l = (nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2]).sqrt();
                if l > 0.0 {
                    nv.map(|x| x / l)
                } else {
                    [0.0, 0.0, 1.0]
                }
            });
            let v = view(&mut bin, &f32s(&mut unit.into_iter()), 34962);
            accessors.push(format!(r#"{{"bufferView":{v},"componentType":5126,"count":{n},"type":"VEC3"}}"#));
            attrs.push(format!(r#""NORMAL":{}"#, accessors.len() - 1));
        }
        if let Some(colors) = &m.data.colors {
            // VEC4 of unsigned bytes keeps every element 4-byte aligned.
            let bytes: Vec<u8> = colors.iter().flat_map(|c| [c[0], c[1], c[2], 255]).collect();
            let v = view(&mut bin, &bytes, 34962);
            accessors.push(format!(
                r#"{{"bufferView":{v},"componentType":5121,"normalized":true,"count":{n},"type":"VEC4"}}"#
            ));
            attrs.push(format!(r#""COLOR_0":{}"#, accessors.len() - 1));
        }
        for (name, values) in &m.data.scalars {
            let v = view(&mut bin, &f32s(&mut values.iter().copied()), 34962);
            accessors.push(format!(r#"{{"bufferView":{v},"componentType":5126,"count":{n},"type":"SCALAR"}}"#));
            attrs.push(format!(r#""_{}":{}"#, json_name(name).to_ascii_uppercase(), accessors.len() - 1));
        }
        // glTF primitives here are triangle lists: quads are split (`Mesh::all_triangles`).
        let idx: Vec<u8> = mesh.all_triangles().flatten().flat_map(|i| i.to_le_bytes()).collect();
        let v = view(&mut bin, &idx, 34963);
        let max_index = mesh.all_triangles().flatten().max().unwrap_or(0);
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
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let uri = uri.map(|u| format!(r#","uri":"{}""#, json_name(u))).unwrap_or_default();
    let scene_nodes: Vec<String> = (0..nodes.len()).map(|k| k.to_string()).collect();
    let json = format!(
        r#"{{"asset":{{"version":"2.0","generator":"isoforge {}"}},"scene":0,"scenes":[{{"nodes":[{}]}}],"nodes":[{}],"meshes":[{}],"accessors":[{}],"bufferViews":[{}],"buffers":[{{"byteLength":{}{uri}}}]}}"#,
        env!("CARGO_PKG_VERSION"),
        scene_nodes.join(","),
        nodes.join(","),
        gmeshes.join(","),
        accessors.join(","),
        views.join(","),
        bin.len()
    );
    Ok((bin, json))
}

/// A string safe inside JSON quotes (names come from file names and iso values).
fn json_name(s: &str) -> String {
    s.chars().map(|c| if c == '"' || c == '\\' || c.is_control() { '_' } else { c }).collect()
}

/// Writes a binary glTF (`.glb`).
pub fn write_glb(w: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    let (bin, json) = build(meshes, None)?;
    let mut json = json.into_bytes();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let total = u32::try_from(total).map_err(|_| io::Error::other("the mesh exceeds the 4 GiB of a .glb file"))?;
    w.write_all(b"glTF")?;
    w.write_all(&2u32.to_le_bytes())?;
    w.write_all(&total.to_le_bytes())?;
    w.write_all(&(json.len() as u32).to_le_bytes())?;
    w.write_all(b"JSON")?;
    w.write_all(&json)?;
    w.write_all(&(bin.len() as u32).to_le_bytes())?;
    w.write_all(b"BIN\0")?;
    w.write_all(&bin)
}

/// The JSON of a `.gltf` whose buffer is the file `bin_uri` (written with [`write_gltf_bin`]).
pub fn write_gltf_json(w: &mut dyn Write, meshes: &[NamedMesh], bin_uri: &str) -> io::Result<()> {
    let (_, json) = build(meshes, Some(bin_uri))?;
    w.write_all(json.as_bytes())
}

/// The binary buffer of a `.gltf` + `.bin` pair.
pub fn write_gltf_bin(w: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    let (bin, _) = build(meshes, None)?;
    w.write_all(&bin)
}
