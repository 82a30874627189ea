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
//! | [`BodyCentredTetrahedra`] | 4 per face octahedron (two cell centres and the face's four corners), 2 per lattice-boundary face pyramid | one per cell centre | centre–corner and centre–centre segments |
//!
//! Every crossing, on an axis edge, a diagonal or a centre segment, is a walker-cached vertex
//! ([`Cell::segment_vertex`]), so each is created once and the mesh is closed and manifold.

use super::{Counting, Extractor, ProbeCell, Segments};
use crate::cube::CellPoint;
use crate::cube::CubeEdge;
use crate::cube::Diagonals;
use crate::cube::FACE_CORNERS;
use crate::extract::{Cell, Hermite, Placed};
use crate::mesh::VertexId;

/// How a cell is split into tetrahedra on its own corners (the body-centred split, which adds
/// cell centres, is its own extractor: [`BodyCentredTetrahedra`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Decomposition {
    /// Five tetrahedra, alternating with cell parity (`mt5`).
    Five,
    /// Six tetrahedra around the main diagonal (`mt6`).
    Six,
}

/// Marching tetrahedra with a chosen [`Decomposition`] of each cell on its corners.
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

/// Marching tetrahedra on the body-centred lattice (`mt-bcc`): a sample at each cell centre, four
/// tetrahedra per face octahedron (the two centres beside a face and its four corners), two per
/// pyramid on a face on the lattice's boundary.
///
/// **Guarantees**: as [`MarchingTetrahedra`]'s. Its output is not counted from the case (the
/// centres decide), so walkers either walk it cell by cell on keyed meshes, or, where the volume
/// gives its centres from its samples, count and fill its solids themselves from
/// [`BodyCentredTables`] ([`Extractor::body_centred`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct BodyCentredTetrahedra;

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
        Decomposition::Six => SIX_TABLE.get_or_init(build),
    }
}

impl Extractor for MarchingTetrahedra {
    const COUNTING: Counting = Counting::Known;

    fn segments(&self) -> Segments {
        self.named()
    }

    #[inline]
    fn case_triangles(&self, case: u8, odd: bool) -> Option<&[[u8; 3]]> {
        Some(&corner_tables(self.decomposition)[case as usize][odd as usize])
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
        }
    }
}

impl Extractor for BodyCentredTetrahedra {
    fn process<C: Cell>(&self, cell: &mut C) {
        body_centred(cell)
    }

    fn body_centred(&self) -> Option<&'static BodyCentredTables> {
        Some(BodyCentredTables::get())
    }

    fn visits_uniform_cells(&self) -> bool {
        // A cell whose corners agree can still hold a crossing on its centre segments (a field
        // centre of the other class, or the neighbour's centre in an octahedron it owns).
        true
    }
}

/// The body-centred split of one cell: the octahedra around its lower faces (each from the cell's
/// centre to the centre across the face, cut into four tetrahedra around that segment) and the
/// pyramids on its faces on the lattice's boundary (cut into two tetrahedra by a diagonal no other
/// cell sees). Each solid's triangles come from a table of its points' signs ([`bcc_tables`]):
/// the same vertices, in the same order, as running [`tetrahedron`] on its tetrahedra in turn.
#[inline]
fn body_centred<C: Cell>(cell: &mut C) {
    let case = cell.case();
    let centre = cell.point_value(Centre) < 0.0;
    if case == 0 || case == 255 {
        // A uniform cell holds a crossing only if its centre or the centre across a lower face
        // (the octahedra it owns) is of the other class.
        let inside = case == 255;
        let other = |v: f32| (v < 0.0) != inside;
        if centre == inside && (0..3u8).all(|a| !cell.has_neighbour(2 * a) || !other(cell.point_value(Beyond(2 * a)))) {
            return;
        }
    }
    let tables = bcc_tables();
    for f in 0..6u8 {
        let corners = FACE_CASE[f as usize][case as usize] as usize;
        if !cell.has_neighbour(f) {
            let pattern = usize::from(centre) | corners << 1;
            solid(cell, &tables.pyramids[f as usize][pattern]);
        } else if f % 2 == 0 {
            let beyond = cell.point_value(Beyond(f)) < 0.0;
            let pattern = usize::from(centre) | usize::from(beyond) << 1 | corners << 2;
            solid(cell, &tables.octahedra[(f / 2) as usize][pattern]);
        }
    }
}

