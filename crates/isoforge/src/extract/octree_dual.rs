//! Dual contouring of a signed octree \[Ju02\] with its stored vertices: the surface PolyMender's
//! and TopoMender's `.sog` files describe \[Ju04\].
//!
//! In: a [`SignedOctree`] (its leaves' vertices and the signs at its points). Out: a [`Mesh`] of
//! quads, one per finest-level edge whose ends differ in sign, joining the vertices of the four
//! leaf cells around it (the same quad as [`SurfaceNets`](super::SurfaceNets), built by the same
//! `surface_nets::around_edge`), wound counter-clockwise seen from outside.

use super::surface_nets::around_edge;
use crate::grid::SignedOctree;
use crate::mesh::Mesh;

/// What [`contour_octree`] made, and the edges it could not close.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OctreeContour {
    /// One vertex per leaf that a quad uses (in leaf pre-order), one quad per crossed edge.
    pub mesh: Mesh,
    /// Crossed edges without a quad: on the root cube's faces (fewer than four cells) or beside
    /// a cell that is not a leaf (only in trees whose nodes disagree on a point's sign). Each
    /// leaves a hole that [`crate::topo::check`] reports as boundary edges.
    pub open_edges: usize,
}

/// Contours `tree`: for every finest-level edge whose two ends differ in sign
/// ([`SignedOctree::corner_outside`]), a quad through the vertices of the four leaves around it.
///
/// **Guarantees**: quads; closed and consistently oriented (normals from inside to outside) when
/// the tree's nodes agree on every point's sign and the surface does not reach the root cube's
/// faces — each crossed edge has four leaf cells around it (a cell with a sign change is a leaf)
/// and gets exactly one quad, and dual edges are shared by exactly two quads.
///
/// **Limits**: as every dual method with one vertex per cell, not manifold where one cell holds
/// two sheets of the surface (a vertex shared by two fans; possibly an edge shared by four
/// quads); quads are not planar. Leaves without a crossed edge (PolyMender keeps cells the
/// surface grazes) make no vertex.
pub fn contour_octree(tree: &SignedOctree) -> OctreeContour {
    const NONE: u32 = u32::MAX;
    let dim = tree.dim();
    let mut out = OctreeContour::default();
    // The mesh vertex of each leaf, by pre-order index; made when a quad first needs it.
    let leaf_index: std::collections::HashMap<[u32; 3], usize> =
        tree.leaves().enumerate().map(|(i, l)| (l.ijk, i)).collect();
    let leaves: Vec<_> = tree.leaves().copied().collect();
    let mut vertex_of = vec![NONE; leaves.len()];
    let leaf_near = |p: [u32; 3], o: [i8; 3]| {
        let cell = [0, 1, 2].map(|a| p[a].wrapping_add_signed(i32::from(o[a])));
        cell.iter().all(|&c| c < dim).then(|| leaf_index.get(&cell).copied()).flatten()
    };
    for (me, leaf) in leaves.iter().enumerate() {
        for axis in 0..3 {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let (_, around) = around_edge(axis);
            // The leaf's four edges along `axis`; each edge is handled by the first leaf around
            // it (in `around` order), so once, including edges on the root cube's faces.
            for (du, dv) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let mut p0 = leaf.ijk;
                p0[u] += du;
                p0[v] += dv;
                let cells = around.map(|o| leaf_near(p0, o));
                if cells.iter().flatten().next() != Some(&me) {
                    continue;
                }
                let mut p1 = p0;
                p1[axis] += 1;
                let inside0 = !tree.corner_outside(p0);
                if inside0 != tree.corner_outside(p1) {
                    continue;
                }
                if cells.iter().any(Option::is_none) {
                    out.open_edges += 1;
                    continue;
                }
                let quad = cells.map(|i| {
                    let i = i.unwrap_or(me);
                    if vertex_of[i] == NONE {
                        vertex_of[i] = out.mesh.positions.len() as u32;
                        out.mesh.positions.push(leaves[i].vertex);
                    }
                    vertex_of[i]
                });
                // Outward is towards the edge's outside end: +axis when its origin is inside.
                if inside0 {
                    out.mesh.quads.push(quad);
                } else {
                    out.mesh.quads.push([quad[0], quad[3], quad[2], quad[1]]);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topo;

    /// The tree of a solid torus (radii `big`, `small`, in cells, about the centre, axis z),
    /// vertices at cell centres.
    fn torus(depth: u32, big: f64, small: f64) -> SignedOctree {
        let c = (1u32 << depth) as f64 / 2.0;
        let inside = move |p: [u32; 3]| {
            let [x, y, z] = p.map(|v| v as f64 - c);
            let q = (x * x + y * y).sqrt() - big;
            q * q + z * z < small * small
        };
        let vertex = move |ijk: [u32; 3]| {
            let s: u32 =
                (0..8).map(|c| inside([ijk[0] + (c >> 2 & 1), ijk[1] + (c >> 1 & 1), ijk[2] + (c & 1)]) as u32).sum();
            (s != 0 && s != 8).then(|| ijk.map(|x| x as f32 + 0.5))
        };
        SignedOctree::from_cells(depth, [0.0; 3], (1u32 << depth) as f32, &|p| !inside(p), &vertex).unwrap()
    }

    #[test]
    fn a_torus_contours_to_a_closed_oriented_genus_one_surface() {
        let out = contour_octree(&torus(5, 9.0, 4.0));
        let r = topo::check(&out.mesh);
        assert_eq!(out.open_edges, 0);
        assert!(r.is_closed() && r.is_oriented(), "{r:?}");
        assert_eq!(r.genus(), Some(1));
        assert!(r.volume > 0.0, "normals point inwards: volume {}", r.volume);
    }

    #[test]
    fn a_surface_reaching_the_root_faces_leaves_open_edges() {
        let everything_inside = SignedOctree::from_cells(1, [0.0; 3], 2.0, &|p| p == [2, 1, 1], &|c| {
            (c[0] == 1).then_some([c[0] as f32 + 0.5, c[1] as f32 + 0.5, c[2] as f32 + 0.5])
        })
        .unwrap();
        let out = contour_octree(&everything_inside);
        // One quad (the x edge from [1, 1, 1]); the four other edges at [2, 1, 1] lie on the root's face.
        assert_eq!((out.mesh.quads.len(), out.open_edges), (1, 4));
    }
}
