//! NRRD (`.nrrd` attached, `.nhdr` detached): raw, gzip and ASCII encodings, either endianness,
//! `spacings`, `space directions`, `space origin`, `byte skip`, `line skip`.
//!
//! World coordinates are the file's own space (`space` is kept as given, e.g. LPS for DICOM-derived
//! volumes). 2D images are read as one z-slab. Spacings must be finite and positive (a flip
//! belongs in `space directions`); `nan`, the format's "no spacing known", gives unit spacing.
//! gzip data is one gzip member holding exactly the declared samples: more bytes, a second
//! member or trailing bytes are refused. ASCII data holds exactly the declared values.

use std::path::{Path, PathBuf};

use isoforge::grid::WorldSpace;
use isoforge::grid::{AnyGrid, DType};

use std::io::Read;

use super::decode;
use super::stream::{self, open_data, Compression, VolumeReader};
use crate::error::{Ctx, Result};
use crate::limits::Limits;

/// Longest header accepted before the blank line.
const MAX_HEADER_BYTES: usize = 1 << 20;

/// Reads an NRRD file (attached or detached header).
///
/// # Errors
/// As [`open_nrrd`] and [`VolumeReader::read_grid`].
pub fn read_nrrd(path: &Path, limits: &Limits) -> Result<AnyGrid> {
    open_nrrd(path, limits)?.read_grid(limits)
}

/// Opens an NRRD file: parses the header and positions the sample stream. The volume's size is
/// checked against `limits` (pass `Limits::new(u64::MAX)` to stream a volume larger than memory).
///
/// # Errors
/// A [`crate::Error`] naming the line, field and value of any header problem, or a data file
/// shorter than the header declares.
pub fn open_nrrd(path: &Path, limits: &Limits) -> Result<VolumeReader> {
    let ctx = Ctx::new(path, "NRRD");
    let head = crate::file::read_prefix(ctx, path, MAX_HEADER_BYTES as u64)?;
    let header_end = header_end(&head);
    let header_text = std::str::from_utf8(&head[..header_end.min(head.len())])
        .map_err(|e| ctx.bad(format!("byte {}: header is not text", e.valid_up_to())))?;
    let h = Header::parse(ctx, header_text)?;
    let need = decode::sample_bytes(ctx, h.dims, h.dtype, limits)? as u64;
    let lattice =
        decode::lattice(ctx, &h.geometry_fields, h.dims, h.spacing, h.origin, h.direction)?.with_space(h.space);

    // The data: after the header, or in the detached file.
    let (data_path, mut offset) = match &h.data_file {
        None => (path.to_path_buf(), header_end as u64),
        Some(name) => (resolve(path, name), 0),
    };
    let dctx = Ctx::new(&data_path, if h.data_file.is_some() { "NRRD data" } else { "NRRD" });
    offset = skip_lines(dctx, &data_path, offset, h.line_skip)?;
    match h.encoding {
        Encoding::Ascii => {
            let crate::file::Input { mut file, len } = crate::file::open(dctx, &data_path)?;
            std::io::Seek::seek(&mut file, std::io::SeekFrom::Start(offset.min(len))).map_err(|e| dctx.io(e))?;
            let grid = decode::ascii_grid(dctx, file.take(len.saturating_sub(offset)), lattice, h.dtype)?;
            Ok(VolumeReader::decoded(dctx, grid))
        }
        Encoding::Raw => {
            let len = crate::file::open(dctx, &data_path)?.len;
            offset = match h.byte_skip {
                ByteSkip::Bytes(n) => offset.saturating_add(n as u64),
                ByteSkip::FromEnd => len.checked_sub(need).ok_or_else(|| {
                    dctx.bad(format!("byte skip -1: the data has {len} bytes, fewer than the {need} needed"))
                })?,
            };
            let data = open_data(dctx, &data_path, offset, Compression::None, need, "raw data")?;
            Ok(VolumeReader::stream(dctx, lattice, h.dtype, h.big_endian, data))
        }
        Encoding::Gzip => {
            let ByteSkip::Bytes(skip) = h.byte_skip else {
                return Err(ctx.unsupported("byte skip -1 is only defined for raw encoding"));
            };
            let mut data = open_data(dctx, &data_path, offset, Compression::GzipOneMember, need, "gzip data")?;
            stream::skip(dctx, &mut data.reader, skip as u64, "gzip data")?;
            Ok(VolumeReader::stream(dctx, lattice, h.dtype, h.big_endian, data))
        }
    }
}

