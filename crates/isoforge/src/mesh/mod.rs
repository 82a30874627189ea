//! Data: the indexed polygon [`Mesh`] (triangles and quads), the [`MeshBuilder`] walkers write
//! into, and the [`MeshSink`] that receives a mesh as it is produced.
//!
//! Positions are `f32` world coordinates; normals (when present) are unit vectors pointing from
//! inside (low values) to outside; polygons are wound counter-clockwise seen from outside.

pub mod bvh;
pub mod colormap;
pub mod decimate;
pub mod distance;
pub mod post;
#[cfg(test)]
pub(crate) mod shapes;
mod sink;
pub mod smooth;

pub use sink::{ExternalError, MeshBatch, MeshSink, OwnedBatch, WriteBehind};

use crate::cube::{CellRange, VertexKey};
use crate::error::{Error, Result};

/// Index of a mesh vertex.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct VertexId(pub u32);

impl VertexId {
    /// "No vertex yet": the empty slot of a vertex cache.
    pub const NONE: VertexId = VertexId(u32::MAX);

    /// The index as `usize`.
    #[inline]
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// An indexed polygon mesh: triangles, and quads from the methods that make them (dual
/// methods); [`triangulate`](Mesh::triangulate) turns the quads into triangles.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions (world coordinates).
    pub positions: Vec<[f32; 3]>,
    /// Per-vertex unit normals; empty when normals were not computed.
    pub normals: Vec<[f32; 3]>,
    /// Triangles as vertex index triples.
    pub triangles: Vec<[u32; 3]>,
    /// Quads as vertex index quadruples, wound like the triangles.
    pub quads: Vec<[u32; 4]>,
}

impl Mesh {
    /// Number of vertices.
    pub fn num_vertices(&self) -> usize {
        self.positions.len()
    }

    /// Number of triangles.
    pub fn num_triangles(&self) -> usize {
        self.triangles.len()
    }

    /// Number of quads.
    pub fn num_quads(&self) -> usize {
        self.quads.len()
    }

