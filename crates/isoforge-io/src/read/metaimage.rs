//! MetaImage (`.mha` with `ElementDataFile = LOCAL`, `.mhd` with a separate data file): raw or
//! zlib-compressed, either byte order, spacing, offset and `TransformMatrix`. The header, up to
//! `ElementDataFile` (its last key), must end within the first 64 KiB; a line running past them
//! is refused as too long.

use std::path::{Path, PathBuf};

use isoforge::grid::{AnyGrid, DType};

use super::decode;
use super::stream::{open_data, Compression, VolumeReader};
use crate::error::{Ctx, Result};
use crate::limits::Limits;

const MAX_HEADER_BYTES: usize = 1 << 16;

/// Reads a MetaImage volume.
///
/// # Errors
/// As [`open_metaimage`] and [`VolumeReader::read_grid`].
pub fn read_metaimage(path: &Path, limits: &Limits) -> Result<AnyGrid> {
    open_metaimage(path, limits)?.read_grid(limits)
}

/// Opens a MetaImage volume: parses the header and positions the sample stream; the size is
/// checked against `limits`.
///
/// # Errors
/// A [`crate::Error`] naming the line, key and value of any header problem, or data shorter
/// than the header declares.
pub fn open_metaimage(path: &Path, limits: &Limits) -> Result<VolumeReader> {
    let ctx = Ctx::new(path, "MetaImage");
    let head = crate::file::read_prefix(ctx, path, MAX_HEADER_BYTES as u64)?;
    let mut h = Header::default();
    let mut offset = 0usize;
    let mut line_no = 0usize;
    let mut data_start = None;
    while offset < head.len() {
        let end = head[offset..].iter().position(|&b| b == b'\n').map_or(head.len(), |p| offset + p);
        line_no += 1;
        if end == MAX_HEADER_BYTES {
            // The line goes on past the bytes read: what was read of it is not the whole value.
            return Err(ctx.bad(format!(
                "line {line_no} is too long: it does not end within the first {MAX_HEADER_BYTES} bytes, where the header (up to ElementDataFile) must end"
            )));
        }
        let line = std::str::from_utf8(&head[offset..end])
            .map_err(|_| ctx.bad(format!("line {line_no}: header is not text")))?
            .trim();
        offset = (end + 1).min(head.len());
        if line.is_empty() {
            continue;
        }
        let (key, value) = line
            .split_once('=')
            .ok_or_else(|| ctx.bad(format!("line {line_no}: {:?} is not \"Key = Value\"", short(line))))?;
        let (key, value) = (key.trim(), value.trim());
        if h.set(ctx, line_no, key, value)? {
            data_start = Some(if end < head.len() { end + 1 } else { head.len() });
            break;
        }
    }
    let data_file =
        h.data_file.clone().ok_or_else(|| ctx.bad("header has no ElementDataFile (it must be the last key)"))?;
    let dims = h.dims.ok_or_else(|| ctx.bad("header has no DimSize"))?;
    let dtype = h.dtype.ok_or_else(|| ctx.bad("header has no ElementType"))?;
    if h.channels != 1 {
        return Err(
            ctx.unsupported(format!("ElementNumberOfChannels = {}: only scalar volumes are supported", h.channels))
        );
    }
    let need = decode::sample_bytes(ctx, dims, dtype, limits)? as u64;
    let direction = match h.transform {
        Some(t) => {
            Some(decode::split_axes(t).ok_or_else(|| ctx.bad("TransformMatrix: an axis is zero or not finite"))?.1)
        }
        None => None,
    };
    let lattice =
        decode::lattice(ctx, "ElementSpacing, Offset, TransformMatrix", dims, h.spacing, h.origin, direction)?
            .with_space(Some(isoforge::grid::WorldSpace::Lps));
    let compression = if h.compressed { Compression::Zlib } else { Compression::None };
    if data_file.eq_ignore_ascii_case("LOCAL") {
        let start = data_start.unwrap_or(head.len()) as u64;
        let data = open_data(ctx, path, start, compression, need, "element data")?;
        return Ok(VolumeReader::stream(ctx, lattice, dtype, h.big_endian, data));
    }
    if data_file.starts_with("LIST") || data_file.contains('%') {
        return Err(ctx.unsupported(format!("ElementDataFile = {data_file}: multi-file data is not supported")));
    }
    let external = path.parent().unwrap_or(Path::new(".")).join(&data_file);
    let dctx = Ctx::new(&external, "MetaImage data");
    let len = crate::file::open(dctx, &external)?.len;
    let skip = match h.header_size {
        Some(-1) if !h.compressed => len.saturating_sub(need),
        Some(n) if n >= 0 => n as u64,
        Some(n) => return Err(ctx.bad(format!("HeaderSize = {n}: must be -1 or a byte count"))),
        None => 0,
    };
    let data = open_data(dctx, &external, skip, compression, need, "element data")?;
    Ok(VolumeReader::stream(dctx, lattice, dtype, h.big_endian, data))
}

struct Header {
    dims: Option<[u32; 3]>,
    ndims: Option<usize>,
    dtype: Option<DType>,
    spacing: [f64; 3],
    origin: [f64; 3],
    transform: Option<[[f64; 3]; 3]>,
    big_endian: bool,
    compressed: bool,
    channels: u32,
    header_size: Option<i64>,
    data_file: Option<String>,
}

