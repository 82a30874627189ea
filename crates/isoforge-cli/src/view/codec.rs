//! The compact binary form in which the page receives a mesh (`/api/mesh`), and the defect edges
//! (`/api/check`). All numbers little-endian; `viewer/page/codec.js` reads it.
//!
//! ```text
//! u32      L, the length of the JSON head
//! L bytes  the JSON head (counts, "box", "index": {"encoding"}, …), padded with spaces to 4
//! u16 × 3V positions quantised to the box: p = min + q / 65535 · (max − min)       (padded to 4)
//! i8  × 2V area-weighted vertex normals, octahedral encoding                    (padded to 4)
//! the rest 3T vertex indices: "u16" when V ≤ 65536, else "varint": each index minus the one
//!          before it (the first minus 0), zigzag-mapped, LEB128
//! ```
//!
//! Why this shape (the 512×512×450 shoulder CT at iso 46.3: 4.1 M vertices, 8.1 M triangles):
//! `f32` positions and `u32` indices are 147 MB; this is 82 MB (positions 24.5 MB, normals
//! 8.2 MB, indices 49.4 MB, two bytes an index: walk order keeps consecutive indices close).
//! Deflate (zlib level 1, measured with node's zlib) would shrink the indices to 22 MB but costs
//! 0.47 s per mesh to compress, far more than the 27 MB it saves take on loopback; positions
//! deflate by a third only. Positions err by at most 1/131070 of the box (0.004 voxel on the shoulder), below a
//! pixel at any zoom the page offers; normals by under a degree.

use isoforge::mesh::Mesh;
use rayon::prelude::*;
use serde_json::Value;
use std::io::Write;

/// Largest quantised coordinate.
const Q: f32 = 65535.0;

/// The mesh's positions, normals and triangles in the form above, after `head` (to which the
/// box and the index encoding are added), written to `w` as it is encoded: [`BATCH`] vertices
/// or triangles at a time, each batch in parallel chunks. What this holds besides the mesh is
/// the vertex normals (12 bytes a vertex) and one batch's bytes, never the whole body.
pub fn write_mesh(w: &mut dyn Write, mesh: &Mesh, mut head: Value) -> std::io::Result<()> {
    let (lo, hi) = bounds(&mesh.positions);
    let v = mesh.positions.len();
    let varint = v > 1 << 16;
    head["box"] = serde_json::json!({ "min": lo, "max": hi });
    head["index"] = serde_json::json!({ "encoding": if varint { "varint" } else { "u16" } });
    let mut out = Vec::with_capacity(6 * BATCH.min(v.max(mesh.triangles.len())) + 1024);
    push_head(&mut out, &head);
    w.write_all(&out)?;
    let scale: [f32; 3] = [0, 1, 2].map(|a| if hi[a] > lo[a] { Q / (hi[a] - lo[a]) } else { 0.0 });
    for batch in mesh.positions.chunks(BATCH) {
        out.clear();
        out.resize(batch.len() * 6, 0);
        out.par_chunks_mut(6 * CHUNK).zip(batch.par_chunks(CHUNK)).for_each(|(bytes, points)| {
            for (b, p) in bytes.chunks_exact_mut(6).zip(points) {
                for a in 0..3 {
                    let q = ((p[a] - lo[a]) * scale[a]).round().clamp(0.0, Q) as u16;
                    b[2 * a..2 * a + 2].copy_from_slice(&q.to_le_bytes());
                }
            }
        });
        w.write_all(&out)?;
    }
    w.write_all(&[0u8; 4][..(4 - v * 6 % 4) % 4])?;
    let normals = vertex_normals(mesh);
    for batch in normals.chunks(BATCH) {
        out.clear();
        out.resize(batch.len() * 2, 0);
        out.par_chunks_mut(2 * CHUNK).zip(batch.par_chunks(CHUNK)).for_each(|(bytes, normals)| {
            for (b, n) in bytes.chunks_exact_mut(2).zip(normals) {
                let [x, y] = octahedral(*n);
                b.copy_from_slice(&[x as u8, y as u8]);
            }
        });
        w.write_all(&out)?;
    }
    drop(normals);
    w.write_all(&[0u8; 4][..(4 - v * 2 % 4) % 4])?;
    for (n, batch) in mesh.triangles.chunks(BATCH).enumerate() {
        out.clear();
        if varint {
            // Each chunk starts from the last index of the chunk before it.
            let first = n * BATCH;
            let parts: Vec<Vec<u8>> = batch
                .par_chunks(CHUNK)
                .enumerate()
                .map(|(c, tris)| {
                    let at = first + c * CHUNK;
                    let prev = if at == 0 { 0 } else { mesh.triangles[at - 1][2] };
                    delta_varint(tris, prev)
                })
                .collect();
            for p in parts {
                w.write_all(&p)?;
            }
        } else {
            for t in batch {
                for &i in t {
                    out.extend_from_slice(&(i as u16).to_le_bytes());
                }
            }
            w.write_all(&out)?;
        }
    }
    Ok(())
}

