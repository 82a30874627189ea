//! Dual contouring \[Ju02\] on uniform lattices: surface nets' connectivity with each cell's vertex
//! fitted to the Hermite data of its crossed edges, so corners and creases are kept.
//!
//! In: a cell's crossings and normals in its own frame ([`Cell::hermite`]: `local`,
//! `local_normal`, from the volume's gradient: exact for fields, central differences for grids).
//! Out: one vertex per active cell at the minimiser of its quadratic error function ([`Qef`]),
//! and per crossed lattice edge a quad (or two triangles) joining the four cells around it.

use super::fans::LoopFans;
use super::qef::Qef;
use super::{Extractor, MarchingCubes};
use crate::cube::{CubeEdge, CASE_EDGES};
use crate::extract::Cell;
use crate::mesh::VertexId;

/// Singular values of a cell's QEF below this fraction of its largest are dropped
/// ([`DualContouring::truncation`]). 0.1 keeps two planes meeting at 11.4° or more as a crease
/// (the singular values of two unit normals at angle θ are in the ratio `tan(θ/2)`), and drops
/// the spread of a smooth patch's normals across a cell.
pub const DEFAULT_TRUNCATION: f32 = 0.1;

/// How far beyond its cell a vertex may go by default, in cell widths, where the normals are
/// exact ([`Hermite::exact`](crate::extract::Hermite::exact): fields) and its planes meet at one
/// point ([`LEAVE_TOLERANCE`]): 1. A box's corner can poke into a cell without crossing any of its
/// edges (that cell is not even active): only a neighbour whose three planes meet there could put
/// a vertex on it, outside its own cell. On 30 random rotated boxes at 32³ with exact normals
/// (`tests/dual_contouring.rs`) the worst corner is 0.64 cell widths off the mesh with margin 0
/// (median 0.015), 0.26 with 0.5 and 0.000 with 1 (about 5.6 % of the vertices then leave their
/// cell). On grids every vertex stays in its cell whatever the margin: central differences can
/// agree on a wrong point (with margin 1, four of 1500 small integer lattices
/// (`tests/properties.rs`) came out inside out).
pub const DEFAULT_MARGIN: f32 = 1.0;

/// Dual contouring: one vertex per active cell at the point that best fits the tangent planes
/// of its edge crossings, and for every crossed lattice edge a quad joining the vertices of the
/// four cells around it (split into two triangles along its shorter diagonal unless `quads`).
///
/// The QEF `Σ (mᵢ · (x − pᵢ))²` is set up in the cell's frame (crossings `pᵢ` and normal
/// covectors `mᵢ`, so residuals are world distances), solved about the mass point (the crossings'
/// mean) by a 3×3 symmetric eigen-decomposition with singular values below
/// [`truncation`](DualContouring::truncation) × the largest dropped (the mass point where nothing
/// is left). A minimiser farther than [`FIT_TOLERANCE`] from any of the planes, or planes whose
/// normals do not cross their edges ([`MIN_CROSSING_COSINE`]), give the mass point instead
/// (disagreeing normals: surface nets' vertex). The vertex is clamped into its cell, or into its
/// cell grown by [`margin`](DualContouring::margin) on every side (each coordinate to
/// [−margin, 1 + margin]) when its normals are exact (fields) and it lies within
/// [`LEAVE_TOLERANCE`] of every plane: a corner or crease the planes meet at may lie in a
/// neighbouring cell; the mass point never leaves the cell, nor does any vertex on a grid.
///
/// **Guarantees**: the connectivity of [`SurfaceNets`](super::SurfaceNets) (the same vertices,
/// one per active cell, and one quad per crossed interior edge), so closed and consistently
/// oriented wherever surface nets are (counter-clockwise seen from outside; triangles split from
/// the quads keep their winding); vertices within `margin` of their cells; corners and creases
/// reproduced when the planes of the cell's crossings meet within that reach. With
/// [`split`](DualContouring::split): closed and oriented on every random lattice tested, 500
/// non-manifold edges and no non-manifold vertex on 1000 random lattices where one vertex per
/// cell has 3812 and 272 (`tests/dual_contouring.rs`); not yet a guarantee (two patches of
/// neighbouring cells can share two face segments).
///
/// **Limits**: not manifold where one cell holds two sheets of the surface (they share its
/// vertex: on the real scans 2 to 122982 non-manifold edges, 88–100 % fewer with `split`;
/// docs/BENCHMARKS.md §6.23, from `isoforge-io/tests/real_data.rs`); a
/// feature whose planes meet beyond the margin is cut there (the clamp); a vertex outside its
/// cell can fold a triangle against its neighbours' (no self-intersection test yet); open along
/// the lattice's faces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DualContouring {
    /// Keep quads (as surface nets do) instead of splitting each along its shorter diagonal.
    pub quads: bool,
    /// Relative truncation of the QEF's singular values (see [`DEFAULT_TRUNCATION`]).
    pub truncation: f32,
    /// How far beyond its cell a vertex fitted to exact normals may go, in cell widths (see
    /// [`DEFAULT_MARGIN`]; 0: strictly inside its cell).
    pub margin: f32,
    /// One vertex per marching-cubes patch of the cell (its crossed edges grouped by the
    /// triangles of [`MarchingCubes`]' case, whose face choices neighbours share) instead of one
    /// per cell: a cell holding two sheets gives each its own vertex, fitted to its own planes
    /// (vertex splitting, in the spirit of manifold dual contouring \[Schaefer07\]). Off by
    /// default: plain \[Ju02\], surface nets' connectivity.
    pub split: bool,
    /// The manifold mode (the default): MC33's loops instead of cells, one vertex per loop that
    /// spans a disk, and a crossing kept as a vertex wherever the dual quad around it would make
    /// the mesh non-manifold (see [`ExtendedMarchingCubes`](super::ExtendedMarchingCubes)' fans
    /// and the `fans` module): closed, manifold, oriented, with the trilinear interpolant's
    /// components and genus. Off: plain \[Ju02\] (or `split`).
    pub manifold: bool,
}

