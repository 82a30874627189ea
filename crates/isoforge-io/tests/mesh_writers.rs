//! Issue 11: the mesh writers take quads (PLY, OBJ, OFF) and read them back; the streamed PLY
//! (binary and ASCII), STL, glTF, OBJ and OFF writers give the in-memory writers' bytes; the binary PLY and STL layouts are the
//! ones they always were.

use isoforge::grid::{AnyGrid, DenseGrid, Lattice};
use isoforge::mesh::{Mesh, MeshBatch, MeshSink};
use isoforge::pipeline::{self, Method, Options};
use isoforge::volume::Iso;
use isoforge_io::write::obj::write_obj;
use isoforge_io::write::ply::{write_ply, PlyStream};
use isoforge_io::write::stl::write_stl;
use isoforge_io::write::MeshStream;
use isoforge_io::{Batch, Limits, MeshData, MeshFormat};

/// A bumpy ball sampled on a small u16 grid (not a sphere: vertices are not symmetric).
fn grid() -> AnyGrid {
    let n = [23u32, 19, 17];
    let mut v = Vec::new();
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let (x, y, z) = (i as f32 - 11.0, j as f32 - 9.0, k as f32 - 8.0);
                let r = (x * x + y * y + z * z).sqrt() + 1.5 * (x * 0.7).sin() * (y * 0.5).cos();
                v.push((1000.0 + 80.0 * r) as u16);
            }
        }
    }
    DenseGrid::new(Lattice::new(n).unwrap(), v).unwrap().into()
}

fn mesh(method: Method, normals: isoforge::mesh::Normals) -> Mesh {
    let opts = Options { method, normals, ..Options::default() };
    pipeline::extract_grid(&grid(), Iso::below(1500.5), &opts, None).unwrap().mesh
}

/// The binary PLY layout written field by field, independently of the writer.
fn reference_ply(m: &Mesh) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat binary_little_endian 1.0\ncomment isoforge {}\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
        env!("CARGO_PKG_VERSION"),
        m.positions.len()
    )
    .into_bytes();
    if !m.normals.is_empty() {
        out.extend_from_slice(b"property float nx\nproperty float ny\nproperty float nz\n");
    }
    out.extend_from_slice(
        format!(
            "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
            m.triangles.len() + m.quads.len()
        )
        .as_bytes(),
    );
    for (i, p) in m.positions.iter().enumerate() {
        let n = m.normals.get(i).map(|n| &n[..]).unwrap_or(&[]);
        for c in p.iter().chain(n) {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    for t in &m.triangles {
        out.push(3);
        t.iter().for_each(|v| out.extend_from_slice(&(*v as i32).to_le_bytes()));
    }
    for q in &m.quads {
        out.push(4);
        q.iter().for_each(|v| out.extend_from_slice(&(*v as i32).to_le_bytes()));
    }
    out
}

fn ply_bytes(m: &Mesh) -> Vec<u8> {
    let mut v = Vec::new();
    write_ply(&mut v, m, false).unwrap();
    v
}

#[test]
fn binary_ply_keeps_its_layout_with_and_without_normals() {
    for normals in [isoforge::mesh::Normals::None, isoforge::mesh::Normals::Gradient] {
        let m = mesh(Method::MarchingCubes, normals);
        assert!(m.triangles.len() > 500 && m.quads.is_empty());
        assert_eq!(ply_bytes(&m), reference_ply(&m), "{normals:?}");
    }
}

#[test]
fn quads_are_written_as_4_gons_and_read_back_as_their_fans() {
    let dir = tempfile::tempdir().unwrap();
    let m = mesh(Method::SurfaceNets, isoforge::mesh::Normals::None);
    assert!(m.quads.len() > 300, "surface nets make quads");
    assert_eq!(ply_bytes(&m), reference_ply(&m));
    // Readers fan polygons: quad (a, b, c, d) → (a, b, c), (a, c, d).
    let mut fanned = m.triangles.clone();
    fanned.extend(m.quads.iter().flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]]));
    for (name, format) in [
        ("q.ply", MeshFormat::Ply),
        ("qa.ply", MeshFormat::PlyAscii),
        ("q.obj", MeshFormat::Obj),
        ("q.off", MeshFormat::Off),
    ] {
        let path = dir.path().join(name);
        let batch = Batch::new();
        batch.write_mesh(&path, &m, &MeshData::default(), format).unwrap();
        batch.commit().unwrap();
        let back = isoforge_io::read_mesh(&path, &Limits::default()).unwrap();
        assert_eq!(back.triangles, fanned, "{name}");
        assert_eq!(back.positions.len(), m.positions.len(), "{name}");
        // The surface is closed and manifold as written.
        let rep = isoforge::topo::check(&back);
        assert!(rep.is_closed() && rep.is_manifold(), "{name}: {rep:?}");
    }
}

