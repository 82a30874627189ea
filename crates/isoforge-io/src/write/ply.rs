//! PLY writer: binary little-endian (default) or ASCII; normals as nx, ny, nz when present.

use std::io::{self, Write};

use isoforge::mesh::Mesh;

/// Writes `mesh` as PLY.
pub fn write_ply(w: &mut dyn Write, mesh: &Mesh, ascii: bool) -> io::Result<()> {
    let normals = !mesh.normals.is_empty();
    let format = if ascii { "ascii" } else { "binary_little_endian" };
    write!(w, "ply\nformat {format} 1.0\ncomment isoforge {}\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
        env!("CARGO_PKG_VERSION"), mesh.positions.len())?;
    if normals {
        w.write_all(b"property float nx\nproperty float ny\nproperty float nz\n")?;
    }
    write!(w, "element face {}\nproperty list uchar int vertex_indices\nend_header\n", mesh.triangles.len())?;
    if ascii {
        for (i, p) in mesh.positions.iter().enumerate() {
            write!(w, "{} {} {}", p[0], p[1], p[2])?;
            if normals {
                let n = mesh.normals[i];
                write!(w, " {} {} {}", n[0], n[1], n[2])?;
            }
            w.write_all(b"\n")?;
        }
        for t in &mesh.triangles {
            writeln!(w, "3 {} {} {}", t[0], t[1], t[2])?;
        }
    } else {
        let mut buf = Vec::with_capacity(1 << 16);
        for (i, p) in mesh.positions.iter().enumerate() {
            for c in p {
                buf.extend_from_slice(&c.to_le_bytes());
            }
            if normals {
                for c in mesh.normals[i] {
                    buf.extend_from_slice(&c.to_le_bytes());
                }
            }
            if buf.len() >= 1 << 16 {
                w.write_all(&buf)?;
                buf.clear();
            }
        }
        for t in &mesh.triangles {
            buf.push(3);
            for v in t {
                buf.extend_from_slice(&(*v as i32).to_le_bytes());
            }
            if buf.len() >= 1 << 16 {
                w.write_all(&buf)?;
                buf.clear();
            }
        }
        w.write_all(&buf)?;
    }
    Ok(())
}