    /// True when the mesh has no polygon.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty() && self.quads.is_empty()
    }

    /// Empties the mesh, keeping capacity.
    pub fn clear(&mut self) {
        self.positions.clear();
        self.normals.clear();
        self.triangles.clear();
        self.quads.clear();
    }

    /// Every polygon (triangles, then quads) as a slice of vertex indices.
    pub fn polygons(&self) -> impl Iterator<Item = &[u32]> + '_ {
        self.triangles.iter().map(|t| &t[..]).chain(self.quads.iter().map(|q| &q[..]))
    }

    /// Splits every quad into two triangles along its shorter diagonal (ties: the diagonal from its
    /// first vertex), appended after the existing triangles in quad order.
    pub fn triangulate(&mut self) {
        let quads = std::mem::take(&mut self.quads);
        self.triangles.reserve(2 * quads.len());
        for q in quads {
            let split = self.split_quad(q);
            self.triangles.extend(split);
        }
    }

    /// Quad `[a, b, c, d]` as two triangles split along its shorter diagonal (ac on a tie), wound
    /// as the quad: what [`triangulate`](Mesh::triangulate) makes of it.
    #[inline]
    pub fn split_quad(&self, q: [u32; 4]) -> [[u32; 3]; 2] {
        split_quad(q, q.map(|v| self.positions[v as usize]))
    }

    /// Every triangle the mesh stands for: its triangles, then its quads split as
    /// [`triangulate`](Mesh::triangulate) splits them (for writers of triangle-only formats,
    /// without copying the mesh).
    pub fn all_triangles(&self) -> impl Iterator<Item = [u32; 3]> + '_ {
        self.triangles.iter().copied().chain(self.quads.iter().flat_map(|&q| self.split_quad(q)))
    }

    /// Triangles after [`triangulate`](Mesh::triangulate): `triangles + 2 · quads`.
    pub fn num_split_triangles(&self) -> usize {
        self.triangles.len() + 2 * self.quads.len()
    }

    /// Reverses every polygon's winding and negates the normals.
    pub fn flip(&mut self) {
        for t in &mut self.triangles {
            t.swap(1, 2);
        }
        for q in &mut self.quads {
            q.swap(1, 3);
        }
        for n in &mut self.normals {
            *n = [-n[0], -n[1], -n[2]];
        }
    }

    /// Checks that every index is in range and `normals` is empty or one per vertex.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] naming the first bad triangle.
    pub fn validate(&self) -> Result<()> {
        if !self.normals.is_empty() && self.normals.len() != self.positions.len() {
            return Err(Error::InvalidInput(format!(
                "mesh has {} normals for {} vertices",
                self.normals.len(),
                self.positions.len()
            )));
        }
        let n = self.positions.len();
        if let Some((i, t)) = self.triangles.iter().enumerate().find(|(_, t)| t.iter().any(|&v| v as usize >= n)) {
            return Err(Error::InvalidInput(format!("triangle {i} {t:?} refers to a vertex beyond the {n} vertices")));
        }
        if let Some((i, q)) = self.quads.iter().enumerate().find(|(_, q)| q.iter().any(|&v| v as usize >= n)) {
            return Err(Error::InvalidInput(format!("quad {i} {q:?} refers to a vertex beyond the {n} vertices")));
        }
        Ok(())
    }

    /// Canonical form for comparing meshes up to vertex numbering and triangle order: each
    /// triangle as its three positions (bit patterns), rotated to start at the smallest, then sorted.
    /// Quads are not included (compare [`triangulate`](Mesh::triangulate)d meshes).
    pub fn canonical_triangles(&self) -> Vec<[[u32; 3]; 3]> {
        let key = |v: u32| {
            let p = self.positions[v as usize];
            [p[0].to_bits(), p[1].to_bits(), p[2].to_bits()]
        };
        let mut out: Vec<[[u32; 3]; 3]> = self
            .triangles
            .iter()
            .map(|t| {
                let k = [key(t[0]), key(t[1]), key(t[2])];
                let m = (0..3).min_by_key(|&i| k[i]).unwrap_or(0);
                [k[m], k[(m + 1) % 3], k[(m + 2) % 3]]
            })
            .collect();
        out.sort_unstable();
        out
    }
}

/// Quad `[a, b, c, d]` with corner positions `p` as two triangles split along its shorter
/// diagonal (ac on a tie), wound as the quad: [`Mesh::split_quad`], for writers that hold the
/// positions elsewhere (a stream's window).
#[inline]
pub fn split_quad([a, b, c, d]: [u32; 4], p: [[f32; 3]; 4]) -> [[u32; 3]; 2] {
    let len2 = |u: usize, v: usize| (0..3).map(|i| ((p[u][i] - p[v][i]) as f64).powi(2)).sum::<f64>();
    if len2(1, 3) < len2(0, 2) {
        [[a, b, d], [b, c, d]]
    } else {
        [[a, b, c], [a, c, d]]
    }
}

/// A vector of `n` zeros backed by huge pages where the platform allows. `vec!` of zeros takes
/// fresh, untouched pages from the allocator (calloc); the kernel is asked for huge pages before
/// the first write, so filling faults in 2 MiB pages instead of 4 KiB ones (page faults were 15 %
/// of a 5-million-triangle extraction). Advisory: a plain `vec!` off Linux or for small sizes.
pub fn huge_vec<T: Copy>(n: usize, zero: T) -> Vec<T> {
    let mut v = vec![zero; n];
    advise_huge(&mut v);
    v
}

/// An empty vector with room for exactly `n` elements, backed by huge pages as [`huge_vec`], its
/// memory left uninitialised: for an output whose every slot is written once (through
/// [`Vec::spare_capacity_mut`]) before `set_len`. Memory the allocator hands back from a freed
/// block is then written once, by the producer, instead of zeroed first (calloc's memset, with
/// its page faults) and written again.
pub fn huge_capacity<T>(n: usize) -> Vec<T> {
    let mut v = Vec::with_capacity(n);
    advise_huge(&mut v);
    v
}