#[test]
fn triangle_only_formats_split_quads_by_their_shorter_diagonal() {
    // STL and glTF hold triangles: each quad becomes the two triangles `Mesh::triangulate` makes
    // (none is dropped), so the file is the triangulated mesh's.
    let dir = tempfile::tempdir().unwrap();
    let m = mesh(Method::SurfaceNets, isoforge::mesh::Normals::None);
    assert!(m.quads.len() > 300 && m.triangles.is_empty());
    let mut split = m.clone();
    split.triangulate();
    assert_eq!(split.triangles.len(), 2 * m.quads.len());
    assert_eq!(m.all_triangles().collect::<Vec<_>>(), split.triangles);
    for (name, format) in [("q.stl", MeshFormat::Stl), ("qa.stl", MeshFormat::StlAscii), ("q.glb", MeshFormat::Glb)] {
        let (a, b) = (dir.path().join(name), dir.path().join(format!("split-{name}")));
        for (path, mesh) in [(&a, &m), (&b, &split)] {
            let batch = Batch::new();
            batch.write_mesh(path, mesh, &MeshData::default(), format).unwrap();
            batch.commit().unwrap();
        }
        assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap(), "{name}");
        if format != MeshFormat::Glb {
            let back = isoforge_io::read_mesh(&a, &Limits::default()).unwrap();
            assert_eq!(back.triangles.len(), 2 * m.quads.len(), "{name}");
            let rep = isoforge::topo::check(&back);
            assert!(rep.is_closed() && rep.is_manifold(), "{name}: {rep:?}");
        }
    }
}

#[test]
fn triangle_labels_refuse_quads() {
    let m = mesh(Method::SurfaceNets, isoforge::mesh::Normals::None);
    let data = MeshData { triangle_labels: Some(vec![1; m.triangles.len()]), ..Default::default() };
    let e = isoforge_io::write::ply::write_ply_with(&mut Vec::new(), &m, &data, false).unwrap_err();
    assert!(e.to_string().contains("quads"), "{e}");
}

/// `m` cut into `parts` batches, batch `b` taking the share `cut(n, b)..cut(n, b + 1)` of each
/// array of `n` items (OBJ and PLY number vertices globally, so any cut will do).
fn batches(m: &Mesh, parts: usize, cut: impl Fn(usize, usize) -> usize) -> Vec<MeshBatch<'_>> {
    let (nv, nt, nq) = (m.positions.len(), m.triangles.len(), m.quads.len());
    (0..parts)
        .map(|b| {
            let r = |n: usize| cut(n, b)..cut(n, b + 1);
            MeshBatch {
                positions: &m.positions[r(nv)],
                normals: if m.normals.is_empty() { &[][..] } else { &m.normals[r(nv)] },
                triangles: &m.triangles[r(nt)],
                quads: &m.quads[r(nq)],
            }
        })
        .collect()
}

/// Pushes `m` to a [`PlyStream`] in uneven batches, as a walk would.
fn stream(m: &Mesh, path: &std::path::Path) {
    let mut s = PlyStream::create(path, !m.normals.is_empty()).unwrap();
    for b in batches(m, 7, |n, b| n * b / 7) {
        s.push(b).unwrap();
    }
    assert!(!path.exists(), "nothing at the path before finish");
    assert_eq!(s.finish().unwrap(), (m.positions.len() as u64, (m.triangles.len() + m.quads.len()) as u64));
}

