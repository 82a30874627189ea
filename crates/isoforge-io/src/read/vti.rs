//! VTK XML image data (`.vti`): one scalar point-data array (the `Scalars` one, else the first
//! single-component array) in any of VTK's layouts — ASCII, inline binary (base64), appended
//! raw or base64 — uncompressed or zlib-compressed (`vtkZLibDataCompressor`), UInt32 or UInt64
//! headers, little- or big-endian. Geometry from `WholeExtent`, `Origin`, `Spacing` and
//! `Direction` (VTK ≥ 9); world = the file's own frame. The samples' size (`WholeExtent` × type)
//! is checked against the limits from the head of the file before it is read whole; the file
//! itself may take twice the limit and 1 MiB (text encodings are longer than their samples).

use std::io::Read;
use std::path::Path;

use isoforge::grid::DType;

use super::decode;
use super::stream::VolumeReader;
use crate::error::{Ctx, Result};
use crate::limits::Limits;

/// Opens a `.vti` file.
///
/// # Errors
/// [`Error::Read`](crate::Error::Read) naming the element, attribute and value for a malformed
/// file; [`Error::Unsupported`](crate::Error::Unsupported) for other VTK file types, pieces that
/// do not cover the whole extent, multi-component arrays, other compressors;
/// [`Error::Limit`](crate::Error::Limit) when the volume exceeds `limits`.
pub fn open_vti(path: &Path, limits: &Limits) -> Result<VolumeReader> {
    let ctx = Ctx::new(path, "VTI");
    check_declared_size(ctx, path, limits)?;
    let len = crate::file::open(ctx, path)?.len;
    let max = max_file_bytes(limits);
    if len > max {
        return Err(ctx.limit(
            format!("the file (a .vti may take twice the limit and 1 MiB of XML: {max} bytes)"),
            len,
            limits.max_bytes,
        ));
    }
    let bytes = decode::read_file(ctx, path, max)?;
    // The XML part ends where raw appended data begins.
    let xml_end = find(&bytes, b"<AppendedData").map_or(bytes.len(), |p| p);
    let xml = String::from_utf8_lossy(&bytes[..xml_end]);
    let root = tag(&xml, "VTKFile").ok_or_else(|| ctx.bad("no <VTKFile> element"))?;
    let file_type = attr(&root, "type").unwrap_or_default();
    if file_type != "ImageData" {
        return Err(ctx.unsupported(format!("VTKFile type {file_type:?}: only ImageData is a volume")));
    }
    let big = attr(&root, "byte_order").as_deref() == Some("BigEndian");
    let header64 = match attr(&root, "header_type").as_deref() {
        None | Some("UInt32") => false,
        Some("UInt64") => true,
        Some(h) => return Err(ctx.bad(format!("header_type {h:?}: expected UInt32 or UInt64"))),
    };
    let compressed = match attr(&root, "compressor").as_deref() {
        None | Some("") => false,
        Some("vtkZLibDataCompressor") => true,
        Some(c) => return Err(ctx.unsupported(format!("compressor {c:?}: only vtkZLibDataCompressor is supported"))),
    };
    let image = tag(&xml, "ImageData").ok_or_else(|| ctx.bad("no <ImageData> element"))?;
    let (ext, dims) = extent(ctx, &image)?;
    // Absent: the defaults; present: three finite numbers, spacings positive.
    let origin0 = match attr(&image, "Origin") {
        Some(_) => numbers(ctx, &image, "Origin", 3)?,
        None => vec![0.0; 3],
    };
    let spacing = match attr(&image, "Spacing") {
        Some(_) => {
            let v = numbers(ctx, &image, "Spacing", 3)?;
            decode::spacings(ctx, "ImageData Spacing", dims, [v[0], v[1], v[2]])?.to_vec()
        }
        None => vec![1.0; 3],
    };
    let direction = match attr(&image, "Direction") {
        Some(_) => {
            let d = numbers(ctx, &image, "Direction", 9)?;
            // Row-major 3×3 whose columns are the index axes.
            Some([[d[0], d[3], d[6]], [d[1], d[4], d[7]], [d[2], d[5], d[8]]])
        }
        None => None,
    };
    if let Some(piece) = tag(&xml, "Piece") {
        if let Some(e) = attr(&piece, "Extent") {
            let pe = numbers(ctx, &piece, "Extent", 6)?;
            if pe != ext {
                return Err(ctx.unsupported(format!(
                    "Piece Extent {e:?} is not the WholeExtent: several pieces are not supported"
                )));
            }
        }
    }
    // The array: the PointData's `Scalars`, else the first DataArray of PointData.
    let xml: &str = &xml;
    let pd_start = xml.find("<PointData").ok_or_else(|| ctx.bad("no <PointData> element"))?;
    let pd = &xml[pd_start..xml[pd_start..].find("</PointData>").map_or(xml.len(), |e| pd_start + e)];
    let scalars = tag(pd, "PointData").and_then(|t| attr(&t, "Scalars"));
    let mut arrays = Vec::new();
    let mut rest = pd;
    while let Some(p) = rest.find("<DataArray") {
        let open_end = rest[p..].find('>').map(|e| p + e + 1).ok_or_else(|| ctx.bad("unterminated <DataArray>"))?;
        let head = rest[p..open_end].to_string();
        let body_end = rest[open_end..].find("</DataArray>").map_or(rest.len(), |e| open_end + e);
        arrays.push((head, &rest[open_end..body_end]));
        rest = &rest[body_end..];
    }
    let (head, body) = arrays
        .iter()
        .find(|(h, _)| scalars.is_some() && attr(h, "Name") == scalars)
        .or_else(|| arrays.first())
        .ok_or_else(|| ctx.bad("PointData has no DataArray"))?;
    let name = attr(head, "Name").unwrap_or_default();
    let components = attr(head, "NumberOfComponents").unwrap_or_else(|| "1".into());
    if components.trim() != "1" {
        return Err(
            ctx.unsupported(format!("DataArray {name:?} has {components} components: one value per point is needed"))
        );
    }
    let ty = attr(head, "type").unwrap_or_default();
    let dtype =
        sample_type(&ty).ok_or_else(|| ctx.unsupported(format!("DataArray {name:?} type {ty:?} is not supported")))?;
    let need = decode::sample_bytes(ctx, dims, dtype, limits)?;
    let lattice = decode::lattice(
        ctx,
        "ImageData Spacing, Origin, Direction",
        dims,
        [spacing[0], spacing[1], spacing[2]],
        [origin0[0], origin0[1], origin0[2]],
        direction,
    )?;
    let format = attr(head, "format").unwrap_or_default();
    let hsize = if header64 { 8 } else { 4 };
    let grid = |payload: &[u8]| decode::decode(ctx, lattice.clone(), dtype, big, &payload[..need]);
    let grid = match format.as_str() {
        "ascii" => decode::ascii_grid(ctx, body.as_bytes(), lattice.clone(), dtype)?,
        "binary" => {
            let data = base64(body.trim(), payload_bound(compressed, hsize, need))
                .ok_or_else(|| ctx.bad(format!("DataArray {name:?}: invalid base64")))?;
            grid(&unpack(ctx, &data, hsize, big, compressed, need)?)?
        }
        "appended" => {
            let offset: usize = attr(head, "offset")
                .and_then(|o| o.trim().parse().ok())
                .ok_or_else(|| ctx.bad(format!("DataArray {name:?}: appended without a valid offset")))?;
            let app = find(&bytes, b"<AppendedData").ok_or_else(|| ctx.bad("no <AppendedData> element"))?;
            let open_end = bytes[app..]
                .iter()
                .position(|&b| b == b'>')
                .map(|e| app + e + 1)
                .ok_or_else(|| ctx.bad("unterminated <AppendedData>"))?;
            let app_head = String::from_utf8_lossy(&bytes[app..open_end]).into_owned();
            let start = bytes[open_end..]
                .iter()
                .position(|&b| b == b'_')
                .map(|e| open_end + e + 1)
                .ok_or_else(|| ctx.bad("AppendedData has no '_' marker"))?;
            let at = start.checked_add(offset).filter(|&a| a <= bytes.len()).ok_or_else(|| {
                ctx.bad(format!("DataArray {name:?} offset {offset} is past the end of the appended data"))
            })?;
            match attr(&app_head, "encoding").as_deref() {
                Some("raw") => grid(&unpack(ctx, &bytes[at..], hsize, big, compressed, need)?)?,
                Some("base64") => {
                    let end = find(&bytes[at..], b"</AppendedData>").map_or(bytes.len(), |e| at + e);
                    let text = String::from_utf8_lossy(&bytes[at..end]);
                    let data = base64(text.trim(), payload_bound(compressed, hsize, need))
                        .ok_or_else(|| ctx.bad("AppendedData: invalid base64"))?;
                    grid(&unpack(ctx, &data, hsize, big, compressed, need)?)?
                }
                e => return Err(ctx.unsupported(format!("AppendedData encoding {e:?}: raw or base64 are supported"))),
            }
        }
        f => return Err(ctx.bad(format!("DataArray {name:?} format {f:?}: expected ascii, binary or appended"))),
    };
    Ok(VolumeReader::decoded(ctx, grid))
}

