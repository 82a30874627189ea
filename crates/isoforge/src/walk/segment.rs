//! Points and segments off the lattice edges: cell centres, face and body diagonals, segments to
//! neighbouring centres. The tetrahedral extractors and MC33's interior vertices use them; every
//! walker caches them by [`SegmentKey`] exactly as it caches axis edges by [`EdgeKey`].
//!
//! Points are named in *doubled* index coordinates, so a cell centre (i + ½, j + ½, k + ½) is the
//! integer point (2i + 1, 2j + 1, 2k + 1) and a key is exact and hashable.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use super::Hermite;
use crate::extract::cube::{CubeEdge, CORNER_OFFSETS};
use crate::mesh::VertexId;
use crate::volume::{Iso, Volume};

/// A point a cell can name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CellPoint {
    /// Corner `c` of the cube diagram (0–7).
    Corner(u8),
    /// The cell's centre.
    Centre,
    /// The centre of the neighbouring cell across face `f` (`2 · axis + side`, see
    /// [`cube`](crate::extract::cube)); it must exist ([`Cell::has_neighbour`](super::Cell::has_neighbour)).
    Beyond(u8),
}

impl CellPoint {
    /// Offset from the cell's corner 0 in doubled index units.
    #[inline]
    pub const fn doubled(self) -> [i64; 3] {
        match self {
            CellPoint::Corner(c) => {
                let o = CORNER_OFFSETS[c as usize];
                [2 * o[0] as i64, 2 * o[1] as i64, 2 * o[2] as i64]
            }
            CellPoint::Centre => [1, 1, 1],
            CellPoint::Beyond(f) => {
                let mut p = [1, 1, 1];
                p[(f / 2) as usize] += if f % 2 == 0 { -2 } else { 2 };
                p
            }
        }
    }

    /// Offset from the cell's corner 0 in index units (cell coordinates).
    #[inline]
    pub fn local(self) -> [f64; 3] {
        self.doubled().map(|x| x as f64 / 2.0)
    }

    /// The axis edge joining two corners that differ along one axis.
    #[inline]
    pub fn axis_edge(a: CellPoint, b: CellPoint) -> Option<CubeEdge> {
        let (CellPoint::Corner(a), CellPoint::Corner(b)) = (a, b) else { return None };
        let diff = a ^ b;
        if diff.count_ones() != 1 {
            return None;
        }
        let axis = diff.trailing_zeros() as u8;
        let lo = a & b; // the lower corner: the one without the differing bit
                        // r gathers the lower corner's bits on the two other axes, in increasing axis order.
        let others: [u8; 2] = match axis {
            0 => [1, 2],
            1 => [0, 2],
            _ => [0, 1],
        };
        let r = ((lo >> others[0]) & 1) | (((lo >> others[1]) & 1) << 1);
        Some(CubeEdge(4 * axis + r))
    }
}

/// A lattice segment named independently of any cell: its two end points in doubled index
/// coordinates, the lexicographically smaller first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SegmentKey {
    /// The lower end point (doubled index coordinates).
    pub a: [u32; 3],
    /// The upper end point.
    pub b: [u32; 3],
}

impl SegmentKey {
    /// The segment between two points of cell `ijk`; `None` if one of them lies outside the
    /// lattice's index range (a missing neighbour).
    #[inline]
    pub fn of_cell(ijk: [u32; 3], p: CellPoint, q: CellPoint) -> Option<(Self, bool)> {
        let abs = |x: CellPoint| -> Option<[u32; 3]> {
            let d = x.doubled();
            let v = [0, 1, 2].map(|a| 2 * ijk[a] as i64 + d[a]);
            v.iter().all(|&c| (0..=u32::MAX as i64).contains(&c)).then(|| v.map(|c| c as u32))
        };
        let (pa, qa) = (abs(p)?, abs(q)?);
        Some(if pa <= qa { (SegmentKey { a: pa, b: qa }, false) } else { (SegmentKey { a: qa, b: pa }, true) })
    }

    /// The index-space end points.
    #[inline]
    pub fn ends(&self) -> ([f64; 3], [f64; 3]) {
        (self.a.map(|x| x as f64 / 2.0), self.b.map(|x| x as f64 / 2.0))
    }
}