impl Default for DualContouring {
    fn default() -> Self {
        DualContouring {
            quads: false,
            truncation: DEFAULT_TRUNCATION,
            margin: DEFAULT_MARGIN,
            split: false,
            manifold: true,
        }
    }
}

impl DualContouring {
    /// The manifold mode's construction: every disk loop fanned and merged.
    fn fans(&self) -> LoopFans {
        LoopFans { fit: *self, feature_cos: None, merge: true, quads: self.quads }
    }

    /// The cell's vertex in its frame, fitted to the planes of the crossed edges in `crossed`:
    /// the QEF's minimiser when it lies within [`FIT_TOLERANCE`] of every plane and every normal
    /// crosses its edge ([`MIN_CROSSING_COSINE`]), the mass point (the crossings' mean) otherwise;
    /// clamped into the cell grown by `margin` when every normal is exact ([`Hermite::exact`](crate::extract::Hermite::exact)) and
    /// it lies within [`LEAVE_TOLERANCE`] of every plane, into the cell itself otherwise.
    #[inline]
    pub fn fit<C: Cell>(&self, cell: &mut C, crossed: u16) -> [f32; 3] {
        let d = *cell.values();
        let mut q = Qef::default();
        let mut planes = [([0.0f32; 3], [0.0f32; 3]); 12];
        let (mut n, mut crossing_normals, mut exact) = (0, true, true);
        for e in 0..12u8 {
            if crossed & (1 << e) != 0 {
                let h = cell.hermite(CubeEdge(e));
                exact &= h.exact;
                q.add(h.local, h.local_normal);
                planes[n] = (h.local, h.local_normal);
                n += 1;
                // The normal must cross the edge towards its outside end (a gradient along the
                // edge's sign change), or its plane says nothing about where the crossing is.
                let axis = CubeEdge(e).axis().index();
                let outward = if d[CubeEdge(e).corners()[0] as usize] < 0.0 { 1.0 } else { -1.0 };
                let m = h.local_normal;
                let len = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
                crossing_normals &= m[axis] * outward > MIN_CROSSING_COSINE * len;
            }
        }
        let (Some(s), Some(mass)) = (q.solve(self.truncation as f64), q.mass_point()) else { return [0.5; 3] };
        // Normals along an edge, or planes that disagree (noise, integer data's plateaus), give a
        // minimiser that can fold the surface inside out: surface nets' vertex instead.
        let x = if crossing_normals && fits(&planes[..n], s.point, FIT_TOLERANCE) { s.point } else { mass };
        // Out of the cell only to a point exact planes meet at (a corner, a crease).
        let reach = if exact && fits(&planes[..n], x, LEAVE_TOLERANCE) { self.margin } else { 0.0 };
        x.map(|c| (c as f32).clamp(-reach, 1.0 + reach))
    }
}

/// How far (in cell widths, along each normal) the QEF's minimiser may be from any of its
/// cell's tangent planes: planes that meet at one point (a corner or crease of the shape) or
/// nearly agree (a smooth patch: the truncated minimiser sits on their mean plane, about a
/// chord's sagitta from each) pass; normals that disagree (noise, plateaus of integer data,
/// where a minimiser turned small components inside out) give surface nets' vertex instead.
pub const FIT_TOLERANCE: f64 = 0.1;

