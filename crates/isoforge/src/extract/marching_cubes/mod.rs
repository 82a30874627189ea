//! Classic marching cubes \[Lorensen87\] with the 256-case table of the Bourke article.

mod table;

pub use table::{CaseTriangles, TRI_TABLE};

use crate::extract::Cell;
use crate::extract::{Counting, Extractor};

/// Marching cubes: each active cell emits the triangles its case lists in [`TRI_TABLE`], on
/// vertices shared through the walker (one per crossed lattice edge).
///
/// **Guarantees**: triangles; the table resolves each ambiguous face the same way from both
/// cells that share it, so the mesh is crack-free, edge- and vertex-manifold and consistently
/// oriented (normals from inside to outside); it is closed when the surface stays inside the
/// lattice, and open only along the lattice's faces otherwise. Every vertex lies on a distinct
/// lattice edge, so the vertex count equals the number of crossed edges.
///
/// **Ambiguous faces** (two inside corners on a diagonal) join the inside corners, the same
/// choice as VTK's tables for inside = below iso, so triangle counts equal `vtkFlyingEdges3D`'s.
///
/// **Limits**: ambiguous faces and cell interiors are not decided by the trilinear interpolant,
/// so components and genus can differ from it (MC33 fixes this); a corner value exactly at iso
/// puts vertices of several edges at that corner, so zero-area triangles can appear (they are kept:
/// removing them would change the connectivity).
#[derive(Debug, Clone, Copy, Default)]
pub struct MarchingCubes;

impl Extractor for MarchingCubes {
    #[inline]
    fn process<C: Cell>(&self, cell: &mut C) {
        for [a, b, c] in TRI_TABLE[cell.case() as usize].iter() {
            let t = [cell.edge_vertex(a), cell.edge_vertex(b), cell.edge_vertex(c)];
            cell.push_triangle(t);
        }
    }

    const COUNTING: Counting = Counting::Known;

    #[inline(always)]
    fn case_triangles(&self, case: u8, _odd: bool) -> Option<&[[u8; 3]]> {
        Some(TRI_TABLE[case as usize].triangles())
    }
}

#[cfg(test)]
mod tests {
    use super::table::{source_case, SOURCE_TRI_TABLE};
    use super::*;
    use crate::cube::{CASE_EDGES, CORNER_OFFSETS, EDGE_CORNERS};

    /// Edge midpoint in cell coordinates.
    fn mid(e: u8) -> [f64; 3] {
        let [a, b] = EDGE_CORNERS[e as usize];
        let (p, q) = (CORNER_OFFSETS[a as usize], CORNER_OFFSETS[b as usize]);
        [0, 1, 2].map(|i| (p[i] + q[i]) as f64 / 2.0)
    }

    #[test]
    fn every_case_uses_exactly_its_crossed_edges() {
        for case in 0..256 {
            let mut used = 0u16;
            for t in TRI_TABLE[case].triangles() {
                for &e in t {
                    used |= 1 << e;
                }
            }
            assert_eq!(
                used, CASE_EDGES[case],
                "case {case}: edges used {used:012b}, crossed {:012b}",
                CASE_EDGES[case]
            );
        }
    }

    #[test]
    fn conversion_preserves_the_source_rows() {
        // Same triangle count per case as the source, and the renumbering is a bijection on cases.
        let mut seen = [false; 256];
        for case in 0..256 {
            let sc = source_case(255 - case);
            assert!(!seen[sc]);
            seen[sc] = true;
            let src_len = SOURCE_TRI_TABLE[sc].iter().take_while(|&&e| e >= 0).count() / 3;
            assert_eq!(TRI_TABLE[case].triangles().len(), src_len, "case {case}");
        }
        // Corner 3 of the source sits at (0, 1, 0) = our corner 2; the triangle around it crosses
        // the edges from (0,1,0) to its three neighbours: ours 1 (x), 4 (y), 10 (z).
        let t = TRI_TABLE[1 << 2].triangles();
        let mut edges = t[0].to_vec();
        edges.sort();
        assert_eq!(edges, vec![1, 4, 10]);
    }

    /// Two inside corners diagonal on a face (everything else outside) are joined across the
    /// ambiguous face: one band, not two caps. This is VTK's choice for `value < iso` inside (its
    /// tables cut between corners at or above iso); see the module docs.
    #[test]
    fn ambiguous_faces_join_inside_corners() {
        use crate::grid::{DenseGrid, Lattice};
        use crate::volume::{GridVolume, Iso};
        let g = DenseGrid::from_fn(Lattice::new([2, 2, 2]).unwrap(), |p| {
            if p == [0, 0, 0] || p == [1, 1, 0] {
                -1.0f32
            } else {
                1.0
            }
        });
        let mc = crate::pipeline::Options { method: crate::pipeline::Method::MarchingCubes, ..Default::default() };
        let m = crate::pipeline::extract(&GridVolume::new(&g), Iso::below(0.0), &mc).unwrap().mesh;
        assert_eq!(crate::topo::check(&m).components.len(), 1);
        // The complement: the two outside corners are cut apart, each capped by its own piece.
        let g = DenseGrid::from_fn(Lattice::new([2, 2, 2]).unwrap(), |p| {
            if p == [0, 0, 0] || p == [1, 1, 0] {
                1.0f32
            } else {
                -1.0
            }
        });
        let m = crate::pipeline::extract(&GridVolume::new(&g), Iso::below(0.0), &mc).unwrap().mesh;
        assert_eq!(crate::topo::check(&m).components.len(), 2);
    }

    #[test]
    fn single_corner_triangles_face_away_from_the_inside_corner() {
        // For each one-corner case, the triangle's right-hand normal points away from the corner.
        for c in 0..8 {
            let t = TRI_TABLE[1 << c].triangles()[0];
            let [a, b, d] = t.map(mid);
            let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let v = [d[0] - a[0], d[1] - a[1], d[2] - a[2]];
            let n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
            let p = CORNER_OFFSETS[c].map(|x| x as f64);
            let away = [a[0] - p[0], a[1] - p[1], a[2] - p[2]];
            assert!(n[0] * away[0] + n[1] * away[1] + n[2] * away[2] > 0.0, "corner {c}");
        }
    }
}
