//! Single-cell catalogue and analytic counts for classic marching cubes.

mod common;

use common::*;
use isoforge::cube::CASE_EDGES;
use isoforge::topo;
use isoforge::volume::Iso;

/// The 4³ lattice with the central cell (1, 1, 1) set to `case` and everything else outside.
fn embedded(case: u8) -> isoforge::grid::DenseGrid<f32> {
    let mut values = vec![1.0f32; 64];
    for c in 0..8u32 {
        if case >> c & 1 == 1 {
            let (i, j, k) = (1 + (c & 1), 1 + (c >> 1 & 1), 1 + (c >> 2 & 1));
            values[(k * 16 + j * 4 + i) as usize] = -1.0;
        }
    }
    grid([4, 4, 4], values)
}

#[test]
fn all_256_cases_embedded_give_closed_oriented_spheres() {
    for case in 0..=255u8 {
        let g = embedded(case);
        let mesh = mc(&vol(&g), Iso::below(0.0));
        let r = topo::check(&mesh);
        let ctx = format!("case {case} ({case:08b})");
        if case == 0 {
            assert!(mesh.is_empty(), "{ctx}");
            continue;
        }
        assert!(
            r.is_watertight(),
            "{ctx}: boundary {:?} non-manifold {:?} {:?} inconsistent {:?}",
            r.boundary_edges.examples,
            r.non_manifold_edges.examples,
            r.non_manifold_vertices.examples,
            r.inconsistent_edges.examples
        );
        assert_eq!(r.isolated_vertices.count, 0, "{ctx}");
        assert_eq!(r.collapsed_triangles.count + r.zero_area_triangles.count + r.duplicate_triangles.count, 0, "{ctx}");
        for (n, c) in r.components.iter().enumerate() {
            assert_eq!(c.euler, 2, "{ctx}: component {n} has χ = {}", c.euler);
            assert!(c.volume > 0.0, "{ctx}: component {n} is inside out (volume {})", c.volume);
        }
        assert_eq!(mesh.num_vertices(), crossed_edges(&g, 0.0), "{ctx}");
    }
}

#[test]
fn single_cell_vertex_counts_follow_the_edge_table() {
    // Alone in a 2³ lattice (open at the lattice faces), each case has one vertex per crossed edge.
    for case in 0..=255u8 {
        let values = (0..8).map(|c| if case >> c & 1 == 1 { -1.0 } else { 1.0 }).collect();
        let g = grid([2, 2, 2], values);
        let mesh = mc(&vol(&g), Iso::below(0.0));
        assert_eq!(mesh.num_vertices(), CASE_EDGES[case as usize].count_ones() as usize, "case {case}");
        let r = topo::check(&mesh);
        assert!(r.is_manifold() && r.is_oriented(), "case {case}");
    }
}

#[test]
fn one_inside_point_is_an_octahedron() {
    let mut values = vec![1.0f32; 27];
    values[13] = -1.0;
    let g = grid([3, 3, 3], values);
    let mesh = mc(&vol(&g), Iso::below(0.0));
    assert_eq!((mesh.num_vertices(), mesh.num_triangles()), (6, 8));
    let r = topo::check(&mesh);
    assert!(r.is_watertight());
    assert_eq!(r.genus(), Some(0));
    // Vertices at the midpoints: an octahedron of "radius" 0.5, volume 4/3 · 0.5³.
    assert!((r.volume - 4.0 / 3.0 * 0.125).abs() < 1e-6, "{}", r.volume);
}

#[test]
fn solid_block_counts() {
    for n in 1..=6u32 {
        let d = n + 2;
        let g = isoforge::grid::DenseGrid::from_fn(isoforge::grid::Lattice::new([d; 3]).unwrap(), |p| {
            if p.iter().all(|&x| x >= 1 && x <= n) {
                -1.0f32
            } else {
                1.0
            }
        });
        let mesh = mc(&vol(&g), Iso::below(0.0));
        let v = 6 * (n * n) as usize;
        assert_eq!(mesh.num_vertices(), v, "n = {n}");
        assert_eq!(mesh.num_triangles(), 2 * v - 4, "n = {n}");
        let r = topo::check(&mesh);
        assert!(r.is_watertight());
        assert_eq!(r.genus(), Some(0));
    }
}

#[test]
fn ties_count_as_outside() {
    // Values exactly at iso are outside: a point at iso next to an inside point puts the crossing
    // on the tie point itself.
    let mut values = vec![1.0f32; 27];
    values[13] = 0.0;
    let g = grid([3, 3, 3], values.clone());
    assert!(mc(&vol(&g), Iso::below(0.0)).is_empty(), "a lone tie point is outside");
    values[13] = -1.0;
    values[14] = 0.0; // the +x neighbour ties
    let g = grid([3, 3, 3], values);
    let mesh = mc(&vol(&g), Iso::below(0.0));
    assert_eq!(mesh.num_vertices(), 6);
    assert!(mesh.positions.contains(&[2.0, 1.0, 1.0]), "{:?}", mesh.positions);
}
