//! OFF writer: triangles, then quads.

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
    let tag = if data.colors.is_some() { "COFF" } else { "OFF" };
    writeln!(w, "{tag}\n{} {} 0", mesh.positions.len(), mesh.triangles.len() + mesh.quads.len())?;
    // Lines into a Vec cannot fail.
    let colors = data.colors.as_deref();
    write_lines(w, &mesh.positions, |buf, ps, at| {
        for (i, p) in ps.iter().enumerate() {
            let _ = match colors {
                Some(c) => {
                    let c = c[at + i];
                    writeln!(buf, "{} {} {} {} {} {} 255", p[0], p[1], p[2], c[0], c[1], c[2])
                }
                None => writeln!(buf, "{} {} {}", p[0], p[1], p[2]),
            };
        }
    })?;
    write_lines(w, &mesh.triangles, |buf, ts, _| face_lines(buf, ts))?;
    write_lines(w, &mesh.quads, |buf, qs, _| face_lines(buf, qs))
}
