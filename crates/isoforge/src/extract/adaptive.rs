//! Adaptive dual contouring \[Ju02\] §3–4: an octree over the volume's cells, built bottom-up
//! from the active finest cells, whose nodes merge their eight children into one vertex where
//! the children's summed quadratic error stays under a bound and the merge keeps the topology;
//! contoured by one polygon per minimal crossed edge.
//!
//! In: any [`Volume`] (its corner values, crossings and gradients, as walkers see them) and an
//! error bound in cell widths. Out: a [`Mesh`] of triangles (or quads and triangles).
//!
//! ```text
//!   level 0   the lattice's active cells (corners of both classes), each fitted by
//!             DualContouring::fit (E = 0: exactly uniform dc's vertices)
//!   level l   a node of 2^l cells per side, present iff it holds an active cell; merged
//!             (a leaf with one vertex) iff its children are leaves or empty, the sign tests
//!             of §4.2 pass, and its summed QEF's error at its vertex is ≤ E²
//!   polygons  per crossed finest edge, the leaves of the four cells around it, repeated
//!             leaves dropped: a quad, a triangle, or nothing (the edge lies inside one leaf or
//!             inside the face between two)
//! ```
//!
//! Only the nodes that hold active cells exist: empty space costs a scan of its values and
//! nothing in the tree.

use std::collections::HashMap;

use super::dual_contouring::DualContouring;
use super::qef::QefSum;
use super::{Cell, Hermite, Placed, ProbeCell};
use crate::cube::{case_of, CellPoint, CubeEdge, EdgeKey, CASE_EDGES, CORNER_OFFSETS};
use crate::error::{Error, Result};
use crate::mesh::{split_quad, Mesh, VertexId};
use crate::volume::{Iso, Volume};
use crate::walk::{edge_hermite, WalkStats};

/// Adaptive dual contouring: [`DualContouring`]'s vertices on the finest cells (its `fit`,
/// `truncation`, `margin` and `quads`), merged up an octree while the error bound holds.
///
/// **Merging** (\[Ju02\] §4): a node of side `s = 2^l` cells merges its eight children when
/// (1) every child is a leaf whose contour is a disk (a finest cell of a manifold case, or a
/// merged node) or holds no active cell (then all its points have one class);
/// (2) it lies inside the lattice's cells;
/// (3) the sign tests of §4.2 on its 27 points (corners, edge midpoints, face centres, centre):
/// its corners' case is manifold (the inside corners connected along cube edges, and the
/// outside ones: one disk), each edge midpoint has the class of one of its edge's ends, each face
/// centre the class of one of its face's corners, the centre that of one of the corners: the
/// coarse cell's contour has the children's topology;
/// (4) the children's summed QEF (planes in cell widths: `Σ dᵢ²` over the crossings' tangent
/// planes, each counted once per finest cell around it) at the node's vertex is at most
/// `adaptivity²`; (5) a corner a child holds (a finest cell whose planes meet at one point, rank
/// 3) stays within [`CORNER_TOLERANCE`] of the merged vertex. The vertex: the QEF's minimiser
/// (singular values truncated as uniform dc's); a node whose minimiser leaves its cube does not
/// merge.
///
/// **Guarantees**: with `adaptivity` 0 the vertices and polygons of plain uniform dual
/// contouring ([`DualContouring`] with `manifold: false`, `split: false`); crack-free across
/// levels (a polygon per minimal crossed edge joining the leaves around it, so neighbouring
/// leaves of different sizes share their polygons' edges); every merged vertex within
/// `adaptivity` cell widths of each of its tangent planes; oriented as uniform dc (inside ⇔ value
/// < iso, counter-clockwise seen from outside).
///
/// **Limits**: not manifold (one vertex per leaf, as plain dc; and a merged leaf can hold a
/// vertex that two sheets share where the sign tests cannot see a feature thinner than a
/// finest cell); a vertex's distance to the *surface* is bounded by its planes', not measured;
/// the values are scanned slab by slab over the whole lattice (empty space is skipped by the
/// tree, not by the scan); single-threaded.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptiveDualContouring {
    /// The uniform method on the finest cells (its `manifold` and `split` are ignored).
    pub dc: DualContouring,
    /// The error bound in cell widths (the smallest spacing): 0 (the default) keeps every
    /// finest cell.
    pub adaptivity: f64,
}

