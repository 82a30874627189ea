//! Data: the lattice vocabulary — the one cube diagram (corner, edge and face numbering), axes,
//! lattice edges and segments ([`EdgeKey`], [`SegmentKey`], [`CellPoint`]), vertex provenance
//! ([`VertexKey`]) and cell ranges ([`CellRange`]). Walkers and extractors both build on it;
//! it depends on nothing.
//!
//! ```text
//!         [6]────── 3 ──────[7]        [c] corner c sits at (c & 1, (c >> 1) & 1, (c >> 2) & 1)
//!         ╱│                 ╱│         plain numbers are edges; edge e runs along axis e / 4
//!        6 │                7 │         (0 = x, 1 = y, 2 = z) and r = e % 4 places it:
//!       ╱  10              ╱  11          x-edges: y = r & 1, z = r >> 1  (corners 2r, 2r + 1)
//!     [4]────── 2 ──────[5]   │           y-edges: x = r & 1, z = r >> 1
//!      │   │              │   │           z-edges: x = r & 1, y = r >> 1
//!      │  [2]────── 1 ────│──[3]
//!      8  ╱               9  ╱          z
//!      │ 4                │ 5           │  y
//!      │╱                 │╱            │ ╱
//!     [0]────── 0 ──────[1]             │╱___ x
//! ```
//! Faces are numbered `2 · axis + side`: 0 = x-min, 1 = x-max, 2 = y-min, 3 = y-max, 4 = z-min, 5 = z-max.
//!
//! Classification (fixed for the whole project): a corner is *inside* when its value is below iso,
//! ties count as outside, and case bit `c` is set when corner `c` is inside.

/// An axis of the lattice.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Axis {
    /// Along i (x), the fastest-varying index.
    X = 0,
    /// Along j (y).
    Y = 1,
    /// Along k (z), the slowest-varying index.
    Z = 2,
}

impl Axis {
    /// All three axes in order.
    pub const ALL: [Axis; 3] = [Axis::X, Axis::Y, Axis::Z];

    /// The axis as an index 0, 1, 2.
    #[inline]
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The unit step along this axis.
    #[inline]
    pub const fn unit(self) -> [u32; 3] {
        match self {
            Axis::X => [1, 0, 0],
            Axis::Y => [0, 1, 0],
            Axis::Z => [0, 0, 1],
        }
    }
}

/// Offset of each corner from the cell's origin point.
pub const CORNER_OFFSETS: [[u32; 3]; 8] = {
    let mut t = [[0; 3]; 8];
    let mut c = 0;
    while c < 8 {
        t[c] = [(c & 1) as u32, ((c >> 1) & 1) as u32, ((c >> 2) & 1) as u32];
        c += 1;
    }
    t
};

/// The two axes other than `axis`, in increasing order: they place an edge (`r = e % 4`).
const fn other_axes(axis: usize) -> (usize, usize) {
    match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// The two corners of each edge, the one with the smaller coordinate first.
pub const EDGE_CORNERS: [[u8; 2]; 12] = {
    let mut t = [[0u8; 2]; 12];
    let mut e = 0;
    while e < 12 {
        let (axis, r) = (e / 4, e % 4);
        // The two fixed coordinates, in increasing axis order, take the bits of r.
        let (a, b) = other_axes(axis);
        let lo = ((r & 1) << a) | ((r >> 1) << b);
        t[e] = [lo as u8, (lo | (1 << axis)) as u8];
        e += 1;
    }
    t
};

/// One of the twelve edges of a cell, numbered as in the module diagram.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct CubeEdge(pub u8);

impl CubeEdge {
    /// The axis the edge runs along.
    #[inline]
    pub const fn axis(self) -> Axis {
        match self.0 / 4 {
            0 => Axis::X,
            1 => Axis::Y,
            _ => Axis::Z,
        }
    }

    /// The edge's two corners, lower first.
    #[inline]
    pub const fn corners(self) -> [u8; 2] {
        EDGE_CORNERS[self.0 as usize]
    }

    /// Offset of the edge's lower corner from the cell origin.
    #[inline]
    pub const fn origin_offset(self) -> [u32; 3] {
        CORNER_OFFSETS[self.corners()[0] as usize]
    }
}

/// A lattice edge named independently of any cell: its lower point and its axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct EdgeKey {
    /// The edge's lower point.
    pub origin: [u32; 3],
    /// The direction from `origin` to the other point.
    pub axis: Axis,
}