#[test]
fn streamed_ply_is_the_in_memory_ply() {
    let dir = tempfile::tempdir().unwrap();
    for (method, normals) in [
        (Method::MarchingCubes, isoforge::mesh::Normals::None),
        (Method::MarchingCubes, isoforge::mesh::Normals::Gradient),
        (Method::SurfaceNets, isoforge::mesh::Normals::None),
    ] {
        let m = mesh(method, normals);
        let path = dir.path().join(format!("{method:?}-{normals:?}.ply"));
        stream(&m, &path);
        assert_eq!(std::fs::read(&path).unwrap(), ply_bytes(&m), "{method:?} {normals:?}");
    }
    // An empty mesh too.
    let path = dir.path().join("empty.ply");
    stream(&Mesh::default(), &path);
    assert_eq!(std::fs::read(&path).unwrap(), ply_bytes(&Mesh::default()));
}

#[test]
fn a_stream_dropped_unfinished_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("gone.ply");
    let m = mesh(Method::MarchingCubes, isoforge::mesh::Normals::None);
    let mut s = PlyStream::create(&path, false).unwrap();
    s.push(MeshBatch { positions: &m.positions, normals: &[], triangles: &m.triangles, quads: &[] }).unwrap();
    drop(s);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// Every facet of `m` (triangles, then quads split), with the unit normal of its winding (zero
/// when degenerate), computed independently of the writer.
fn reference_facets(m: &Mesh) -> Vec<[[f32; 3]; 4]> {
    let tris: Vec<[u32; 3]> =
        m.triangles.iter().copied().chain(m.quads.iter().flat_map(|&q| m.split_quad(q))).collect();
    tris.iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| m.positions[v as usize]);
            let (u, v) = ([0, 1, 2].map(|i| b[i] - a[i]), [0, 1, 2].map(|i| c[i] - a[i]));
            let n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            [if len > 0.0 { n.map(|x| x / len) } else { n }, a, b, c]
        })
        .collect()
}

/// The binary STL layout written field by field, independently of the writer: the 80-byte
/// header, the count, then per facet its normal, its corners and a zero attribute count.
fn reference_stl(m: &Mesh) -> Vec<u8> {
    let mut out = vec![0u8; 80];
    let tag = format!("isoforge {} binary STL", env!("CARGO_PKG_VERSION"));
    out[..tag.len()].copy_from_slice(tag.as_bytes());
    let facets = reference_facets(m);
    out.extend_from_slice(&(facets.len() as u32).to_le_bytes());
    for f in facets {
        for x in f.as_flattened() {
            out.extend_from_slice(&x.to_le_bytes());
        }
        out.extend_from_slice(&[0, 0]);
    }
    out
}

/// The ASCII STL text, independently of the writer.
fn reference_stl_ascii(m: &Mesh) -> Vec<u8> {
    let mut out = String::from("solid isoforge\n");
    for [n, a, b, c] in reference_facets(m) {
        out += &format!("  facet normal {} {} {}\n    outer loop\n", n[0], n[1], n[2]);
        for p in [a, b, c] {
            out += &format!("      vertex {} {} {}\n", p[0], p[1], p[2]);
        }
        out += "    endloop\n  endfacet\n";
    }
    (out + "endsolid isoforge\n").into_bytes()
}

fn stl_bytes(m: &Mesh) -> Vec<u8> {
    let mut v = Vec::new();
    write_stl(&mut v, m).unwrap();
    v
}

/// Pushes `m` to a [`MeshStream`] of `format` in `batch`, in `parts` batches of vertices, all
/// its polygons in batch `at` (so they refer to the batch before, their own and the next at most
/// when `parts` ≤ 3, as a walk's do).
fn stream_as(
    format: MeshFormat,
    m: &Mesh,
    batch: &Batch,
    path: &std::path::Path,
    parts: usize,
    at: usize,
) -> Result<(u64, u64), String> {
    let mut s = MeshStream::create_in(batch, path, format, !m.normals.is_empty()).unwrap().expect("streams");
    let (nv, normals) = (m.positions.len(), !m.normals.is_empty());
    for b in 0..parts {
        let (mine, r) = (b == at, nv * b / parts..nv * (b + 1) / parts);
        let batch = MeshBatch {
            positions: &m.positions[r.clone()],
            normals: if normals { &m.normals[r] } else { &[] },
            triangles: if mine { &m.triangles } else { &[] },
            quads: if mine { &m.quads } else { &[] },
        };
        MeshSink::push(&mut s, batch).map_err(|e| e.to_string())?;
    }
    s.finish().map_err(|e| e.to_string())
}