/// Vertices or triangles per written batch: 16 parallel chunks.
const BATCH: usize = 16 * CHUNK;

/// Most bytes [`write_mesh`] holds for one batch (its varint indices: up to 5 bytes an index).
pub const BATCH_BYTES: u64 = (BATCH * 15) as u64;

/// Vertices or triangles per parallel task.
const CHUNK: usize = 1 << 16;

/// `head`, then `pairs` as `u32` × 2 (the defect edges of `/api/check`).
pub fn encode_edges(pairs: &[[u32; 2]], head: &Value) -> Vec<u8> {
    let mut out = Vec::with_capacity(64 + pairs.len() * 8);
    push_head(&mut out, head);
    for p in pairs {
        out.extend_from_slice(&p[0].to_le_bytes());
        out.extend_from_slice(&p[1].to_le_bytes());
    }
    out
}

fn push_head(out: &mut Vec<u8>, head: &Value) {
    let text = head.to_string();
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(text.as_bytes());
    pad(out, b' ');
}

fn pad(out: &mut Vec<u8>, byte: u8) {
    while !out.len().is_multiple_of(4) {
        out.push(byte);
    }
}

/// Component-wise min and max (zeros for no vertices).
fn bounds(positions: &[[f32; 3]]) -> ([f32; 3], [f32; 3]) {
    let Some(first) = positions.first() else { return ([0.0; 3], [0.0; 3]) };
    positions.iter().fold((*first, *first), |(mut lo, mut hi), p| {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
        (lo, hi)
    })
}

/// Each index minus the previous one, zigzag-mapped (0, −1, 1, −2 → 0, 1, 2, 3), as LEB128
/// (7 bits a byte, low first, high bit set on all but the last byte).
fn delta_varint(triangles: &[[u32; 3]], prev: u32) -> Vec<u8> {
    let mut out = Vec::with_capacity(triangles.len() * 7);
    let mut prev = prev as i64;
    for t in triangles {
        for &v in t {
            let d = v as i64 - prev;
            prev = v as i64;
            let mut z = ((d << 1) ^ (d >> 63)) as u64;
            while z >= 0x80 {
                out.push((z as u8) | 0x80);
                z >>= 7;
            }
            out.push(z as u8);
        }
    }
    out
}

