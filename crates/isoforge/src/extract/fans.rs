//! Loop fans: marching cubes 33's surface with a vertex of its own inside the loops that ask
//! for one, and the fans of neighbouring cells flipped to meet vertex to vertex. The one
//! construction behind extended marching cubes \[Kobbelt01\] and manifold dual contouring.
//!
//! In: a cell's MC33 topology (loops of crossed edges, tunnels) and which of its disk loops get
//! a placed vertex (a *fan loop*: EMC's feature loops, every disk loop for dual contouring).
//! Out: triangles, in four steps that each keep MC33's guarantees:
//! 1. **MC33** triangulates the other loops and every tunnel (bands) as it always does.
//! 2. **Fans.** A fan loop is triangulated as a fan from its vertex: one triangle per loop
//!    segment, `[vertex, q, p]` for segment p → q (a disk re-triangulated with one interior
//!    vertex: the same surface, closed, manifold and oriented where MC33's is).
//! 3. **Flips.** A segment on a face between two fan loops (one per cell) carries two fan
//!    triangles; they are replaced by the two triangles on the diagonal joining the two loops'
//!    vertices (Kobbelt's edge flip: a crease between two feature vertices runs along it). A flip
//!    is refused when both loops hold both segments of that face (an ambiguous face whose two
//!    segments both join the same two loops): the two vertices would be joined twice. Otherwise
//!    the new edge exists nowhere else (the loops of two cells meet only on their common face),
//!    so every flip keeps the mesh manifold.
//! 4. **Merges** (dual contouring only). Around a crossed lattice edge whose four faces all
//!    flipped, the crossing's vertex has exactly four triangles, towards the four cells' loop
//!    vertices: it is removed and the four vertices make the dual quad (or its two triangles).
//!    The quad's diagonals join cells that share only that edge, so no edge is doubled. Where a
//!    face refuses its flip or a cell has a tunnel, the crossings stay: the mesh is the dual
//!    contouring mesh except there, and manifold everywhere.
//!
//! Who emits what, so that each triangle is made once and only from cells a walker has already
//! placed (offsets ≤ 0): a fan triangle on a face without a neighbour by its cell; on any other
//! face, by the face's upper cell (the face is its lower one), for both sides; a flipped
//! triangle (the half of a flipped pair at one crossing) or a merged quad by the cell whose
//! corner 0 starts the crossing's lattice edge (surface nets' rule), or, for an edge on the
//! lattice's upper faces that starts no cell, by the face's upper cell.
//!
//! Every step keeps the topology: the mesh has the components and genus of MC33's, that is of
//! the trilinear interpolant. Geometry is the caller's: vertices are placed by
//! [`DualContouring::fit`] (inside their cells), and a vertex far from its loop's plane can fold
//! a fan (`check --self-intersections` counts such faces).

use super::mc33::{self, common_face, CellTopology};
use super::surface_nets::around_edge;
use super::{DualContouring, Placed};
use crate::cube::{CubeEdge, FACE_EDGES};
use crate::extract::Cell;
use crate::mesh::{split_quad, VertexId};

/// Which disk loops get a vertex, and whether crossings whose four faces flipped are merged.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LoopFans {
    /// Places the vertices ([`DualContouring::fit`]: QEF with truncation, inside the cell).
    pub fit: DualContouring,
    /// `Some(cos)`: only loops whose crossings' normals spread wider than the angle with this
    /// cosine (a feature) get a vertex (extended marching cubes); `None`: every disk loop
    /// (dual contouring).
    pub feature_cos: Option<f32>,
    /// Remove crossings whose four faces flipped (dual contouring's quads).
    pub merge: bool,
    /// Keep merged quads as quads.
    pub quads: bool,
}

/// The bit mask of a list of cube edges.
fn mask_of(edges: &[u8]) -> u16 {
    edges.iter().fold(0, |m, &e| m | 1 << e)
}

/// The edges of face `f` as a bit mask.
fn face_mask(f: u8) -> u16 {
    mask_of(&FACE_EDGES[f as usize])
}