fn stream_stl(m: &Mesh, batch: &Batch, path: &std::path::Path, parts: usize, at: usize) -> Result<(u64, u64), String> {
    stream_as(MeshFormat::Stl, m, batch, path, parts, at)
}

#[test]
fn stl_keeps_its_layout_and_streams_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    for method in [Method::MarchingCubes, Method::SurfaceNets] {
        let m = mesh(method, isoforge::mesh::Normals::None);
        let want = reference_stl(&m);
        assert!(want.len() > 84 + 50 * 100, "{method:?}: a real mesh");
        assert!(stl_bytes(&m) == want, "{method:?}: in-memory STL layout");
        let text = reference_stl_ascii(&m);
        let path = dir.path().join("memory.stl");
        isoforge_io::write_mesh(&path, &m, MeshFormat::StlAscii).unwrap();
        assert!(std::fs::read(&path).unwrap() == text, "{method:?}: in-memory ASCII STL");
        for ((parts, at), (format, want)) in [(1, 0), (2, 1), (3, 1)]
            .into_iter()
            .flat_map(|p| [(MeshFormat::Stl, &want), (MeshFormat::StlAscii, &text)].map(|f| (p, f)))
        {
            let path = dir.path().join(format!("{method:?}-{parts}-{format:?}.stl"));
            let batch = Batch::new();
            let n = stream_as(format, &m, &batch, &path, parts, at).unwrap();
            assert_eq!(n, (m.positions.len() as u64, (m.triangles.len() + 2 * m.quads.len()) as u64));
            assert!(!path.exists(), "nothing at the path before the batch commits");
            batch.commit().unwrap();
            assert!(
                std::fs::read(&path).unwrap() == *want,
                "{method:?} {format:?} in {parts} batches: streamed STL differs"
            );
        }
    }
    let path = dir.path().join("empty.stl");
    let batch = Batch::new();
    stream_stl(&Mesh::default(), &batch, &path, 2, 0).unwrap();
    batch.commit().unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), reference_stl(&Mesh::default()));
}

#[test]
fn an_stl_stream_refuses_vertices_it_has_let_go_and_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("late.stl");
    let m = mesh(Method::MarchingCubes, isoforge::mesh::Normals::None);
    // Polygons in the fourth of four batches refer to the first: beyond the sink's contract.
    let batch = Batch::new();
    let e = stream_stl(&m, &batch, &path, 4, 3).unwrap_err().to_string();
    assert!(e.contains("late.stl") && e.contains("refers to vertex"), "{e}");
    // The failed file never goes back to the batch, which refuses to commit without it.
    assert!(batch.commit().is_err(), "a failed stream must not commit");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "no output, no scratch file");
}

/// Pushes `m` to a text [`MeshStream`] (OBJ, OFF, ASCII PLY) in `parts` uneven batches (they
/// number vertices globally, so any split will do) and commits it.
fn stream_text(format: MeshFormat, m: &Mesh, path: &std::path::Path, parts: usize) -> (u64, u64) {
    let batch = Batch::new();
    let mut s = MeshStream::create_in(&batch, path, format, !m.normals.is_empty()).unwrap().expect("streams");
    for b in batches(m, parts, |n, b| n * b * b / (parts * parts)) {
        MeshSink::push(&mut s, b).unwrap();
    }
    assert!(!path.exists(), "nothing at the path before the batch commits");
    let n = s.finish().unwrap();
    batch.commit().unwrap();
    n
}