/// Asks the kernel to back the 2 MiB-aligned part of `v`'s buffer (its capacity) with huge pages.
fn advise_huge<T>(v: &mut Vec<T>) {
    #[cfg(target_os = "linux")]
    {
        const HUGE: usize = 2 << 20;
        let bytes = v.capacity() * std::mem::size_of::<T>();
        let start = v.as_mut_ptr() as usize;
        let aligned = start.next_multiple_of(HUGE);
        let len = (start + bytes).saturating_sub(aligned) / HUGE * HUGE;
        if len > 0 {
            // SAFETY: [aligned, aligned + len) lies inside `v`'s allocation, which we own;
            // MADV_HUGEPAGE only changes how the kernel backs those pages, never their contents.
            unsafe {
                libc::madvise(aligned as *mut libc::c_void, len, libc::MADV_HUGEPAGE);
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = v;
}

/// Whether vertices get normals written to the output.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Normals {
    /// Unit normals from the field gradient (central differences for grids).
    Gradient,
    /// No normals (`Mesh::normals` stays empty): the default, as in the peer benchmarks; viewers
    /// compute normals themselves, and gradient normals cost 30–75 % of a grid extraction.
    #[default]
    None,
}

/// Which vertices a [`MeshBuilder`] records the [`VertexKey`] of.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum KeyRecord {
    /// None (the usual case).
    #[default]
    None,
    /// Every vertex.
    All,
    /// The vertices a walk of this range may share with walks of neighbouring ranges: those whose
    /// edge, segment or cell touches the range's boundary planes (what stitching needs).
    Boundary(CellRange),
}

/// Accumulates vertices and polygons; fails cleanly when the mesh outgrows `u32` indices.
///
/// Walkers push each vertex with its [`VertexKey`]; the builder keeps the keys asked for by its
/// [`KeyRecord`] (vertex provenance, for stitching chunks).
#[derive(Debug, Default)]
pub struct MeshBuilder {
    mesh: Mesh,
    with_normals: bool,
    reverse_winding: bool,
    overflow: bool,
    record: KeyRecord,
    keys: Vec<(u32, VertexKey)>,
    /// Vertices already handed to a sink (ids continue after them).
    drained: u64,
}

impl MeshBuilder {
    /// Largest number of vertices a mesh may hold (`u32` indices, `NONE` reserved).
    pub const MAX_VERTICES: u64 = u32::MAX as u64 - 1;

    /// A builder that stores normals or not.
    pub fn new(normals: Normals) -> Self {
        MeshBuilder { with_normals: normals == Normals::Gradient, ..Default::default() }
    }

    /// A builder that reuses `mesh`'s buffers (cleared).
    pub fn reuse(mut mesh: Mesh, normals: Normals) -> Self {
        mesh.clear();
        MeshBuilder { mesh, with_normals: normals == Normals::Gradient, ..Default::default() }
    }

    /// Records the keys of the vertices `record` selects (see [`finish_keyed`](MeshBuilder::finish_keyed)).
    pub fn with_keys(mut self, record: KeyRecord) -> Self {
        self.record = record;
        self
    }

    /// Which keys are recorded.
    #[inline]
    pub fn key_record(&self) -> KeyRecord {
        self.record
    }

    /// True when normals are stored.
    #[inline]
    pub fn wants_normals(&self) -> bool {
        self.with_normals
    }

    /// Takes the vertices and polygons pushed since the last call, as one batch for a
    /// [`MeshSink`]; vertex ids keep counting from where they were (streamed walks).
    pub fn drain_into(&mut self, sink: &mut dyn MeshSink) -> std::result::Result<(), ExternalError> {
        let m = &self.mesh;
        sink.push(MeshBatch {
            positions: &m.positions,
            normals: &m.normals,
            triangles: &m.triangles,
            quads: &m.quads,
        })?;
        self.drained += m.positions.len() as u64;
        self.mesh.clear();
        Ok(())
    }

    /// Adds a vertex (`key`: where it comes from); its normal is ignored when normals are off.
    #[inline]
    pub fn push_vertex(&mut self, key: VertexKey, p: [f32; 3], n: [f32; 3]) -> VertexId {
        let id = self.drained + self.mesh.positions.len() as u64;
        if id >= Self::MAX_VERTICES {
            self.overflow = true;
            return VertexId(0);
        }
        self.mesh.positions.push(p);
        if self.with_normals {
            self.mesh.normals.push(n);
        }
        match self.record {
            KeyRecord::None => {}
            KeyRecord::All => self.keys.push((id as u32, key)),
            KeyRecord::Boundary(r) => {
                if touches_boundary(&key, &r) {
                    self.keys.push((id as u32, key));
                }
            }
        }
        VertexId(id as u32)
    }

    /// Reverses the winding of every polygon pushed from now on: walkers set it for mirrored
    /// lattices, whose world frame is left-handed, so polygons stay counter-clockwise from outside.
    pub fn set_reverse_winding(&mut self, reverse: bool) {
        self.reverse_winding = reverse;
    }

    /// Adds a triangle.
    #[inline]
    pub fn push_triangle(&mut self, t: [VertexId; 3]) {
        let t = if self.reverse_winding { [t[0].0, t[2].0, t[1].0] } else { [t[0].0, t[1].0, t[2].0] };
        self.mesh.triangles.push(t);
    }

    /// Adds a quad.
    #[inline]
    pub fn push_quad(&mut self, q: [VertexId; 4]) {
        let q = if self.reverse_winding { [q[0].0, q[3].0, q[2].0, q[1].0] } else { q.map(|v| v.0) };
        self.mesh.quads.push(q);
    }

    /// Triangles and quads pushed since the last drain.
    pub fn polygon_counts(&self) -> (usize, usize) {
        (self.mesh.triangles.len(), self.mesh.quads.len())
    }

    /// Number of vertices so far (drained ones included).
    pub fn num_vertices(&self) -> u64 {
        self.drained + self.mesh.positions.len() as u64
    }

    /// Replaces the contents with a mesh a walker assembled itself (a parallel walker fills
    /// preallocated arrays), with the recorded keys of its vertices.
    pub fn set_assembled(&mut self, mesh: Mesh, keys: Vec<(u32, VertexKey)>) {
        self.mesh = mesh;
        self.keys = keys;
    }

    /// The finished mesh.
    ///
    /// # Errors
    /// [`Error::Limit`] when more than [`MeshBuilder::MAX_VERTICES`] vertices were pushed.
    pub fn finish(self) -> Result<Mesh> {
        Ok(self.finish_keyed()?.0)
    }

    /// The finished mesh and the recorded keys (vertex id, key), in vertex order.
    ///
    /// # Errors
    /// As [`finish`](MeshBuilder::finish).
    pub fn finish_keyed(self) -> Result<(Mesh, Vec<(u32, VertexKey)>)> {
        if self.overflow {
            return Err(Error::Limit {
                what: "mesh vertices",
                requested: Self::MAX_VERTICES + 1,
                allowed: Self::MAX_VERTICES,
            });
        }
        Ok((self.mesh, self.keys))
    }
}

/// Whether the vertex `key` may be shared with a walk of a neighbouring range: its edge, segment
/// or cell reaches one of the range's boundary planes (on an axis where the range has a neighbour
/// or not: a range does not know the lattice, so both ends count).
#[inline]
pub fn touches_boundary(key: &VertexKey, r: &CellRange) -> bool {
    let (lo, hi) = key.extent2();
    (0..3).any(|a| lo[a] <= 2 * r.lo[a] || hi[a] >= 2 * r.hi[a])
}
