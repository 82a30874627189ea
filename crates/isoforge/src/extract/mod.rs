//! ③ Extractor: turns one [`Cell`] at a time into polygons.
//!
//! In: a cell (corner values, case, access to shared vertices). Out: triangles or quads pushed
//! through the cell. Numbering and tables live in [`crate::cube`].
//!
//! | extractor | output | manifold | closed when the surface stays inside the lattice | topology of the trilinear interpolant | sharp features |
//! |---|---|---|---|---|---|
//! | [`MarchingCubes`] \[Lorensen87\] | triangles | yes (edge and vertex) | yes | no (fixed choice on ambiguous faces) | no |
//! | [`MarchingCubes33`] \[Chernyaev95\] | triangles | yes | yes | yes | no |
//! | [`MarchingTetrahedra`] \[Doi91\] | triangles | yes | yes | of the tetrahedral split | no |
//! | [`SurfaceNets`] \[Gibson98\] | quads | no (dual: non-manifold where a cell holds two sheets) | yes | no | no |
//! | [`DualContouring`] \[Ju02\] | triangles (quads on request) | no (surface nets' connectivity) | yes | no | yes: corners and creases whose planes meet inside the cell |
//! | [`AdaptiveDualContouring`] \[Ju02\] §4 (a whole volume, not per cell) | triangles (quads and triangles on request) | no | yes (crack-free across levels) | no; the uniform dc's components and genus kept by the sign tests | as dual contouring, merged vertices within the error bound of their planes |
//! | [`Masked`] | as the inner extractor, open at the mask's edge | | | | |
//! | [`contour_octree`] \[Ju02\] (a [`SignedOctree`](crate::grid::SignedOctree)'s stored vertices) | quads | no (one vertex per cell) | yes, when the tree's signs agree | no | as the stored vertices |
//!
//! How walkers run extractors: [`place`](Extractor::place) (dual methods' own vertices) for every
//! cell that needs it, then [`process`](Extractor::process) for every cell with a crossing. A
//! walker that allocates before it fills (count → prefix sums → fill, the Flying Edges walker's
//! fast path) asks [`case_triangles`](Extractor::case_triangles) (a table it applies itself) or
//! [`counts`](Extractor::counts) first, then hands each counted cell's [`Decision`] back to
//! [`process_decided`](Extractor::process_decided); extractors that cannot tell their output
//! before making it run on per-slab meshes stitched by vertex key instead.

pub mod adaptive;
mod cell;
pub mod dual_contouring;
pub mod extended;
mod fans;
pub mod marching_cubes;
pub mod masked;
pub mod mc33;
pub mod octree_dual;
pub mod qef;
pub mod squares;
pub mod surface_nets;
pub mod tetrahedra;

pub use adaptive::{AdaptiveContour, AdaptiveDualContouring, Adaptivity};
pub use cell::{Cell, Hermite, Placed};
pub use dual_contouring::DualContouring;
pub use extended::ExtendedMarchingCubes;
pub use marching_cubes::MarchingCubes;
pub use masked::{Masked, PointMask};
pub use mc33::MarchingCubes33;
pub use octree_dual::{contour_octree, OctreeContour};
pub use squares::{marching_squares, Polyline, Saddle};
pub use surface_nets::SurfaceNets;
pub use tetrahedra::{BodyCentredTables, BodyCentredTetrahedra, Decomposition, MarchingTetrahedra};

use crate::cube::{cell_segment, CellPoint, CubeEdge, Diagonals};
use crate::mesh::VertexId;

/// What `process` will emit for one cell, known before the cell is processed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CellCounts {
    /// Triangles.
    pub triangles: u16,
    /// Quads.
    pub quads: u16,
    /// Vertices the cell places itself ([`Cell::place_vertex`]: private, never shared).
    pub placed: u16,
}

/// What [`Extractor::counts`] found out about a cell, in the extractor's own encoding, handed back
/// to [`Extractor::process_decided`] so the cell is not decided twice (MC33: its topology).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Decision(pub u32);

/// How the output of a cell can be known before processing it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Counting {
    /// Not known in advance: the cell names segments or other cells' vertices. Walkers that
    /// allocate before filling run such extractors on per-slab meshes stitched by vertex key.
    Unknown,
    /// From the case alone (`Some` in [`Extractor::counts`] without looking at the values), or
    /// from the cell's values and position when the case does not decide. The cell may use only
    /// [`edge_vertex`](Cell::edge_vertex), private [`place_vertex`](Cell::place_vertex) and
    /// polygons.
    Known,
}