/// The crossing on segment `key` given the offset values at its ends `a` (`d0`) and `b` (`d1`),
/// with its outward normal when `normals` is set. Shared by every walker.
pub fn segment_hermite<V: Volume + ?Sized>(
    vol: &V,
    key: SegmentKey,
    d0: f32,
    d1: f32,
    iso: Iso,
    normals: bool,
) -> Hermite {
    let (p0, p1) = key.ends();
    let t = vol.segment_crossing(p0, p1, d0, d1, iso) as f64;
    let p = [0, 1, 2].map(|a| p0[a] + (p1[a] - p0[a]) * t);
    point_hermite(vol, p, iso, normals, || {
        // Flat field: the segment's world direction, pointing to its outside end.
        let w0 = vol.lattice().to_world(p0);
        let w1 = vol.lattice().to_world(p1);
        let s = if d0 < 0.0 { 1.0 } else { -1.0 };
        [0, 1, 2].map(|a| ((w1[a] - w0[a]) * s) as f32)
    })
}

/// A vertex at index-space point `p` with the volume's outward normal there (or `flat()` where
/// the gradient vanishes).
pub fn point_hermite<V: Volume + ?Sized>(
    vol: &V,
    p: [f64; 3],
    iso: Iso,
    normals: bool,
    flat: impl FnOnce() -> [f32; 3],
) -> Hermite {
    let w = vol.lattice().to_world(p);
    let point = [w[0] as f32, w[1] as f32, w[2] as f32];
    if !normals {
        return Hermite { point, normal: [0.0; 3] };
    }
    let n = (vol.gradient_at(p) * iso.sign()).normalize_or_zero();
    let normal =
        if n == glam::Vec3::ZERO { glam::Vec3::from(flat()).normalize_or_zero().to_array() } else { n.to_array() };
    Hermite { point, normal }
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
    if face % 2 == 0 {
        ijk[a] > 0
    } else {
        ijk[a] + 2 < dims[a]
    }
}

/// An index-space point at cell coordinates `local` of cell `ijk`.
#[inline]
pub(crate) fn cell_point(ijk: [u32; 3], local: [f32; 3]) -> [f64; 3] {
    [0, 1, 2].map(|a| ijk[a] as f64 + local[a] as f64)
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

/// A multiplicative hasher for small integer keys (the default SipHash is several times slower
/// and DoS resistance is not needed for lattice coordinates).
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct KeyHasher(u64);

impl Hasher for KeyHasher {
    #[inline]
    fn finish(&self) -> u64 {
        self.0
    }
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }
    #[inline]
    fn write_u32(&mut self, x: u32) {
        self.write_u64(x as u64);
    }
    #[inline]
    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    #[inline]
    fn write_usize(&mut self, x: usize) {
        self.write_u64(x as u64);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::extract::cube::EDGE_CORNERS;

    #[test]
    fn axis_edges_are_found_from_their_corners() {
        for e in 0..12u8 {
            let [a, b] = EDGE_CORNERS[e as usize];
            assert_eq!(CellPoint::axis_edge(CellPoint::Corner(a), CellPoint::Corner(b)), Some(CubeEdge(e)));
            assert_eq!(CellPoint::axis_edge(CellPoint::Corner(b), CellPoint::Corner(a)), Some(CubeEdge(e)));
        }
        assert_eq!(CellPoint::axis_edge(CellPoint::Corner(0), CellPoint::Corner(3)), None);
        assert_eq!(CellPoint::axis_edge(CellPoint::Corner(0), CellPoint::Centre), None);
    }

    #[test]
    fn segment_keys_are_shared_by_neighbouring_cells() {
        // The x-max face diagonal 1–7 of cell (0,0,0) is the x-min face diagonal 0–6 of (1,0,0).
        let (k0, _) = SegmentKey::of_cell([0, 0, 0], CellPoint::Corner(1), CellPoint::Corner(7)).unwrap();
        let (k1, _) = SegmentKey::of_cell([1, 0, 0], CellPoint::Corner(6), CellPoint::Corner(0)).unwrap();
        assert_eq!(k0, k1);
        // The centre-to-centre segment across a face, seen from both cells.
        let (c0, _) = SegmentKey::of_cell([0, 0, 0], CellPoint::Centre, CellPoint::Beyond(3)).unwrap();
        let (c1, flipped) = SegmentKey::of_cell([0, 1, 0], CellPoint::Beyond(2), CellPoint::Centre).unwrap();
        assert_eq!(c0, c1);
        assert!(!flipped);
        assert!(SegmentKey::of_cell([0, 0, 0], CellPoint::Centre, CellPoint::Beyond(0)).is_none());
    }
}