/// The points of the octahedron around lower face `f`: the centre, the centre across `f`, the
/// face's corners in [`FACE_CORNERS`] order.
fn octahedron_points(f: u8) -> [CellPoint; 6] {
    let r = FACE_CORNERS[f as usize].map(Corner);
    [Centre, Beyond(f), r[0], r[1], r[2], r[3]]
}

/// The points of the pyramid on boundary face `f`: the centre, the face's corners.
fn pyramid_points(f: u8) -> [CellPoint; 5] {
    let r = FACE_CORNERS[f as usize].map(Corner);
    [Centre, r[0], r[1], r[2], r[3]]
}

/// The tetrahedra of the octahedron around lower face `f` (`f` even) or of the pyramid on
/// boundary face `f`, in the order the split visits them.
fn solid_tetrahedra(f: u8, octahedron: bool) -> Vec<[CellPoint; 4]> {
    let r = FACE_CORNERS[f as usize].map(Corner);
    if octahedron {
        (0..4).map(|i| [Centre, Beyond(f), r[i], r[(i + 1) % 4]]).collect()
    } else {
        vec![[Centre, r[0], r[1], r[2]], [Centre, r[0], r[2], r[3]]]
    }
}

/// For each face and case, the face's corners' signs as bits in [`FACE_CORNERS`] order.
const FACE_CASE: [[u8; 256]; 6] = {
    let mut t = [[0u8; 256]; 6];
    let mut f = 0;
    while f < 6 {
        let mut case = 0;
        while case < 256 {
            let mut i = 0;
            while i < 4 {
                t[f][case] |= (((case >> FACE_CORNERS[f][i]) & 1) << i) as u8;
                i += 1;
            }
            case += 1;
        }
        f += 1;
    }
    t
};

/// What [`tetrahedron`] makes in one solid for one sign pattern of its points.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct SolidCase {
    /// The solid's points (unused entries repeat the last).
    points: [CellPoint; 6],
    /// The crossed segments, as pairs of points, in the order `tetrahedron` first names them.
    segments: [[u8; 2]; 12],
    segment_count: u8,
    /// The triangles, as indices into `segments`, in the order `tetrahedron` pushes them.
    triangles: [[u8; 3]; 8],
    triangle_count: u8,
}

/// The triangles of the octahedra (by lower face axis, then the 6-bit sign pattern: centre,
/// centre beyond, the face's corners) and of the boundary pyramids (by face, then the 5-bit
/// pattern: centre, corners).
struct BccTables {
    octahedra: [[SolidCase; 64]; 3],
    pyramids: [[SolidCase; 32]; 6],
}

/// The body-centred tables, built once by running [`tetrahedron`] on a probe per solid and pattern.
fn bcc_tables() -> &'static BccTables {
    static TABLES: std::sync::OnceLock<BccTables> = std::sync::OnceLock::new();
    TABLES.get_or_init(|| BccTables {
        octahedra: std::array::from_fn(|a| {
            let f = 2 * a as u8;
            std::array::from_fn(|pattern| SolidProbe::run(&octahedron_points(f), &solid_tetrahedra(f, true), pattern))
        }),
        pyramids: std::array::from_fn(|f| {
            let f = f as u8;
            std::array::from_fn(|pattern| SolidProbe::run(&pyramid_points(f), &solid_tetrahedra(f, false), pattern))
        }),
    })
}

/// Number of the segments a body-centred cell's solids can cross, as the counted walk numbers
/// them ([`BodyCentredTables`]):
///
/// ```text
///   0–11   the cell's edges (CubeEdge)
///   12–19  centre → corner c                                  (12 + c)
///   20–31  centre across lower face 2a → corner c of that face (20 + 4a + q: q = c without bit a)
///   32–34  centre → centre across lower face 2a               (32 + a)
///   35–40  diagonal FACE_CORNERS[f][0]–[2] of boundary face f  (35 + f)
/// ```
pub(crate) const BCC_SEGMENTS: usize = 41;

