//! OBJ writer: `v`, `vn` when normals exist, and 1-based `f` (with `//n` references).

use std::io::{self, Write};

use isoforge::mesh::Mesh;

/// Writes `mesh` as OBJ.
pub fn write_obj(w: &mut dyn Write, mesh: &Mesh) -> io::Result<()> {
    writeln!(w, "# isoforge {}", env!("CARGO_PKG_VERSION"))?;
    for p in &mesh.positions {
        writeln!(w, "v {} {} {}", p[0], p[1], p[2])?;
    }
    for n in &mesh.normals {
        writeln!(w, "vn {} {} {}", n[0], n[1], n[2])?;
    }
    let with_n = !mesh.normals.is_empty();
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| v + 1);
        if with_n {
            writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}")?;
        } else {
            writeln!(w, "f {a} {b} {c}")?;
        }
    }
    Ok(())
}