impl EdgeKey {
    /// The edge of `cell` named `e` in the cube numbering.
    #[inline]
    pub fn of_cell(cell: [u32; 3], e: CubeEdge) -> Self {
        let o = e.origin_offset();
        EdgeKey { origin: [cell[0] + o[0], cell[1] + o[1], cell[2] + o[2]], axis: e.axis() }
    }

    /// The cube edge of cell `cell` that is this edge, or `None` if the cell does not touch it
    /// (the inverse of [`of_cell`](EdgeKey::of_cell)).
    #[inline]
    pub fn in_cell(&self, cell: [u32; 3]) -> Option<CubeEdge> {
        let rel = [0, 1, 2].map(|a| self.origin[a] as i64 - cell[a] as i64);
        let axis = self.axis.index();
        if rel[axis] != 0 || rel.iter().any(|&x| !(0..=1).contains(&x)) {
            return None;
        }
        let (u, v) = other_axes(axis);
        Some(CubeEdge((4 * axis + (rel[u] as usize | ((rel[v] as usize) << 1))) as u8))
    }

    /// The edge's upper point.
    #[inline]
    pub fn end(&self) -> [u32; 3] {
        let u = self.axis.unit();
        [self.origin[0] + u[0], self.origin[1] + u[1], self.origin[2] + u[2]]
    }

    /// The index-space point at parameter `t` from `origin` (0) to `end` (1).
    #[inline]
    pub fn point_at(&self, t: f64) -> [f64; 3] {
        // Chosen per axis, not stored at the axis' index: a store at a run-time index followed by
        // the wider load of the whole point stalls store forwarding (15 % of the Flying Edges fill).
        let a = self.axis.index();
        [0, 1, 2].map(|i| if i == a { self.origin[i] as f64 + t } else { self.origin[i] as f64 })
    }
}

/// The corners of each face (`2 · axis + side`) in counter-clockwise order seen from outside the
/// cell. With u = axis + 1 and v = axis + 2 (mod 3), e_u × e_v = e_axis: the max face runs
/// (0,0) (1,0) (1,1) (0,1) in (u, v), the min face the other way round.
pub const FACE_CORNERS: [[u8; 4]; 6] = {
    let mut t = [[0u8; 4]; 6];
    let mut f = 0;
    while f < 6 {
        let (a, side) = (f / 2, f % 2);
        let (u, v) = ((a + 1) % 3, (a + 2) % 3);
        let uv: [(usize, usize); 4] =
            if side == 1 { [(0, 0), (1, 0), (1, 1), (0, 1)] } else { [(0, 0), (0, 1), (1, 1), (1, 0)] };
        let mut i = 0;
        while i < 4 {
            t[f][i] = ((side << a) | (uv[i].0 << u) | (uv[i].1 << v)) as u8;
            i += 1;
        }
        f += 1;
    }
    t
};

/// The edge joining corners `a` and `b` (either order), or `None` unless they differ in exactly
/// one coordinate. The inverse of [`EDGE_CORNERS`].
#[inline]
pub const fn edge_between(a: u8, b: u8) -> Option<CubeEdge> {
    let diff = a ^ b;
    if diff.count_ones() != 1 {
        return None;
    }
    let axis = diff.trailing_zeros() as usize;
    let lo = (a & b) as usize; // the lower corner: the one without the differing bit
    let (p, q) = other_axes(axis);
    Some(CubeEdge((4 * axis + (((lo >> p) & 1) | (((lo >> q) & 1) << 1))) as u8))
}

/// The edges of each face in the order of [`FACE_CORNERS`]: edge `i` joins corners `i` and `i + 1`.
pub const FACE_EDGES: [[u8; 4]; 6] = {
    let mut t = [[0u8; 4]; 6];
    let mut f = 0;
    while f < 6 {
        let mut i = 0;
        while i < 4 {
            t[f][i] = match edge_between(FACE_CORNERS[f][i], FACE_CORNERS[f][(i + 1) % 4]) {
                Some(e) => e.0,
                None => panic!("consecutive face corners share an edge"),
            };
            i += 1;
        }
        f += 1;
    }
    t
};

/// The two faces each edge lies on.
pub const EDGE_FACES: [[u8; 2]; 12] = {
    let mut t = [[0u8; 2]; 12];
    let mut e = 0;
    while e < 12 {
        let [c, _] = EDGE_CORNERS[e];
        let axis = e / 4;
        let mut n = 0;
        let mut a = 0;
        while a < 3 {
            if a != axis {
                t[e][n] = (2 * a + ((c as usize >> a) & 1)) as u8;
                n += 1;
            }
            a += 1;
        }
        e += 1;
    }
    t
};

