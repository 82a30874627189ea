//! OFF writer.

use std::io::{self, Write};

use isoforge::mesh::Mesh;

/// Writes `mesh` as OFF.
pub fn write_off(w: &mut dyn Write, mesh: &Mesh) -> io::Result<()> {
    writeln!(w, "OFF\n{} {} 0", mesh.positions.len(), mesh.triangles.len())?;
    for p in &mesh.positions {
        writeln!(w, "{} {} {}", p[0], p[1], p[2])?;
    }
    for t in &mesh.triangles {
        writeln!(w, "3 {} {} {}", t[0], t[1], t[2])?;
    }
    Ok(())
}
