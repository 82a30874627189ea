//! Binary STL writer (facet normals from the triangle's winding). STL holds triangles only: a
//! mesh's quads are written split along their shorter diagonal ([`Mesh::all_triangles`]).

use std::io::{self, Write};

use isoforge::mesh::Mesh;

/// A triangle's unit normal from its winding (zero when degenerate) and its corners.
fn facet(mesh: &Mesh, t: [u32; 3]) -> ([f32; 3], [[f32; 3]; 3]) {
    let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    (if len > 0.0 { n.map(|x| x / len) } else { n }, [a, b, c])
}

/// Writes `mesh` as binary STL.
pub fn write_stl(w: &mut dyn Write, mesh: &Mesh) -> io::Result<()> {
    let n = u32::try_from(mesh.num_split_triangles())
        .map_err(|_| io::Error::other("more triangles than binary STL can count"))?;
    let mut header = [0u8; 80];
    let tag = format!("isoforge {} binary STL", env!("CARGO_PKG_VERSION"));
    header[..tag.len()].copy_from_slice(tag.as_bytes());
    w.write_all(&header)?;
    w.write_all(&n.to_le_bytes())?;
    let mut buf = Vec::with_capacity(50 * 1024);
    for t in mesh.all_triangles() {
        let (nrm, [a, b, c]) = facet(mesh, t);
        for p in [nrm, a, b, c] {
            for x in p {
                buf.extend_from_slice(&x.to_le_bytes());
            }
        }
        buf.extend_from_slice(&[0, 0]);
        if buf.len() >= 50 * 1000 {
            w.write_all(&buf)?;
            buf.clear();
        }
    }
    w.write_all(&buf)
}

/// Writes `mesh` as ASCII STL (`solid … endsolid`), facet normals from the winding.
pub fn write_stl_ascii(w: &mut dyn Write, mesh: &Mesh) -> io::Result<()> {
    writeln!(w, "solid isoforge")?;
    let mut out = io::BufWriter::with_capacity(1 << 16, w);
    for t in mesh.all_triangles() {
        let (n, [a, b, c]) = facet(mesh, t);
        writeln!(out, "  facet normal {} {} {}\n    outer loop", n[0], n[1], n[2])?;
        for p in [a, b, c] {
            writeln!(out, "      vertex {} {} {}", p[0], p[1], p[2])?;
        }
        writeln!(out, "    endloop\n  endfacet")?;
    }
    writeln!(out, "endsolid isoforge")?;
    out.flush()
}
