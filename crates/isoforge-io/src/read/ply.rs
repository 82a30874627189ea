//! PLY (ASCII and binary, either endianness): `vertex` x, y, z and a `face` index list; other
//! elements and properties are skipped; polygons become triangle fans.

use std::path::Path;

use isoforge::mesh::Mesh;

use super::decode;
use super::mesh_text::{check_mesh_size, coord, push_fan, push_vertex};
use crate::error::{Ctx, Result};
use crate::limits::Limits;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Ty {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Ty {
    fn parse(s: &str) -> Option<Ty> {
        Some(match s {
            "char" | "int8" => Ty::I8,
            "uchar" | "uint8" => Ty::U8,
            "short" | "int16" => Ty::I16,
            "ushort" | "uint16" => Ty::U16,
            "int" | "int32" => Ty::I32,
            "uint" | "uint32" => Ty::U32,
            "float" | "float32" => Ty::F32,
            "double" | "float64" => Ty::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            Ty::I8 | Ty::U8 => 1,
            Ty::I16 | Ty::U16 => 2,
            Ty::I32 | Ty::U32 | Ty::F32 => 4,
            Ty::F64 => 8,
        }
    }
}

#[derive(Debug, Clone)]
enum Prop {
    Scalar(Ty, String),
    List(Ty, Ty, String),
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Prop>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    Binary { big: bool },
}

/// Reads a PLY mesh.
///
/// # Errors
/// A [`crate::Error`] naming the header line, element, property or index at fault.
pub fn read_ply(path: &Path, limits: &Limits) -> Result<Mesh> {
    let ctx = Ctx::new(path, "PLY");
    let bytes = decode::read_file(ctx, path, limits.max_bytes)?;
    // Header: text up to and including "end_header\n".
    let marker = b"end_header";
    let end = bytes
        .windows(marker.len())
        .take(1 << 20)
        .position(|w| w == marker)
        .ok_or_else(|| ctx.bad("no end_header line"))?;
    let body_start = bytes[end..].iter().position(|&b| b == b'\n').map_or(bytes.len(), |p| end + p + 1);
    let header = std::str::from_utf8(&bytes[..end]).map_err(|_| ctx.bad("header is not text"))?;
    let mut lines = decode::numbered_lines(header);
    if lines.next().map(|(_, l)| l.trim()) != Some("ply") {
        return Err(ctx.bad("line 1: missing the \"ply\" magic"));
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    for (no, line) in lines {
        let toks: Vec<&str> = line.split_whitespace().collect();
        let bad = |why: &str| ctx.bad(format!("line {no}: {:?}: {why}", line.chars().take(60).collect::<String>()));
        match toks.first().copied() {
            None | Some("comment") | Some("obj_info") => {}
            Some("format") => {
                format = Some(match toks.get(1).copied() {
                    Some("ascii") => Format::Ascii,
                    Some("binary_little_endian") => Format::Binary { big: false },
                    Some("binary_big_endian") => Format::Binary { big: true },
                    _ => return Err(bad("format must be ascii, binary_little_endian or binary_big_endian")),
                });
            }
            Some("element") => {
                let (Some(name), Some(count)) = (toks.get(1), toks.get(2).and_then(|c| c.parse::<u64>().ok())) else {
                    return Err(bad("expected \"element NAME COUNT\""));
                };
                elements.push(Element { name: name.to_string(), count, props: Vec::new() });
            }
            Some("property") => {
                let el = elements.last_mut().ok_or_else(|| bad("property before any element"))?;
                let prop = if toks.get(1) == Some(&"list") {
                    match (toks.get(2).and_then(|t| Ty::parse(t)), toks.get(3).and_then(|t| Ty::parse(t)), toks.get(4))
                    {
                        (Some(c), Some(i), Some(n)) if !matches!(c, Ty::F32 | Ty::F64) => {
                            Prop::List(c, i, n.to_string())
                        }
                        _ => {
                            return Err(bad(
                                "expected \"property list COUNT_TYPE INDEX_TYPE NAME\" with an integer count type",
                            ))
                        }
                    }
                } else {
                    match (toks.get(1).and_then(|t| Ty::parse(t)), toks.get(2)) {
                        (Some(t), Some(n)) => Prop::Scalar(t, n.to_string()),
                        _ => return Err(bad("unknown property type")),
                    }
                };
                el.props.push(prop);
            }
            Some(_) => return Err(bad("unknown header keyword")),
        }
    }
    let format = format.ok_or_else(|| ctx.bad("header has no format line"))?;
    let count = |name: &str| elements.iter().find(|e| e.name == name).map_or(0, |e| e.count);
    let (nv, nf) = (count("vertex"), count("face"));
    check_mesh_size(ctx, nv, nf, limits)?;
    let body = &bytes[body_start.min(bytes.len())..];
    // Every declared count is bounded by the body before any loop runs: each instance needs at
    // least its fixed-size bytes (binary) or a character and a separator per value (ASCII).
    // This catches absurd counts (`element junk 18446744073709551615`) before allocating or looping.
    let min_instance = |e: &Element| -> u64 {
        e.props
            .iter()
            .map(|p| match (format, p) {
                (Format::Binary { .. }, Prop::Scalar(t, _)) => t.size() as u64,
                (Format::Binary { .. }, Prop::List(c, _, _)) => c.size() as u64,
                (Format::Ascii, _) => 2,
            })
            .sum()
    };
    let mut min = 0u64;
    for e in &elements {
        min = min.saturating_add(e.count.saturating_mul(min_instance(e)));
    }
    // An ASCII file may end without a newline after its last value.
    let slack = u64::from(format == Format::Ascii);
    if min > (body.len() as u64).saturating_add(slack) {
        return Err(ctx.bad(format!(
            "body has {} bytes, the header's element counts need at least {min} (truncated file or absurd count?)",
            body.len()
        )));
    }
    if let Format::Binary { big } = format {
        if let Some(mesh) = binary_triangles(&elements, big, body) {
            return Ok(mesh);
        }
    }
    let mut src = Source { ctx, format, body, pos: 0 };
    let mut mesh = Mesh::default();
    mesh.positions.reserve(nv as usize);
    mesh.triangles.reserve(nf as usize);
    let mut poly: Vec<u32> = Vec::new();
    for el in &elements {
        let xyz: Vec<Option<usize>> = ["x", "y", "z"]
            .iter()
            .map(|n| el.props.iter().position(|p| matches!(p, Prop::Scalar(_, m) if m == n)))
            .collect();
        if el.name == "vertex" && xyz.iter().any(|p| p.is_none()) {
            return Err(ctx.bad("element vertex lacks an x, y or z property"));
        }
        if el.props.is_empty() {
            continue; // instances without properties occupy no bytes: nothing to read
        }
        for idx in 0..el.count {
            let mut p = [0.0f64; 3];
            for (pi, prop) in el.props.iter().enumerate() {
                match prop {
                    Prop::Scalar(t, _) => {
                        let v = src.scalar(*t, || format!("{} {idx}", el.name))?;
                        if el.name == "vertex" {
                            if let Some(a) = xyz.iter().position(|&x| x == Some(pi)) {
                                p[a] = v;
                            }
                        }
                    }
                    Prop::List(c, it, name) => {
                        let n = src.scalar(*c, || format!("{} {idx} list length", el.name))?;
                        if !(0.0..=1e6).contains(&n) {
                            return Err(ctx.bad(format!("{} {idx}: list length {n} is not valid", el.name)));
                        }
                        let is_faces = el.name == "face" && (name == "vertex_indices" || name == "vertex_index");
                        poly.clear();
                        for _ in 0..n as usize {
                            let v = src.scalar(*it, || format!("{} {idx} index", el.name))?;
                            if is_faces {
                                if !(v >= 0.0 && v < nv as f64) || v.fract() != 0.0 {
                                    return Err(ctx.bad(format!("face {idx}: vertex index {v} is outside 0..{nv}")));
                                }
                                poly.push(v as u32);
                            }
                        }
                        if is_faces {
                            if poly.len() < 3 {
                                return Err(
                                    ctx.bad(format!("face {idx} has {} vertices, at least 3 are needed", poly.len()))
                                );
                            }
                            push_fan(ctx, &mut mesh, &poly, limits)?;
                        }
                    }
                }
            }
            if el.name == "vertex" {
                let what = || format!("vertex {idx}");
                let p = [coord(ctx, p[0], what)?, coord(ctx, p[1], what)?, coord(ctx, p[2], what)?];
                push_vertex(ctx, &mut mesh, p, limits)?;
            }
        }
    }
    Ok(mesh)
}

/// Vertices decoded per parallel piece of [`binary_triangles`].
const PIECE: usize = 1 << 15;

/// The common binary layout decoded in parallel, in one pass over the bytes: a `vertex` element
/// of fixed-size scalars with `float` x, y, z, then a `face` element whose only property is its
/// index list of `int` or `uint`, every face a triangle (what isoforge and most tools write).
/// `None` for anything else, and for a file this layout does not fit or whose values the
/// general reader would refuse (a list length other than 3, an index out of range, a
/// non-finite coordinate, too few bytes): the general reader then reads it and names the fault.
/// The size limits were checked from the header: triangles alone make no more than it declared.
fn binary_triangles(elements: &[Element], big: bool, body: &[u8]) -> Option<Mesh> {
    use rayon::prelude::*;
    let [vertex, face] = elements else { return None };
    if vertex.name != "vertex" || face.name != "face" {
        return None;
    }
    // Vertex record: stride and the offsets of x, y, z (each a float).
    let mut stride = 0usize;
    let mut xyz = [None; 3];
    for prop in &vertex.props {
        let Prop::Scalar(t, name) = prop else { return None };
        if let Some(a) = ["x", "y", "z"].iter().position(|n| n == name) {
            if *t != Ty::F32 || xyz[a].is_some() {
                return None;
            }
            xyz[a] = Some(stride);
        }
        stride += t.size();
    }
    let [Some(ox), Some(oy), Some(oz)] = xyz else { return None };
    let [Prop::List(count_ty, index_ty, name)] = face.props.as_slice() else { return None };
    if !matches!(name.as_str(), "vertex_indices" | "vertex_index") || !matches!(index_ty, Ty::I32 | Ty::U32) {
        return None;
    }
    let (nv, nf) = (usize::try_from(vertex.count).ok()?, usize::try_from(face.count).ok()?);
    let face_stride = count_ty.size() + 3 * 4;
    let vertex_bytes = nv.checked_mul(stride)?;
    let face_bytes = nf.checked_mul(face_stride)?;
    let vertices = body.get(..vertex_bytes)?;
    let faces = body.get(vertex_bytes..vertex_bytes.checked_add(face_bytes)?)?;
    let word = |b: &[u8], at: usize| -> Option<u32> {
        let w: [u8; 4] = b.get(at..at + 4)?.try_into().ok()?;
        Some(if big { u32::from_be_bytes(w) } else { u32::from_le_bytes(w) })
    };
    let mut positions = vec![[0.0f32; 3]; nv];
    let ok = positions.par_chunks_mut(PIECE).zip(vertices.par_chunks(PIECE * stride.max(1))).all(|(out, src)| {
        out.iter_mut().zip(src.chunks_exact(stride.max(1))).all(|(p, r)| {
            let mut q = [0.0f32; 3];
            for (a, o) in [ox, oy, oz].into_iter().enumerate() {
                match word(r, o).map(f32::from_bits) {
                    Some(v) if v.is_finite() => q[a] = v,
                    _ => return false,
                }
            }
            *p = q;
            true
        })
    });
    if !ok {
        return None;
    }
    // The list length: 3 in whatever integer type the header gave.
    let three = {
        let mut b = [0u8; 8];
        let n = count_ty.size();
        let at = if big { n - 1 } else { 0 };
        b[at] = 3;
        b
    };
    let count_bytes = count_ty.size();
    let mut triangles = vec![[0u32; 3]; nf];
    let ok = triangles.par_chunks_mut(PIECE).zip(faces.par_chunks(PIECE * face_stride)).all(|(out, src)| {
        out.iter_mut().zip(src.chunks_exact(face_stride)).all(|(t, r)| {
            if r.get(..count_bytes) != three.get(..count_bytes) {
                return false;
            }
            for (k, slot) in t.iter_mut().enumerate() {
                match word(r, count_bytes + 4 * k) {
                    // An `int` index is negative when its top bit is set: then it is ≥ 2³¹ > nv.
                    Some(v) if (v as usize) < nv && (*index_ty == Ty::U32 || v <= i32::MAX as u32) => *slot = v,
                    _ => return false,
                }
            }
            true
        })
    });
    ok.then(|| Mesh { positions, triangles, ..Mesh::default() })
}

struct Source<'a> {
    ctx: Ctx<'a>,
    format: Format,
    body: &'a [u8],
    pos: usize,
}

impl Source<'_> {
    fn scalar(&mut self, t: Ty, what: impl Fn() -> String) -> Result<f64> {
        match self.format {
            Format::Binary { big } => {
                let n = t.size();
                let b = self.body.get(self.pos..self.pos + n).ok_or_else(|| {
                    self.ctx.bad(format!("{}: data ends at byte {} (truncated file?)", what(), self.pos))
                })?;
                self.pos += n;
                let mut a = [0u8; 8];
                a[..n].copy_from_slice(b);
                if big {
                    a[..n].reverse();
                }
                Ok(match t {
                    Ty::I8 => a[0] as i8 as f64,
                    Ty::U8 => a[0] as f64,
                    Ty::I16 => i16::from_le_bytes([a[0], a[1]]) as f64,
                    Ty::U16 => u16::from_le_bytes([a[0], a[1]]) as f64,
                    Ty::I32 => i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
                    Ty::U32 => u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
                    Ty::F32 => f32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
                    Ty::F64 => f64::from_le_bytes(a),
                })
            }
            Format::Ascii => {
                let rest = &self.body[self.pos..];
                let start = rest
                    .iter()
                    .position(|b| !b.is_ascii_whitespace())
                    .ok_or_else(|| self.ctx.bad(format!("{}: data ends early (truncated file?)", what())))?;
                let len = rest[start..].iter().position(|b| b.is_ascii_whitespace()).unwrap_or(rest.len() - start);
                let tok = std::str::from_utf8(&rest[start..start + len]).unwrap_or("");
                self.pos += start + len;
                tok.parse::<f64>().map_err(|_| {
                    self.ctx.bad(format!("{}: {:?} is not a number", what(), tok.chars().take(30).collect::<String>()))
                })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A binary PLY of `faces` over four vertices; each vertex carries a `uchar` before x and a
    /// `float nx` after z (skipped), indices as `uint` or `int`, either endianness.
    fn file(big: bool, signed: bool, faces: &[&[i64]], coord: f32) -> Vec<u8> {
        let endian = if big { "big" } else { "little" };
        let ity = if signed { "int" } else { "uint" };
        let mut out = format!(
            "ply\nformat binary_{endian}_endian 1.0\nelement vertex 4\nproperty uchar flag\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nelement face {}\nproperty list uchar {ity} vertex_indices\nend_header\n",
            faces.len()
        )
        .into_bytes();
        let f32b = |x: f32| if big { x.to_be_bytes() } else { x.to_le_bytes() };
        let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, coord]];
        for q in p {
            out.push(7);
            q.iter().chain(&[0.5]).for_each(|&c| out.extend_from_slice(&f32b(c)));
        }
        for f in faces {
            out.push(f.len() as u8);
            for &v in *f {
                let w = v as u32;
                out.extend_from_slice(&if big { w.to_be_bytes() } else { w.to_le_bytes() });
            }
        }
        out
    }

    fn read(bytes: &[u8]) -> Result<Mesh> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.ply");
        std::fs::write(&path, bytes).unwrap();
        read_ply(&path, &Limits::default())
    }

    #[test]
    fn the_parallel_binary_path_reads_what_the_general_one_reads() {
        let tetra: &[&[i64]] = &[&[0, 2, 1], &[0, 1, 3], &[0, 3, 2], &[1, 2, 3]];
        for big in [false, true] {
            for signed in [false, true] {
                let bytes = file(big, signed, tetra, 1.0);
                let elements = [
                    Element {
                        name: "vertex".into(),
                        count: 4,
                        props: ["flag", "x", "y", "z", "nx"]
                            .iter()
                            .map(|n| Prop::Scalar(if *n == "flag" { Ty::U8 } else { Ty::F32 }, n.to_string()))
                            .collect(),
                    },
                    Element {
                        name: "face".into(),
                        count: 4,
                        props: vec![Prop::List(
                            Ty::U8,
                            if signed { Ty::I32 } else { Ty::U32 },
                            "vertex_indices".into(),
                        )],
                    },
                ];
                let body = &bytes[bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11..];
                let fast = binary_triangles(&elements, big, body).expect("the common layout");
                let m = read(&bytes).unwrap();
                assert_eq!(fast, m);
                assert_eq!(m.triangles, vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]);
                assert_eq!(m.positions[3], [0.0, 0.0, 1.0]);
            }
        }
    }

    #[test]
    fn files_the_parallel_path_does_not_fit_are_read_or_refused_as_before() {
        // A quad: fanned by the general reader.
        let m = read(&file(false, true, &[&[0, 1, 2, 3], &[1, 2, 3]], 1.0)).unwrap();
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3], [1, 2, 3]]);
        // An index out of range, a negative one, a non-finite coordinate: the general errors.
        for (bytes, want) in [
            (file(false, false, &[&[0, 1, 2], &[1, 2, 9]], 1.0), "face 1: vertex index 9 is outside 0..4"),
            (file(true, true, &[&[0, -1, 2]], 1.0), "face 0: vertex index -1 is outside 0..4"),
            (file(false, true, &[&[0, 1, 2]], f32::NAN), "vertex 3: coordinate NaN is not a finite number"),
        ] {
            let e = read(&bytes).unwrap_err().to_string();
            assert!(e.contains(want), "{e}");
        }
    }
}
