//! VTK legacy files holding `DATASET STRUCTURED_POINTS` with one `SCALARS` array (ASCII or BINARY;
//! binary data is big-endian, as the format says). `DIMENSIONS`, `SPACING` (or `ASPECT_RATIO`) and
//! `ORIGIN` give the lattice; VTK image data has no direction. `POINT_DATA`, when given, must be
//! the point count; ASCII data holds exactly that many values (a keyword may follow them).

use std::path::Path;

use isoforge::grid::DType;

use super::decode;
use super::stream::{open_data, Compression, VolumeReader};
use crate::error::{Ctx, Result};
use crate::limits::Limits;

/// The longest header read before the data (a legacy header is a few lines).
const MAX_HEADER: usize = 64 << 10;

/// Opens a VTK legacy structured-points file.
///
/// # Errors
/// [`Error::Read`](crate::Error::Read) naming the line and keyword for a malformed header,
/// [`Error::Unsupported`](crate::Error::Unsupported) for other datasets, vectors or several
/// components, [`Error::Limit`](crate::Error::Limit) when the volume exceeds `limits`.
pub fn open_vtk(path: &Path, limits: &Limits) -> Result<VolumeReader> {
    let ctx = Ctx::new(path, "VTK");
    let head = crate::file::read_prefix(ctx, path, MAX_HEADER as u64)?;
    // Lines up to and including LOOKUP_TABLE; the data starts after that line.
    let mut pos = 0usize;
    let mut line_no = 0usize;
    let mut next_line = |pos: &mut usize| -> Option<(usize, String)> {
        if *pos >= head.len() {
            return None;
        }
        let end = head[*pos..].iter().position(|&b| b == b'\n').map(|e| *pos + e + 1).unwrap_or(head.len());
        let text = String::from_utf8_lossy(&head[*pos..end]).trim().to_string();
        *pos = end;
        line_no += 1;
        Some((line_no, text))
    };
    let first = next_line(&mut pos).map(|l| l.1).unwrap_or_default();
    if !first.starts_with("# vtk DataFile") {
        return Err(ctx.bad(format!("line 1: {first:?} is not \"# vtk DataFile Version …\"")));
    }
    let _title = next_line(&mut pos);
    let (mut binary, mut dims, mut spacing, mut origin, mut dtype, mut points) =
        (None, None, [1.0; 3], [0.0; 3], None, None);
    loop {
        let Some((n, line)) = next_line(&mut pos) else {
            return Err(ctx.bad("the header ends before LOOKUP_TABLE (no SCALARS data found in the first 64 KiB)"));
        };
        if line.is_empty() {
            continue;
        }
        let mut words = line.split_whitespace();
        let key = words.next().unwrap_or_default().to_ascii_uppercase();
        let rest: Vec<&str> = words.collect();
        let numbers = |what: &str| -> Result<[f64; 3]> {
            let v: Option<Vec<f64>> = rest.iter().map(|t| t.parse().ok()).collect();
            match v {
                Some(v) if v.len() == 3 && v.iter().all(|x| x.is_finite()) => Ok([v[0], v[1], v[2]]),
                _ => Err(ctx.bad(format!("line {n}: {what} {:?}: expected three finite numbers", rest.join(" ")))),
            }
        };
        match key.as_str() {
            "ASCII" => binary = Some(false),
            "BINARY" => binary = Some(true),
            "DATASET" => {
                let kind = rest.first().copied().unwrap_or_default();
                if !kind.eq_ignore_ascii_case("STRUCTURED_POINTS") {
                    return Err(ctx.unsupported(format!(
                        "line {n}: DATASET {kind}: only STRUCTURED_POINTS (image data) is a volume"
                    )));
                }
            }
            "DIMENSIONS" => {
                let d: Option<Vec<u32>> = rest.iter().map(|t| decode::parse_dim(t)).collect();
                match d {
                    Some(d) if d.len() == 3 => dims = Some([d[0], d[1], d[2]]),
                    _ => {
                        return Err(ctx.bad(format!(
                            "line {n}: DIMENSIONS {:?}: expected three positive integers",
                            rest.join(" ")
                        )))
                    }
                }
            }
            "SPACING" | "ASPECT_RATIO" => {
                spacing = numbers(&key)?;
                if spacing.iter().any(|&s| s <= 0.0) {
                    return Err(ctx.bad(format!("line {n}: {key} {spacing:?}: must be positive")));
                }
            }
            "ORIGIN" => origin = numbers("ORIGIN")?,
            "POINT_DATA" => points = Some(rest.first().copied().unwrap_or_default().to_string()),
            "CELL_DATA" => {
                return Err(ctx.unsupported(format!("line {n}: CELL_DATA: only point data is a sampled volume")))
            }
            "SCALARS" => {
                let ty = rest.get(1).copied().unwrap_or_default();
                dtype = Some(match ty {
                    "unsigned_char" => DType::U8,
                    "char" => DType::I8,
                    "unsigned_short" => DType::U16,
                    "short" => DType::I16,
                    "unsigned_int" => DType::U32,
                    "int" => DType::I32,
                    "float" => DType::F32,
                    "double" => DType::F64,
                    other => return Err(ctx.unsupported(format!("line {n}: SCALARS type {other:?} is not supported"))),
                });
                if let Some(c) = rest.get(2) {
                    if *c != "1" {
                        return Err(ctx.unsupported(format!(
                            "line {n}: SCALARS with {c} components: one value per point is needed"
                        )));
                    }
                }
            }
            "LOOKUP_TABLE" => break,
            "VECTORS" | "NORMALS" | "TENSORS" | "COLOR_SCALARS" | "FIELD" => {
                return Err(ctx.unsupported(format!("line {n}: {key} data: only SCALARS are read")));
            }
            _ => {}
        }
    }
    let dims = dims.ok_or_else(|| ctx.bad("no DIMENSIONS line"))?;
    let dtype = dtype.ok_or_else(|| ctx.bad("no SCALARS line"))?;
    let binary = binary.ok_or_else(|| ctx.bad("line 3: neither ASCII nor BINARY"))?;
    let count = dims.iter().map(|&d| d as u64).product::<u64>();
    // A count that is not a number (`-5`, `1e3`) is as wrong as a count that differs.
    if let Some(p) = points {
        if p.parse::<u64>().ok() != Some(count) {
            return Err(ctx.bad(format!("POINT_DATA {p} does not match DIMENSIONS {dims:?} ({count} points)")));
        }
    }
    let need = decode::sample_bytes(ctx, dims, dtype, limits)? as u64;
    let lattice = decode::lattice(ctx, "SPACING, ORIGIN", dims, spacing, origin, None)?;
    if binary {
        let data = open_data(ctx, path, pos as u64, Compression::None, need, "binary data")?;
        return Ok(VolumeReader::stream(ctx, lattice, dtype, true, data));
    }
    let crate::file::Input { mut file, len } = crate::file::open(ctx, path)?;
    std::io::Seek::seek(&mut file, std::io::SeekFrom::Start(pos as u64)).map_err(|e| ctx.io(e))?;
    let text = std::io::Read::take(file, len.saturating_sub(pos as u64));
    Ok(VolumeReader::decoded(ctx, decode::ascii_grid(ctx, text, lattice, dtype)?))
}