/// The segments off the lattice edges an extractor names, for walkers that number vertices by
/// segment family (the Flying Edges walker's fast path): the split diagonal of every face, and
/// the main diagonal 0–7 of every cell ([`crate::cube::cell_segment`] numbers them).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Segments {
    /// How faces are split (`None`: no face diagonal).
    pub diagonals: Option<Diagonals>,
    /// Whether cells' main diagonals are named.
    pub main_diagonal: bool,
}

/// Processes one cell at a time; walkers call it for every cell with a crossing.
pub trait Extractor {
    /// Whether [`place`](Extractor::place) does anything (dual methods): walkers then also
    /// place the vertices of the cells just before their range (its halo), so polygons can refer
    /// to them.
    const PLACES_VERTICES: bool = false;

    /// Places the cell's own vertices ([`Cell::place_vertex`]). Called for every active cell in
    /// walk order, before [`process`](Extractor::process) of the same cell.
    fn place<C: Cell>(&self, cell: &mut C) {
        let _ = cell;
    }

    /// Emits the cell's polygons through `cell`.
    fn process<C: Cell>(&self, cell: &mut C);

    /// Whether and how the output of a cell is known in advance (see [`counts`](Extractor::counts)).
    /// A property of the type, not of a value: a walker compiles only the path its extractor
    /// takes (the counted passes, or the keyed ones), not both for every extractor.
    const COUNTING: Counting = Counting::Unknown;

    /// The segments besides lattice edges that [`case_triangles`](Extractor::case_triangles)
    /// and counted cells name (none by default).
    fn segments(&self) -> Segments {
        Segments::default()
    }

    /// The triangles `process` emits for every cell of `case` and parity (`odd`: the cell's
    /// corner 0 has an odd coordinate sum), as triples of cell segments (its 12 edges, then the
    /// [`segments`](Extractor::segments) it names, numbered by
    /// [`crate::cube::cell_segment`]) wound outward, when the case alone decides
    /// them and the cell places no vertex: a table walkers may apply themselves (the Flying Edges
    /// walker's bit-row fast path). `None`: the cell goes through [`process`](Extractor::process).
    #[inline]
    fn case_triangles(&self, case: u8, odd: bool) -> Option<&[[u8; 3]]> {
        let _ = (case, odd);
        None
    }

    /// What [`process`](Extractor::process) will emit for a cell of `case` without a
    /// [`case_triangles`](Extractor::case_triangles) entry, for extractors with
    /// [`Counting::Known`]; `values` gives the cell's offset values and `ijk` its position. Also
    /// returns what was decided on the way: a walker that counts a cell may later hand it to
    /// [`process_decided`](Extractor::process_decided) instead of calling `process`. The default
    /// says nothing (never called for [`Counting::Unknown`]) and decides nothing.
    fn counts(&self, case: u8, ijk: [u32; 3], values: impl FnOnce() -> [f32; 8]) -> (CellCounts, Decision) {
        let _ = values;
        let odd = (ijk[0] + ijk[1] + ijk[2]) % 2 == 1;
        let triangles = self.case_triangles(case, odd).map_or(0, |t| t.len() as u16);
        (CellCounts { triangles, ..Default::default() }, Decision::default())
    }

    /// The triangles [`process_decided`](Extractor::process_decided) emits for a cell that
    /// [`counts`](Extractor::counts) returned `decision` for, numbered as in
    /// [`case_triangles`](Extractor::case_triangles), when the decision alone fixes them and the
    /// cell places no vertex (MC33: every loop a plain fan). A walker may apply them itself;
    /// `None` (the default): the cell goes through `process_decided`.
    #[inline]
    fn decided_triangles(&self, decision: Decision) -> Option<&[[u8; 3]]> {
        let _ = decision;
        None
    }

    /// [`process`](Extractor::process) for a cell that [`counts`](Extractor::counts) returned
    /// `decision` for: must emit exactly what `process` emits, in the same order (walkers that
    /// do not count a cell call `process`; both give one mesh). The default calls `process`.
    #[inline]
    fn process_decided<C: Cell>(&self, cell: &mut C, decision: Decision) {
        let _ = decision;
        self.process(cell);
    }

