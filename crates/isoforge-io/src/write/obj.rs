//! OBJ writer: `v`, `vn` when normals exist, and 1-based `f` (with `//n` references): triangles,
//! then quads.

use std::io::{self, Write};

use isoforge::mesh::Mesh;

use crate::attributes::MeshData;

/// Writes `mesh` as OBJ.
pub fn write_obj(w: &mut dyn Write, mesh: &Mesh) -> io::Result<()> {
    write_obj_with(w, mesh, &MeshData::default())
}

/// Writes `mesh` as OBJ with vertex colours (`v x y z r g b`, the common extension read by
/// MeshLab, Blender and trimesh). Scalar attributes have no OBJ form and are not written.
pub fn write_obj_with(w: &mut dyn Write, mesh: &Mesh, data: &MeshData) -> io::Result<()> {
    writeln!(w, "# isoforge {}", env!("CARGO_PKG_VERSION"))?;
    write_object(w, mesh, data, 0, 0)
}

/// One mesh's `v`, `vn` and `f` lines, indices offset by the vertices and normals written before.
fn write_object(w: &mut dyn Write, mesh: &Mesh, data: &MeshData, base_v: usize, base_n: usize) -> io::Result<()> {
    if !data.fits(mesh) {
        return Err(io::Error::other("mesh data does not have one entry per vertex"));
    }
    for (i, p) in mesh.positions.iter().enumerate() {
        match &data.colors {
            Some(c) => {
                let [r, g, b] = c[i].map(|x| x as f32 / 255.0);
                writeln!(w, "v {} {} {} {r} {g} {b}", p[0], p[1], p[2])?
            }
            None => writeln!(w, "v {} {} {}", p[0], p[1], p[2])?,
        }
    }
    for n in &mesh.normals {
        writeln!(w, "vn {} {} {}", n[0], n[1], n[2])?;
    }
    let with_n = !mesh.normals.is_empty();
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| v as usize + base_v + 1);
        if with_n {
            let [na, nb, nc] = t.map(|v| v as usize + base_n + 1);
            writeln!(w, "f {a}//{na} {b}//{nb} {c}//{nc}")?;
        } else {
            writeln!(w, "f {a} {b} {c}")?;
        }
    }
    for q in &mesh.quads {
        let [a, b, c, d] = q.map(|v| v as usize + base_v + 1);
        if with_n {
            let [na, nb, nc, nd] = q.map(|v| v as usize + base_n + 1);
            writeln!(w, "f {a}//{na} {b}//{nb} {c}//{nc} {d}//{nd}")?;
        } else {
            writeln!(w, "f {a} {b} {c} {d}")?;
        }
    }
    Ok(())
}

/// Writes several meshes into one OBJ, each an object (`o NAME`) with its own vertices
/// (colours as in [`write_obj_with`]); indices continue across objects as OBJ requires.
pub fn write_obj_objects(w: &mut dyn Write, meshes: &[crate::attributes::NamedMesh]) -> io::Result<()> {
    writeln!(w, "# isoforge {}", env!("CARGO_PKG_VERSION"))?;
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