/// The cosine (in cell coordinates) between a crossing's normal and its edge's direction towards
/// the outside end that the cell's planes must exceed to be used: central differences on
/// plateaus of integer data give normals across the edge (cosine 0) or against it, whose planes
/// put vertices on the wrong side of the surface. Zero: a box face nearly parallel to an edge is
/// still a good plane (a threshold of 0.1 lost corners of rotated boxes).
pub const MIN_CROSSING_COSINE: f32 = 0.0;

/// How close (in cell widths) to every plane a minimiser must be to leave its cell: planes that
/// meet at one point, as a shape's exact normals do at a corner or crease. Central differences
/// on integer data rarely agree that well; where they did with a looser bound (0.1), a vertex
/// pulled out of its cell turned one of 1500 small integer lattices' surfaces inside out.
pub const LEAVE_TOLERANCE: f64 = 0.01;

/// Whether `x` (cell coordinates) lies within `tolerance` cell widths of every plane `(p, m)`.
fn fits(planes: &[([f32; 3], [f32; 3])], x: [f64; 3], tolerance: f64) -> bool {
    planes.iter().all(|&(p, m)| {
        let (p, m) = (p.map(f64::from), m.map(f64::from));
        let len = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
        let d = (0..3).map(|i| m[i] * (x[i] - p[i])).sum::<f64>();
        len > 0.0 && d.abs() <= tolerance * len
    })
}

impl Extractor for DualContouring {
    const PLACES_VERTICES: bool = true;

    fn place<C: Cell>(&self, cell: &mut C) {
        if self.manifold {
            return self.fans().place(cell);
        }
        let crossed = CASE_EDGES[cell.case() as usize];
        if self.split {
            for &patch in patches(cell.case()).iter().take_while(|&&m| m != 0) {
                let x = self.fit(cell, patch);
                cell.place_vertex(x, patch);
            }
        } else {
            let x = self.fit(cell, crossed);
            cell.place_vertex(x, crossed);
        }
    }

    fn process<C: Cell>(&self, cell: &mut C) {
        if self.manifold {
            return self.fans().process(cell);
        }
        let d = *cell.values();
        let crossed = CASE_EDGES[cell.case() as usize];
        for axis in 0..3 {
            let (e, around) = super::surface_nets::around_edge(axis);
            if crossed & (1 << e.0) == 0 {
                continue;
            }
            let mut q = [VertexId::NONE; 4];
            let mut p = [[0.0f32; 3]; 4];
            let found = around.iter().enumerate().all(|(i, &o)| match cell.placed(o, e) {
                Some(v) => {
                    (q[i], p[i]) = (v.vertex, v.point);
                    true
                }
                None => false,
            });
            // A missing cell: the edge lies on the lattice's boundary, no quad.
            if !found {
                continue;
            }
            // Outward is towards the edge's outside end: +axis when its origin (corner 0) is inside.
            let (q, p) = if d[0] < 0.0 { (q, p) } else { ([q[0], q[3], q[2], q[1]], [p[0], p[3], p[2], p[1]]) };
            if self.quads {
                cell.push_quad(q);
            } else {
                // `Mesh::triangulate`'s split (shorter world diagonal, the quad's winding).
                for t in crate::mesh::split_quad(q.map(|v| v.0), p) {
                    cell.push_triangle(t.map(VertexId));
                }
            }
        }
    }
}

