//! The contract between walkers and extractors: [`Cell`], a walker's cursor on one cell, and
//! [`Hermite`] data. It lives with the extractors, which are written against it; walkers
//! implement it (so `extract` depends on no walker, and `walk` on `extract` only).

#[cfg(doc)]
use crate::cube::CORNER_OFFSETS;
use crate::cube::{CellPoint, CubeEdge};
use crate::mesh::VertexId;
#[cfg(doc)]
use crate::{cube::VertexKey, volume::Volume};

/// A walker's cursor on one cell. Extractors are generic over it and see nothing else.
///
/// **The cell's frame.** Extractors place vertices in cell coordinates: `local` ∈ [0, 1]³, the
/// lattice index `ijk + local` (corner `c` at [`CORNER_OFFSETS`]`[c]`). Everything a cell hands
/// out for placing is in that frame: [`crossing`](Cell::crossing) and [`Hermite::local`], and
/// normals as [`Hermite::local_normal`], the plane's covector in cell coordinates scaled so that
/// `local_normal · (u − local)` is the world distance of cell point `u` from the crossing's
/// tangent plane (spacing and direction applied). World data ([`Hermite::point`],
/// [`Hermite::normal`], [`Placed::point`]) is what the mesh stores.
///
/// Vertices come in three kinds, each created once per walk and shared through the walker's
/// caches: crossings on lattice edges ([`edge_vertex`](Cell::edge_vertex)), crossings on other
/// lattice segments ([`segment_vertex`](Cell::segment_vertex)), and vertices a cell places inside
/// itself ([`place_vertex`](Cell::place_vertex), which neighbours can refer to through
/// [`placed_vertex`](Cell::placed_vertex)).
pub trait Cell {
    /// Lattice index of the cell's corner 0 (global: the same in a walk of any range).
    fn ijk(&self) -> [u32; 3];
    /// The eight corner values offset by iso (inside ⇔ < 0), in corner order.
    fn values(&self) -> &[f32; 8];
    /// Case index: bit `c` set ⇔ corner `c` inside.
    fn case(&self) -> u8;

    /// Hermite data of edge `e` (its corners must differ in class): the crossing and the unit
    /// outward normal of the field there, computed once per lattice edge. What an algorithm
    /// needs (dual contouring, feature detection); independent of the normals the output stores.
    fn hermite(&mut self, e: CubeEdge) -> Hermite;
    /// The crossing on edge `e` (its corners must differ in class) in the cell's frame: the
    /// volume's crossing, where [`edge_vertex`](Cell::edge_vertex) puts its vertex, without the
    /// normal (cheaper than [`hermite`](Cell::hermite)); computed once per lattice edge.
    fn crossing(&mut self, e: CubeEdge) -> [f32; 3];
    /// The mesh vertex at the crossing on edge `e` (its corners must differ in class), created on
    /// first request and shared with every other cell touching the same lattice edge.
    fn edge_vertex(&mut self, e: CubeEdge) -> VertexId;

    /// Whether the neighbouring cell across `face` (`2 · axis + side`) exists in the lattice.
    fn has_neighbour(&self, face: u8) -> bool;
    /// The value offset by iso at a cell point: a corner's from [`values`](Cell::values), a
    /// centre's from [`Volume::value_at`] (computed once per cell).
    fn point_value(&mut self, p: CellPoint) -> f32;
    /// The mesh vertex where segment `a`–`b` crosses (their values differ in class), created on
    /// first request and shared with every cell that names the same lattice segment; axis edges
    /// give the same vertex as [`edge_vertex`](Cell::edge_vertex).
    fn segment_vertex(&mut self, a: CellPoint, b: CellPoint) -> VertexId;

    /// Places a new vertex inside this cell at cell coordinates `local` ∈ [0, 1]³, serving the
    /// crossed cube edges in the bit mask `edges` (0: a vertex only this cell uses). Vertices are
    /// numbered in placement order `n = 0, 1, …`; their key is [`VertexKey::Cell`].
    fn place_vertex(&mut self, local: [f32; 3], edges: u16) -> VertexId;
    /// The vertex that the cell at `ijk + offset` placed for the lattice edge that is edge `e` of
    /// this cell, if it placed one. `offset` ∈ {−1, 0}³ and the neighbour must contain that edge:
    /// cells at or before this one in walk order, which walkers have always placed (dual methods
    /// emit a cell's polygons for its edges at corner 0: 0, 4 and 8). `None` also when the
    /// neighbour lies outside the lattice.
    #[inline]
    fn placed_vertex(&mut self, offset: [i8; 3], e: CubeEdge) -> Option<VertexId> {
        self.placed(offset, e).map(|p| p.vertex)
    }
    /// [`placed_vertex`](Cell::placed_vertex) with its world position (what a dual method needs
    /// to split a quad along its shorter diagonal) and the edges it serves in its own cell (what
    /// tells a method which of the neighbour's loops or patches the vertex stands for).
    fn placed(&mut self, offset: [i8; 3], e: CubeEdge) -> Option<Placed>;

    /// Emits a triangle (wound counter-clockwise seen from outside).
    fn push_triangle(&mut self, t: [VertexId; 3]);
    /// Emits a quad (wound counter-clockwise seen from outside).
    fn push_quad(&mut self, q: [VertexId; 4]);
}

/// A vertex a cell placed, as a neighbour sees it ([`Cell::placed`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placed {
    /// The mesh vertex.
    pub vertex: VertexId,
    /// Its world position, as the mesh stores it.
    pub point: [f32; 3],
    /// The crossed cube edges it serves, numbered in the cell that placed it (the `edges` mask
    /// of [`Cell::place_vertex`]).
    pub edges: u16,
}

/// A crossing with its outward unit normal: the Hermite data dual methods fit vertices to, in
/// world coordinates (what the mesh stores) and in the frame of the cell that asked (what
/// [`Cell::place_vertex`] takes; see [`Cell`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hermite {
    /// World position of the crossing.
    pub point: [f32; 3],
    /// Unit normal pointing from inside to outside (from the field's gradient; the edge's
    /// direction where the gradient vanishes).
    pub normal: [f32; 3],
    /// The crossing in cell coordinates: on the cell's edge, [`Cell::crossing`]'s point.
    pub local: [f32; 3],
    /// The normal as a covector of cell coordinates, `m_a = spacing_a · (direction_a · normal)`:
    /// `local_normal · (u − local)` is the world distance of cell point `u` from the tangent
    /// plane (a unit vector on a lattice of unit spacing).
    pub local_normal: [f32; 3],
    /// Whether the normal is the field's own gradient ([`Volume::exact_gradients`]: fields), not an
    /// estimate from samples (central differences on grids): planes that meet at a point beyond
    /// the cell then mark a true corner there, not an artefact of the estimate.
    pub exact: bool,
}

impl Hermite {
    /// The same crossing seen from a cell where its lattice edge is edge `e`: `local` moved to
    /// that cell's edge (the parameter along the edge is kept; the other two coordinates are the
    /// edge's corner offsets, so no rounding).
    #[inline]
    pub fn on_edge(mut self, e: CubeEdge) -> Self {
        let axis = e.axis().index();
        let t = self.local[axis];
        self.local = e.origin_offset().map(|x| x as f32);
        self.local[axis] = t;
        self
    }
}
