//! Walker-side handling of segments off the lattice edges ([`SegmentKey`], see [`crate::cube`]):
//! crossings and normals on them, centre values, and the two-generation cache every slab walker
//! keeps (the tetrahedral extractors and MC33's interior vertices use them).

use std::collections::HashMap;
use std::hash::BuildHasherDefault;

use crate::math::KeyHasher;

use crate::cube::{CellPoint, SegmentKey, VertexKey};
use crate::mesh::{MeshBuilder, VertexId};
use crate::volume::{Iso, Volume};

/// The world point at index-space `p`, as stored in a mesh.
#[inline]
pub(crate) fn world_point<V: Volume + ?Sized>(vol: &V, p: [f64; 3]) -> [f32; 3] {
    let w = vol.lattice().to_world(p);
    [w[0] as f32, w[1] as f32, w[2] as f32]
}

/// The outward unit normal at index-space point `p` (or `flat()` where the gradient vanishes).
#[inline]
fn point_normal<V: Volume + ?Sized>(vol: &V, p: [f64; 3], iso: Iso, flat: impl FnOnce() -> [f32; 3]) -> [f32; 3] {
    let n = (vol.gradient_at(p) * iso.sign()).normalize_or_zero();
    if n == glam::Vec3::ZERO {
        glam::Vec3::from(flat()).normalize_or_zero().to_array()
    } else {
        n.to_array()
    }
}

/// The index-space point where segment `key` crosses, given the offset values at its ends `a`
/// (`d0`) and `b` (`d1`). Shared by every walker.
#[inline]
pub(crate) fn segment_point<V: Volume + ?Sized>(vol: &V, key: SegmentKey, d0: f32, d1: f32, iso: Iso) -> [f64; 3] {
    point_between(vol, key.ends().into(), d0, d1, iso)
}

/// [`segment_point`] of the segment whose index-space ends ([`SegmentKey::ends`]) are `p0` (offset
/// `d0`) and `p1`: for walkers that know the ends without building the key.
#[inline(always)]
pub(crate) fn point_between<V: Volume + ?Sized>(
    vol: &V,
    [p0, p1]: [[f64; 3]; 2],
    d0: f32,
    d1: f32,
    iso: Iso,
) -> [f64; 3] {
    let t = vol.segment_crossing(p0, p1, d0, d1, iso) as f64;
    [0, 1, 2].map(|a| p0[a] + (p1[a] - p0[a]) * t)
}

/// The outward unit normal at `p` on segment `key` (its end `a` has offset value `d0`): the
/// gradient's, or the segment's direction towards its outside end where the gradient vanishes.
#[inline]
pub(crate) fn segment_normal<V: Volume + ?Sized>(vol: &V, key: SegmentKey, p: [f64; 3], d0: f32, iso: Iso) -> [f32; 3] {
    normal_between(vol, key.ends().into(), p, d0, iso)
}

/// [`segment_normal`] of the segment whose index-space ends are `p0` (offset `d0`) and `p1`.
#[inline]
pub(crate) fn normal_between<V: Volume + ?Sized>(
    vol: &V,
    [p0, p1]: [[f64; 3]; 2],
    p: [f64; 3],
    d0: f32,
    iso: Iso,
) -> [f32; 3] {
    point_normal(vol, p, iso, || {
        let (w0, w1) = (vol.lattice().to_world(p0), vol.lattice().to_world(p1));
        let s = if d0 < 0.0 { 1.0 } else { -1.0 };
        [0, 1, 2].map(|a| ((w1[a] - w0[a]) * s) as f32)
    })
}

/// Creates the vertex at the crossing on segment `key` in `out` (with its normal when `out`
/// stores normals).
pub(crate) fn push_segment_vertex<V: Volume + ?Sized>(
    vol: &V,
    key: SegmentKey,
    d0: f32,
    d1: f32,
    iso: Iso,
    out: &mut MeshBuilder,
) -> VertexId {
    let p = segment_point(vol, key, d0, d1, iso);
    let n = if out.wants_normals() { segment_normal(vol, key, p, d0, iso) } else { [0.0; 3] };
    out.push_vertex(VertexKey::Segment(key), world_point(vol, p), n)
}