/// The two points of body-centred segment `s` (see [`BCC_SEGMENTS`]).
pub(crate) fn bcc_segment_points(s: u8) -> [CellPoint; 2] {
    match s {
        0..=11 => crate::cube::EDGE_CORNERS[s as usize].map(Corner),
        12..=19 => [Centre, Corner(s - 12)],
        20..=31 => {
            let (a, q) = ((s - 20) / 4, (s - 20) % 4);
            // Insert a zero bit at position a into q.
            let low = q & ((1 << a) - 1);
            let c = low | (q >> a) << (a + 1);
            [Beyond(2 * a), Corner(c)]
        }
        32..=34 => [Centre, Beyond(2 * (s - 32))],
        _ => {
            let f = FACE_CORNERS[(s - 35) as usize];
            [Corner(f[0]), Corner(f[2])]
        }
    }
}

/// The body-centred segment joining `p` and `q` (either order).
fn bcc_segment_of(p: CellPoint, q: CellPoint) -> u8 {
    (0..BCC_SEGMENTS as u8)
        .find(|&s| {
            let [a, b] = bcc_segment_points(s);
            [a, b] == [p, q] || [b, a] == [p, q]
        })
        .expect("a body-centred solid names only numbered segments")
}

/// One solid (octahedron or boundary pyramid) for one sign pattern, in `BCC_SEGMENTS` numbers:
/// its crossed segments in the order the split first names them, and its triangles on them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BccSolid {
    pub(crate) segments: [u8; 12],
    pub(crate) segment_count: u8,
    pub(crate) triangles: [[u8; 3]; 8],
    pub(crate) triangle_count: u8,
}

/// The body-centred split tabulated for walkers that count (the Flying Edges walker's counted
/// path): per solid and sign pattern the triangles on numbered segments (`BCC_SEGMENTS`), and
/// the triangle count of every cell away from the lattice's boundary.
#[derive(Debug)]
pub struct BodyCentredTables {
    /// By lower face axis, then pattern: bit 0 centre, 1 centre beyond, 2–5 the face's corners
    /// in [`FACE_CORNERS`] order.
    pub(crate) octahedra: [[BccSolid; 64]; 3],
    /// By face, then pattern: bit 0 centre, 1–4 the face's corners.
    pub(crate) pyramids: [[BccSolid; 32]; 6],
    /// Triangles of a cell with all six neighbours, by `case | centre << 8 | beyond x, y, z << 9..`.
    pub(crate) interior: [u8; 4096],
    /// For each face and case, the face's corners' signs as bits in [`FACE_CORNERS`] order.
    pub(crate) face_case: [[u8; 256]; 6],
}

impl BodyCentredTables {
    /// The pattern (index into `octahedra[a]`) of the octahedron around the lower face on axis
    /// `a` of a cell whose index is `x` (as `interior`'s: case, centre, centres beyond).
    #[inline]
    pub(crate) fn octahedron_pattern(x: usize, a: usize) -> usize {
        (x >> 8 & 1) | (x >> (9 + a) & 1) << 1 | (FACE_CASE[2 * a][x & 0xff] as usize) << 2
    }

    /// The tables, built once from [`bcc_tables`].
    pub(crate) fn get() -> &'static Self {
        static TABLES: std::sync::OnceLock<BodyCentredTables> = std::sync::OnceLock::new();
        TABLES.get_or_init(|| {
            let t = bcc_tables();
            let convert = |s: &SolidCase| {
                let mut segments = [0u8; 12];
                for (o, &[p, q]) in segments.iter_mut().zip(&s.segments[..s.segment_count as usize]) {
                    *o = bcc_segment_of(s.points[p as usize], s.points[q as usize]);
                }
                BccSolid {
                    segments,
                    segment_count: s.segment_count,
                    triangles: s.triangles,
                    triangle_count: s.triangle_count,
                }
            };
            let octahedra = std::array::from_fn(|a| std::array::from_fn(|p| convert(&t.octahedra[a][p])));
            let pyramids = std::array::from_fn(|f| std::array::from_fn(|p| convert(&t.pyramids[f][p])));
            let interior = std::array::from_fn(|x| {
                (0..3).map(|a| t.octahedra[a][Self::octahedron_pattern(x, a)].triangle_count).sum()
            });
            BodyCentredTables { octahedra, pyramids, interior, face_case: FACE_CASE }
        })
    }
}