impl Default for AdaptiveDualContouring {
    fn default() -> Self {
        AdaptiveDualContouring { dc: DualContouring { manifold: false, ..DualContouring::default() }, adaptivity: 0.0 }
    }
}

/// An error bound in cell widths held exactly, in millionths, so that a method holding one
/// compares and hashes ([`crate::pipeline::Method::DualContouring`]'s `adaptivity`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct Adaptivity(u32);

impl Adaptivity {
    /// No merging: uniform dual contouring.
    pub const UNIFORM: Adaptivity = Adaptivity(0);
    /// The largest bound, in cell widths.
    pub const MAX_CELLS: f64 = 1000.0;

    /// The bound `e` cell widths (rounded to millionths).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] unless `e` is a number from 0 to [`Adaptivity::MAX_CELLS`].
    pub fn from_cells(e: f64) -> Result<Self> {
        if !(0.0..=Self::MAX_CELLS).contains(&e) {
            return Err(Error::InvalidInput(format!(
                "adaptivity {e}: expected an error bound from 0 to {} cell widths",
                Self::MAX_CELLS
            )));
        }
        Ok(Adaptivity((e * 1e6).round() as u32))
    }

    /// The bound in cell widths.
    pub fn cells(self) -> f64 {
        f64::from(self.0) / 1e6
    }

    /// Whether the bound is 0 (uniform dual contouring).
    pub fn is_uniform(self) -> bool {
        self.0 == 0
    }
}

/// What [`AdaptiveDualContouring::contour`] made.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AdaptiveContour {
    /// The surface.
    pub mesh: Mesh,
    /// Active finest cells (uniform dc's vertex count).
    pub active_cells: usize,
    /// The cells scanned, and those wholly inside or outside (as a walk counts them).
    pub stats: WalkStats,
    /// Leaves used by the mesh, by level (index = level; `leaves[0]` the finest cells kept).
    pub leaves: Vec<usize>,
    /// Nodes whose children were all leaves but whose sign tests failed (topology kept).
    pub refused_topology: usize,
    /// Nodes whose children were all leaves, signs safe, but whose QEF error exceeded the bound
    /// (or whose minimiser left the node's cube).
    pub refused_error: usize,
    /// Nodes whose vertex would have moved a child's corner more than [`CORNER_TOLERANCE`].
    pub refused_corner: usize,
}

/// A node of the tree: the QEF of its planes, its vertex (lattice index coordinates) and whether
/// it is a leaf whose contour is a disk (may merge into its parent).
#[derive(Debug, Clone, Copy)]
struct Node {
    qef: QefSum,
    vertex: [f64; 3],
    mergeable: bool,
    /// The vertex, when it stands for a corner: a finest cell whose planes meet at one point
    /// (rank 3 after truncation), or a merged node holding one.
    corner: Option<[f64; 3]>,
}

/// What a parent gathers from its children present.
struct Children {
    /// Their summed QEF.
    qef: QefSum,
    /// Every child may merge (and no two corners apart).
    mergeable: bool,
    /// The corner one of them holds.
    corner: Option<[f64; 3]>,
}

/// How far (in cell widths) a merged vertex may move from a corner one of its children holds;
/// children holding two corners farther apart than twice this never merge. Keeps the corners
/// where uniform dc has them (the planes of a corner and of a curved cut meeting it would
/// otherwise pull the merged vertex up to the error bound off the corner).
pub const CORNER_TOLERANCE: f64 = 0.01;

/// Finest cells per lattice and nodes in the tree at most (checked before allocating).
const MAX_CELLS: u64 = 1 << 31;