#[test]
fn streamed_text_is_the_in_memory_text() {
    let dir = tempfile::tempdir().unwrap();
    let obj = |m: &Mesh| {
        let mut v = Vec::new();
        write_obj(&mut v, m).unwrap();
        v
    };
    // A mesh past the writers' windows (formatted in parallel pieces, gathered across batches):
    // indices and positions need not make a surface for OBJ.
    let mut seed = 0x0b1_u64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    let nv = 150_000u32;
    let big = Mesh {
        positions: (0..nv).map(|_| [0, 1, 2].map(|_| (next() % 2_000_001) as f32 / 1000.0 - 1000.0)).collect(),
        normals: Vec::new(),
        triangles: (0..300_000).map(|_| [0, 1, 2].map(|_| (next() % nv as u64) as u32)).collect(),
        quads: (0..1_000).map(|_| [0, 1, 2, 3].map(|_| (next() % nv as u64) as u32)).collect(),
    };
    let mut with_normals = mesh(Method::MarchingCubes, isoforge::mesh::Normals::Gradient);
    with_normals.quads = vec![[0, 1, 2, 3]; 5];
    let cases = [
        ("mc", mesh(Method::MarchingCubes, isoforge::mesh::Normals::None)),
        ("normals", with_normals),
        ("sn", mesh(Method::SurfaceNets, isoforge::mesh::Normals::None)),
        ("big", big),
        ("empty", Mesh::default()),
    ];
    for (format, ext) in [(MeshFormat::Obj, "obj"), (MeshFormat::Off, "off"), (MeshFormat::PlyAscii, "ply")] {
        for (name, m) in &cases {
            let path = dir.path().join(format!("memory.{ext}"));
            isoforge_io::write_mesh(&path, m, format).unwrap();
            let want = std::fs::read(&path).unwrap();
            if format == MeshFormat::Obj {
                assert!(want == obj(m), "{name}: write_mesh writes write_obj's bytes");
            }
            for parts in [1, 7] {
                let path = dir.path().join(format!("{name}-{parts}.{ext}"));
                let n = stream_text(format, m, &path, parts);
                assert_eq!(n, (m.positions.len() as u64, (m.triangles.len() + m.quads.len()) as u64));
                assert!(std::fs::read(&path).unwrap() == want, "{name} in {parts} batches: streamed {ext} differs");
            }
        }
    }
    // The in-memory lines themselves: the first vertex and the last face of the big mesh.
    let text = String::from_utf8(obj(&cases[3].1)).unwrap();
    let p = cases[3].1.positions[0];
    assert!(text.contains(&format!("\nv {} {} {}\n", p[0], p[1], p[2])), "first vertex line");
    let q = cases[3].1.quads.last().unwrap().map(|v| v + 1);
    assert!(text.ends_with(&format!("f {} {} {} {}\n", q[0], q[1], q[2], q[3])), "last quad line");
}

/// The files a glTF output of `name` in `dir` consists of: the `.glb`, or the `.gltf` and its
/// `.bin` (whose name the JSON holds, so both runs use the same names, in different folders).
fn gltf_files(dir: &std::path::Path, name: &str, format: MeshFormat) -> Vec<Vec<u8>> {
    let ext = if format == MeshFormat::Glb { "glb" } else { "gltf" };
    let path = dir.join(format!("{name}.{ext}"));
    let mut files = vec![std::fs::read(&path).unwrap()];
    if format == MeshFormat::Gltf {
        files.push(std::fs::read(MeshFormat::gltf_buffer(&path)).unwrap());
    }
    files
}

/// A `.gltf` stream refuses a `.bin` beside it that is not its own, unreserved as reserved.
#[test]
fn a_gltf_stream_keeps_an_unrelated_buffer() {
    let dir = tempfile::tempdir().unwrap();
    let (path, bin) = (dir.path().join("x.gltf"), dir.path().join("x.bin"));
    std::fs::write(&bin, b"unrelated").unwrap();
    for reserve_first in [false, true] {
        let batch = Batch::new();
        if reserve_first {
            batch.reserve(&path, "the output").unwrap();
        }
        let e = MeshStream::create_in(&batch, &path, MeshFormat::Gltf, false).err().expect("refused").to_string();
        assert!(e.contains("is not the buffer of"), "{e}");
        drop(batch);
        assert_eq!(std::fs::read(&bin).unwrap(), b"unrelated");
        assert!(!path.exists());
    }
}