/// Area-weighted vertex normals (unnormalised: the sum of the incident triangles' cross
/// products, which point outward for the library's counter-clockwise winding). One part of the
/// triangles per thread, each summing into the range of vertices it touches (walk order keeps
/// those ranges short and nearly disjoint), then the parts are added up.
fn vertex_normals(mesh: &Mesh) -> Vec<[f32; 3]> {
    let len = mesh.positions.len();
    let per = mesh.triangles.len().div_ceil(rayon::current_num_threads().max(1)).max(CHUNK);
    let parts: Vec<(usize, Vec<[f32; 3]>)> = mesh
        .triangles
        .par_chunks(per)
        .map(|tris| {
            let valid = |t: &&[u32; 3]| t.iter().all(|&v| (v as usize) < len);
            let lo = tris.iter().filter(valid).flat_map(|t| t.iter()).min().map_or(0, |&v| v as usize);
            let hi = tris.iter().filter(valid).flat_map(|t| t.iter()).max().map_or(0, |&v| v as usize + 1);
            let mut n = vec![[0.0f32; 3]; hi.saturating_sub(lo)];
            for t in tris.iter().filter(valid) {
                let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
                let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
                let w = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
                let x = [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]];
                for &v in t {
                    let s = &mut n[v as usize - lo];
                    for k in 0..3 {
                        s[k] += x[k];
                    }
                }
            }
            (lo, n)
        })
        .collect();
    let mut n = vec![[0.0f32; 3]; len];
    for (lo, part) in parts {
        for (s, p) in n[lo..].iter_mut().zip(part) {
            for k in 0..3 {
                s[k] += p[k];
            }
        }
    }
    n
}