impl AdaptiveDualContouring {
    /// Contours `vol` at `iso`; `normals`: with unit normals from the volume's gradient.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when `adaptivity` is negative or not finite; [`Error::Limit`]
    /// past 2³¹ cells or `u32` vertex indices.
    pub fn contour<V: Volume + ?Sized>(&self, vol: &V, iso: Iso, normals: bool) -> Result<AdaptiveContour> {
        let e = self.adaptivity;
        if !(e.is_finite() && e >= 0.0) {
            return Err(Error::InvalidInput(format!("adaptivity {e}: must be a finite number ≥ 0 (cell widths)")));
        }
        let lattice = vol.lattice();
        let mut out = AdaptiveContour::default();
        if !lattice.has_cells() {
            return Ok(out);
        }
        let dims = lattice.dims();
        let cells = dims.map(|n| n - 1);
        if cells.iter().map(|&c| u64::from(c)).product::<u64>() > MAX_CELLS {
            return Err(Error::Limit {
                what: "adaptive dc cells",
                requested: cells.iter().map(|&c| u64::from(c)).product::<u64>(),
                allowed: MAX_CELLS,
            });
        }
        let h = lattice.spacing().iter().fold(f64::INFINITY, |m, &s| m.min(s.abs()));
        let h = if h > 0.0 && h.is_finite() { h } else { 1.0 };

        // Level 0: the active cells, fitted as uniform dc fits them.
        let (nx, ny) = (dims[0] as usize, dims[1] as usize);
        let mut slabs = [vec![0.0f32; nx * ny], vec![0.0f32; nx * ny]];
        vol.fill_slab(0, iso, &mut slabs[0]);
        let mut finest: Vec<([u32; 3], [f32; 8])> = Vec::new();
        let mut level0: HashMap<[u32; 3], Node> = HashMap::new();
        for k in 0..cells[2] {
            vol.fill_slab(k + 1, iso, &mut slabs[((k + 1) % 2) as usize]);
            let (s0, s1) = (&slabs[(k % 2) as usize], &slabs[((k + 1) % 2) as usize]);
            for j in 0..cells[1] as usize {
                for i in 0..cells[0] as usize {
                    let d = CORNER_OFFSETS.map(|o| {
                        let s = if o[2] == 0 { s0 } else { s1 };
                        s[(j + o[1] as usize) * nx + i + o[0] as usize]
                    });
                    let case = case_of(&d);
                    out.stats.cells += 1;
                    if case == 0 || case == 255 {
                        out.stats.cells_outside += u64::from(case == 0);
                        out.stats.cells_inside += u64::from(case == 255);
                        continue;
                    }
                    let ijk = [i as u32, j as u32, k];
                    let mut cell = FitCell::new(vol, iso, ijk, d);
                    let local = self.dc.fit(&mut cell, CASE_EDGES[case as usize]);
                    let mut qef = QefSum::default();
                    for hm in cell.planes.iter().flatten() {
                        let p = [0, 1, 2].map(|a| f64::from(ijk[a]) + f64::from(hm.local[a]));
                        qef.add(p, hm.local_normal.map(|m| f64::from(m) / h));
                    }
                    let vertex = [0, 1, 2].map(|a| f64::from(ijk[a]) + f64::from(local[a]));
                    let rank = qef.qef.solve(f64::from(self.dc.truncation)).map_or(0, |s| s.rank);
                    let corner = (e > 0.0 && rank == 3).then_some(vertex);
                    level0.insert(ijk, Node { qef, vertex, mergeable: manifold_case(case), corner });
                    finest.push((ijk, d));
                }
            }
        }
        out.active_cells = finest.len();

        // Levels 1, 2, …: parents of the nodes below, merged where safe.
        let mut levels = vec![level0];
        let inside = |p: [u32; 3]| vol.value_at_point(p, iso) < 0.0;
        loop {
            let l = levels.len() as u32;
            // No node of side s fits in the lattice's cells past its smallest side.
            if e <= 0.0 || l >= 31 || cells.iter().any(|&c| c < 1u32 << l) {
                break;
            }
            let s = 1u32 << l;
            let below = &levels[levels.len() - 1];
            // Per parent: the summed QEF, whether every child present may merge, and the corner
            // its children hold (children holding two distinct corners may not).
            let mut parents: HashMap<[u32; 3], Children> = HashMap::with_capacity(below.len() / 4 + 1);
            for (key, node) in below {
                let p = parents.entry(key.map(|c| c >> 1)).or_insert(Children {
                    qef: QefSum::default(),
                    mergeable: true,
                    corner: None,
                });
                p.qef.merge(&node.qef);
                p.mergeable &= node.mergeable;
                if let Some(c) = node.corner {
                    match p.corner {
                        None => p.corner = Some(c),
                        Some(d) if distance(c, d) > 2.0 * CORNER_TOLERANCE => p.mergeable = false,
                        Some(_) => {}
                    }
                }
            }
            let mut next = HashMap::with_capacity(parents.len());
            let mut any = false;
            for (key, Children { qef, mergeable: children, corner }) in parents {
                let origin = key.map(|c| c * s);
                let mut node = Node { qef, vertex: [0.0; 3], mergeable: false, corner: None };
                let within = (0..3).all(|a| u64::from(origin[a]) + u64::from(s) <= u64::from(cells[a]));
                if children && within {
                    if !signs_are_safe(&inside, origin, s) {
                        out.refused_topology += 1;
                    } else {
                        match self.vertex(&qef, origin, s) {
                            Some(x) if corner.is_some_and(|c| distance(c, x) > CORNER_TOLERANCE) => {
                                out.refused_corner += 1;
                            }
                            Some(x) if qef.error(x) <= e * e => {
                                node.vertex = x;
                                node.mergeable = true;
                                node.corner = corner.map(|_| x);
                                any = true;
                            }
                            _ => out.refused_error += 1,
                        }
                    }
                }
                next.insert(key, node);
            }
            levels.push(next);
            if !any {
                break;
            }
        }

        // Polygons: per crossed finest edge at a cell's corner 0, the leaves around it.
        let mirrored = lattice.is_mirrored();
        let mut vertex_of: HashMap<(u32, [u32; 3]), u32> = HashMap::new();
        let mut leaf_levels: Vec<usize> = Vec::new();
        let mut leaf_of = |c: [u32; 3], mesh: &mut Mesh| -> Result<u32> {
            let (mut l, mut key) = (0usize, c);
            while l + 1 < levels.len() && levels[l + 1].get(&key.map(|x| x >> 1)).is_some_and(|n| n.mergeable) {
                l += 1;
                key = key.map(|x| x >> 1);
            }
            if let Some(&v) = vertex_of.get(&(l as u32, key)) {
                return Ok(v);
            }
            let x = levels[l][&key].vertex;
            let v = u32::try_from(mesh.positions.len()).ok().filter(|&v| v < u32::MAX).ok_or(Error::Limit {
                what: "vertices",
                requested: 1 << 32,
                allowed: u64::from(u32::MAX),
            })?;
            let w = lattice.to_world(x);
            mesh.positions.push([w[0] as f32, w[1] as f32, w[2] as f32]);
            if normals {
                let n = (vol.gradient_at(x) * iso.sign()).normalize_or_zero();
                mesh.normals.push([n.x, n.y, n.z]);
            }
            vertex_of.insert((l as u32, key), v);
            if leaf_levels.len() <= l {
                leaf_levels.resize(l + 1, 0);
            }
            leaf_levels[l] += 1;
            Ok(v)
        };
        let mut mesh = Mesh::default();
        for &(ijk, d) in &finest {
            let crossed = CASE_EDGES[case_of(&d) as usize];
            for axis in 0..3 {
                let (edge, around) = super::surface_nets::around_edge(axis);
                if crossed & (1 << edge.0) == 0 {
                    continue;
                }
                let cells_around: Option<Vec<[u32; 3]>> = around
                    .iter()
                    .map(|o| {
                        let c = [0, 1, 2].map(|a| i64::from(ijk[a]) + i64::from(o[a]));
                        c.iter().all(|&x| x >= 0).then(|| c.map(|x| x as u32))
                    })
                    .collect();
                // A cell beyond the lattice: the edge lies on its boundary, no polygon.
                let Some(cells_around) = cells_around else { continue };
                let mut q = [0u32; 4];
                for (slot, &c) in q.iter_mut().zip(&cells_around) {
                    *slot = leaf_of(c, &mut mesh)?;
                }
                // Outward is towards the edge's outside end: +axis when its origin is inside.
                let q = if (d[0] < 0.0) != mirrored { q } else { [q[0], q[3], q[2], q[1]] };
                // Leaves repeat only next to each other around an edge (a cube holding two
                // diagonal cells holds all four).
                let mut ring: Vec<u32> = Vec::with_capacity(4);
                for (i, &v) in q.iter().enumerate() {
                    // All four equal: none kept (the edge lies inside one leaf).
                    if v != q[(i + 3) % 4] {
                        ring.push(v);
                    }
                }
                match ring.len() {
                    4 if self.dc.quads => mesh.quads.push([ring[0], ring[1], ring[2], ring[3]]),
                    4 => {
                        let p = [ring[0], ring[1], ring[2], ring[3]].map(|v| mesh.positions[v as usize]);
                        for t in split_quad([ring[0], ring[1], ring[2], ring[3]], p) {
                            mesh.triangles.push(t);
                        }
                    }
                    3 => mesh.triangles.push([ring[0], ring[1], ring[2]]),
                    _ => {}
                }
            }
        }
        out.mesh = mesh;
        out.leaves = leaf_levels;
        Ok(out)
    }

