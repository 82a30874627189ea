//! Marching tetrahedra [Doi91; Treece99]: each cell split into tetrahedra, each tetrahedron cut
//! by at most one triangle or quad. No ambiguity exists in a tetrahedron (the field is linear
//! along its edges and the 16 cases have one triangulation each), so no decider is needed.
//!
//! Three decompositions (seed 003):
//!
//! | decomposition | tetrahedra per cell | extra samples | diagonals |
//! |---|---|---|---|
//! | [`Five`](Decomposition::Five) | 5: four corner tetrahedra and a central one, mirrored on odd cells (i + j + k) so face diagonals match | none | one per face, alternating |
//! | [`Six`](Decomposition::Six) | 6 around the main diagonal 0–7 | none | one per face (low–low to high–high) and the body diagonal |
//! | [`BodyCentred`](Decomposition::BodyCentred) | 4 per face octahedron (two cell centres and the face's four corners), 2 per lattice-boundary face pyramid | one per cell centre | centre–corner and centre–centre segments |
//!
//! Every crossing, on an axis edge, a diagonal or a centre segment, is a walker-cached vertex
//! ([`Cell::segment_vertex`]), so each is created once and the mesh is closed and manifold.

use super::{Counting, Extractor, ProbeCell, Segments};
use crate::cube::CellPoint;
use crate::cube::Diagonals;
use crate::cube::FACE_CORNERS;
use crate::extract::Cell;

/// How a cell is split into tetrahedra.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Decomposition {
    /// Five tetrahedra, alternating with cell parity (`mt5`).
    Five,
    /// Six tetrahedra around the main diagonal (`mt6`).
    Six,
    /// Body-centred: a sample at each cell centre, four tetrahedra per face octahedron (`mt-bcc`).
    BodyCentred,
}

/// Marching tetrahedra with a chosen [`Decomposition`].
///
/// **Guarantees**: closed (when the surface stays inside the lattice), edge- and vertex-manifold,
/// consistently oriented (normals from inside to outside). Topology is that of the piecewise
/// linear interpolant on the tetrahedra, which differs from the trilinear one in ambiguous cells.
///
/// **Limits**: more and thinner triangles than marching cubes (see docs/BENCHMARKS.md).
#[derive(Debug, Clone, Copy)]
pub struct MarchingTetrahedra {
    /// The split.
    pub decomposition: Decomposition,
}

use CellPoint::{Beyond, Centre, Corner};

/// Five tetrahedra for even cells (corners 0, 3, 5, 6 cut off) and odd cells (1, 2, 4, 7).
const FIVE: [[[u8; 4]; 5]; 2] = [
    [[0, 1, 2, 4], [3, 1, 2, 7], [5, 1, 4, 7], [6, 2, 4, 7], [1, 2, 4, 7]],
    [[1, 0, 3, 5], [2, 0, 3, 6], [4, 0, 5, 6], [7, 3, 5, 6], [0, 3, 5, 6]],
];

/// Six tetrahedra 0 → a → b → 7 along the monotone paths of the cube's edges.
const SIX: [[u8; 4]; 6] = [[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]];

impl MarchingTetrahedra {
    /// The face diagonals and main diagonal this split names.
    fn named(&self) -> Segments {
        match self.decomposition {
            Decomposition::Five => Segments { diagonals: Some(Diagonals::OddCorners), main_diagonal: false },
            Decomposition::Six => Segments { diagonals: Some(Diagonals::MinToMax), main_diagonal: true },
            Decomposition::BodyCentred => Segments::default(),
        }
    }
}

/// The triangles of every case and parity of a split on the cell's corners alone (five and six
/// tetrahedra: the signs decide everything), as cell segments: what `process` makes, tabulated
/// once by running it on a probe.
fn corner_tables(d: Decomposition) -> &'static [[Vec<[u8; 3]>; 2]; 256] {
    type Table = [[Vec<[u8; 3]>; 2]; 256];
    static FIVE_TABLE: std::sync::OnceLock<Table> = std::sync::OnceLock::new();
    static SIX_TABLE: std::sync::OnceLock<Table> = std::sync::OnceLock::new();
    let x = MarchingTetrahedra { decomposition: d };
    let build = || -> Table {
        std::array::from_fn(|case| {
            [false, true].map(|odd| {
                let v: [f32; 8] = std::array::from_fn(|c| if case >> c & 1 == 1 { -1.0 } else { 1.0 });
                let mut probe = ProbeCell::new([u32::from(odd), 0, 0], v).naming(x.named());
                x.process(&mut probe);
                debug_assert!(!probe.other_vertices, "{d:?}: the split names a segment it does not declare");
                probe.triangles
            })
        })
    };
    match d {
        Decomposition::Five => FIVE_TABLE.get_or_init(build),
        _ => SIX_TABLE.get_or_init(build),
    }
}

impl Extractor for MarchingTetrahedra {
    fn counting(&self) -> Counting {
        match self.decomposition {
            Decomposition::BodyCentred => Counting::Unknown,
            Decomposition::Five | Decomposition::Six => Counting::Known,
        }
    }

