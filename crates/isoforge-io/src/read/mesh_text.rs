//! Small helpers shared by the mesh readers.

use isoforge::mesh::Mesh;

use crate::error::{Ctx, Result};
use crate::limits::Limits;

/// Bytes a mesh of `vertices` and `triangles` needs (positions + indices), checked against limits.
pub(crate) fn check_mesh_size(ctx: Ctx, vertices: u64, triangles: u64, limits: &Limits) -> Result<()> {
    let bytes = vertices.checked_mul(12).and_then(|v| triangles.checked_mul(12).and_then(|t| v.checked_add(t)));
    match bytes {
        Some(b) if b <= limits.max_bytes => Ok(()),
        Some(b) => Err(ctx.limit(format!("{vertices} vertices and {triangles} triangles"), b, limits.max_bytes)),
        None => Err(ctx.bad(format!("{vertices} vertices and {triangles} triangles: the size overflows"))),
    }
}

/// Bytes a mesh takes in memory (positions and triangles), as [`check_mesh_size`] counts them.
fn mesh_bytes(vertices: usize, triangles: usize) -> u64 {
    (vertices as u64).saturating_add(triangles as u64).saturating_mul(12)
}

/// Appends polygon `poly` (already 0-based, validated) as a triangle fan, refusing to grow the
/// mesh past the limit (polygons can make more triangles than a header's face count says).
pub(crate) fn push_fan(ctx: Ctx, mesh: &mut Mesh, poly: &[u32], limits: &Limits) -> Result<()> {
    let add = poly.len().saturating_sub(2);
    let bytes = mesh_bytes(mesh.positions.len(), mesh.triangles.len() + add);
    if bytes > limits.max_bytes {
        return Err(ctx.limit(
            format!("{} vertices and {} triangles", mesh.positions.len(), mesh.triangles.len() + add),
            bytes,
            limits.max_bytes,
        ));
    }
    for i in 1..poly.len().saturating_sub(1) {
        mesh.triangles.push([poly[0], poly[i], poly[i + 1]]);
    }
    Ok(())
}

/// Appends vertex `p`, refusing to grow the mesh past the limit.
pub(crate) fn push_vertex(ctx: Ctx, mesh: &mut Mesh, p: [f32; 3], limits: &Limits) -> Result<()> {
    let bytes = mesh_bytes(mesh.positions.len() + 1, mesh.triangles.len());
    if bytes > limits.max_bytes {
        return Err(ctx.limit(
            format!("{} vertices and {} triangles", mesh.positions.len() + 1, mesh.triangles.len()),
            bytes,
            limits.max_bytes,
        ));
    }
    mesh.positions.push(p);
    Ok(())
}

/// A finite coordinate or an error naming where it was found.
pub(crate) fn coord(ctx: Ctx, v: f64, what: impl FnOnce() -> String) -> Result<f32> {
    if v.is_finite() && v.abs() <= f32::MAX as f64 {
        Ok(v as f32)
    } else {
        Err(ctx.bad(format!("{}: coordinate {v} is not a finite number", what())))
    }
}
