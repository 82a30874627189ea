//! Naive surface nets \[Gibson98\]: the simplest dual method, and the reference user of the dual
//! contracts (placed vertices, neighbours' vertices, quads) that dual contouring and extended
//! marching cubes build on.

use super::Extractor;
use crate::cube::{CubeEdge, CASE_EDGES};
use crate::extract::Cell;

/// Surface nets: one vertex per active cell at the mean of its edge crossings (the volume's
/// crossings, [`Cell::crossing`]: the points marching cubes' vertices sit on), and for every
/// crossed lattice edge a quad joining the vertices of the four cells around it.
///
/// **Guarantees**: quads (`Mesh::triangulate` splits them); closed when the surface stays inside
/// the lattice (every crossed interior edge gets exactly one quad, shared edges are the dual
/// edges between neighbouring cells), consistently oriented (counter-clockwise seen from outside).
///
/// **Limits**: not manifold where one cell holds two sheets of the surface (they share its single
/// vertex); vertices are not on the surface (mean of crossings), so shapes are smoothed and sharp
/// features are cut; open along the lattice's faces (edges there have fewer than four cells).
#[derive(Debug, Clone, Copy, Default)]
pub struct SurfaceNets;

impl Extractor for SurfaceNets {
    const PLACES_VERTICES: bool = true;

    fn place<C: Cell>(&self, cell: &mut C) {
        let crossed = CASE_EDGES[cell.case() as usize];
        let (mut sum, mut n) = ([0.0f32; 3], 0.0f32);
        for e in 0..12u8 {
            if crossed & (1 << e) == 0 {
                continue;
            }
            // The volume's crossing (the one edge vertices sit on), in the cell's frame.
            let p = cell.crossing(CubeEdge(e));
            for (s, x) in sum.iter_mut().zip(p) {
                *s += x;
            }
            n += 1.0;
        }
        cell.place_vertex(sum.map(|s| s / n), crossed);
    }

    fn process<C: Cell>(&self, cell: &mut C) {
        let d = *cell.values();
        let crossed = CASE_EDGES[cell.case() as usize];
        for axis in 0..3 {
            let (e, around) = around_edge(axis);
            if crossed & (1 << e.0) == 0 {
                continue;
            }
            let mut q = [crate::mesh::VertexId::NONE; 4];
            // A missing cell: the edge lies on the lattice's boundary, no quad.
            if !around.iter().zip(q.iter_mut()).all(|(&o, slot)| cell.placed_vertex(o, e).map(|v| *slot = v).is_some())
            {
                continue;
            }
            // Outward is towards the edge's outside end: +axis when its origin (corner 0) is inside.
            if d[0] < 0.0 {
                cell.push_quad(q);
            } else {
                cell.push_quad([q[0], q[3], q[2], q[1]]);
            }
        }
    }
}

/// The cell's edge along `axis` at corner 0 (edge 4 · axis) and the offsets of the four cells
/// around it: 0 or −1 on the two other axes u, v (u × v = axis), counter-clockwise seen from the
/// axis' positive side — the cells whose vertices make a dual method's quad for that edge.
pub(crate) fn around_edge(axis: usize) -> (CubeEdge, [[i8; 3]; 4]) {
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let offset = |du: i8, dv: i8| {
        let mut o = [0i8; 3];
        o[u] = du;
        o[v] = dv;
        o
    };
    (CubeEdge(4 * axis as u8), [offset(-1, -1), offset(0, -1), offset(0, 0), offset(-1, 0)])
}