/// Emits one solid's tabulated triangles through `cell`.
#[inline]
fn solid<C: Cell>(cell: &mut C, t: &SolidCase) {
    if t.triangle_count == 0 {
        return;
    }
    let mut ids = [VertexId::NONE; 12];
    for (id, &[p, q]) in ids.iter_mut().zip(&t.segments[..t.segment_count as usize]) {
        *id = cell.segment_vertex(t.points[p as usize], t.points[q as usize]);
    }
    for tri in &t.triangles[..t.triangle_count as usize] {
        cell.push_triangle(tri.map(|s| ids[s as usize]));
    }
}

/// A cell that records what [`tetrahedron`] does on a solid's points with given signs.
struct SolidProbe {
    case: SolidCase,
    pattern: usize,
}

impl SolidProbe {
    /// Runs `tetrahedra` (on `points`, whose bit `i` in `pattern` says point `i` is inside).
    fn run(points: &[CellPoint], tetrahedra: &[[CellPoint; 4]], pattern: usize) -> SolidCase {
        let mut padded = [points[points.len() - 1]; 6];
        padded[..points.len()].copy_from_slice(points);
        let case = SolidCase {
            points: padded,
            segments: [[0; 2]; 12],
            segment_count: 0,
            triangles: [[0; 3]; 8],
            triangle_count: 0,
        };
        let mut probe = SolidProbe { case, pattern };
        for &t in tetrahedra {
            tetrahedron(&mut probe, t);
        }
        probe.case
    }

    fn index(&self, p: CellPoint) -> u8 {
        self.case.points.iter().position(|&q| q == p).expect("a solid's tetrahedra use its points") as u8
    }
}

