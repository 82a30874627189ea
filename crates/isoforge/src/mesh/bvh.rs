//! A bounding volume hierarchy over boxes (a mesh's triangles): the one spatial index of the
//! library, for nearest-triangle queries, box overlaps and the hierarchical sums of fast winding
//! numbers (`voxelize`).
//!
//! Built top-down by splitting at the median centroid along the widest axis of the centroids'
//! box, so it is balanced (depth ⌈log₂(n / LEAF_ITEMS)⌉) and deterministic. Nodes are stored in
//! depth-first order: a node's left child follows it, its right child is at `right`.

use crate::math::Aabb;

/// Items per leaf at most.
pub const LEAF_ITEMS: usize = 4;

/// One node: its box, and either its items (`order[first..first + count]`) or its children.
#[derive(Debug, Clone, Copy)]
pub struct BvhNode {
    /// The box of everything below.
    pub bounds: Aabb,
    /// Leaf: index of its first item in [`Bvh::order`]; inner node: index of its right child.
    first: u32,
    /// Number of items of a leaf; 0 for an inner node.
    count: u32,
}

impl BvhNode {
    /// True for a leaf.
    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// The hierarchy. Items are numbered as in the boxes given to [`Bvh::build`].
#[derive(Debug, Clone, Default)]
pub struct Bvh {
    nodes: Vec<BvhNode>,
    order: Vec<u32>,
}

impl Bvh {
    /// Builds the hierarchy of `boxes` (an empty one when there are none).
    pub fn build(boxes: &[Aabb]) -> Self {
        let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
        let centres: Vec<[f64; 3]> = boxes.iter().map(|b| [0, 1, 2].map(|a| 0.5 * (b.min[a] + b.max[a]))).collect();
        let mut nodes = Vec::with_capacity(2 * boxes.len().div_ceil(LEAF_ITEMS));
        if !boxes.is_empty() {
            split(boxes, &centres, &mut order, 0, &mut nodes);
        }
        Bvh { nodes, order }
    }

    /// The nodes, root first (empty for no items).
    pub fn nodes(&self) -> &[BvhNode] {
        &self.nodes
    }

    /// The children of inner node `n` (indices into [`nodes`](Bvh::nodes)).
    #[inline]
    pub fn children(&self, n: usize) -> [usize; 2] {
        debug_assert!(!self.nodes[n].is_leaf());
        [n + 1, self.nodes[n].first as usize]
    }

    /// The items of leaf `n`.
    #[inline]
    pub fn items(&self, n: usize) -> &[u32] {
        let node = &self.nodes[n];
        &self.order[node.first as usize..(node.first + node.count) as usize]
    }

    /// The items of every leaf below node `n` (inner or leaf), contiguous in build order.
    pub fn items_below(&self, n: usize) -> &[u32] {
        // The leftmost and rightmost leaves bound the node's contiguous run of items.
        let (mut lo, mut hi) = (n, n);
        while !self.nodes[lo].is_leaf() {
            lo += 1;
        }
        while !self.nodes[hi].is_leaf() {
            hi = self.nodes[hi].first as usize;
        }
        let end = self.nodes[hi].first + self.nodes[hi].count;
        &self.order[self.nodes[lo].first as usize..end as usize]
    }

    /// The item nearest to `p` and its squared distance, for items within `sqrt(max_d2)`:
    /// `item_d2(i)` is the exact squared distance from `p` to item `i`. Boxes prune, closer child
    /// first; ties keep the lower item index, so the answer is deterministic.
    pub fn nearest(&self, p: [f64; 3], max_d2: f64, item_d2: &mut dyn FnMut(u32) -> f64) -> Option<(u32, f64)> {
        let mut best: Option<(u32, f64)> = None;
        let mut bound = max_d2;
        if self.nodes.is_empty() || box_d2(&self.nodes[0].bounds, p) > bound {
            return None;
        }
        // A balanced tree is at most ~log₂(n) deep and this search keeps one pending sibling
        // per level: 64 slots hold any tree of up to 2⁶⁴ items.
        let mut stack = [0usize; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let n = stack[top];
            if box_d2(&self.nodes[n].bounds, p) > bound {
                continue;
            }
            if self.nodes[n].is_leaf() {
                for &i in self.items(n) {
                    let d2 = item_d2(i);
                    let better = match best {
                        None => d2 <= bound,
                        Some((j, b)) => d2 < b || (d2 == b && i < j),
                    };
                    if better {
                        best = Some((i, d2));
                        bound = d2;
                    }
                }
                continue;
            }
            let [a, b] = self.children(n);
            let (da, db) = (box_d2(&self.nodes[a].bounds, p), box_d2(&self.nodes[b].bounds, p));
            // Push the farther child first so the nearer one is searched first.
            let (near, far, dfar) = if da <= db { (a, b, db) } else { (b, a, da) };
            if dfar <= bound {
                stack[top] = far;
                top += 1;
            }
            stack[top] = near;
            top += 1;
        }
        best
    }