mod range;
mod segment;

/// How cells' faces are split by diagonals (tetrahedral methods): each lattice face gets one
/// diagonal, the same seen from both cells that share it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Diagonals {
    /// From the face's lowest corner to its highest (six tetrahedra around the main diagonal).
    MinToMax,
    /// Between the two face corners whose lattice coordinates sum to an odd number (five
    /// tetrahedra, mirrored from cell to cell).
    OddCorners,
}

impl Diagonals {
    /// The corners of the diagonal of face `f` in a cell whose corner 0 has an `odd` coordinate
    /// sum, as in [`FACE_CORNERS`]: either its corners 0 and 2 (lowest and highest) or 1 and 3.
    #[inline]
    pub const fn of_face(self, f: u8, odd: bool) -> [u8; 2] {
        let c = FACE_CORNERS[f as usize];
        let low_high = match self {
            Diagonals::MinToMax => true,
            // Corners 0 and 2 of the face have `side + 0` and `side + 2` bits set: their
            // coordinate sums have the parity of `odd + side`.
            Diagonals::OddCorners => odd ^ (f % 2 == 1),
        };
        if low_high {
            [c[0], c[2]]
        } else {
            [c[1], c[3]]
        }
    }
}

/// Segments a cell can name besides its edges, numbered after them: `12 + f` is the diagonal
/// of face `f` (the one [`Diagonals`] picks), [`MAIN_DIAGONAL`] the diagonal from corner 0 to 7.
pub const CELL_SEGMENTS: usize = 19;
/// The cell segment joining corners 0 and 7.
pub const MAIN_DIAGONAL: u8 = 18;

/// The cell segment joining corners `a` and `b` under `diagonals` in a cell of parity `odd`: an
/// edge, the split diagonal of a face, or the main diagonal; `None` for any other pair.
pub const fn cell_segment(a: u8, b: u8, diagonals: Option<Diagonals>, odd: bool) -> Option<u8> {
    if let Some(e) = edge_between(a, b) {
        return Some(e.0);
    }
    if (a == 0 && b == 7) || (a == 7 && b == 0) {
        return Some(MAIN_DIAGONAL);
    }
    let Some(d) = diagonals else { return None };
    let mut f = 0;
    while f < 6 {
        let [p, q] = d.of_face(f, odd);
        if (p == a && q == b) || (p == b && q == a) {
            return Some(12 + f);
        }
        f += 1;
    }
    None
}

pub use range::CellRange;
pub use segment::{CellPoint, SegmentKey, VertexKey};

/// The case index of eight corner values already offset by iso: bit `c` set ⇔ `d[c] < 0`.
#[inline]
pub fn case_of(d: &[f32; 8]) -> u8 {
    let mut case = 0u8;
    for (c, &v) in d.iter().enumerate() {
        case |= ((v < 0.0) as u8) << c;
    }
    case
}