    /// A merged node's vertex (lattice index coordinates): the QEF's minimiser, `None` when it
    /// leaves the node's cube `origin ..= origin + s` (planes meeting beyond the cube: a corner
    /// or crease of a neighbour; the mass point there cut creases by up to 0.4 h at E = 0.5).
    fn vertex(&self, qef: &QefSum, origin: [u32; 3], s: u32) -> Option<[f64; 3]> {
        let lo = origin.map(f64::from);
        let hi = lo.map(|x| x + f64::from(s));
        let sol = qef.qef.solve(f64::from(self.dc.truncation))?;
        (0..3).all(|a| sol.point[a] >= lo[a] && sol.point[a] <= hi[a]).then_some(sol.point)
    }
}

/// Euclidean distance in lattice index coordinates.
fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt()
}

/// Whether a cell case's contour is one disk: its inside corners are connected along cube
/// edges, and so are its outside ones (no ambiguous face then; 0 and 255 have no contour).
pub fn manifold_case(case: u8) -> bool {
    case != 0 && case != 255 && connected(case) && connected(!case)
}

/// Whether the corners in `set` (bit c = corner c) are connected along cube edges.
fn connected(set: u8) -> bool {
    let start = set & set.wrapping_neg();
    let mut reached = start;
    loop {
        let mut grown = reached;
        for c in 0..8u8 {
            if reached >> c & 1 == 1 {
                // Neighbours along x, y, z: flip one bit of the corner number.
                for b in [1u8, 2, 4] {
                    grown |= 1 << (c ^ b);
                }
            }
        }
        grown &= set;
        if grown == reached {
            return reached == set;
        }
        reached = grown;
    }
}

