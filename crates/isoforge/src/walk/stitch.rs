//! Joining the meshes of cell ranges by vertex key (never by comparing coordinates).

use std::collections::HashMap;
use std::hash::BuildHasherDefault;

use crate::math::KeyHasher;

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

/// The parts of a walk done in pieces (each a piece's keyed mesh and counts, or its error), in
/// order: the first error, or the pieces stitched ([`stitch_keyed`]) and their counts summed.
pub(crate) fn stitch_parts(parts: Vec<Result<(KeyedMesh, super::WalkStats)>>) -> Result<(KeyedMesh, super::WalkStats)> {
    let mut stats = super::WalkStats::default();
    let mut meshes = Vec::with_capacity(parts.len());
    for part in parts {
        let (m, s) = part?;
        stats.add(s);
        meshes.push(m);
    }
    Ok((stitch_keyed(&meshes)?, stats))
}

/// [`stitch`], keeping the keys the parts recorded (renumbered, each once, in vertex order).
///
/// # Errors
/// As [`stitch`].
pub fn stitch_keyed(parts: &[KeyedMesh]) -> Result<KeyedMesh> {
    // PASS 1, over the keys alone (parts in order): a keyed vertex met before is dropped and
    // takes the earlier one's id; every other vertex is kept, numbered after the kept vertices
    // before it. A part's unkeyed vertices are never dropped, so its numbering is its first
    // id plus the vertex index minus the dropped vertices before it (PASS 2 fills it in).
    let keyed = parts.iter().map(|p| p.keys.len()).sum();
    let mut first: HashMap<VertexKey, u32, BuildHasherDefault<KeyHasher>> =
        HashMap::with_capacity_and_hasher(keyed, Default::default());
    let mut keys_out: Vec<(u32, VertexKey)> = Vec::with_capacity(keyed);
    // Per part: its first id, and its dropped vertices with the ids they take, in vertex order.
    let mut bases: Vec<u64> = Vec::with_capacity(parts.len());
    let mut dropped: Vec<Vec<(u32, u32)>> = Vec::with_capacity(parts.len());
    let mut next: u64 = 0;
    for part in parts {
        let n = part.mesh.num_vertices() as u64;
        let mut gone = Vec::new();
        let mut last = None;
        for &(v, key) in &part.keys {
            if u64::from(v) >= n || last.is_some_and(|l| l >= v) {
                return Err(Error::Internal(format!(
                    "stitch: a key names vertex {v} of a part with {n} vertices (or out of order)"
                )));
            }
            last = Some(v);
            match first.get(&key) {
                Some(&id) => gone.push((v, id)),
                None => {
                    let id = next + u64::from(v) - gone.len() as u64;
                    if id >= MeshBuilder::MAX_VERTICES {
                        return Err(too_many(id + 1));
                    }
                    first.insert(key, id as u32);
                    keys_out.push((id as u32, key));
                }
            }
        }
        bases.push(next);
        next += n - gone.len() as u64;
        if next > MeshBuilder::MAX_VERTICES {
            return Err(too_many(next));
        }
        dropped.push(gone);
    }
    // PASS 2: each part's vertex map, its kept vertices copied (the runs between dropped ones)
    // and its polygons renumbered, every part in parallel.
    let remap: Vec<Vec<u32>> = map_parts(parts.len(), |i| {
        let n = parts[i].mesh.num_vertices();
        let mut map = Vec::with_capacity(n);
        let mut id = bases[i] as u32;
        let mut from = 0u32;
        for &(v, to) in &dropped[i] {
            let run = v - from;
            map.extend((0..run).map(|r| id + r));
            id += run;
            map.push(to);
            from = v + 1;
        }
        map.extend((0..n as u32 - from).map(|r| id + r));
        map
    });
    // Normals when the parts have them (a part without vertices has none either way).
    let with_normals = parts.iter().any(|p| !p.mesh.normals.is_empty())
        && parts.iter().all(|p| p.mesh.normals.len() == p.mesh.positions.len());
    let mut out = Mesh::default();
    let kept_sizes: Vec<usize> = parts.iter().zip(&dropped).map(|(p, d)| p.mesh.num_vertices() - d.len()).collect();
    // The kept vertices of part `i`, in order, copied run by run into `dst`.
    let copy_kept = |i: usize, src: &[[f32; 3]], dst: &mut [[f32; 3]]| {
        let (mut from, mut at) = (0usize, 0usize);
        for &(v, _) in &dropped[i] {
            let run = v as usize - from;
            dst[at..at + run].copy_from_slice(&src[from..v as usize]);
            at += run;
            from = v as usize + 1;
        }
        dst[at..].copy_from_slice(&src[from..]);
    };
    fill_by_part(&mut out.positions, &kept_sizes, |i, dst| copy_kept(i, &parts[i].mesh.positions, dst));
    if with_normals {
        fill_by_part(&mut out.normals, &kept_sizes, |i, dst| copy_kept(i, &parts[i].mesh.normals, dst));
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

fn too_many(requested: u64) -> Error {
    Error::Limit { what: "mesh vertices", requested, allowed: MeshBuilder::MAX_VERTICES }
}

/// `f(i)` for every part `i < n`, in parallel when enabled; results in part order.
fn map_parts<R: Send>(n: usize, f: impl Fn(usize) -> R + Sync + Send) -> Vec<R> {
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        (0..n).into_par_iter().map(f).collect()
    }
    #[cfg(not(feature = "parallel"))]
    (0..n).map(f).collect()
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The stitch vertex by vertex, as it was before PASS 1 went over the keys alone.
    fn by_vertex(parts: &[KeyedMesh]) -> (Mesh, Vec<(u32, VertexKey)>) {
        let mut first = HashMap::new();
        let (mut out, mut keys_out) = (Mesh::default(), Vec::new());
        for part in parts {
            let keyed: HashMap<u32, VertexKey> = part.keys.iter().copied().collect();
            let mut map = Vec::new();
            for v in 0..part.mesh.num_vertices() as u32 {
                let key = keyed.get(&v).copied();
                let id = match key.and_then(|k| first.get(&k).copied()) {
                    Some(id) => id,
                    None => {
                        let id = out.positions.len() as u32;
                        out.positions.push(part.mesh.positions[v as usize]);
                        if !part.mesh.normals.is_empty() {
                            out.normals.push(part.mesh.normals[v as usize]);
                        }
                        if let Some(k) = key {
                            first.insert(k, id);
                            keys_out.push((id, k));
                        }
                        id
                    }
                };
                map.push(id);
            }
            out.triangles.extend(part.mesh.triangles.iter().map(|t| t.map(|v| map[v as usize])));
            out.quads.extend(part.mesh.quads.iter().map(|q| q.map(|v| map[v as usize])));
        }
        // Normals only when every part with vertices has them.
        if parts.iter().any(|p| p.mesh.normals.len() != p.mesh.positions.len()) {
            out.normals.clear();
        }
        (out, keys_out)
    }

    #[test]
    fn stitch_equals_the_vertex_by_vertex_join() {
        let mut h = 0x2545_f491_u32;
        let mut rand = move |n: u32| {
            h ^= h << 13;
            h ^= h >> 17;
            h ^= h << 5;
            h % n
        };
        for trial in 0..200 {
            let mut parts = Vec::new();
            for p in 0..1 + rand(5) {
                let n = rand(40);
                let mut mesh = Mesh::default();
                for v in 0..n {
                    mesh.positions.push([trial as f32, p as f32, v as f32]);
                    mesh.normals.push([v as f32, 0.0, 1.0]);
                }
                if n > 0 {
                    for _ in 0..rand(30) {
                        mesh.triangles.push([rand(n), rand(n), rand(n)]);
                    }
                    for _ in 0..rand(5) {
                        mesh.quads.push([rand(n), rand(n), rand(n), rand(n)]);
                    }
                }
                // Keys from a small pool, so parts (and a part itself) repeat them.
                let mut keys = Vec::new();
                for v in 0..n {
                    if rand(3) == 0 {
                        keys.push((v, VertexKey::Cell { ijk: [rand(12), 0, 0], n: 0 }));
                    }
                }
                parts.push(KeyedMesh { mesh, keys });
            }
            let got = stitch_keyed(&parts).unwrap();
            let (mesh, keys) = by_vertex(&parts);
            assert_eq!(got.mesh, mesh, "trial {trial}");
            assert_eq!(got.keys, keys, "trial {trial}");
        }
    }

    #[test]
    fn stitch_rejects_keys_past_or_out_of_order() {
        let mesh = Mesh { positions: vec![[0.0; 3]; 3], ..Default::default() };
        let key = |x| VertexKey::Cell { ijk: [x, 0, 0], n: 0 };
        let past = KeyedMesh { mesh: mesh.clone(), keys: vec![(3, key(0))] };
        assert!(matches!(stitch_keyed(&[past]), Err(Error::Internal(_))));
        let unordered = KeyedMesh { mesh, keys: vec![(2, key(0)), (1, key(1))] };
        assert!(matches!(stitch_keyed(&[unordered]), Err(Error::Internal(_))));
    }
}