/// The XML read before the whole file: enough for the `<ImageData>` and `<DataArray>` tags.
const HEAD_BYTES: u64 = 1 << 20;

/// Refuses a volume whose samples exceed `limits` from the head of the file alone (its
/// `WholeExtent` and the smallest `DataArray` type there), before the file is read whole.
/// Whatever the head does not hold is checked after the whole read.
fn check_declared_size(ctx: Ctx, path: &Path, limits: &Limits) -> Result<()> {
    let head = crate::file::read_prefix(ctx, path, HEAD_BYTES)?;
    let xml = String::from_utf8_lossy(&head[..find(&head, b"<AppendedData").unwrap_or(head.len())]);
    let Some((_, dims)) = tag(&xml, "ImageData").and_then(|image| extent(ctx, &image).ok()) else {
        return Ok(());
    };
    let mut smallest: Option<DType> = None;
    let mut rest: &str = &xml;
    while let Some(p) = rest.find("<DataArray") {
        if let Some(t) = tag(&rest[p..], "DataArray").and_then(|t| attr(&t, "type")).and_then(|t| sample_type(&t)) {
            smallest = Some(smallest.map_or(t, |s| if t.size() < s.size() { t } else { s }));
        }
        rest = &rest[p + 1..];
    }
    decode::sample_bytes(ctx, dims, smallest.unwrap_or(DType::U8), limits).map(drop)
}