/// \[Ju02\] §4.2's sign tests on the cube `origin + [0, s]³` (`s` even): its corners' case
/// manifold, and each edge midpoint, face centre and the centre of the class of at least one
/// corner of its edge, face, cube.
fn signs_are_safe(inside: &impl Fn([u32; 3]) -> bool, origin: [u32; 3], s: u32) -> bool {
    let half = s / 2;
    // The 27 points by their offsets in half sides (0, 1, 2 per axis).
    let at = |o: [u32; 3]| inside([0, 1, 2].map(|a| origin[a] + o[a] * half));
    let corner = |c: usize| CORNER_OFFSETS[c].map(|x| 2 * x);
    let mut case = 0u8;
    for c in 0..8 {
        case |= u8::from(at(corner(c))) << c;
    }
    if !manifold_case(case) {
        return false;
    }
    let class = |c: usize| case >> c & 1 == 1;
    for e in 0..12u8 {
        let [a, b] = CubeEdge(e).corners().map(usize::from);
        let mid = [0, 1, 2].map(|i| (corner(a)[i] + corner(b)[i]) / 2);
        let m = at(mid);
        if m != class(a) && m != class(b) {
            return false;
        }
    }
    for axis in 0..3 {
        for side in 0..2u32 {
            let mut centre = [1, 1, 1];
            centre[axis] = 2 * side;
            let m = at(centre);
            if !(0..8).any(|c| CORNER_OFFSETS[c][axis] == side && class(c) == m) {
                return false;
            }
        }
    }
    let m = at([1, 1, 1]);
    (0..8).any(|c| class(c) == m)
}

