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

/// A loop that only a sheet left by thinning holds (the outside of a knotted solid cannot thin
/// to a graph: its spine is two-dimensional): a loop-closing edge of the skeleton's graph that
/// no combination of the remaining faces' boundaries cancels, with a cocycle dual to it.
#[derive(Debug, Clone, PartialEq)]
pub struct SheetLoop {
    /// The loop-closing edge (an element) standing for the loop.
    pub element: usize,
    /// The edges (elements) of a cocycle that is 1 on this loop and 0 on every other loop of
    /// the skeleton: it vanishes on every remaining face's boundary, so it pulls back through
    /// the collapses like an edge's indicator does on a graph.
    pub cocycle: Vec<usize>,
}

/// The loops held by sheets: among the loop-closing edges of `edges` that bound a face (weight
/// infinite), those independent of the faces' boundaries (mod 2, one column reduction over the
/// faces in element order), each with its dual cocycle.
pub fn sheet_loops(c: &CellComplex, edges: &[SkeletonEdge]) -> Vec<SheetLoop> {
    // The closing edges on sheets, numbered in element order; a face's boundary in the basis
    // of fundamental cycles is the set of its closing edges (tree edges add nothing).
    // Edges on the grid's border are numbered last, so they are the ones the faces cancel and a
    // loop is represented where it runs, not out at the border.
    let mut closing: Vec<usize> =
        edges.iter().filter(|e| e.closes_loop && e.weight == f64::INFINITY).map(|e| e.element).collect();
    closing.sort_by_key(|&e| (c.on_border(e), e));
    if closing.is_empty() {
        return Vec::new();
    }
    let number: HashMap<usize, u32> = closing.iter().enumerate().map(|(k, &e)| (e, k as u32)).collect();
    let mut reduced: HashMap<u32, Vec<u32>> = HashMap::new();
    for f in 0..c.len() {
        if !c.contains(f) || c.dimension(f) != 2 {
            continue;
        }
        let mut col: Vec<u32> = c.faces(f).filter_map(|(e, _)| number.get(&e).copied()).collect();
        col.sort_unstable();
        while let Some(&low) = col.last() {
            match reduced.get(&low) {
                Some(other) => col = symmetric_difference(&col, other),
                None => {
                    reduced.insert(low, col);
                    break;
                }
            }
        }
    }
    let survivors: Vec<u32> = (0..closing.len() as u32).filter(|k| !reduced.contains_key(k)).collect();
    let mut pivots: Vec<u32> = reduced.keys().copied().collect();
    pivots.sort_unstable();
    survivors
        .iter()
        .map(|&s| {
            // 1 on `s`, 0 on the other survivors; each pivot's value makes its reduced column
            // (whose other entries are lower) sum to 0, so every face's boundary sums to 0.
            let mut value = vec![false; closing.len()];
            value[s as usize] = true;
            for &p in &pivots {
                value[p as usize] =
                    reduced[&p].iter().filter(|&&j| j != p).fold(false, |acc, &j| acc ^ value[j as usize]);
            }
            SheetLoop {
                element: closing[s as usize],
                cocycle: (0..closing.len()).filter(|&k| value[k]).map(|k| closing[k]).collect(),
            }
        })
        .collect()
}

/// The symmetric difference of two sorted lists.
fn symmetric_difference(a: &[u32], b: &[u32]) -> Vec<u32> {
    let (mut i, mut j, mut out) = (0, 0, Vec::with_capacity(a.len() + b.len()));
    while i < a.len() || j < b.len() {
        match (a.get(i), b.get(j)) {
            (Some(x), Some(y)) if x == y => {
                i += 1;
                j += 1;
            }
            (Some(x), Some(y)) if x < y => {
                out.push(*x);
                i += 1;
            }
            (Some(_), Some(y)) => {
                out.push(*y);
                j += 1;
            }
            (Some(x), None) => {
                out.push(*x);
                i += 1;
            }
            (None, Some(y)) => {
                out.push(*y);
                j += 1;
            }
            (None, None) => unreachable!(),
        }
    }
    out
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

    #[test]
    fn a_knots_outside_keeps_sheets_and_its_one_loop_is_found_there_with_a_cocycle() {
        // A trefoil tube on 40³ points.
        let n = 40;
        let solid: Vec<bool> = (0..n * n * n)
            .map(|i| {
                let p = [i % n, i / n % n, i / (n * n)].map(|v| (v as f64 - 19.5) / 6.0);
                (0..1000).any(|k| {
                    let t = k as f64 * std::f64::consts::TAU / 1000.0;
                    let q = [t.sin() + 2.0 * (2.0 * t).sin(), t.cos() - 2.0 * (2.0 * t).cos(), -(3.0 * t).sin()];
                    (0..3).map(|a| (p[a] - q[a]).powi(2)).sum::<f64>() < 0.3f64.powi(2)
                })
            })
            .collect();
        let mut c = CellComplex::dual_of_complement([n; 3], &solid);
        thin(&mut c, true);
        let sheets = (0..c.len()).filter(|&i| c.contains(i) && c.dimension(i) == 2 && !c.on_border(i)).count();
        assert!(sheets > 0, "a knot's outside thins to sheets");
        let edges = spanning_loops(&c, |_| 1.0);
        assert!(edges.iter().all(|e| !e.closes_loop || e.weight.is_infinite()), "no loop on the graph alone");
        let loops = sheet_loops(&c, &edges);
        assert_eq!(loops.len(), 1, "H1 of a knot's outside is Z");
        // A cocycle: even on the boundary of every face left.
        let on: std::collections::HashSet<usize> = loops[0].cocycle.iter().copied().collect();
        assert!(on.contains(&loops[0].element));
        for f in (0..c.len()).filter(|&f| c.contains(f) && c.dimension(f) == 2) {
            assert_eq!(c.faces(f).filter(|(e, _)| on.contains(e)).count() % 2, 0, "face {f}");
        }
    }
}
