//! OFF writer: triangles, then quads (streamed by the text stream of `write/text.rs`).

use std::io::{self, Write};

use isoforge::mesh::Mesh;

use super::text::{face_lines, write_lines};
use crate::attributes::MeshData;

/// Writes `mesh` as OFF.
pub fn write_off(w: &mut dyn Write, mesh: &Mesh) -> io::Result<()> {
    write_off_with(w, mesh, &MeshData::default())
}

/// Writes `mesh` as OFF, or as COFF (`x y z r g b a` per vertex) when `data` has colours.
pub fn write_off_with(w: &mut dyn Write, mesh: &Mesh, data: &MeshData) -> io::Result<()> {
    if !data.fits(mesh) {
        return Err(io::Error::other("mesh data does not match the mesh"));
    }
    w.write_all(
        header(mesh.positions.len() as u64, (mesh.triangles.len() + mesh.quads.len()) as u64, data.colors.is_some())
            .as_bytes(),
    )?;
    let colors = data.colors.as_deref();
    write_lines(w, &mesh.positions, |buf, ps, at| vertex_lines(buf, ps, colors, at))?;
    write_lines(w, &mesh.triangles, |buf, ts, _| face_lines(buf, ts))?;
    write_lines(w, &mesh.quads, |buf, qs, _| face_lines(buf, qs))
}

/// The header: `OFF` (`COFF` with colours) and the counts.
pub(super) fn header(vertices: u64, faces: u64, colors: bool) -> String {
    format!("{}\n{vertices} {faces} 0\n", if colors { "COFF" } else { "OFF" })
}

/// Appends `x y z` lines (`x y z r g b 255` with colours, `colors[at..]` for these points).
pub(super) fn vertex_lines(buf: &mut Vec<u8>, points: &[[f32; 3]], colors: Option<&[[u8; 3]]>, at: usize) {
    for (i, p) in points.iter().enumerate() {
        // Lines into a Vec cannot fail.
        let _ = match colors {
            Some(c) => {
                let c = c[at + i];
                writeln!(buf, "{} {} {} {} {} {} 255", p[0], p[1], p[2], c[0], c[1], c[2])
            }
            None => writeln!(buf, "{} {} {}", p[0], p[1], p[2]),
        };
    }
}
