//! PLY writer: binary little-endian (default) or ASCII; normals as nx, ny, nz when present.

use std::io::{self, Write};

use isoforge::mesh::Mesh;

use crate::attributes::MeshData;

/// Writes `mesh` as PLY.
pub fn write_ply(w: &mut dyn Write, mesh: &Mesh, ascii: bool) -> io::Result<()> {
    write_ply_with(w, mesh, &MeshData::default(), ascii)
}

/// Writes `mesh` as PLY with extra vertex properties: `red green blue` (uchar) for colours, then
/// one `float NAME` per scalar attribute.
pub fn write_ply_with(w: &mut dyn Write, mesh: &Mesh, data: &MeshData, ascii: bool) -> io::Result<()> {
    if !data.fits(mesh) {
        return Err(io::Error::other("vertex data does not have one entry per vertex"));
    }
    let normals = !mesh.normals.is_empty();
    let format = if ascii { "ascii" } else { "binary_little_endian" };
    write!(w, "ply\nformat {format} 1.0\ncomment isoforge {}\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
        env!("CARGO_PKG_VERSION"), mesh.positions.len())?;
    if normals {
        w.write_all(b"property float nx\nproperty float ny\nproperty float nz\n")?;
    }
    if data.colors.is_some() {
        w.write_all(b"property uchar red\nproperty uchar green\nproperty uchar blue\n")?;
    }
    for (name, _) in &data.scalars {
        let name: String = name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '_' { c } else { '_' }).collect();
        writeln!(w, "property float {name}")?;
    }
    write!(w, "element face {}\nproperty list uchar int vertex_indices\n", mesh.triangles.len())?;
    if data.triangle_labels.is_some() {
        w.write_all(b"property int label\n")?;
    }
    w.write_all(b"end_header\n")?;
    if ascii {
        for (i, p) in mesh.positions.iter().enumerate() {
            write!(w, "{} {} {}", p[0], p[1], p[2])?;
            if normals {
                let n = mesh.normals[i];
                write!(w, " {} {} {}", n[0], n[1], n[2])?;
            }
            if let Some(c) = &data.colors {
                write!(w, " {} {} {}", c[i][0], c[i][1], c[i][2])?;
            }
            for (_, v) in &data.scalars {
                write!(w, " {}", v[i])?;
            }
            w.write_all(b"\n")?;
        }
        for (k, t) in mesh.triangles.iter().enumerate() {
            match &data.triangle_labels {
                Some(l) => writeln!(w, "3 {} {} {} {}", t[0], t[1], t[2], l[k])?,
                None => writeln!(w, "3 {} {} {}", t[0], t[1], t[2])?,
            }
        }
    } else {
        let mut buf = Vec::with_capacity(1 << 16);
        for (i, p) in mesh.positions.iter().enumerate() {
            for c in p {
                buf.extend_from_slice(&c.to_le_bytes());
            }
            if normals {
                for c in mesh.normals[i] {
                    buf.extend_from_slice(&c.to_le_bytes());
                }
            }
            if let Some(c) = &data.colors {
                buf.extend_from_slice(&c[i]);
            }
            for (_, v) in &data.scalars {
                buf.extend_from_slice(&v[i].to_le_bytes());
            }
            if buf.len() >= 1 << 16 {
                w.write_all(&buf)?;
                buf.clear();
            }
        }
        for (k, t) in mesh.triangles.iter().enumerate() {
            buf.push(3);
            for v in t {
                buf.extend_from_slice(&(*v as i32).to_le_bytes());
            }
            if let Some(l) = &data.triangle_labels {
                buf.extend_from_slice(&l[k].to_le_bytes());
            }
            if buf.len() >= 1 << 16 {
                w.write_all(&buf)?;
                buf.clear();
            }
        }
        w.write_all(&buf)?;
    }
    Ok(())
}

/// Width the streamed header reserves for each count, so the counts can be written at the end.
const COUNT_WIDTH: usize = 20;

/// A binary PLY written as the mesh is produced ([`isoforge::walk::MeshSink`]): vertices go to the
/// file, triangles to a side file; [`PlyStream::finish`] appends the triangles, writes the counts
/// into the header's reserved space and renames into place. Until then `path` is untouched, and a
/// stream dropped unfinished removes its temporary files.
pub struct PlyStream {
    path: std::path::PathBuf,
    main_tmp: std::path::PathBuf,
    tris_tmp: std::path::PathBuf,
    main: io::BufWriter<std::fs::File>,
    tris: io::BufWriter<std::fs::File>,
    normals: bool,
    vertices: u64,
    triangles: u64,
    finished: bool,
}