impl Default for Header {
    fn default() -> Self {
        Header {
            dims: None,
            ndims: None,
            dtype: None,
            spacing: [1.0; 3],
            origin: [0.0; 3],
            transform: None,
            big_endian: false,
            compressed: false,
            channels: 1,
            header_size: None,
            data_file: None,
        }
    }
}

impl Header {
    /// Applies one key; returns true at `ElementDataFile` (the header's last key).
    fn set(&mut self, ctx: Ctx, no: usize, key: &str, value: &str) -> Result<bool> {
        let bad = |why: &str| ctx.bad(format!("line {no}: {key} = {:?}: {why}", short(value)));
        let n = self.ndims.unwrap_or(3);
        let vec3 = |fill: f64| -> Result<[f64; 3]> {
            let v: Vec<f64> = decode::parse_numbers(value)
                .filter(|v: &Vec<f64>| v.len() == n && v.iter().all(|x| x.is_finite()))
                .ok_or_else(|| bad(&format!("needs {n} finite numbers")))?;
            let mut out = [fill; 3];
            out[..n].copy_from_slice(&v);
            Ok(out)
        };
        match key {
            "NDims" => {
                let d: usize = value.parse().map_err(|_| bad("must be 2 or 3"))?;
                if !(2..=3).contains(&d) {
                    return Err(
                        ctx.unsupported(format!("line {no}: NDims = {d}: only 2D and 3D volumes are supported"))
                    );
                }
                self.ndims = Some(d);
            }
            "DimSize" => {
                let v: Option<Vec<u32>> = value.split_whitespace().map(decode::parse_dim).collect();
                let v = v.filter(|v| v.len() == n).ok_or_else(|| bad(&format!("needs {n} positive integers")))?;
                let mut d = [1; 3];
                d[..n].copy_from_slice(&v);
                self.dims = Some(d);
            }
            "ElementType" => {
                self.dtype = Some(match value {
                    "MET_UCHAR" => DType::U8,
                    "MET_CHAR" => DType::I8,
                    "MET_USHORT" => DType::U16,
                    "MET_SHORT" => DType::I16,
                    "MET_UINT" => DType::U32,
                    "MET_INT" => DType::I32,
                    "MET_FLOAT" => DType::F32,
                    "MET_DOUBLE" => DType::F64,
                    other => {
                        return Err(
                            ctx.unsupported(format!("line {no}: ElementType = {other}: unsupported sample type"))
                        )
                    }
                });
            }
            "ElementSpacing" => {
                self.spacing = vec3(1.0)?;
                if self.spacing.iter().any(|&s| s <= 0.0) {
                    return Err(bad("spacings must be positive"));
                }
            }
            "Offset" | "Origin" | "Position" => self.origin = vec3(0.0)?,
            "TransformMatrix" | "Rotation" | "Orientation" => {
                let v: Vec<f64> = decode::parse_numbers(value)
                    .filter(|v: &Vec<f64>| v.len() == n * n)
                    .ok_or_else(|| bad(&format!("needs {} numbers", n * n)))?;
                let mut m = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
                for a in 0..n {
                    for b in 0..n {
                        m[a][b] = v[a * n + b]; // each group of n is one index axis in world space
                    }
                }
                self.transform = Some(m);
            }
            "ElementByteOrderMSB" | "BinaryDataByteOrderMSB" => {
                self.big_endian = parse_bool(value).ok_or_else(|| bad("must be True or False"))?
            }
            "CompressedData" => self.compressed = parse_bool(value).ok_or_else(|| bad("must be True or False"))?,
            "ElementNumberOfChannels" => self.channels = value.parse().map_err(|_| bad("must be a whole number"))?,
            "HeaderSize" => self.header_size = Some(value.parse().map_err(|_| bad("must be a whole number"))?),
            "ObjectType" if value != "Image" => {
                return Err(ctx.unsupported(format!("line {no}: ObjectType = {value}: only Image is supported")))
            }
            "ElementDataFile" => {
                self.data_file = Some(value.to_string());
                return Ok(true);
            }
            _ => {}
        }
        Ok(false)
    }
}

/// The external data file a `.mhd` header names (`ElementDataFile = NAME`), if any.
pub(crate) fn data_file(path: &Path) -> Option<PathBuf> {
    let head = crate::file::read_prefix(Ctx::new(path, "MetaImage"), path, MAX_HEADER_BYTES as u64).ok()?;
    let text = String::from_utf8_lossy(&head).into_owned();
    let value = text.lines().find_map(|l| {
        let (k, v) = l.split_once('=')?;
        (k.trim() == "ElementDataFile").then(|| v.trim().to_string())
    })?;
    if value.eq_ignore_ascii_case("LOCAL") || value.starts_with("LIST") || value.contains('%') {
        return None;
    }
    Some(path.parent().unwrap_or(Path::new(".")).join(value))
}

fn parse_bool(s: &str) -> Option<bool> {
    match s.to_ascii_lowercase().as_str() {
        "true" | "1" => Some(true),
        "false" | "0" => Some(false),
        _ => None,
    }
}

fn short(s: &str) -> String {
    s.chars().take(60).collect()
}