/// Whether a segment on a face between two fan loops is flipped: both loops exist, and not both
/// hold every edge of the face (`a` and `b` with their faces in their own cells' numbering).
fn flips(a: Option<Placed>, fa: u8, b: Option<Placed>, fb: u8) -> bool {
    match (a, b) {
        (Some(a), Some(b)) => {
            let (ma, mb) = (face_mask(fa), face_mask(fb));
            !(a.edges & ma == ma && b.edges & mb == mb)
        }
        _ => false,
    }
}

/// Offset of the cell across face `f` (`2 · axis + side`).
fn across(f: u8) -> [i8; 3] {
    let mut o = [0i8; 3];
    o[(f / 2) as usize] = if f.is_multiple_of(2) { -1 } else { 1 };
    o
}

impl LoopFans {
    /// Whether loop `edges` is a feature: two of its crossings' normals more than the feature
    /// angle apart (always, without a feature test).
    fn wants_vertex<C: Cell>(&self, cell: &mut C, edges: &[u8]) -> bool {
        let Some(cos) = self.feature_cos else { return true };
        let mut normals = [[0.0f32; 3]; 12];
        for (n, &e) in normals.iter_mut().zip(edges) {
            *n = cell.hermite(CubeEdge(e)).normal;
        }
        let normals = &normals[..edges.len()];
        normals.iter().enumerate().any(|(i, a)| normals[i + 1..].iter().any(|b| dot(*a, *b) < cos))
    }

    /// Places a vertex for each disk loop that wants one (serving the loop's edges).
    pub(crate) fn place<C: Cell>(&self, cell: &mut C) {
        let d = *cell.values();
        let topo = CellTopology::of_case(cell.case(), &d);
        let tubes = topo.tube_loops();
        for l in (0..topo.n_loops()).filter(|l| tubes >> l & 1 == 0) {
            let edges = topo.loop_edges(l);
            if self.wants_vertex(cell, edges) {
                let mask = mask_of(edges);
                let x = self.fit.fit(cell, mask);
                cell.place_vertex(x, mask);
            }
        }
    }

    /// Emits the cell's triangles (see the module documentation for who emits what).
    pub(crate) fn process<C: Cell>(&self, cell: &mut C) {
        let d = *cell.values();
        let topo = CellTopology::of_case(cell.case(), &d);
        // This cell's fan loops: the vertex `place` made for each.
        let mut fan: [Option<Placed>; 4] = [None; 4];
        let mut fans = 0u8;
        for (l, slot) in fan.iter_mut().enumerate().take(topo.n_loops()) {
            *slot = cell.placed([0; 3], CubeEdge(topo.loop_edges(l)[0]));
            fans |= (slot.is_some() as u8) << l;
        }
        // 1. MC33 for the rest.
        mc33::triangulate(cell, &topo, fans);
        // 2–3. Segments: on faces without a neighbour (own fans), and on lower faces (both sides).
        for l in 0..topo.n_loops() {
            let edges = topo.loop_edges(l);
            for i in 0..edges.len() {
                let (p, q) = (edges[i], edges[(i + 1) % edges.len()]);
                let f = common_face(p, q);
                if cell.has_neighbour(f) {
                    if f.is_multiple_of(2) {
                        self.lower_face_segment(cell, f, p, q, fan[l]);
                    }
                } else if let Some(x) = fan[l] {
                    let (vp, vq) = (cell.edge_vertex(CubeEdge(p)), cell.edge_vertex(CubeEdge(q)));
                    cell.push_triangle([x.vertex, vq, vp]);
                }
            }
        }
        // 3–4. Flipped halves and merges around the lattice edges this cell's corner 0 starts.
        for axis in 0..3 {
            self.corner_edge(cell, axis, d[0] < 0.0);
        }
    }