    /// Calls `f(i)` for every item of the leaves whose box overlaps `query` (closed boxes): a
    /// superset of the items whose own box does, which the caller tests exactly.
    pub fn candidates(&self, query: &Aabb, f: &mut dyn FnMut(u32)) {
        if self.nodes.is_empty() {
            return;
        }
        // Depth first, one pending sibling per level: 64 slots hold any balanced tree (see
        // `nearest`), and no allocation per query.
        let mut stack = [0usize; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let n = stack[top];
            if !overlaps(&self.nodes[n].bounds, query) {
                continue;
            }
            if self.nodes[n].is_leaf() {
                self.items(n).iter().for_each(|&i| f(i));
            } else {
                let [a, b] = self.children(n);
                stack[top] = b;
                stack[top + 1] = a;
                top += 2;
            }
        }
    }
}

/// Appends the subtree over `order[lo..]` (its slice) to `nodes`, depth first.
fn split(boxes: &[Aabb], centres: &[[f64; 3]], order: &mut [u32], offset: usize, nodes: &mut Vec<BvhNode>) {
    let mut bounds = Aabb::EMPTY;
    let mut cbox = Aabb::EMPTY;
    for &i in order.iter() {
        let b = &boxes[i as usize];
        bounds.add(b.min);
        bounds.add(b.max);
        cbox.add(centres[i as usize]);
    }
    let at = nodes.len();
    if order.len() <= LEAF_ITEMS {
        nodes.push(BvhNode { bounds, first: offset as u32, count: order.len() as u32 });
        return;
    }
    nodes.push(BvhNode { bounds, first: 0, count: 0 });
    let size = cbox.size();
    let axis = (0..3).max_by(|&a, &b| size[a].total_cmp(&size[b]).then(b.cmp(&a))).unwrap_or(0);
    let mid = order.len() / 2;
    // Median by centre along the axis; ties by index so the split does not depend on the sort.
    order.select_nth_unstable_by(mid, |&a, &b| {
        centres[a as usize][axis].total_cmp(&centres[b as usize][axis]).then(a.cmp(&b))
    });
    let (left, right) = order.split_at_mut(mid);
    split(boxes, centres, left, offset, nodes);
    nodes[at].first = nodes.len() as u32;
    split(boxes, centres, right, offset + mid, nodes);
}

/// Squared distance from `p` to the box (0 inside).
#[inline]
pub fn box_d2(b: &Aabb, p: [f64; 3]) -> f64 {
    let mut d2 = 0.0;
    for a in 0..3 {
        let d = (b.min[a] - p[a]).max(p[a] - b.max[a]).max(0.0);
        d2 += d * d;
    }
    d2
}

#[inline]
fn overlaps(a: &Aabb, b: &Aabb) -> bool {
    (0..3).all(|k| a.min[k] <= b.max[k] && b.min[k] <= a.max[k])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point_boxes(n: usize) -> Vec<Aabb> {
        // A deterministic scatter (a low-discrepancy sequence), each point a degenerate box.
        (0..n)
            .map(|i| {
                let p = [0.618_033_99, 0.754_877_67, 0.569_840_29].map(|g| (i as f64 * g).fract());
                Aabb { min: p, max: p }
            })
            .collect()
    }

    #[test]
    fn nearest_agrees_with_brute_force_and_every_item_is_in_one_leaf() {
        let boxes = point_boxes(1000);
        let bvh = Bvh::build(&boxes);
        let mut seen = bvh.items_below(0).to_vec();
        seen.sort_unstable();
        assert_eq!(seen, (0..1000).collect::<Vec<u32>>());
        for q in point_boxes(1200).iter().skip(1000) {
            let p = q.min.map(|v| v * 1.1 - 0.05);
            let mut d2 = |i: u32| box_d2(&boxes[i as usize], p);
            let got = bvh.nearest(p, f64::INFINITY, &mut d2).unwrap();
            let want =
                (0..1000u32).map(|i| (i, box_d2(&boxes[i as usize], p))).min_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
            assert_eq!(got, want);
            // Nothing within a radius smaller than the nearest.
            assert_eq!(bvh.nearest(p, want.1 * 0.99, &mut d2), None);
        }
    }

    #[test]
    fn candidates_hold_every_box_in_a_query_and_few_others() {
        let boxes = point_boxes(500);
        let bvh = Bvh::build(&boxes);
        let q = Aabb { min: [0.2, 0.1, 0.3], max: [0.6, 0.5, 0.9] };
        let mut got = Vec::new();
        bvh.candidates(&q, &mut |i| got.push(i));
        got.sort_unstable();
        let want: Vec<u32> = (0..500u32).filter(|&i| overlaps(&boxes[i as usize], &q)).collect();
        assert!(!want.is_empty());
        assert!(want.iter().all(|i| got.binary_search(i).is_ok()));
        assert!(got.len() < 3 * want.len(), "{} candidates for {}", got.len(), want.len());
        assert!(Bvh::build(&[]).nearest([0.0; 3], 1.0, &mut |_| 0.0).is_none());
    }
}
