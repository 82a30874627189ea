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

/// Appends polygon `poly` (already 0-based, validated) as a triangle fan.
pub(crate) fn push_fan(mesh: &mut Mesh, poly: &[u32]) {
    for i in 1..poly.len().saturating_sub(1) {
        mesh.triangles.push([poly[0], poly[i], poly[i + 1]]);
    }
}

/// A finite coordinate or an error naming where it was found.
pub(crate) fn coord(ctx: Ctx, v: f64, what: impl FnOnce() -> String) -> Result<f32> {
    if v.is_finite() && v.abs() <= f32::MAX as f64 {
        Ok(v as f32)
    } else {
        Err(ctx.bad(format!("{}: coordinate {v} is not a finite number", what())))
    }
}