/// The `WholeExtent` of an `<ImageData>` start tag and the lattice dims it spans.
fn extent(ctx: Ctx, image: &str) -> Result<(Vec<f64>, [u32; 3])> {
    let ext = numbers(ctx, image, "WholeExtent", 6)?;
    let mut dims = [0u32; 3];
    for a in 0..3 {
        let n = ext[2 * a + 1] - ext[2 * a] + 1.0;
        if !(n >= 1.0 && n <= u32::MAX as f64 && n.fract() == 0.0) {
            return Err(ctx.bad(format!("ImageData WholeExtent {ext:?}: axis {a} has no points")));
        }
        dims[a] = n as u32;
    }
    Ok((ext, dims))
}

/// The sample type of a `DataArray` `type` attribute.
fn sample_type(ty: &str) -> Option<DType> {
    Some(match ty {
        "Int8" => DType::I8,
        "UInt8" => DType::U8,
        "Int16" => DType::I16,
        "UInt16" => DType::U16,
        "Int32" => DType::I32,
        "UInt32" => DType::U32,
        "Float32" => DType::F32,
        "Float64" => DType::F64,
        _ => return None,
    })
}

/// The largest `.vti` file read into memory: twice the sample limit (text encodings take more
/// room than the samples) and 1 MiB of XML.
fn max_file_bytes(limits: &Limits) -> u64 {
    limits.max_bytes.saturating_mul(2).saturating_add(1 << 20)
}

/// How many decoded bytes of a base64 array are needed: the header and the samples when
/// uncompressed; everything when compressed (the block sizes say how much).
fn payload_bound(compressed: bool, hsize: usize, need: usize) -> usize {
    if compressed {
        usize::MAX
    } else {
        hsize.saturating_add(need)
    }
}

/// The samples behind a VTK binary header: `[nbytes]` then the data, or, compressed,
/// `[nblocks, block size, last block size, compressed sizes…]` then zlib blocks.
fn unpack<'d>(
    ctx: Ctx,
    data: &'d [u8],
    hsize: usize,
    big: bool,
    compressed: bool,
    need: usize,
) -> Result<std::borrow::Cow<'d, [u8]>> {
    let word = |i: usize| -> Result<u64> {
        let b = data.get(i * hsize..(i + 1) * hsize).ok_or_else(|| ctx.bad("binary data ends inside its header"))?;
        Ok(match (hsize, big) {
            (4, false) => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as u64,
            (4, true) => u32::from_be_bytes([b[0], b[1], b[2], b[3]]) as u64,
            (_, false) => u64::from_le_bytes(b.try_into().unwrap_or([0; 8])),
            (_, true) => u64::from_be_bytes(b.try_into().unwrap_or([0; 8])),
        })
    };
    if !compressed {
        let n = word(0)? as usize;
        if n < need {
            return Err(ctx.bad(format!("the array declares {n} bytes, the volume needs {need}")));
        }
        let body = data.get(hsize..hsize + need).ok_or_else(|| {
            ctx.bad(format!("binary data ends after {} of the {need} bytes", data.len().saturating_sub(hsize)))
        })?;
        return Ok(std::borrow::Cow::Borrowed(body));
    }
    let blocks = word(0)? as usize;
    if blocks > 1 << 24 {
        return Err(ctx.bad(format!("{blocks} compressed blocks: not plausible")));
    }
    let mut out = Vec::with_capacity(need);
    let mut pos = hsize * (3 + blocks);
    for b in 0..blocks {
        if out.len() > need {
            break; // enough samples; the rest is not read
        }
        let csize = word(3 + b)? as usize;
        let chunk = data
            .get(pos..pos.saturating_add(csize))
            .ok_or_else(|| ctx.bad(format!("compressed block {b} is cut short")))?;
        flate2::read::ZlibDecoder::new(chunk)
            .take((need + 1 - out.len().min(need)) as u64)
            .read_to_end(&mut out)
            .map_err(|e| ctx.bad(format!("compressed block {b}: {e}")))?;
        pos += csize;
    }
    if out.len() < need {
        return Err(ctx.bad(format!("compressed data holds {} of the {need} bytes", out.len())));
    }
    Ok(std::borrow::Cow::Owned(out))
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

