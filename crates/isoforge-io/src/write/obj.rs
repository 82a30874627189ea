//! OBJ writer: `v`, `vn` when normals exist, and 1-based `f` (with `//n` references): triangles,
//! then quads, the lines formatted in parallel pieces (streamed by the text stream of
//! `write/text.rs`).

use std::io::{self, Write};

use isoforge::mesh::Mesh;

use super::text::write_lines;
use crate::attributes::MeshData;

/// The first line.
pub(super) fn header() -> String {
    format!("# isoforge {}\n", env!("CARGO_PKG_VERSION"))
}

/// Appends `TAG x y z` lines (`TAG x y z r g b` with colours, as fractions of 255), the floats
/// as Rust prints them (shortest round trip).
pub(super) fn vertex_lines(buf: &mut Vec<u8>, tag: &str, points: &[[f32; 3]], colors: Option<&[[u8; 3]]>) {
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
pub(super) fn face_lines<const N: usize>(
    buf: &mut Vec<u8>,
    faces: &[[u32; N]],
    base_v: u64,
    base_n: u64,
    with_n: bool,
) {
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
