//! The skeleton a thinning leaves, as a weighted graph, and its loops: the edges a maximum
//! spanning tree leaves out.
//!
//! Points are the graph's nodes and edges its edges, each weighted by `size` (the area of the
//! disc the solid holds around it); an edge that still bounds a face (thinning can stop at a 2D
//! sheet) weighs infinity, so it is never taken for a loop. A maximum spanning tree (Kruskal,
//! heaviest first, ties by element) keeps the thickest path between any two points; every edge
//! it leaves out closes one independent cycle — a handle of the complex — at its thinnest.

use std::collections::HashMap;

use super::complex::CellComplex;
use crate::math::UnionFind;

/// One edge of a skeleton.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SkeletonEdge {
    /// The edge's element in the complex.
    pub element: usize,
    /// Its two points' elements.
    pub ends: [usize; 2],
    /// Its size (infinite while it bounds a face).
    pub weight: f64,
    /// Whether the maximum spanning tree leaves it out: it closes a loop.
    pub closes_loop: bool,
}

/// A thinned complex's edges, with those closing loops marked, in a deterministic order.
pub fn spanning_loops(c: &CellComplex, size: impl Fn(usize) -> f64) -> Vec<SkeletonEdge> {
    let mut edges = Vec::new();
    let mut node: HashMap<usize, u32> = HashMap::new();
    for i in 0..c.len() {
        if !c.contains(i) || c.dimension(i) != 1 {
            continue;
        }
        let (bounds_face, _) = c.present_cofaces(i);
        let w = if bounds_face > 0 { f64::INFINITY } else { size(i) };
        let mut ends = [0; 2];
        for (k, (p, _)) in c.faces(i).enumerate() {
            ends[k] = p;
            let next = node.len() as u32;
            node.entry(p).or_insert(next);
        }
        edges.push(SkeletonEdge { element: i, ends, weight: w, closes_loop: false });
    }
    let mut order: Vec<usize> = (0..edges.len()).collect();
    order.sort_by(|&a, &b| edges[b].weight.total_cmp(&edges[a].weight).then(edges[a].element.cmp(&edges[b].element)));
    let mut sets = UnionFind::new(node.len());
    for k in order {
        let e = &mut edges[k];
        let [a, b] = e.ends.map(|p| node[&p]);
        e.closes_loop = sets.union(a, b).is_none();
    }
    edges
}

#[cfg(test)]
mod tests {
    use super::super::distance::squared_distance_to_absent;
    use super::super::thin::thin;
    use super::*;

    #[test]
    fn two_rings_of_different_thickness_give_two_loops_with_their_sizes() {
        // Two disjoint square rings in one box: cross-sections 1×1 and 3×3 points.
        let n = 30;
        let solid: Vec<bool> = (0..n * n * n)
            .map(|i| {
                let p = [i % n, i / n % n, i / (n * n)];
                let ring = |lo: usize, side: usize, w: usize, z0: usize| {
                    let in_box = |a: usize, b: usize| (a..b).contains(&p[0]) && (a..b).contains(&p[1]);
                    (z0..z0 + w).contains(&p[2]) && in_box(lo, lo + side) && !in_box(lo + w, lo + side - w)
                };
                ring(2, 10, 1, 2) || ring(14, 14, 3, 10)
            })
            .collect();
        let mut c = CellComplex::of_solid([n; 3], &solid);
        let d2 = squared_distance_to_absent(&c, [0.5; 3]);
        thin(&mut c, false);
        let edges = spanning_loops(&c, |e| std::f64::consts::PI * d2[e] as f64);
        let mut loops: Vec<f64> = edges.iter().filter(|e| e.closes_loop).map(|e| e.weight).collect();
        loops.sort_by(f64::total_cmp);
        assert_eq!(loops.len(), 2, "{loops:?}");
        // Half a spacing around a ring one point thick; more than a spacing around a 3 × 3 tube
        // (1.5 at its middle, less where the cycle turns a corner off the middle).
        assert_eq!(loops[0], std::f64::consts::PI * 0.25);
        assert!(loops[1] >= std::f64::consts::PI * 1.25, "{loops:?}");
    }
}