/// The crossed edges of `case` grouped by the connected patches of marching cubes' triangles
/// (masks of cube edges; the unused entries 0).
fn patches(case: u8) -> [u16; 4] {
    let mut root: [u8; 12] = std::array::from_fn(|e| e as u8);
    fn find(root: &mut [u8; 12], mut e: u8) -> u8 {
        while root[e as usize] != e {
            root[e as usize] = root[root[e as usize] as usize];
            e = root[e as usize];
        }
        e
    }
    for t in MarchingCubes.case_triangles(case, false).unwrap_or(&[]) {
        for w in [[t[0], t[1]], [t[1], t[2]]] {
            let (a, b) = (find(&mut root, w[0]), find(&mut root, w[1]));
            root[a.max(b) as usize] = a.min(b);
        }
    }
    let mut out = [0u16; 4];
    let crossed = CASE_EDGES[case as usize];
    for e in (0..12u8).filter(|e| crossed & (1 << e) != 0) {
        let r = find(&mut root, e);
        // Patches in the order of their smallest edge.
        let slot = out.iter().position(|&m| m == 0 || m.trailing_zeros() as u8 == r).unwrap_or(3);
        out[slot] |= 1 << e;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::extract::{Hermite, Placed, ProbeCell};

    /// A cell whose Hermite data are given: the vertex [`DualContouring::fit`] places.
    struct Given {
        probe: ProbeCell,
        planes: Vec<(u8, [f32; 3], [f32; 3])>,
    }

    impl Cell for Given {
        fn ijk(&self) -> [u32; 3] {
            self.probe.ijk()
        }
        fn values(&self) -> &[f32; 8] {
            self.probe.values()
        }
        fn case(&self) -> u8 {
            self.probe.case()
        }
        fn hermite(&mut self, e: CubeEdge) -> Hermite {
            let &(_, local, n) = self.planes.iter().find(|p| p.0 == e.0).expect("a crossed edge");
            Hermite { point: local, normal: n, local, local_normal: n, exact: true }
        }
        fn crossing(&mut self, e: CubeEdge) -> [f32; 3] {
            self.hermite(e).local
        }
        fn edge_vertex(&mut self, e: CubeEdge) -> VertexId {
            self.probe.edge_vertex(e)
        }
        fn has_neighbour(&self, face: u8) -> bool {
            self.probe.has_neighbour(face)
        }
        fn point_value(&mut self, p: crate::cube::CellPoint) -> f32 {
            self.probe.point_value(p)
        }
        fn segment_vertex(&mut self, a: crate::cube::CellPoint, b: crate::cube::CellPoint) -> VertexId {
            self.probe.segment_vertex(a, b)
        }
        fn place_vertex(&mut self, local: [f32; 3], edges: u16) -> VertexId {
            self.probe.place_vertex(local, edges)
        }
        fn placed(&mut self, offset: [i8; 3], e: CubeEdge) -> Option<Placed> {
            self.probe.placed(offset, e)
        }
        fn push_triangle(&mut self, t: [VertexId; 3]) {
            self.probe.push_triangle(t)
        }
        fn push_quad(&mut self, q: [VertexId; 4]) {
            self.probe.push_quad(q)
        }
    }

    /// Corner 0 alone inside, the surface the three planes x = a, y = b, z = c around it: the
    /// vertex is the corner (a, b, c) where surface nets' mean of crossings is not; a corner
    /// beyond the cell is clamped into it (or its margin).
    #[test]
    fn a_cube_corner_is_placed_on_the_corner_and_clamped_into_the_cell() {
        let case_values = [-1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0];
        let cell = |corner: [f32; 3]| {
            let [a, b, c] = corner;
            // Edges 0 (x), 4 (y), 8 (z) at corner 0 cross the faces x = a, y = b, z = c.
            Given {
                probe: ProbeCell::new([0; 3], case_values),
                planes: vec![
                    (0, [a, 0.0, 0.0], [1.0, 0.0, 0.0]),
                    (4, [0.0, b, 0.0], [0.0, 1.0, 0.0]),
                    (8, [0.0, 0.0, c], [0.0, 0.0, 1.0]),
                ],
            }
        };
        let dc = DualContouring { margin: 0.0, ..DualContouring::default() };
        let crossed = CASE_EDGES[1];
        assert_eq!(crossed, 1 | 1 << 4 | 1 << 8);
        let x = dc.fit(&mut cell([0.3, 0.6, 0.45]), crossed);
        assert!(x.iter().zip([0.3, 0.6, 0.45]).all(|(a, b)| (a - b).abs() < 1e-6), "{x:?}");
        // A corner the planes put outside the cell (x = 1.4 cannot cross edge 0, but the fit
        // must still stay inside).
        let x = dc.fit(&mut cell([1.4, 0.5, -0.2]), crossed);
        assert_eq!(x, [1.0, 0.5, 0.0]);
        let wide = DualContouring { margin: 0.25, ..DualContouring::default() };
        assert_eq!(wide.fit(&mut cell([1.4, 0.5, -0.2]), crossed), [1.25, 0.5, -0.2]);
    }

    /// Marching cubes' patches partition a case's crossed edges: one patch for a single corner,
    /// two for two opposite corners (case 0x81).
    #[test]
    fn patches_partition_the_crossed_edges() {
        for case in 0..=255u8 {
            let p = patches(case);
            let all = p.iter().fold(0u16, |a, &m| {
                assert_eq!(a & m, 0, "case {case:#x}: patches overlap");
                a | m
            });
            assert_eq!(all, CASE_EDGES[case as usize], "case {case:#x}");
        }
        let count = |c: u8| patches(c).iter().filter(|&&m| m != 0).count();
        assert_eq!(count(0x01), 1);
        assert_eq!(count(0x81), 2);
        assert_eq!(count(0), 0);
    }

    /// Split quads: the triangles of `Mesh::triangulate`, winding kept.
    #[test]
    fn quads_are_split_along_the_shorter_diagonal() {
        let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.2, 1.2, 0.0], [0.0, 1.0, 0.0]];
        assert_eq!(crate::mesh::split_quad([0, 1, 2, 3], p), [[0, 1, 3], [1, 2, 3]]);
    }
}