/// A direction as two signed bytes on the octahedron `|x| + |y| + |z| = 1`, its lower half folded
/// over the upper (Cigolle et al., "A Survey of Efficient Representations for Independent Unit
/// Vectors", JCGT 2014). The zero vector gives (0, 0), read back as +z.
fn octahedral(n: [f32; 3]) -> [i8; 2] {
    let l1 = n[0].abs() + n[1].abs() + n[2].abs();
    if !(l1 > 0.0) || !l1.is_finite() {
        return [0, 0];
    }
    let (mut x, mut y) = (n[0] / l1, n[1] / l1);
    if n[2] < 0.0 {
        let (fx, fy) = ((1.0 - y.abs()) * x.signum(), (1.0 - x.abs()) * y.signum());
        (x, y) = (fx, fy);
    }
    [x, y].map(|c| (c * 127.0).round().clamp(-127.0, 127.0) as i8)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decode_octahedral(e: [i8; 2]) -> [f32; 3] {
        let (x, y) = (e[0] as f32 / 127.0, e[1] as f32 / 127.0);
        let z = 1.0 - x.abs() - y.abs();
        let t = (-z).max(0.0);
        let n = [x - t * x.signum(), y - t * y.signum(), z];
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        n.map(|c| c / l)
    }

    #[test]
    fn octahedral_normals_round_trip_within_a_degree() {
        let mut worst = 0.0f32;
        for i in 0..40 {
            for j in 0..80 {
                let (th, ph) = (std::f32::consts::PI * (i as f32 + 0.5) / 40.0, std::f32::consts::PI * j as f32 / 40.0);
                let n = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
                let d = decode_octahedral(octahedral(n.map(|c| c * 3.0)));
                let dot = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
                worst = worst.max(dot.clamp(-1.0, 1.0).acos().to_degrees());
            }
        }
        assert!(worst < 1.0, "worst error {worst}°");
        assert_eq!(octahedral([0.0; 3]), [0, 0]);
        assert_eq!(octahedral([f32::NAN, 0.0, 1.0]), [0, 0]);
    }

    #[test]
    fn normals_sum_the_incident_triangles_across_parts() {
        // A strip of 2 × CHUNK + 1 triangles in the plane z = 0, consistently wound: the parts meet
        // mid-strip, and every vertex's normal is −z with the weight of its triangles.
        let n = 2 * CHUNK + 1;
        let positions: Vec<[f32; 3]> = (0..n + 2).map(|i| [i as f32 / 2.0, (i % 2) as f32, 0.0]).collect();
        let triangles: Vec<[u32; 3]> =
            (0..n as u32).map(|i| if i % 2 == 0 { [i, i + 1, i + 2] } else { [i + 1, i, i + 2] }).collect();
        let mesh = Mesh { positions, triangles, ..Mesh::default() };
        let normals = vertex_normals(&mesh);
        assert!(normals.iter().all(|v| v[0] == 0.0 && v[1] == 0.0 && v[2] < 0.0), "every triangle faces −z");
        // Inner vertices belong to three triangles of area 1/2 (cross product length 1 each).
        assert!(normals[2..n].iter().all(|v| v[2] == -3.0), "{:?}", &normals[..4]);
        assert_eq!([0, 1, n, n + 1].map(|i| normals[i][2]), [-1.0, -2.0, -2.0, -1.0]);
    }

    #[test]
    fn varint_deltas_decode_to_the_indices() {
        let tris = vec![[0u32, 1, 2], [2, 1, 300], [70000, 5, u32::MAX], [0, 0, 0]];
        let bytes = delta_varint(&tris, 0);
        let (mut out, mut prev, mut z, mut shift) = (Vec::new(), 0i64, 0u64, 0);
        for b in bytes {
            z |= ((b & 0x7f) as u64) << shift;
            shift += 7;
            if b < 0x80 {
                let d = (z >> 1) as i64 ^ -((z & 1) as i64);
                prev += d;
                out.push(prev as u32);
                (z, shift) = (0, 0);
            }
        }
        assert_eq!(out, tris.concat());
        assert_eq!(delta_varint(&[[0, 1, 0]], 0), vec![0, 2, 1], "zigzag: +1 → 2, −1 → 1");
    }

    /// A writer that keeps what it gets and the largest single write.
    #[derive(Default)]
    struct Recorder {
        bytes: Vec<u8>,
        largest: usize,
    }

    impl Write for Recorder {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.largest = self.largest.max(buf.len());
            self.bytes.extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn meshes_are_written_a_batch_at_a_time() {
        // More than one batch of vertices and of triangles: no write is larger than a batch of
        // positions, and the varint indices carry across batches.
        let v = BATCH + BATCH / 2;
        let positions: Vec<[f32; 3]> = (0..v).map(|i| [i as f32, (i % 7) as f32, (i % 3) as f32]).collect();
        let triangles: Vec<[u32; 3]> =
            (0..v as u32 - 2).map(|i| [i, i + 2, (i as u64 * 7919 % v as u64) as u32]).collect();
        let mesh = Mesh { positions, triangles, ..Mesh::default() };
        let mut w = Recorder::default();
        write_mesh(&mut w, &mesh, serde_json::json!({})).unwrap();
        assert!(w.largest <= 6 * BATCH, "a write of {} bytes", w.largest);
        let body = w.bytes;
        let n = u32::from_le_bytes(body[..4].try_into().unwrap()) as usize;
        let head: Value = serde_json::from_slice(&body[4..4 + n]).unwrap();
        assert_eq!(head["index"]["encoding"], "varint");
        let at = ((4 + n).div_ceil(4) * 4 + 6 * v).div_ceil(4) * 4 + 2 * v;
        let (mut out, mut prev, mut z, mut shift) = (Vec::new(), 0i64, 0u64, 0);
        for &b in &body[at..] {
            z |= ((b & 0x7f) as u64) << shift;
            shift += 7;
            if b < 0x80 {
                prev += (z >> 1) as i64 ^ -((z & 1) as i64);
                out.push(prev as u32);
                (z, shift) = (0, 0);
            }
        }
        assert_eq!(out, mesh.triangles.concat());
        // A failed write stops the encoding with its error.
        struct Broken;
        impl Write for Broken {
            fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
                Err(std::io::ErrorKind::BrokenPipe.into())
            }
            fn flush(&mut self) -> std::io::Result<()> {
                Ok(())
            }
        }
        assert!(write_mesh(&mut Broken, &mesh, serde_json::json!({})).is_err());
    }
}