/// A finest cell as [`DualContouring::fit`] sees it: its values and the volume's Hermite data
/// (as a walker gives them), which it keeps for the cell's QEF.
struct FitCell<'a, V: ?Sized> {
    vol: &'a V,
    iso: Iso,
    ijk: [u32; 3],
    probe: ProbeCell,
    planes: [Option<Hermite>; 12],
}

impl<'a, V: Volume + ?Sized> FitCell<'a, V> {
    fn new(vol: &'a V, iso: Iso, ijk: [u32; 3], d: [f32; 8]) -> Self {
        FitCell { vol, iso, ijk, probe: ProbeCell::new(ijk, d), planes: [None; 12] }
    }
}

impl<V: Volume + ?Sized> Cell for FitCell<'_, V> {
    fn ijk(&self) -> [u32; 3] {
        self.ijk
    }
    fn values(&self) -> &[f32; 8] {
        self.probe.values()
    }
    fn case(&self) -> u8 {
        self.probe.case()
    }
    fn hermite(&mut self, e: CubeEdge) -> Hermite {
        if let Some(h) = self.planes[e.0 as usize] {
            return h;
        }
        let [c0, c1] = e.corners();
        let d = self.probe.values();
        let h =
            edge_hermite(self.vol, EdgeKey::of_cell(self.ijk, e), d[c0 as usize], d[c1 as usize], self.iso).on_edge(e);
        self.planes[e.0 as usize] = Some(h);
        h
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
    fn point_value(&mut self, p: CellPoint) -> f32 {
        self.probe.point_value(p)
    }
    fn segment_vertex(&mut self, a: CellPoint, b: CellPoint) -> VertexId {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// One disk per case exactly where marching cubes makes one connected patch without an
    /// ambiguous face: single corners, edges and faces are; opposite corners, face diagonals
    /// and the tetrahedral pattern are not.
    #[test]
    fn manifold_cases_are_those_with_connected_classes() {
        assert!(manifold_case(0x01) && manifold_case(0x03) && manifold_case(0x0f) && manifold_case(0xfe));
        assert!(!manifold_case(0x00) && !manifold_case(0xff));
        // Corners 0 and 7: opposite; 0 and 3: a face diagonal; 0, 3, 5, 6: the tetrahedral case.
        assert!(!manifold_case(0x81) && !manifold_case(0x09) && !manifold_case(0x69));
        // Complements agree.
        for case in 0..=255u8 {
            assert_eq!(manifold_case(case), manifold_case(!case), "{case:#x}");
        }
        // A plane cutting the cube (inside below x + 2y + 4z = t) is always one disk.
        for t in 1..8 {
            let case = (0..8u8).filter(|&c| c < t).fold(0u8, |m, c| m | 1 << c);
            assert!(manifold_case(case), "{case:#x}");
        }
    }

    #[test]
    fn adaptivity_is_held_in_millionths_and_checked() {
        assert_eq!(Adaptivity::from_cells(0.25).unwrap().cells(), 0.25);
        assert!(Adaptivity::from_cells(0.0).unwrap().is_uniform());
        for bad in [-0.1, f64::NAN, f64::INFINITY, 1000.5] {
            assert!(Adaptivity::from_cells(bad).is_err(), "{bad}");
        }
    }

    /// The sign tests see a feature between the corners: a midpoint, face centre or centre of
    /// the other class than its corners refuses the merge; a plane does not.
    #[test]
    fn sign_tests_refuse_hidden_features() {
        let plane = |p: [u32; 3]| p[0] + p[1] < 3;
        assert!(signs_are_safe(&plane, [0; 3], 2));
        // A ball around the centre, the corners outside: refused.
        assert!(!signs_are_safe(&|p: [u32; 3]| p == [1, 1, 1], [0; 3], 2));
        // The plane with one edge midpoint flipped (a bump crossing edge 0 twice).
        let bump = |p: [u32; 3]| if p == [1, 0, 2] { !plane(p) } else { plane(p) };
        assert!(!signs_are_safe(&bump, [0; 3], 2));
        // A face centre flipped against all its corners (x = 0 face: all inside).
        let dent = |p: [u32; 3]| if p == [0, 1, 1] { false } else { plane(p) };
        assert!(!signs_are_safe(&dent, [0; 3], 2));
    }
}
