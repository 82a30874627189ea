//! Wavefront OBJ: `v` positions and `f` faces (`a`, `a/b`, `a//c`, `a/b/c`, negative indices);
//! polygons become triangle fans; everything else is ignored.

use std::path::Path;

use isoforge::mesh::Mesh;

use super::decode;
use super::mesh_text::{coord, push_fan, push_vertex};
use crate::error::{Ctx, Result};
use crate::limits::Limits;

/// Reads an OBJ mesh.
///
/// # Errors
/// A [`crate::Error`] naming the line and token at fault.
pub fn read_obj(path: &Path, limits: &Limits) -> Result<Mesh> {
    let ctx = Ctx::new(path, "OBJ");
    let bytes = decode::read_file(ctx, path, limits.max_bytes)?;
    let text = String::from_utf8_lossy(&bytes);
    let mut mesh = Mesh::default();
    let mut poly = Vec::new();
    for (no, line) in decode::numbered_lines(&text) {
        let mut toks = line.split_whitespace();
        match toks.next() {
            Some("v") => {
                let mut p = [0.0f32; 3];
                for (a, slot) in p.iter_mut().enumerate() {
                    let t = toks.next().ok_or_else(|| ctx.bad(format!("line {no}: vertex needs 3 coordinates")))?;
                    let v: f64 =
                        t.parse().map_err(|_| ctx.bad(format!("line {no}: coordinate {:?} is not a number", t)))?;
                    *slot = coord(ctx, v, || format!("line {no}, coordinate {a}"))?;
                }
                push_vertex(ctx, &mut mesh, p, limits)?;
            }
            Some("f") => {
                poly.clear();
                let n = mesh.positions.len() as i64;
                for t in toks {
                    let first = t.split('/').next().unwrap_or("");
                    let i: i64 =
                        first.parse().map_err(|_| ctx.bad(format!("line {no}: face index {t:?} is not a number")))?;
                    let idx = if i > 0 { i - 1 } else { n + i };
                    if i == 0 || idx < 0 || idx >= n {
                        return Err(
                            ctx.bad(format!("line {no}: face index {i} is outside the {n} vertices defined so far"))
                        );
                    }
                    poly.push(idx as u32);
                }
                if poly.len() < 3 {
                    return Err(ctx.bad(format!("line {no}: face has {} vertices, at least 3 are needed", poly.len())));
                }
                push_fan(ctx, &mut mesh, &poly, limits)?;
            }
            _ => {}
        }
    }
    Ok(mesh)
}