    /// For the body-centred tetrahedra: their split tabulated per solid, so a walker whose
    /// volume gives cell centres from its samples can count and fill them itself (the Flying
    /// Edges walker's counted path) instead of stitching keyed meshes. `None` by default.
    fn body_centred(&self) -> Option<&'static BodyCentredTables> {
        None
    }

    /// Whether walkers must also call [`process`](Extractor::process) for cells whose eight
    /// corners are all on one side (extractors that sample off the lattice, such as cell centres
    /// of a field, can find a surface there).
    fn visits_uniform_cells(&self) -> bool {
        false
    }
}

/// A cell that only records what an extractor does with it: triangles as cell-segment triples
/// (its edge vertices are numbered by their cube edge, the segments it is told to name by their
/// cell segment), and counts of quads and placed vertices. Lets
/// an extractor tabulate its cases, or count a cell's output by running `process` itself.
pub(crate) struct ProbeCell {
    ijk: [u32; 3],
    segments: Segments,
    values: [f32; 8],
    case: u8,
    /// Triangles on edge vertices, as cube-edge triples.
    pub(crate) triangles: Vec<[u8; 3]>,
    /// Whether a triangle used a vertex other than an edge vertex.
    pub(crate) other_vertices: bool,
    pub(crate) counts: CellCounts,
}

/// Ids of placed vertices in a [`ProbeCell`] (above any cube edge).
const PROBE_PLACED: u32 = 1 << 16;

impl ProbeCell {
    /// A cell at `ijk` with `values` (offset by iso).
    pub(crate) fn new(ijk: [u32; 3], values: [f32; 8]) -> Self {
        ProbeCell {
            ijk,
            segments: Segments::default(),
            values,
            case: crate::cube::case_of(&values),
            triangles: Vec::new(),
            other_vertices: false,
            counts: CellCounts::default(),
        }
    }

    /// Numbers the `segments` as cell segments (see [`Extractor::case_triangles`]).
    pub(crate) fn naming(mut self, segments: Segments) -> Self {
        self.segments = segments;
        self
    }
}

impl Cell for ProbeCell {
    fn ijk(&self) -> [u32; 3] {
        self.ijk
    }
    fn values(&self) -> &[f32; 8] {
        &self.values
    }
    fn case(&self) -> u8 {
        self.case
    }
    fn hermite(&mut self, _e: CubeEdge) -> Hermite {
        Hermite { point: [0.0; 3], normal: [0.0; 3], local: [0.0; 3], local_normal: [0.0; 3], exact: false }
    }
    fn crossing(&mut self, e: CubeEdge) -> [f32; 3] {
        let mut p = e.origin_offset().map(|x| x as f32);
        p[e.axis().index()] = 0.5;
        p
    }
    fn edge_vertex(&mut self, e: CubeEdge) -> VertexId {
        VertexId(e.0 as u32)
    }
    fn has_neighbour(&self, _face: u8) -> bool {
        false
    }
    fn point_value(&mut self, p: CellPoint) -> f32 {
        match p {
            CellPoint::Corner(c) => self.values[c as usize],
            _ => f32::NAN,
        }
    }
    fn segment_vertex(&mut self, a: CellPoint, b: CellPoint) -> VertexId {
        let odd = (self.ijk[0] + self.ijk[1] + self.ijk[2]) % 2 == 1;
        let named = match (a, b) {
            (CellPoint::Corner(a), CellPoint::Corner(b)) => {
                cell_segment(a, b, self.segments.diagonals, odd).filter(|&s| {
                    s < 12 || s >= 18 && self.segments.main_diagonal || s < 18 && self.segments.diagonals.is_some()
                })
            }
            _ => None,
        };
        match named {
            Some(s) => VertexId(s as u32),
            None => {
                self.other_vertices = true;
                VertexId(PROBE_PLACED - 1)
            }
        }
    }
    fn place_vertex(&mut self, _local: [f32; 3], _edges: u16) -> VertexId {
        self.counts.placed += 1;
        VertexId(PROBE_PLACED + self.counts.placed as u32)
    }
    fn placed(&mut self, _offset: [i8; 3], _e: CubeEdge) -> Option<Placed> {
        self.other_vertices = true;
        None
    }
    fn push_triangle(&mut self, t: [VertexId; 3]) {
        self.counts.triangles += 1;
        if t.iter().all(|v| (v.0 as usize) < crate::cube::CELL_SEGMENTS) {
            self.triangles.push(t.map(|v| v.0 as u8));
        } else {
            self.other_vertices = true;
        }
    }
    fn push_quad(&mut self, _q: [VertexId; 4]) {
        self.counts.quads += 1;
    }
}