fn stream_header(vertices: u64, triangles: u64, normals: bool) -> String {
    let mut h = format!(
        "ply\nformat binary_little_endian 1.0\ncomment isoforge {}\nelement vertex {:<w$}\nproperty float x\nproperty float y\nproperty float z\n",
        env!("CARGO_PKG_VERSION"),
        vertices,
        w = COUNT_WIDTH
    );
    if normals {
        h.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    h.push_str(&format!(
        "element face {:<w$}\nproperty list uchar int vertex_indices\nend_header\n",
        triangles,
        w = COUNT_WIDTH
    ));
    h
}

impl PlyStream {
    /// Starts writing `path` (through temporary files beside it).
    ///
    /// # Errors
    /// The files cannot be created.
    pub fn create(path: &std::path::Path, normals: bool) -> io::Result<Self> {
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let main_tmp = path.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
        let tris_tmp = path.with_file_name(format!(".{name}.faces.tmp-{}", std::process::id()));
        let main = std::fs::File::create(&main_tmp)?;
        let tris = match std::fs::File::create(&tris_tmp) {
            Ok(f) => f,
            Err(e) => {
                let _ = std::fs::remove_file(&main_tmp);
                return Err(e);
            }
        };
        let mut s = PlyStream {
            path: path.to_path_buf(),
            main_tmp,
            tris_tmp,
            main: io::BufWriter::with_capacity(1 << 20, main),
            tris: io::BufWriter::with_capacity(1 << 20, tris),
            normals,
            vertices: 0,
            triangles: 0,
            finished: false,
        };
        s.main.write_all(stream_header(0, 0, normals).as_bytes())?;
        Ok(s)
    }

    /// Appends vertices and polygons.
    ///
    /// # Errors
    /// Writing fails, or `normals` does not match the stream.
    pub fn push(&mut self, batch: isoforge::mesh::MeshBatch<'_>) -> io::Result<()> {
        let isoforge::mesh::MeshBatch { positions, normals, triangles, quads } = batch;
        if self.normals == normals.is_empty() && !positions.is_empty() {
            return Err(io::Error::other("normals given to a stream created without them, or missing"));
        }
        let mut buf = Vec::with_capacity(positions.len() * 24);
        for (i, p) in positions.iter().enumerate() {
            for c in p {
                buf.extend_from_slice(&c.to_le_bytes());
            }
            if self.normals {
                for c in normals[i] {
                    buf.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
        self.main.write_all(&buf)?;
        buf.clear();
        for t in triangles {
            buf.push(3);
            for v in t {
                buf.extend_from_slice(&(*v as i32).to_le_bytes());
            }
        }
        for q in quads {
            buf.push(4);
            for v in q {
                buf.extend_from_slice(&(*v as i32).to_le_bytes());
            }
        }
        self.tris.write_all(&buf)?;
        self.vertices += positions.len() as u64;
        self.triangles += (triangles.len() + quads.len()) as u64;
        Ok(())
    }

    /// Appends the triangles, writes the counts and renames the file into place.
    ///
    /// # Errors
    /// Writing or renaming fails (the temporary files are removed).
    pub fn finish(mut self) -> io::Result<(u64, u64)> {
        use std::io::{Seek, SeekFrom};
        let result = (|| {
            self.tris.flush()?;
            let mut tris = std::fs::File::open(&self.tris_tmp)?;
            io::copy(&mut tris, &mut self.main)?;
            self.main.flush()?;
            let file = self.main.get_mut();
            file.seek(SeekFrom::Start(0))?;
            file.write_all(stream_header(self.vertices, self.triangles, self.normals).as_bytes())?;
            file.sync_all()?;
            std::fs::rename(&self.main_tmp, &self.path)
        })();
        self.finished = result.is_ok();
        let _ = std::fs::remove_file(&self.tris_tmp);
        result.map(|()| (self.vertices, self.triangles))
    }
}

impl Drop for PlyStream {
    fn drop(&mut self) {
        if !self.finished {
            let _ = std::fs::remove_file(&self.main_tmp);
            let _ = std::fs::remove_file(&self.tris_tmp);
        }
    }
}

impl isoforge::mesh::MeshSink for PlyStream {
    fn push(&mut self, batch: isoforge::mesh::MeshBatch<'_>) -> Result<(), isoforge::mesh::ExternalError> {
        PlyStream::push(self, batch).map_err(|e| {
            let msg = format!("{}: {e}", self.path.display());
            msg.into()
        })
    }
}