/// Creates the `n`-th vertex cell `ijk` places, at cell coordinates `local` (normal from the
/// gradient there when `out` stores normals); returns it with its world position.
pub(crate) fn push_cell_vertex<V: Volume + ?Sized>(
    vol: &V,
    iso: Iso,
    ijk: [u32; 3],
    n: u8,
    local: [f32; 3],
    out: &mut MeshBuilder,
) -> (VertexId, [f32; 3]) {
    let p = [0, 1, 2].map(|a| ijk[a] as f64 + local[a] as f64);
    let normal = if out.wants_normals() { point_normal(vol, p, iso, || [0.0; 3]) } else { [0.0; 3] };
    let w = world_point(vol, p);
    (out.push_vertex(VertexKey::Cell { ijk, n }, w, normal), w)
}

/// The cell at `ijk + offset`, or `None` below index 0.
#[inline]
pub(crate) fn neighbour(ijk: [u32; 3], offset: [i8; 3]) -> Option<[u32; 3]> {
    let c = [0, 1, 2].map(|a| ijk[a] as i64 + offset[a] as i64);
    c.iter().all(|&x| x >= 0 && x <= u32::MAX as i64).then(|| c.map(|x| x as u32))
}

/// The offset value at `p` for cell `ijk` with corner values `d`, centres computed once per cell
/// through `memo` (NaN = not yet computed).
#[inline]
pub(crate) fn point_value<V: Volume + ?Sized>(
    vol: &V,
    iso: Iso,
    ijk: [u32; 3],
    d: &[f32; 8],
    memo: &mut [f32; 7],
    p: CellPoint,
) -> f32 {
    let s = match p {
        CellPoint::Corner(c) => return d[c as usize],
        CellPoint::Centre => 0,
        CellPoint::Beyond(f) => 1 + f as usize,
    };
    if memo[s].is_nan() {
        let l = p.local();
        memo[s] = vol.value_at([0, 1, 2].map(|a| ijk[a] as f64 + l[a]), iso);
    }
    memo[s]
}

/// [`segment_ends`] for a walker's cell: corner values `d`, centres computed through `memo`.
#[inline]
pub(crate) fn cell_segment<V: Volume + ?Sized>(
    vol: &V,
    iso: Iso,
    ijk: [u32; 3],
    d: &[f32; 8],
    memo: &mut [f32; 7],
    (a, b): (CellPoint, CellPoint),
) -> (SegmentKey, f32, f32) {
    segment_ends(ijk, a, b, |p| point_value(vol, iso, ijk, d, memo, p))
}

/// Whether cell `ijk` of a lattice with `dims` points has a neighbour across `face`.
#[inline]
pub(crate) fn has_neighbour(dims: [u32; 3], ijk: [u32; 3], face: u8) -> bool {
    let a = (face / 2) as usize;
    if face.is_multiple_of(2) {
        ijk[a] > 0
    } else {
        ijk[a] + 2 < dims[a]
    }
}

/// Vertex ids of non-axis segments for a walker that advances slab by slab: a segment is only
/// named by cells of two consecutive slabs, so two generations of maps suffice.
#[derive(Debug, Default)]
pub(crate) struct SegmentCache {
    older: HashMap<SegmentKey, VertexId, BuildHasherDefault<KeyHasher>>,
    newer: HashMap<SegmentKey, VertexId, BuildHasherDefault<KeyHasher>>,
}

impl SegmentCache {
    #[inline]
    pub(crate) fn get(&self, k: &SegmentKey) -> Option<VertexId> {
        self.newer.get(k).or_else(|| self.older.get(k)).copied()
    }
    #[inline]
    pub(crate) fn insert(&mut self, k: SegmentKey, id: VertexId) {
        self.newer.insert(k, id);
    }
    /// After a slab of cells: forgets the segments of the slab before it.
    pub(crate) fn advance(&mut self) {
        std::mem::swap(&mut self.older, &mut self.newer);
        self.newer.clear();
    }
    pub(crate) fn clear(&mut self) {
        self.older.clear();
        self.newer.clear();
    }
}

/// The key of segment `a`–`b` of cell `ijk` and the offset values at the key's two ends.
///
/// # Panics
/// When `a` or `b` is the centre of a neighbour that does not exist (an extractor bug: they must
/// check [`Cell::has_neighbour`](super::Cell::has_neighbour)).
#[inline]
pub(crate) fn segment_ends(
    ijk: [u32; 3],
    a: CellPoint,
    b: CellPoint,
    mut value: impl FnMut(CellPoint) -> f32,
) -> (SegmentKey, f32, f32) {
    let (key, flipped) =
        SegmentKey::of_cell(ijk, a, b).expect("extractors name only neighbours that exist (Cell::has_neighbour)");
    let (da, db) = (value(a), value(b));
    if flipped {
        (key, db, da)
    } else {
        (key, da, db)
    }
}