/// The detached data file a header names (`data file: NAME`), if any; `None` when the header
/// cannot be read (the reader reports why).
pub(crate) fn data_file(path: &Path) -> Option<PathBuf> {
    let head = crate::file::read_prefix(Ctx::new(path, "NRRD"), path, MAX_HEADER_BYTES as u64).ok()?;
    let text = String::from_utf8_lossy(&head[..header_end(&head)]).into_owned();
    let found = decode::numbered_lines(&text).take_while(|(_, l)| !l.is_empty()).find_map(|(_, l)| {
        let (field, value) = l.split_once(": ")?;
        matches!(field.to_ascii_lowercase().as_str(), "data file" | "datafile").then(|| resolve(path, value.trim()))
    });
    found
}

fn header_end(bytes: &[u8]) -> usize {
    decode::find_header_end(bytes, MAX_HEADER_BYTES).unwrap_or(bytes.len())
}

fn resolve(header: &Path, name: &str) -> PathBuf {
    let p = Path::new(name);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        header.parent().unwrap_or(Path::new(".")).join(p)
    }
}

/// The offset after `n` more lines from `offset` in `path`.
fn skip_lines(ctx: Ctx, path: &Path, offset: u64, n: usize) -> Result<u64> {
    if n == 0 {
        return Ok(offset);
    }
    let crate::file::Input { mut file, len } = crate::file::open(ctx, path)?;
    std::io::Seek::seek(&mut file, std::io::SeekFrom::Start(offset)).map_err(|e| ctx.io(e))?;
    let mut r = std::io::BufReader::new(file.take(len.saturating_sub(offset)));
    let mut pos = offset;
    let mut line = Vec::new();
    for i in 0..n {
        line.clear();
        let got = std::io::BufRead::read_until(&mut r, b'\n', &mut line).map_err(|e| ctx.io(e))?;
        if got == 0 {
            return Err(ctx.bad(format!("line skip {n}: data has only {i} lines")));
        }
        pos += got as u64;
    }
    Ok(pos)
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Encoding {
    Raw,
    Gzip,
    Ascii,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum ByteSkip {
    Bytes(usize),
    FromEnd,
}

struct Header {
    dims: [u32; 3],
    dtype: DType,
    encoding: Encoding,
    big_endian: bool,
    spacing: [f64; 3],
    origin: [f64; 3],
    direction: Option<[[f64; 3]; 3]>,
    data_file: Option<String>,
    byte_skip: ByteSkip,
    line_skip: usize,
    space: Option<WorldSpace>,
    /// The header fields the geometry came from, for messages.
    geometry_fields: String,
}

impl Header {
    fn parse(ctx: Ctx, text: &str) -> Result<Header> {
        let mut lines = decode::numbered_lines(text);
        match lines.next() {
            Some((_, magic)) if magic.starts_with("NRRD000") => {}
            Some((_, magic)) => {
                return Err(ctx.bad(format!("line 1: {:?} is not an NRRD magic (NRRD0001…NRRD0005)", truncate(magic))))
            }
            None => return Err(ctx.bad("empty file")),
        }
        let mut dimension = None;
        let (mut sizes, mut dtype, mut encoding, mut endian) = (None, None, None, None);
        let (mut spacings, mut directions, mut origin, mut data_file) = (None, None, None, None);
        let (mut byte_skip, mut line_skip) = (ByteSkip::Bytes(0), 0usize);
        let mut space = None;
        for (no, line) in lines {
            if line.is_empty() {
                break;
            }
            if line.starts_with('#') {
                continue;
            }
            if line.contains(":=") {
                continue; // key/value pairs: free-form metadata
            }
            let Some((field, value)) = line.split_once(": ") else {
                return Err(ctx.bad(format!("line {no}: {:?} is not \"field: value\"", truncate(line))));
            };
            let value = value.trim();
            let bad = |why: &str| ctx.bad(format!("line {no}: {field} {:?}: {why}", truncate(value)));
            match field.to_ascii_lowercase().as_str() {
                "dimension" => {
                    let d: usize = value.parse().map_err(|_| bad("must be a whole number"))?;
                    if !(2..=3).contains(&d) {
                        return Err(ctx.unsupported(format!(
                            "line {no}: dimension {d}: only 2D and 3D scalar volumes are supported"
                        )));
                    }
                    dimension = Some(d);
                }
                "sizes" => {
                    let v: Option<Vec<u32>> = value.split_whitespace().map(decode::parse_dim).collect();
                    sizes = Some(v.ok_or_else(|| bad("sizes must be positive integers"))?);
                }
                "type" => {
                    dtype = Some(parse_type(value).ok_or_else(|| {
                        ctx.unsupported(format!(
                            "line {no}: type {:?}: unknown or unsupported sample type",
                            truncate(value)
                        ))
                    })?);
                }
                "encoding" => {
                    encoding = Some(match value.to_ascii_lowercase().as_str() {
                        "raw" => Encoding::Raw,
                        "gzip" | "gz" => Encoding::Gzip,
                        "ascii" | "text" | "txt" => Encoding::Ascii,
                        other => {
                            return Err(ctx.unsupported(format!(
                                "line {no}: encoding {other:?} is not supported (raw, gzip, ascii)"
                            )))
                        }
                    });
                }
                "endian" => {
                    endian = Some(match value {
                        "little" => false,
                        "big" => true,
                        _ => return Err(bad("must be little or big")),
                    });
                }
                "spacings" => {
                    let v: Option<Vec<f64>> = value.split_whitespace().map(|t| t.parse().ok()).collect();
                    spacings = Some((no, v.ok_or_else(|| bad("spacings must be numbers"))?));
                }
                "space directions" => {
                    let mut v = Vec::new();
                    for tok in value.split_whitespace() {
                        if tok == "none" {
                            continue;
                        }
                        let inner = tok
                            .strip_prefix('(')
                            .and_then(|t| t.strip_suffix(')'))
                            .ok_or_else(|| bad("vectors must look like (x,y,z)"))?;
                        let n: Vec<f64> = decode::parse_numbers(inner)
                            .filter(|n: &Vec<f64>| n.len() == 3)
                            .ok_or_else(|| bad("vectors must have 3 numbers"))?;
                        v.push([n[0], n[1], n[2]]);
                    }
                    directions = Some((no, v));
                }
                "space origin" => {
                    let inner = value
                        .strip_prefix('(')
                        .and_then(|t| t.strip_suffix(')'))
                        .ok_or_else(|| bad("must look like (x,y,z)"))?;
                    let n: Vec<f64> = decode::parse_numbers(inner)
                        .filter(|n: &Vec<f64>| n.len() == 3 && n.iter().all(|x| x.is_finite()))
                        .ok_or_else(|| bad("must be 3 finite numbers"))?;
                    origin = Some((no, [n[0], n[1], n[2]]));
                }
                "data file" | "datafile" => {
                    if value.starts_with("LIST") || value.split_whitespace().count() > 1 {
                        return Err(ctx.unsupported(format!(
                            "line {no}: data file {:?}: multi-file data is not supported",
                            truncate(value)
                        )));
                    }
                    data_file = Some(value.to_string());
                }
                "byte skip" | "byteskip" => {
                    byte_skip = match value {
                        "-1" => ByteSkip::FromEnd,
                        v => ByteSkip::Bytes(v.parse().map_err(|_| bad("must be -1 or a whole number"))?),
                    };
                }
                "line skip" | "lineskip" => line_skip = value.parse().map_err(|_| bad("must be a whole number"))?,
                "space" => {
                    space = match value.to_ascii_lowercase().as_str() {
                        "left-posterior-superior" | "lps" => Some(WorldSpace::Lps),
                        "right-anterior-superior" | "ras" => Some(WorldSpace::Ras),
                        _ => None, // scanner-xyz, 3D-right-handed…: no anatomical frame
                    }
                }
                _ => {} // kinds, content, min, max, units, labels, …: not needed for meshing
            }
        }
        let dimension = dimension.ok_or_else(|| ctx.bad("header has no \"dimension\" field"))?;
        let sizes = sizes.ok_or_else(|| ctx.bad("header has no \"sizes\" field"))?;
        if sizes.len() != dimension {
            return Err(ctx.bad(format!("sizes has {} values but dimension is {dimension}", sizes.len())));
        }
        let dtype = dtype.ok_or_else(|| ctx.bad("header has no \"type\" field"))?;
        let encoding = encoding.ok_or_else(|| ctx.bad("header has no \"encoding\" field"))?;
        let big_endian = match endian {
            Some(e) => e,
            None if dtype.size() == 1 || encoding == Encoding::Ascii => false,
            None => return Err(ctx.bad(format!("header has no \"endian\" field, needed for {dtype} samples"))),
        };
        let mut dims = [1u32; 3];
        dims[..dimension].copy_from_slice(&sizes);
        let mut spacing = [1.0; 3];
        let mut direction = None;
        let mut origin3 = [0.0; 3];
        let mut fields: Vec<String> = Vec::new();
        if let Some((no, dirs)) = directions {
            if dirs.len() != dimension {
                return Err(
                    ctx.bad(format!("line {no}: space directions has {} vectors for {dimension} axes", dirs.len()))
                );
            }
            let mut axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
            axes[..dimension].copy_from_slice(&dirs);
            let (s, d) = decode::split_axes(axes).ok_or_else(|| {
                ctx.bad(format!("line {no}: space directions {dirs:?}: every vector must be finite and non-zero"))
            })?;
            spacing = s;
            direction = Some(d);
            fields.push(format!("line {no}: space directions"));
        } else if let Some((no, sp)) = spacings {
            if sp.len() != dimension {
                return Err(ctx.bad(format!("line {no}: spacings has {} values for {dimension} axes", sp.len())));
            }
            // NRRD writes "nan" for an axis without spacing information: unit spacing there.
            // Anything else must be a finite positive distance (a flip belongs in "space directions").
            for (a, &s) in sp.iter().enumerate() {
                spacing[a] = if s.is_nan() { 1.0 } else { s };
            }
            let mut dims3 = [1u32; 3];
            dims3[..dimension].copy_from_slice(&sizes);
            spacing = decode::spacings(ctx, &format!("line {no}: spacings"), dims3, spacing)?;
            fields.push(format!("line {no}: spacings"));
        }
        if let Some((no, o)) = origin {
            origin3 = o;
            fields.push(format!("line {no}: space origin"));
        }
        Ok(Header {
            dims,
            dtype,
            encoding,
            big_endian,
            spacing,
            origin: origin3,
            direction,
            data_file,
            byte_skip,
            line_skip,
            space,
            geometry_fields: if fields.is_empty() { "sizes".to_string() } else { fields.join(", ") },
        })
    }
}

fn parse_type(s: &str) -> Option<DType> {
    Some(match s {
        "signed char" | "int8" | "int8_t" => DType::I8,
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => DType::U8,
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => DType::I16,
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => DType::U16,
        "int" | "signed int" | "int32" | "int32_t" => DType::I32,
        "uint" | "unsigned int" | "uint32" | "uint32_t" => DType::U32,
        "float" => DType::F32,
        "double" => DType::F64,
        _ => return None,
    })
}

fn truncate(s: &str) -> String {
    s.chars().take(60).collect()
}