#[test]
fn streamed_gltf_is_the_in_memory_gltf() {
    let dir = tempfile::tempdir().unwrap();
    let folder = |name: &str| {
        let d = dir.path().join(name);
        std::fs::create_dir_all(&d).unwrap();
        d
    };
    for format in [MeshFormat::Glb, MeshFormat::Gltf] {
        let ext = if format == MeshFormat::Glb { "glb" } else { "gltf" };
        for (method, normals) in [
            (Method::MarchingCubes, isoforge::mesh::Normals::None),
            (Method::MarchingCubes, isoforge::mesh::Normals::Gradient),
            (Method::SurfaceNets, isoforge::mesh::Normals::Gradient),
        ] {
            let m = mesh(method, normals);
            let name = format!("{method:?}-{normals:?}");
            isoforge_io::write_mesh(&folder("memory").join(format!("{name}.{ext}")), &m, format).unwrap();
            let want = gltf_files(&folder("memory"), &name, format);
            assert!(want.iter().map(Vec::len).sum::<usize>() > 12 * m.positions.len(), "{name}: a real mesh");
            if format == MeshFormat::Gltf {
                let json = String::from_utf8(want[0].clone()).unwrap();
                assert!(json.contains(&format!(r#""uri":"{name}.bin""#)), "the .gltf names its buffer: {json}");
                let (vertex_bytes, triangles) =
                    (12 + 12 * !m.normals.is_empty() as usize, m.triangles.len() + 2 * m.quads.len());
                assert_eq!(want[1].len(), vertex_bytes * m.positions.len() + 12 * triangles, "{name}: the buffer");
            }
            for (parts, at) in [(1, 0), (2, 1), (3, 1)] {
                let streamed = folder(&format!("stream-{parts}"));
                let path = streamed.join(format!("{name}.{ext}"));
                let batch = Batch::new();
                let n = stream_as(format, &m, &batch, &path, parts, at).unwrap();
                assert_eq!(n, (m.positions.len() as u64, (m.triangles.len() + 2 * m.quads.len()) as u64));
                assert!(!path.exists(), "nothing at the path before the batch commits");
                assert!(!MeshFormat::gltf_buffer(&path).exists(), "no buffer before the batch commits");
                batch.commit().unwrap();
                assert!(
                    gltf_files(&streamed, &name, format) == want,
                    "{name} in {parts} batches: streamed .{ext} differs"
                );
            }
        }
        // A stream that fails midway (the second batch's normals do not match) leaves nothing at
        // either path, and its batch refuses to commit.
        let m = mesh(Method::MarchingCubes, isoforge::mesh::Normals::Gradient);
        let path = folder("midway").join(format!("m.{ext}"));
        let batch = Batch::new();
        let mut s = MeshStream::create_in(&batch, &path, format, true).unwrap().expect("streams");
        let half = m.positions.len() / 2;
        let first =
            MeshBatch { positions: &m.positions[..half], normals: &m.normals[..half], triangles: &[], quads: &[] };
        MeshSink::push(&mut s, first).unwrap();
        let second = MeshBatch { positions: &m.positions[half..], normals: &[], triangles: &m.triangles, quads: &[] };
        let e = MeshSink::push(&mut s, second).unwrap_err().to_string();
        assert!(e.contains(&format!("m.{ext}")) && e.contains("normals"), "{e}");
        drop(s);
        assert!(batch.commit().is_err(), "a failed stream must not commit");
        assert_eq!(std::fs::read_dir(folder("midway")).unwrap().count(), 0, "the failed stream left files");
        // An empty mesh is an error, as in memory, and leaves nothing.
        let path = dir.path().join(format!("empty.{ext}"));
        let batch = Batch::new();
        let e = stream_as(format, &Mesh::default(), &batch, &path, 2, 0).unwrap_err();
        assert!(e.contains(&format!("empty.{ext}")) && e.contains("empty"), "{e}");
        assert!(batch.commit().is_err(), "a failed stream must not commit");
        assert!(!path.exists() && !MeshFormat::gltf_buffer(&path).exists());
    }
}
