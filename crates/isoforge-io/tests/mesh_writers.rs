//! Issue 11: the mesh writers take quads (PLY, OBJ, OFF) and read them back; the streamed PLY
//! writer gives the in-memory writer's bytes; the binary PLY layout is the one it always was.

use isoforge::grid::{AnyGrid, DenseGrid, Lattice};
use isoforge::mesh::{Mesh, MeshBatch};
use isoforge::pipeline::{self, Method, Options};
use isoforge::volume::Iso;
use isoforge_io::write::ply::{write_ply, PlyStream};
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

/// Pushes `m` to a [`PlyStream`] in uneven batches, as a walk would.
fn stream(m: &Mesh, path: &std::path::Path) {
    let mut s = PlyStream::create(path, !m.normals.is_empty()).unwrap();
    let (nv, nt, nq) = (m.positions.len(), m.triangles.len(), m.quads.len());
    let parts = 7;
    for b in 0..parts {
        let r = |n: usize| n * b / parts..n * (b + 1) / parts;
        let normals = if m.normals.is_empty() { &[][..] } else { &m.normals[r(nv)] };
        s.push(MeshBatch {
            positions: &m.positions[r(nv)],
            normals,
            triangles: &m.triangles[r(nt)],
            quads: &m.quads[r(nq)],
        })
        .unwrap();
    }
    assert!(!path.exists(), "nothing at the path before finish");
    assert_eq!(s.finish().unwrap(), (nv as u64, (nt + nq) as u64));
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
