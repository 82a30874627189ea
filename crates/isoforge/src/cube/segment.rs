//! Points and segments off the lattice edges (cell centres, face and body diagonals, segments to
//! neighbouring centres) and the provenance of mesh vertices.
//!
//! Points are named in *doubled* index coordinates, so a cell centre (i + ½, j + ½, k + ½) is the
//! integer point (2i + 1, 2j + 1, 2k + 1) and every key is exact and hashable.

use super::{edge_between, Axis, CubeEdge, EdgeKey, CORNER_OFFSETS};

/// A point a cell can name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CellPoint {
    /// Corner `c` of the cube diagram (0–7).
    Corner(u8),
    /// The cell's centre.
    Centre,
    /// The centre of the neighbouring cell across face `f` (`2 · axis + side`); it must exist
    /// (see `Cell::has_neighbour`).
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
        match (a, b) {
            (CellPoint::Corner(a), CellPoint::Corner(b)) => edge_between(a, b),
            _ => None,
        }
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
    /// The segment between two points of cell `ijk`, and whether `p` is the key's upper end;
    /// `None` if one of them lies outside the index range (a missing neighbour).
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

/// Where a mesh vertex comes from: the lattice edge or segment whose crossing it is, or the cell
/// that placed it. Every walker records the same key for the same vertex, so meshes of chunks
/// (cell ranges) are stitched by key, never by comparing coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum VertexKey {
    /// The crossing on a lattice edge (shared by the up to four cells around it).
    Edge(EdgeKey),
    /// The crossing on a segment off the lattice edges (diagonals, centre segments).
    Segment(SegmentKey),
    /// The `n`-th vertex a cell placed inside itself (cell-private: MC33 centroids, dual vertices).
    Cell {
        /// The cell's lattice index (its corner 0).
        ijk: [u32; 3],
        /// The vertex's number within the cell, in the order the extractor placed them.
        n: u8,
    },
}

impl VertexKey {
    /// The box the vertex's edge, segment or cell spans, in doubled index coordinates
    /// (lowest, highest corner): what decides which cell ranges can share the vertex.
    #[inline]
    pub fn extent2(&self) -> ([u32; 3], [u32; 3]) {
        match self {
            VertexKey::Edge(e) => (e.origin.map(|x| 2 * x), e.end().map(|x| 2 * x)),
            VertexKey::Segment(s) => ([0, 1, 2].map(|a| s.a[a].min(s.b[a])), [0, 1, 2].map(|a| s.a[a].max(s.b[a]))),
            VertexKey::Cell { ijk, .. } => (ijk.map(|x| 2 * x), ijk.map(|x| 2 * x + 2)),
        }
    }

    /// Words in a key's integer form ([`to_words`](VertexKey::to_words)).
    pub const WORDS: usize = 7;

    /// The key as plain integers, to send it between processes (Python's distributed
    /// extraction): `[0, origin x, y, z, axis, 0, 0]` for an edge, `[1, a x, y, z, b x, y, z]` for
    /// a segment, `[2, i, j, k, n, 0, 0]` for a cell's vertex. [`from_words`](VertexKey::from_words)
    /// reads it back.
    pub fn to_words(&self) -> [u32; Self::WORDS] {
        match *self {
            VertexKey::Edge(e) => [0, e.origin[0], e.origin[1], e.origin[2], e.axis as u32, 0, 0],
            VertexKey::Segment(s) => [1, s.a[0], s.a[1], s.a[2], s.b[0], s.b[1], s.b[2]],
            VertexKey::Cell { ijk, n } => [2, ijk[0], ijk[1], ijk[2], u32::from(n), 0, 0],
        }
    }

    /// The key whose integer form is `w`; `None` for words no key has (an unknown tag, an axis
    /// past 2, a cell vertex number past 255, unused words not 0).
    pub fn from_words(w: [u32; Self::WORDS]) -> Option<Self> {
        let [tag, p, q, r, s, t, u] = w;
        match tag {
            0 if s < 3 && t == 0 && u == 0 => {
                Some(VertexKey::Edge(EdgeKey { origin: [p, q, r], axis: [Axis::X, Axis::Y, Axis::Z][s as usize] }))
            }
            1 => Some(VertexKey::Segment(SegmentKey { a: [p, q, r], b: [s, t, u] })),
            2 if t == 0 && u == 0 => Some(VertexKey::Cell { ijk: [p, q, r], n: u8::try_from(s).ok()? }),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cube::EDGE_CORNERS;

    #[test]
    fn keys_round_trip_through_words() {
        let keys = [
            VertexKey::Edge(EdgeKey { origin: [3, u32::MAX, 0], axis: Axis::Z }),
            VertexKey::Edge(EdgeKey { origin: [0, 0, 7], axis: Axis::X }),
            VertexKey::Segment(SegmentKey { a: [1, 2, 3], b: [4, 5, u32::MAX] }),
            VertexKey::Cell { ijk: [9, 8, 7], n: 255 },
        ];
        for k in keys {
            assert_eq!(VertexKey::from_words(k.to_words()), Some(k));
        }
        assert_eq!(VertexKey::from_words([0, 1, 2, 3, 3, 0, 0]), None);
        assert_eq!(VertexKey::from_words([2, 1, 2, 3, 256, 0, 0]), None);
        assert_eq!(VertexKey::from_words([3, 0, 0, 0, 0, 0, 0]), None);
        assert_eq!(VertexKey::from_words([0, 1, 2, 3, 1, 0, 9]), None);
    }

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