    fn segments(&self) -> Segments {
        self.named()
    }

    #[inline]
    fn case_triangles(&self, case: u8, odd: bool) -> Option<&[[u8; 3]]> {
        match self.decomposition {
            Decomposition::BodyCentred => None,
            d => Some(&corner_tables(d)[case as usize][odd as usize]),
        }
    }

    fn process<C: Cell>(&self, cell: &mut C) {
        match self.decomposition {
            Decomposition::Five => {
                let [i, j, k] = cell.ijk();
                for t in FIVE[((i + j + k) % 2) as usize] {
                    tetrahedron(cell, t.map(Corner));
                }
            }
            Decomposition::Six => {
                for t in SIX {
                    tetrahedron(cell, t.map(Corner));
                }
            }
            Decomposition::BodyCentred => {
                let case = cell.case();
                if case == 0 || case == 255 {
                    // A uniform cell holds a crossing only if its centre or the centre across a
                    // lower face (the octahedra it owns) is of the other class.
                    let inside = case == 255;
                    let other = |v: f32| (v < 0.0) != inside;
                    if !other(cell.point_value(Centre))
                        && (0..3u8).all(|a| !cell.has_neighbour(2 * a) || !other(cell.point_value(Beyond(2 * a))))
                    {
                        return;
                    }
                }
                for f in 0..6u8 {
                    let r = FACE_CORNERS[f as usize].map(Corner);
                    if !cell.has_neighbour(f) {
                        // A face on the lattice's boundary: the pyramid from the centre, split by
                        // a diagonal that no other cell sees.
                        tetrahedron(cell, [Centre, r[0], r[1], r[2]]);
                        tetrahedron(cell, [Centre, r[0], r[2], r[3]]);
                    } else if f % 2 == 0 {
                        // The octahedron around a lower face belongs to this cell; the one around
                        // an upper face to the neighbour.
                        for i in 0..4 {
                            tetrahedron(cell, [Centre, Beyond(f), r[i], r[(i + 1) % 4]]);
                        }
                    }
                }
            }
        }
    }

    fn visits_uniform_cells(&self) -> bool {
        // A cell whose corners agree can still hold a crossing on its centre segments (a field
        // centre of the other class, or the neighbour's centre in an octahedron it owns).
        self.decomposition == Decomposition::BodyCentred
    }
}

/// Even permutations of (0, 1, 2, 3) putting vertex `i` first.
const FIRST: [[usize; 4]; 4] = [[0, 1, 2, 3], [1, 0, 3, 2], [2, 0, 1, 3], [3, 0, 2, 1]];

/// Even permutations putting the pair {p, q} first, indexed by the pair's bit mask.
const PAIR: [[usize; 4]; 16] = {
    let mut t = [[0usize; 4]; 16];
    t[0b0011] = [0, 1, 2, 3];
    t[0b0101] = [0, 2, 3, 1];
    t[0b1001] = [0, 3, 1, 2];
    t[0b0110] = [1, 2, 0, 3];
    t[0b1010] = [1, 3, 2, 0];
    t[0b1100] = [2, 3, 0, 1];
    t
};

/// Triangulates the level set in one tetrahedron, wound counter-clockwise seen from outside.
fn tetrahedron<C: Cell>(cell: &mut C, mut p: [CellPoint; 4]) {
    // Orient positively: det(p1 − p0, p2 − p0, p3 − p0) > 0 (exact in doubled coordinates).
    let q = p.map(|x| x.doubled());
    let e = |i: usize| [0, 1, 2].map(|a| q[i][a] - q[0][a]);
    let (a, b, c) = (e(1), e(2), e(3));
    let det =
        a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0]);
    if det < 0 {
        p.swap(1, 2);
    }
    let mut mask = 0usize;
    for (i, &x) in p.iter().enumerate() {
        if cell.point_value(x) < 0.0 {
            mask |= 1 << i;
        }
    }
    let seg = |cell: &mut C, i: usize, j: usize| cell.segment_vertex(p[i], p[j]);
    match mask.count_ones() {
        1 => {
            // One inside vertex a: the triangle around it faces away from it.
            let [a, b, c, d] = FIRST[mask.trailing_zeros() as usize];
            let t = [seg(cell, a, b), seg(cell, a, c), seg(cell, a, d)];
            cell.push_triangle(t);
        }
        3 => {
            // One outside vertex a: the triangle faces towards it.
            let [a, b, c, d] = FIRST[(!mask & 0xf).trailing_zeros() as usize];
            let t = [seg(cell, a, b), seg(cell, a, d), seg(cell, a, c)];
            cell.push_triangle(t);
        }
        2 => {
            // Inside pair {a, b}: the quad ac, ad, bd, bc, split along ac–bd (inside the tetrahedron).
            let [a, b, c, d] = PAIR[mask];
            let (ac, ad, bd, bc) = (seg(cell, a, c), seg(cell, a, d), seg(cell, b, d), seg(cell, b, c));
            cell.push_triangle([ac, ad, bd]);
            cell.push_triangle([ac, bd, bc]);
        }
        _ => {}
    }
}