/// The start tag `<name …>` (attributes included).
fn tag(xml: &str, name: &str) -> Option<String> {
    let mut from = 0;
    while let Some(p) = xml[from..].find(&format!("<{name}")) {
        let start = from + p;
        let after = xml[start + 1 + name.len()..].chars().next();
        if matches!(after, Some(c) if c.is_whitespace() || c == '>' || c == '/') {
            let end = xml[start..].find('>')? + start;
            return Some(xml[start..=end].to_string());
        }
        from = start + 1;
    }
    None
}

/// The value of attribute `name="…"` in a start tag.
fn attr(tag: &str, name: &str) -> Option<String> {
    let mut from = 0;
    while let Some(p) = tag[from..].find(name) {
        let at = from + p;
        let before_ok = at == 0 || tag[..at].ends_with(|c: char| c.is_whitespace());
        let rest = tag[at + name.len()..].trim_start();
        if before_ok && rest.starts_with('=') {
            let rest = rest[1..].trim_start();
            let quote = rest.chars().next()?;
            if quote == '"' || quote == '\'' {
                let end = rest[1..].find(quote)?;
                return Some(rest[1..1 + end].to_string());
            }
        }
        from = at + 1;
    }
    None
}

fn numbers(ctx: Ctx, tag: &str, name: &str, n: usize) -> Result<Vec<f64>> {
    let v = attr(tag, name).ok_or_else(|| ctx.bad(format!("{name} is missing")))?;
    match decode::parse_numbers::<f64>(&v) {
        Some(x) if x.len() == n && x.iter().all(|v| v.is_finite()) => Ok(x),
        _ => Err(ctx.bad(format!("{name} {v:?}: expected {n} finite numbers"))),
    }
}

/// Decodes base64 text made of one or more padded chunks (VTK encodes headers and data apart),
/// stopping once `max` bytes are decoded.
fn base64(text: &str, max: usize) -> Option<Vec<u8>> {
    let val = |c: u8| -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => return None,
        } as u32)
    };
    let mut chars = text.bytes().filter(|b| !b.is_ascii_whitespace());
    let mut out = Vec::with_capacity((text.len() / 4 * 3).min(max));
    while out.len() < max {
        let mut q = [0u8; 4];
        let mut got = 0;
        for slot in &mut q {
            match chars.next() {
                Some(c) => {
                    *slot = c;
                    got += 1;
                }
                None => break,
            }
        }
        match got {
            0 => break,
            4 => {}
            _ => return None, // not a whole quad
        }
        let pad = q.iter().rev().take_while(|&&c| c == b'=').count();
        if pad > 2 || q[..4 - pad].contains(&b'=') {
            return None;
        }
        let mut n = 0u32;
        for &c in &q[..4 - pad] {
            n = n << 6 | val(c)?;
        }
        n <<= 6 * pad as u32;
        let b = n.to_be_bytes();
        out.extend_from_slice(&b[1..4 - pad]);
    }
    out.truncate(max);
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_chunks_and_attributes() {
        assert_eq!(base64("TWFu", usize::MAX).unwrap(), b"Man");
        assert_eq!(base64("TWE=TWFu", usize::MAX).unwrap(), b"MaMan");
        assert_eq!(base64("TWE=TWFu", 2).unwrap(), b"Ma");
        assert_eq!(base64("TQ==", usize::MAX).unwrap(), b"M");
        assert!(base64("TQ=", usize::MAX).is_none());
        assert!(base64("T=Q=", usize::MAX).is_none());
        let t = r#"<DataArray type="Float32" Name="v" format="appended" offset="0" >"#;
        assert_eq!(attr(t, "type").as_deref(), Some("Float32"));
        assert_eq!(attr(t, "offset").as_deref(), Some("0"));
        assert_eq!(attr(t, "Name").as_deref(), Some("v"));
        assert_eq!(attr(t, "ame"), None);
        assert_eq!(
            tag("<a><PointData Scalars=\"v\"><PointDataX>", "PointData").as_deref(),
            Some("<PointData Scalars=\"v\">")
        );
    }
}
