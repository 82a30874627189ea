//! OFF: `OFF`, counts, vertices, then faces as `n i0 … in-1` (colours after a face are ignored).

use std::path::Path;

use isoforge::mesh::Mesh;

use super::decode;
use super::mesh_text::{check_mesh_size, coord, push_fan};
use crate::error::{Ctx, Result};
use crate::limits::Limits;

/// Reads an OFF mesh.
///
/// # Errors
/// A [`crate::Error`] naming the line and value at fault.
pub fn read_off(path: &Path, limits: &Limits) -> Result<Mesh> {
    let ctx = Ctx::new(path, "OFF");
    let bytes = decode::read_file(ctx, path, limits.max_bytes)?;
    let text = String::from_utf8_lossy(&bytes);
    let mut lines = decode::numbered_lines(&text)
        .map(|(n, l)| (n, l.split('#').next().unwrap_or("").trim()))
        .filter(|(_, l)| !l.is_empty());
    let (no, first) = lines.next().ok_or_else(|| ctx.bad("empty file"))?;
    // COFF / NOFF / CNOFF carry per-vertex colours or normals after x y z: only x y z are read.
    let first = first.trim_start_matches(['C', 'N']);
    let counts_line = match first.strip_prefix("OFF") {
        Some(rest) if rest.trim().is_empty() => lines.next().ok_or_else(|| ctx.bad("no counts line"))?,
        Some(rest) => (no, rest.trim()),
        None => {
            return Err(
                ctx.bad(format!("line {no}: {:?} is not the OFF magic", first.chars().take(30).collect::<String>()))
            )
        }
    };
    let counts: Vec<u64> = counts_line
        .1
        .split_whitespace()
        .map(|t| t.parse().ok())
        .collect::<Option<_>>()
        .filter(|c: &Vec<u64>| c.len() >= 2)
        .ok_or_else(|| ctx.bad(format!("line {}: counts must be \"vertices faces edges\"", counts_line.0)))?;
    let (nv, nf) = (counts[0], counts[1]);
    check_mesh_size(ctx, nv, nf, limits)?;
    if nv.saturating_add(nf) > bytes.len() as u64 {
        return Err(ctx.bad(format!(
            "counts {nv} vertices, {nf} faces exceed what a {}-byte file can hold (truncated file?)",
            bytes.len()
        )));
    }
    let mut mesh = Mesh::default();
    for v in 0..nv {
        let (no, l) =
            lines.next().ok_or_else(|| ctx.bad(format!("file ends at vertex {v} of {nv} (truncated file?)")))?;
        let c: Vec<f64> = l
            .split_whitespace()
            .take(3)
            .map(|t| t.parse().ok())
            .collect::<Option<_>>()
            .filter(|c: &Vec<f64>| c.len() == 3)
            .ok_or_else(|| ctx.bad(format!("line {no}: vertex {v} needs 3 numbers")))?;
        let what = || format!("line {no}");
        mesh.positions.push([coord(ctx, c[0], what)?, coord(ctx, c[1], what)?, coord(ctx, c[2], what)?]);
    }
    let mut poly = Vec::new();
    for f in 0..nf {
        let (no, l) =
            lines.next().ok_or_else(|| ctx.bad(format!("file ends at face {f} of {nf} (truncated file?)")))?;
        let mut toks = l.split_whitespace();
        let n: usize = toks
            .next()
            .and_then(|t| t.parse().ok())
            .filter(|&n| n >= 3)
            .ok_or_else(|| ctx.bad(format!("line {no}: face {f} must start with a vertex count of at least 3")))?;
        poly.clear();
        for _ in 0..n {
            let i: u64 = toks
                .next()
                .and_then(|t| t.parse().ok())
                .ok_or_else(|| ctx.bad(format!("line {no}: face {f} has fewer than {n} indices")))?;
            if i >= nv {
                return Err(ctx.bad(format!("line {no}: face {f}: vertex index {i} is outside 0..{nv}")));
            }
            poly.push(i as u32);
        }
        push_fan(ctx, &mut mesh, &poly, limits)?;
    }
    Ok(mesh)
}