impl Cell for SolidProbe {
    fn ijk(&self) -> [u32; 3] {
        [1; 3]
    }
    fn values(&self) -> &[f32; 8] {
        unreachable!("tetrahedra ask for point values")
    }
    fn case(&self) -> u8 {
        unreachable!("tetrahedra ask for point values")
    }
    fn hermite(&mut self, _e: CubeEdge) -> Hermite {
        unreachable!("tetrahedra need no Hermite data")
    }
    fn crossing(&mut self, _e: CubeEdge) -> [f32; 3] {
        unreachable!("tetrahedra name segments")
    }
    fn edge_vertex(&mut self, _e: CubeEdge) -> VertexId {
        unreachable!("tetrahedra name segments")
    }
    fn has_neighbour(&self, _face: u8) -> bool {
        true
    }
    fn point_value(&mut self, p: CellPoint) -> f32 {
        if self.pattern >> self.index(p) & 1 == 1 {
            -1.0
        } else {
            1.0
        }
    }
    fn segment_vertex(&mut self, a: CellPoint, b: CellPoint) -> VertexId {
        let (a, b) = (self.index(a), self.index(b));
        let c = &mut self.case;
        let known =
            c.segments[..c.segment_count as usize].iter().position(|&[p, q]| [p, q] == [a, b] || [q, p] == [a, b]);
        VertexId(known.unwrap_or_else(|| {
            c.segments[c.segment_count as usize] = [a, b];
            c.segment_count += 1;
            c.segment_count as usize - 1
        }) as u32)
    }
    fn place_vertex(&mut self, _local: [f32; 3], _edges: u16) -> VertexId {
        unreachable!("tetrahedra place no vertex")
    }
    fn placed(&mut self, _offset: [i8; 3], _e: CubeEdge) -> Option<Placed> {
        unreachable!("tetrahedra place no vertex")
    }
    fn push_triangle(&mut self, t: [VertexId; 3]) {
        let c = &mut self.case;
        c.triangles[c.triangle_count as usize] = t.map(|v| v.0 as u8);
        c.triangle_count += 1;
    }
    fn push_quad(&mut self, _q: [VertexId; 4]) {
        unreachable!("tetrahedra make triangles")
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// A cell with given signs at its corners, centre and the centres across its faces, that
    /// records the vertices in the order they are first named (by lattice segment) and the
    /// triangles on them.
    struct Recorder {
        /// Bit per point: corners 0–7, centre 8, beyond faces 9–14.
        signs: u16,
        neighbours: u8,
        case: u8,
        values: [f32; 8],
        vertices: HashMap<([i64; 3], [i64; 3]), u32>,
        order: Vec<([i64; 3], [i64; 3])>,
        triangles: Vec<[u32; 3]>,
    }

    impl Recorder {
        fn new(signs: u16, neighbours: u8) -> Self {
            let values = std::array::from_fn(|c| if signs >> c & 1 == 1 { -1.0 } else { 1.0 });
            Recorder {
                signs,
                neighbours,
                case: (signs & 0xff) as u8,
                values,
                vertices: HashMap::new(),
                order: Vec::new(),
                triangles: Vec::new(),
            }
        }
    }

    impl Cell for Recorder {
        fn ijk(&self) -> [u32; 3] {
            [1; 3]
        }
        fn values(&self) -> &[f32; 8] {
            &self.values
        }
        fn case(&self) -> u8 {
            self.case
        }
        fn hermite(&mut self, _e: CubeEdge) -> Hermite {
            unreachable!()
        }
        fn crossing(&mut self, _e: CubeEdge) -> [f32; 3] {
            unreachable!()
        }
        fn edge_vertex(&mut self, e: CubeEdge) -> VertexId {
            let [a, b] = e.corners();
            self.segment_vertex(Corner(a), Corner(b))
        }
        fn has_neighbour(&self, face: u8) -> bool {
            self.neighbours >> face & 1 == 1
        }
        fn point_value(&mut self, p: CellPoint) -> f32 {
            let bit = match p {
                Corner(c) => c,
                Centre => 8,
                Beyond(f) => {
                    assert!(self.has_neighbour(f), "asked for a missing neighbour's centre");
                    9 + f
                }
            };
            if self.signs >> bit & 1 == 1 {
                -1.0
            } else {
                1.0
            }
        }
        fn segment_vertex(&mut self, a: CellPoint, b: CellPoint) -> VertexId {
            let (a, b) = (a.doubled(), b.doubled());
            let key = if a <= b { (a, b) } else { (b, a) };
            let n = self.order.len() as u32;
            let id = *self.vertices.entry(key).or_insert(n);
            if id == n {
                self.order.push(key);
            }
            VertexId(id)
        }
        fn place_vertex(&mut self, _local: [f32; 3], _edges: u16) -> VertexId {
            unreachable!()
        }
        fn placed(&mut self, _offset: [i8; 3], _e: CubeEdge) -> Option<Placed> {
            unreachable!()
        }
        fn push_triangle(&mut self, t: [VertexId; 3]) {
            self.triangles.push(t.map(|v| v.0));
        }
        fn push_quad(&mut self, _q: [VertexId; 4]) {
            unreachable!()
        }
    }

    /// The body-centred split tetrahedron by tetrahedron, as it ran before the tables.
    fn by_tetrahedra<C: Cell>(cell: &mut C) {
        let case = cell.case();
        if case == 0 || case == 255 {
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
                tetrahedron(cell, [Centre, r[0], r[1], r[2]]);
                tetrahedron(cell, [Centre, r[0], r[2], r[3]]);
            } else if f % 2 == 0 {
                for i in 0..4 {
                    tetrahedron(cell, [Centre, Beyond(f), r[i], r[(i + 1) % 4]]);
                }
            }
        }
    }

    #[test]
    fn tabulated_body_centred_split_equals_tetrahedra() {
        // Every sign of the corners, the centre and the lower neighbours' centres (each octahedron
        // sees all 64 patterns of its points), under several sets of existing neighbours (each
        // pyramid sees all 32 of its patterns).
        let mut triangles = 0;
        for signs in 0..1u16 << 12 {
            for neighbours in [0b11_1111, 0b00_0000, 0b10_1010, 0b01_0101, 0b11_0110, 0b01_1011] {
                // The upper neighbours' centres (bits 10, 12, 14) are never read.
                let signs = (signs & 0x1ff) | (signs >> 9 & 1) << 9 | (signs >> 10 & 1) << 11 | (signs >> 11 & 1) << 13;
                let (mut table, mut reference) = (Recorder::new(signs, neighbours), Recorder::new(signs, neighbours));
                body_centred(&mut table);
                by_tetrahedra(&mut reference);
                assert_eq!(table.order, reference.order, "vertex order, signs {signs:#b}, neighbours {neighbours:#b}");
                assert_eq!(table.triangles, reference.triangles, "signs {signs:#b}, neighbours {neighbours:#b}");
                triangles += table.triangles.len();
            }
        }
        assert!(triangles > 0);
    }

