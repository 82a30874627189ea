//! STL, binary or ASCII. STL stores each triangle's corners separately; they are joined into
//! shared vertices by exact (bitwise) equality of coordinates, the only joining STL allows.

use std::collections::HashMap;
use std::path::Path;

use isoforge::mesh::Mesh;

use super::decode;
use super::mesh_text::{check_mesh_size, coord, push_fan};
use crate::error::{Ctx, Result};
use crate::limits::Limits;

/// Reads an STL mesh.
///
/// # Errors
/// A [`crate::Error`] naming the byte offset or line at fault.
pub fn read_stl(path: &Path, limits: &Limits) -> Result<Mesh> {
    let ctx = Ctx::new(path, "STL");
    let bytes = decode::read_file(ctx, path, limits.max_bytes)?;
    let binary_count = bytes.get(80..84).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as u64);
    let mut w = Welder::default();
    match binary_count {
        Some(n) if 84 + 50 * n == bytes.len() as u64 => {
            check_mesh_size(ctx, 3 * n, n, limits)?;
            for t in 0..n as usize {
                let rec = &bytes[84 + 50 * t..84 + 50 * t + 50];
                let mut tri = [0u32; 3];
                for (c, slot) in tri.iter_mut().enumerate() {
                    let mut p = [0.0f32; 3];
                    for (a, q) in p.iter_mut().enumerate() {
                        let o = 12 + 12 * c + 4 * a;
                        let v = f32::from_le_bytes([rec[o], rec[o + 1], rec[o + 2], rec[o + 3]]);
                        *q = coord(ctx, v as f64, || format!("triangle {t}"))?;
                    }
                    *slot = w.id(p);
                }
                w.mesh.triangles.push(tri);
            }
        }
        _ if bytes.starts_with(b"solid") => {
            let text = String::from_utf8_lossy(&bytes);
            let mut corner = Vec::with_capacity(3);
            for (no, line) in decode::numbered_lines(&text) {
                let mut toks = line.split_whitespace();
                match toks.next() {
                    Some("vertex") => {
                        let v: Vec<f64> = toks
                            .map(|t| t.parse().map_err(|_| ctx.bad(format!("line {no}: {t:?} is not a number"))))
                            .collect::<Result<_>>()?;
                        if v.len() != 3 {
                            return Err(ctx.bad(format!("line {no}: vertex needs 3 coordinates")));
                        }
                        let what = || format!("line {no}");
                        corner.push(w.id([coord(ctx, v[0], what)?, coord(ctx, v[1], what)?, coord(ctx, v[2], what)?]));
                    }
                    Some("endloop") => {
                        if corner.len() != 3 {
                            return Err(
                                ctx.bad(format!("line {no}: facet has {} vertices, STL facets have 3", corner.len()))
                            );
                        }
                        push_fan(ctx, &mut w.mesh, &corner, limits)?;
                        corner.clear();
                    }
                    _ => {}
                }
            }
            if !corner.is_empty() {
                return Err(ctx.bad("file ends inside a facet (truncated file?)"));
            }
        }
        Some(n) => {
            return Err(ctx.bad(format!(
                "binary header declares {n} triangles ({} bytes) but the file has {} bytes, and it is not ASCII STL",
                84 + 50 * n,
                bytes.len()
            )));
        }
        None => return Err(ctx.bad(format!("{} bytes: too short for binary STL and not ASCII STL", bytes.len()))),
    }
    Ok(w.mesh)
}

#[derive(Default)]
struct Welder {
    mesh: Mesh,
    ids: HashMap<[u32; 3], u32>,
}

impl Welder {
    fn id(&mut self, p: [f32; 3]) -> u32 {
        // +0.0 and −0.0 are the same point.
        let key = p.map(|x| if x == 0.0 { 0 } else { x.to_bits() });
        let next = self.mesh.positions.len() as u32;
        *self.ids.entry(key).or_insert_with(|| {
            self.mesh.positions.push(p);
            next
        })
    }
}