/// Bit mask of the edges whose two corners differ in classification, for each case.
pub const CASE_EDGES: [u16; 256] = {
    let mut t = [0u16; 256];
    let mut case = 0;
    while case < 256 {
        let mut e = 0;
        while e < 12 {
            let [a, b] = EDGE_CORNERS[e];
            if ((case >> a) & 1) != ((case >> b) & 1) {
                t[case] |= 1 << e;
            }
            e += 1;
        }
        case += 1;
    }
    t
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edges_join_neighbouring_corners_along_their_axis() {
        for e in 0..12u8 {
            let edge = CubeEdge(e);
            let [a, b] = edge.corners();
            let (pa, pb) = (CORNER_OFFSETS[a as usize], CORNER_OFFSETS[b as usize]);
            let diff: Vec<i64> = (0..3).map(|i| pb[i] as i64 - pa[i] as i64).collect();
            let mut expect = vec![0; 3];
            expect[edge.axis().index()] = 1;
            assert_eq!(diff, expect, "edge {e}");
        }
        // x-edges join corners 2r and 2r + 1 (the VTK Flying Edges order).
        for r in 0..4u8 {
            assert_eq!(CubeEdge(r).corners(), [2 * r, 2 * r + 1]);
        }
        // All twelve edges are distinct.
        let mut seen: Vec<[u8; 2]> = EDGE_CORNERS.to_vec();
        seen.sort();
        seen.dedup();
        assert_eq!(seen.len(), 12);
    }

    #[test]
    fn faces_run_counter_clockwise_seen_from_outside() {
        for f in 0..6 {
            let c = FACE_CORNERS[f].map(|c| CORNER_OFFSETS[c as usize].map(|x| x as i64));
            let (a, side) = (f / 2, f % 2);
            assert!(c.iter().all(|p| p[a] == side as i64), "face {f}: corners off the face");
            // (c1 − c0) × (c2 − c1) points along the outward normal.
            let (e1, e2) = ([0, 1, 2].map(|i| c[1][i] - c[0][i]), [0, 1, 2].map(|i| c[2][i] - c[1][i]));
            let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
            let mut expect = [0i64; 3];
            expect[a] = if side == 1 { 1 } else { -1 };
            assert_eq!(n, expect, "face {f}");
            for i in 0..4 {
                let e = FACE_EDGES[f][i];
                assert_eq!(Some(CubeEdge(e)), edge_between(FACE_CORNERS[f][i], FACE_CORNERS[f][(i + 1) % 4]));
                assert!(EDGE_FACES[e as usize].contains(&(f as u8)), "face {f}: edge {e} not on it");
            }
        }
    }

    #[test]
    fn edge_keys_and_cube_edges_invert_each_other() {
        let cell = [3, 5, 7];
        for e in 0..12u8 {
            let key = EdgeKey::of_cell(cell, CubeEdge(e));
            assert_eq!(key.in_cell(cell), Some(CubeEdge(e)));
            // The same lattice edge seen from a neighbour that shares it.
            let o = CubeEdge(e).origin_offset();
            let axis = CubeEdge(e).axis().index();
            let mut other = cell;
            for a in 0..3 {
                if a != axis && o[a] == 1 {
                    other[a] += 1;
                }
            }
            let seen = key.in_cell(other).unwrap();
            assert_eq!(EdgeKey::of_cell(other, seen), key);
        }
        assert_eq!(EdgeKey { origin: [0, 0, 0], axis: Axis::X }.in_cell([0, 2, 0]), None);
    }

    #[test]
    fn face_diagonals_agree_between_the_two_cells_of_a_face() {
        for d in [Diagonals::MinToMax, Diagonals::OddCorners] {
            for odd in [false, true] {
                for axis in 0..3u8 {
                    // Face `2a + 1` of a cell is face `2a` of its neighbour along a (parity flips).
                    let [p, q] = d.of_face(2 * axis + 1, odd);
                    let [r, s] = d.of_face(2 * axis, !odd);
                    let shift = |c: u8| c & !(1 << axis);
                    let mut mine = [shift(p), shift(q)];
                    let mut theirs = [r, s];
                    mine.sort();
                    theirs.sort();
                    assert_eq!(mine, theirs, "{d:?} odd {odd} axis {axis}");
                    assert_eq!(cell_segment(p, q, Some(d), odd), Some(12 + 2 * axis + 1));
                }
            }
        }
        // Five tetrahedra: the diagonals join the corners of odd coordinate sum.
        for f in 0..6 {
            for odd in [false, true] {
                let [p, q] = Diagonals::OddCorners.of_face(f, odd);
                assert!(((p.count_ones() + u32::from(odd)) % 2 == 1) && ((q.count_ones() + u32::from(odd)) % 2 == 1));
            }
        }
        assert_eq!(cell_segment(0, 7, None, false), Some(MAIN_DIAGONAL));
        assert_eq!(cell_segment(1, 6, None, false), None);
    }

    #[test]
    fn edge_between_inverts_edge_corners() {
        for e in 0..12u8 {
            let [a, b] = EDGE_CORNERS[e as usize];
            assert_eq!(edge_between(a, b), Some(CubeEdge(e)));
            assert_eq!(edge_between(b, a), Some(CubeEdge(e)));
        }
        assert_eq!(edge_between(0, 3), None);
        assert_eq!(edge_between(0, 7), None);
        assert_eq!(edge_between(5, 5), None);
    }

    #[test]
    fn case_edges_are_symmetric_under_complement() {
        for case in 0..256 {
            assert_eq!(CASE_EDGES[case], CASE_EDGES[255 - case]);
        }
        assert_eq!(CASE_EDGES[1], 0b0001_0001_0001); // corner 0: edges 0, 4, 8
    }
}