    /// The body-centred split as the counted walk applies it: per face, the solid's table entry in
    /// numbered segments (`BodyCentredTables`), each segment resolved to its two points.
    fn by_numbered_tables(cell: &mut Recorder) -> usize {
        let t = BodyCentredTables::get();
        let case = cell.case();
        let centre = usize::from(cell.point_value(Centre) < 0.0);
        let mut interior = 0;
        for f in 0..6u8 {
            let corners = t.face_case[f as usize][case as usize] as usize;
            let solid = if !cell.has_neighbour(f) {
                &t.pyramids[f as usize][centre | corners << 1]
            } else if f % 2 == 0 {
                let beyond = usize::from(cell.point_value(Beyond(f)) < 0.0);
                interior |= beyond << (9 + f / 2);
                &t.octahedra[(f / 2) as usize][centre | beyond << 1 | corners << 2]
            } else {
                continue;
            };
            let ids: Vec<VertexId> = solid.segments[..solid.segment_count as usize]
                .iter()
                .map(|&s| {
                    let [p, q] = bcc_segment_points(s);
                    cell.segment_vertex(p, q)
                })
                .collect();
            for tri in &solid.triangles[..solid.triangle_count as usize] {
                cell.push_triangle(tri.map(|s| ids[s as usize]));
            }
        }
        case as usize | centre << 8 | interior
    }

    #[test]
    fn numbered_body_centred_tables_equal_the_split() {
        let t = BodyCentredTables::get();
        let mut triangles = 0;
        for signs in 0..1u16 << 12 {
            for neighbours in [0b11_1111, 0b00_0000, 0b10_1010, 0b01_0101, 0b11_0110, 0b01_1011] {
                let signs = (signs & 0x1ff) | (signs >> 9 & 1) << 9 | (signs >> 10 & 1) << 11 | (signs >> 11 & 1) << 13;
                let (mut table, mut reference) = (Recorder::new(signs, neighbours), Recorder::new(signs, neighbours));
                let index = by_numbered_tables(&mut table);
                by_tetrahedra(&mut reference);
                assert_eq!(table.order, reference.order, "vertex order, signs {signs:#b}, neighbours {neighbours:#b}");
                assert_eq!(table.triangles, reference.triangles, "signs {signs:#b}, neighbours {neighbours:#b}");
                if neighbours == 0b11_1111 {
                    assert_eq!(t.interior[index] as usize, table.triangles.len(), "interior count {index:#x}");
                }
                triangles += table.triangles.len();
            }
        }
        assert!(triangles > 0);
        // Every numbered segment names two distinct points, and no two name the same pair.
        let mut seen = std::collections::HashSet::new();
        for s in 0..BCC_SEGMENTS as u8 {
            let [p, q] = bcc_segment_points(s);
            assert_ne!(p, q);
            assert!(seen.insert((p.doubled().min(q.doubled()), p.doubled().max(q.doubled()))), "segment {s}");
        }
    }

    #[test]
    fn octahedron_tables_cover_every_pattern() {
        let t = bcc_tables();
        for a in 0..3 {
            for pattern in 0..64 {
                let n = t.octahedra[a][pattern].triangle_count;
                // Uniform octahedra are empty; any other cuts at least one of its 4 tetrahedra.
                assert_eq!(n == 0, pattern == 0 || pattern == 63, "axis {a}, pattern {pattern:#b}");
            }
        }
        for f in 0..6 {
            for pattern in 0..32 {
                assert_eq!(t.pyramids[f][pattern].triangle_count == 0, pattern == 0 || pattern == 31);
            }
        }
    }
}
