//! Joining the meshes of cell ranges by vertex key (never by comparing coordinates).

use std::collections::HashMap;
use std::hash::BuildHasherDefault;

use super::segment::KeyHasher;

use crate::cube::VertexKey;
use crate::error::{Error, Result};
use crate::mesh::{Mesh, MeshBuilder};

/// A mesh walked over a cell range, with the keys of the vertices neighbouring ranges may share
/// (`(vertex, key)`, in vertex order: what a [`MeshBuilder`] records with
/// [`KeyRecord::Boundary`](crate::mesh::KeyRecord::Boundary) or `All`).
#[derive(Debug, Clone, Default)]
pub struct KeyedMesh {
    /// The range's mesh.
    pub mesh: Mesh,
    /// Keys of (at least) its shared vertices.
    pub keys: Vec<(u32, VertexKey)>,
}

impl KeyedMesh {
    /// The finished contents of a builder that recorded keys.
    ///
    /// # Errors
    /// As [`MeshBuilder::finish`].
    pub fn from_builder(b: MeshBuilder) -> Result<Self> {
        let (mesh, keys) = b.finish_keyed()?;
        Ok(KeyedMesh { mesh, keys })
    }
}

/// Joins the meshes of cell ranges that tile (part of) a lattice into one: vertices with equal
/// keys become one, kept where they first occur (parts in order), and polygons are renumbered.
/// With the meshes of walks over the tiles of a range, the result has exactly the vertices and
/// polygons of one walk over the whole range (the order of parts decides the numbering).
///
/// # Errors
/// [`Error::Limit`] past `u32` vertex indices; [`Error::Internal`] when a part's keys name a
/// vertex it does not have.
pub fn stitch(parts: &[KeyedMesh]) -> Result<Mesh> {
    Ok(stitch_keyed(parts)?.mesh)
}

/// [`stitch`], keeping the keys the parts recorded (renumbered, each once, in vertex order).
///
/// # Errors
/// As [`stitch`].
pub fn stitch_keyed(parts: &[KeyedMesh]) -> Result<KeyedMesh> {
    // PASS 1: each part's vertex → global vertex; duplicates resolve through the key map.
    let keyed = parts.iter().map(|p| p.keys.len()).sum();
    let mut first: HashMap<VertexKey, u32, BuildHasherDefault<KeyHasher>> =
        HashMap::with_capacity_and_hasher(keyed, Default::default());
    let mut keys_out: Vec<(u32, VertexKey)> = Vec::new();
    let mut remap: Vec<Vec<u32>> = Vec::with_capacity(parts.len());
    let mut kept: Vec<Vec<u32>> = Vec::with_capacity(parts.len());
    let mut next: u64 = 0;
    for part in parts {
        let n = part.mesh.num_vertices();
        let mut map = Vec::with_capacity(n);
        let mut own = Vec::new();
        let mut keys = part.keys.iter().peekable();
        for v in 0..n as u32 {
            let key = match keys.peek() {
                Some(&&(id, key)) if id == v => {
                    keys.next();
                    Some(key)
                }
                _ => None,
            };
            let existing = key.and_then(|k| first.get(&k).copied());
            let id = match existing {
                Some(id) => id,
                None => {
                    if next >= MeshBuilder::MAX_VERTICES {
                        return Err(Error::Limit {
                            what: "mesh vertices",
                            requested: next + 1,
                            allowed: MeshBuilder::MAX_VERTICES,
                        });
                    }
                    let id = next as u32;
                    next += 1;
                    if let Some(k) = key {
                        first.insert(k, id);
                        keys_out.push((id, k));
                    }
                    own.push(v);
                    id
                }
            };
            map.push(id);
        }
        if let Some(&(id, _)) = keys.next() {
            return Err(Error::Internal(format!("stitch: a key names vertex {id} of a part with {n} vertices")));
        }
        remap.push(map);
        kept.push(own);
    }
    // PASS 2: copy the kept vertices and renumber the polygons.
    let with_normals =
        parts.iter().all(|p| p.mesh.normals.len() == p.mesh.positions.len() && !p.mesh.normals.is_empty());
    // Each part writes its share of every array, in parallel when enabled.
    let mut out = Mesh::default();
    let kept_sizes: Vec<usize> = kept.iter().map(Vec::len).collect();
    fill_by_part(&mut out.positions, &kept_sizes, |i, dst| {
        dst.iter_mut().zip(&kept[i]).for_each(|(d, &v)| *d = parts[i].mesh.positions[v as usize]);
    });
    if with_normals {
        fill_by_part(&mut out.normals, &kept_sizes, |i, dst| {
            dst.iter_mut().zip(&kept[i]).for_each(|(d, &v)| *d = parts[i].mesh.normals[v as usize]);
        });
    }
    let sizes: Vec<usize> = parts.iter().map(|p| p.mesh.triangles.len()).collect();
    fill_by_part(&mut out.triangles, &sizes, |i, dst| {
        let map = &remap[i];
        dst.iter_mut().zip(&parts[i].mesh.triangles).for_each(|(d, t)| *d = t.map(|v| map[v as usize]));
    });
    let sizes: Vec<usize> = parts.iter().map(|p| p.mesh.quads.len()).collect();
    fill_by_part(&mut out.quads, &sizes, |i, dst| {
        let map = &remap[i];
        dst.iter_mut().zip(&parts[i].mesh.quads).for_each(|(d, q)| *d = q.map(|v| map[v as usize]));
    });
    Ok(KeyedMesh { mesh: out, keys: keys_out })
}

/// Sets `out` to the concatenation of per-part slices of `sizes`, each written by `f(part, slice)`
/// (in parallel when enabled).
fn fill_by_part<T: Copy + Default + Send>(out: &mut Vec<T>, sizes: &[usize], f: impl Fn(usize, &mut [T]) + Sync) {
    out.clear();
    out.resize(sizes.iter().sum(), T::default());
    let mut slices = Vec::with_capacity(sizes.len());
    let mut rest = &mut out[..];
    for &n in sizes {
        let (part, tail) = rest.split_at_mut(n);
        slices.push(part);
        rest = tail;
    }
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        slices.into_par_iter().enumerate().for_each(|(i, s)| f(i, s));
    }
    #[cfg(not(feature = "parallel"))]
    slices.into_iter().enumerate().for_each(|(i, s)| f(i, s));
}
