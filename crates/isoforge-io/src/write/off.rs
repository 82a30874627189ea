//! OFF writer: triangles, then quads.

use std::io::{self, Write};

use isoforge::mesh::Mesh;

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
    for (i, p) in mesh.positions.iter().enumerate() {
        match &data.colors {
            Some(c) => writeln!(w, "{} {} {} {} {} {} 255", p[0], p[1], p[2], c[i][0], c[i][1], c[i][2])?,
            None => writeln!(w, "{} {} {}", p[0], p[1], p[2])?,
        }
    }
    for t in &mesh.triangles {
        writeln!(w, "3 {} {} {}", t[0], t[1], t[2])?;
    }
    for q in &mesh.quads {
        writeln!(w, "4 {} {} {} {}", q[0], q[1], q[2], q[3])?;
    }
    Ok(())
}
