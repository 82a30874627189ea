//! Data: the indexed triangle [`Mesh`] and the [`MeshBuilder`] walkers write into.
//!
//! Positions are `f32` world coordinates; normals (when present) are unit vectors pointing from
//! inside (low values) to outside; triangles are wound counter-clockwise seen from outside.

pub mod colormap;

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

/// An indexed triangle mesh.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions (world coordinates).
    pub positions: Vec<[f32; 3]>,
    /// Per-vertex unit normals; empty when normals were not computed.
    pub normals: Vec<[f32; 3]>,
    /// Triangles as vertex index triples.
    pub triangles: Vec<[u32; 3]>,
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

    /// True when the mesh has no triangle.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Empties the mesh, keeping capacity.
    pub fn clear(&mut self) {
        self.positions.clear();
        self.normals.clear();
        self.triangles.clear();
    }

    /// Reverses every triangle's winding and negates the normals.
    pub fn flip(&mut self) {
        for t in &mut self.triangles {
            t.swap(1, 2);
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
        Ok(())
    }

    /// Canonical form for comparing meshes up to vertex numbering and triangle order: each
    /// triangle as its three positions (bit patterns), rotated to start at the smallest, then sorted.
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

/// A vector of `n` zeros backed by huge pages where the platform allows. `vec!` of zeros takes
/// fresh, untouched pages from the allocator (calloc); the kernel is asked for huge pages before
/// the first write, so filling faults in 2 MiB pages instead of 4 KiB ones (page faults were 15 %
/// of a 5-million-triangle extraction). Advisory: a plain `vec!` off Linux or for small sizes.
pub fn huge_vec<T: Copy>(n: usize, zero: T) -> Vec<T> {
    #[allow(unused_mut)]
    let mut v = vec![zero; n];
    #[cfg(target_os = "linux")]
    {
        const HUGE: usize = 2 << 20;
        let bytes = std::mem::size_of_val(v.as_slice());
        let start = v.as_mut_ptr() as usize;
        let aligned = start.next_multiple_of(HUGE);
        let len = (start + bytes).saturating_sub(aligned) / HUGE * HUGE;
        if len > 0 {
            // SAFETY: [aligned, aligned + len) lies inside `v`'s buffer, which we own;
            // MADV_HUGEPAGE only changes how the kernel backs those pages, never their contents.
            unsafe {
                libc::madvise(aligned as *mut libc::c_void, len, libc::MADV_HUGEPAGE);
            }
        }
    }
    v
}

/// Accumulates vertices and triangles; fails cleanly when the mesh outgrows `u32` indices.
#[derive(Debug, Default)]
pub struct MeshBuilder {
    mesh: Mesh,
    with_normals: bool,
    reverse_winding: bool,
    overflow: bool,
}

impl MeshBuilder {
    /// Largest number of vertices a mesh may hold (`u32` indices, `NONE` reserved).
    pub const MAX_VERTICES: u64 = u32::MAX as u64 - 1;

    /// A builder that stores normals when `with_normals` is true.
    pub fn new(with_normals: bool) -> Self {
        MeshBuilder { mesh: Mesh::default(), with_normals, reverse_winding: false, overflow: false }
    }

    /// A builder that reuses `mesh`'s buffers (cleared).
    pub fn reuse(mut mesh: Mesh, with_normals: bool) -> Self {
        mesh.clear();
        MeshBuilder { mesh, with_normals, reverse_winding: false, overflow: false }
    }

    /// True when normals are stored.
    #[inline]
    pub fn wants_normals(&self) -> bool {
        self.with_normals
    }

    /// Adds a vertex; its normal is ignored when normals are off.
    #[inline]
    pub fn push_vertex(&mut self, p: [f32; 3], n: [f32; 3]) -> VertexId {
        let id = self.mesh.positions.len() as u64;
        if id >= Self::MAX_VERTICES {
            self.overflow = true;
            return VertexId(0);
        }
        self.mesh.positions.push(p);
        if self.with_normals {
            self.mesh.normals.push(n);
        }
        VertexId(id as u32)
    }

    /// Reverses the winding of every triangle pushed from now on: walkers set it for mirrored
    /// lattices, whose world frame is left-handed, so triangles stay counter-clockwise from outside.
    pub fn set_reverse_winding(&mut self, reverse: bool) {
        self.reverse_winding = reverse;
    }

    /// Adds a triangle.
    #[inline]
    pub fn push_triangle(&mut self, t: [VertexId; 3]) {
        let t = if self.reverse_winding { [t[0].0, t[2].0, t[1].0] } else { [t[0].0, t[1].0, t[2].0] };
        self.mesh.triangles.push(t);
    }

    /// Number of vertices so far.
    pub fn num_vertices(&self) -> usize {
        self.mesh.positions.len()
    }

    /// The finished mesh.
    ///
    /// # Errors
    /// [`Error::Limit`] when more than [`MeshBuilder::MAX_VERTICES`] vertices were pushed.
    pub fn finish(self) -> Result<Mesh> {
        if self.overflow {
            return Err(Error::Limit {
                what: "mesh vertices",
                requested: Self::MAX_VERTICES + 1,
                allowed: Self::MAX_VERTICES,
            });
        }
        Ok(self.mesh)
    }
}