    /// Segment p → q of this cell's loop (vertex `own`, if a fan) on its lower face `f`: both
    /// sides' fan triangles, or, flipped, the halves at crossings no cell's corner 0 starts.
    fn lower_face_segment<C: Cell>(&self, cell: &mut C, f: u8, p: u8, q: u8, own: Option<Placed>) {
        let below = across(f);
        let other = cell.placed(below, CubeEdge(p));
        if let (true, Some(a), Some(b)) = (flips(other, f + 1, own, f), other, own) {
            // The flipped pair is [b, q, a] at q and [a, p, b] at p; each half belongs to the
            // cell whose corner 0 starts its crossing's edge, when there is one (crossings are
            // made only when asked: a merged one never is).
            if !starts_a_cell(cell, q) {
                let vq = cell.edge_vertex(CubeEdge(q));
                cell.push_triangle([b.vertex, vq, a.vertex]);
            }
            if !starts_a_cell(cell, p) {
                let vp = cell.edge_vertex(CubeEdge(p));
                cell.push_triangle([a.vertex, vp, b.vertex]);
            }
            return;
        }
        let (vp, vq) = (cell.edge_vertex(CubeEdge(p)), cell.edge_vertex(CubeEdge(q)));
        if let Some(x) = own {
            cell.push_triangle([x.vertex, vq, vp]);
        }
        if let Some(x) = other {
            cell.push_triangle([x.vertex, vp, vq]);
        }
    }

    /// Around this cell's edge along `axis` at corner 0 (if crossed; `inside`: corner 0 is
    /// inside): the flipped halves at its crossing, or the merged quad.
    fn corner_edge<C: Cell>(&self, cell: &mut C, axis: usize, inside: bool) {
        let (e, around) = around_edge(axis);
        if crate::cube::CASE_EDGES[cell.case() as usize] & (1 << e.0) == 0 {
            return;
        }
        let (u, v) = (((axis + 1) % 3) as u8, ((axis + 2) % 3) as u8);
        let x: [Option<Placed>; 4] = around.map(|o| cell.placed(o, e));
        // Face i joins cells i and i + 1 (counter-clockwise seen from +axis): its index in
        // each cell's numbering.
        let faces = [(2 * u + 1, 2 * u), (2 * v + 1, 2 * v), (2 * u, 2 * u + 1), (2 * v, 2 * v + 1)];
        let flipped: [bool; 4] = std::array::from_fn(|i| flips(x[i], faces[i].0, x[(i + 1) % 4], faces[i].1));
        let id = |i: usize| x[i].map(|p| p.vertex).unwrap_or(VertexId::NONE);
        if self.merge && flipped.iter().all(|&f| f) {
            let (q, pts) = ([0, 1, 2, 3].map(id), [0, 1, 2, 3].map(|i| x[i].map(|p| p.point).unwrap_or_default()));
            // Outward is towards the edge's outside end: +axis when corner 0 is inside.
            let (q, pts) = if inside { (q, pts) } else { ([q[0], q[3], q[2], q[1]], [pts[0], pts[3], pts[2], pts[1]]) };
            if self.quads {
                cell.push_quad(q);
            } else {
                for t in split_quad(q.map(|v| v.0), pts) {
                    cell.push_triangle(t.map(VertexId));
                }
            }
            return;
        }
        let c = cell.edge_vertex(e);
        for i in (0..4).filter(|&i| flipped[i]) {
            let (a, b) = (id(i), id((i + 1) % 4));
            cell.push_triangle(if inside { [c, a, b] } else { [c, b, a] });
        }
    }
}

/// Whether the lattice edge that is cube edge `e` of this cell starts a cell (is the corner-0
/// edge of some cell): not when it lies on one of the lattice's upper faces.
fn starts_a_cell<C: Cell>(cell: &C, e: u8) -> bool {
    let (axis, o) = (CubeEdge(e).axis().index(), CubeEdge(e).origin_offset());
    (0..3).filter(|&a| a != axis && o[a] == 1).all(|a| cell.has_neighbour(2 * a as u8 + 1))
}

#[inline]
fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
