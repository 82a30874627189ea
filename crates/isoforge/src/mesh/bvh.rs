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
    /// Builds the hierarchy of `boxes` (an empty one when there are none); the two halves of
    /// big nodes in parallel (the tree is the same for any thread count).
    pub fn build(boxes: &[Aabb]) -> Self {
        let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
        let centres: Vec<[f64; 3]> = boxes.iter().map(|b| [0, 1, 2].map(|a| 0.5 * (b.min[a] + b.max[a]))).collect();
        let blank = BvhNode { bounds: Aabb::EMPTY, first: 0, count: 0 };
        let mut nodes = vec![blank; node_count(boxes.len())];
        if !boxes.is_empty() {
            split(boxes, &centres, &mut order, 0, &mut nodes, 0);
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

    /// The node pairs a self-join ([`self_join`](Bvh::self_join)) of the whole tree is cut into:
    /// `(a, a)` for the pairs within node `a`, `(a, b)` for the pairs across two disjoint
    /// subtrees whose boxes overlap. Every pair of items whose leaves' boxes overlap is below
    /// exactly one of them; the descent stops at nodes of at most `items` items, so the
    /// pieces can be joined in parallel.
    pub fn self_join_pieces(&self, items: usize) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        if !self.nodes.is_empty() {
            self.pieces(0, 0, items.max(1), &mut out);
        }
        out
    }

    fn pieces(&self, a: usize, b: usize, items: usize, out: &mut Vec<(usize, usize)>) {
        let small = |n: usize| self.nodes[n].is_leaf() || self.items_below(n).len() <= items;
        if a == b {
            if small(a) {
                out.push((a, a));
                return;
            }
            let [l, r] = self.children(a);
            self.pieces(l, l, items, out);
            self.pieces(r, r, items, out);
            self.pieces(l, r, items, out);
            return;
        }
        if !overlaps(&self.nodes[a].bounds, &self.nodes[b].bounds) {
            return;
        }
        if small(a) && small(b) {
            out.push((a, b));
            return;
        }
        // Descend the bigger side (by items below).
        if small(b) || (!small(a) && self.items_below(a).len() >= self.items_below(b).len()) {
            let [l, r] = self.children(a);
            self.pieces(l, b, items, out);
            self.pieces(r, b, items, out);
        } else {
            let [l, r] = self.children(b);
            self.pieces(a, l, items, out);
            self.pieces(a, r, items, out);
        }
    }

    /// Calls `f(s, t)` (slots of [`order`](Bvh::order), each unordered pair once, `s != t`) for
    /// every pair of items below the piece `(a, b)` of [`self_join_pieces`](Bvh::self_join_pieces)
    /// whose leaves' boxes overlap: a superset of the pairs whose own boxes do, which the caller
    /// tests exactly. Each pair of overlapping subtrees is visited once (no query per item).
    /// Slots, not items: a caller that keeps its per-item data in slot order reads a leaf's
    /// items, and its neighbours', from one place in memory.
    pub fn self_join(&self, a: usize, b: usize, f: &mut dyn FnMut(u32, u32)) {
        let (na, nb) = (&self.nodes[a], &self.nodes[b]);
        let slots = |n: &BvhNode| n.first..n.first + n.count;
        if a == b {
            if na.is_leaf() {
                for s in slots(na) {
                    for t in s + 1..na.first + na.count {
                        f(s, t);
                    }
                }
            } else {
                let [l, r] = self.children(a);
                self.self_join(l, l, f);
                self.self_join(r, r, f);
                self.self_join(l, r, f);
            }
            return;
        }
        if !overlaps(&na.bounds, &nb.bounds) {
            return;
        }
        match (na.is_leaf(), nb.is_leaf()) {
            (true, true) => {
                for s in slots(na) {
                    for t in slots(nb) {
                        f(s, t);
                    }
                }
            }
            // Descend the inner node; of two inner nodes, the one with the larger box.
            (false, true) => self.children(a).iter().for_each(|&c| self.self_join(c, b, f)),
            (true, false) => self.children(b).iter().for_each(|&c| self.self_join(a, c, f)),
            (false, false) => {
                if extent(&na.bounds) >= extent(&nb.bounds) {
                    self.children(a).iter().for_each(|&c| self.self_join(c, b, f));
                } else {
                    self.children(b).iter().for_each(|&c| self.self_join(a, c, f));
                }
            }
        }
    }

    /// The items in build order: slot `s` of a leaf holds item `order()[s]`.
    pub fn order(&self) -> &[u32] {
        &self.order
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

/// Nodes of the tree over `n` items: one leaf for up to [`LEAF_ITEMS`], else a node over the
/// trees of `n / 2` and `n - n / 2` (how [`split`] cuts), so each subtree's slot range is known
/// before it is built.
fn node_count(n: usize) -> usize {
    // (nodes(m), nodes(m + 1)) from (nodes(m / 2), nodes(m / 2 + 1)): the halves of m and m + 1
    // are m / 2 or m / 2 + 1.
    fn pair(m: usize) -> (usize, usize) {
        let one = |k: usize, h: (usize, usize), h0: usize| -> usize {
            if k <= LEAF_ITEMS {
                return 1;
            }
            let at = |x: usize| if x == h0 { h.0 } else { h.1 };
            1 + at(k / 2) + at(k - k / 2)
        };
        if m < LEAF_ITEMS {
            return (1, 1);
        }
        let h0 = m / 2;
        let h = pair(h0);
        (one(m, h, h0), one(m + 1, h, h0))
    }
    if n == 0 {
        0
    } else {
        pair(n).0
    }
}

/// Items from which [`split`] builds the two halves of a node in parallel.
const PARALLEL_ITEMS: usize = 1 << 15;

/// Writes the subtree over `order` (items `offset..offset + order.len()` of the build order) to
/// `nodes` (exactly its [`node_count`] slots, depth first; `base` is the index of `nodes[0]`).
fn split(boxes: &[Aabb], centres: &[[f64; 3]], order: &mut [u32], offset: usize, nodes: &mut [BvhNode], base: usize) {
    if order.len() <= LEAF_ITEMS {
        let mut bounds = Aabb::EMPTY;
        for &i in order.iter() {
            let b = &boxes[i as usize];
            bounds.add(b.min);
            bounds.add(b.max);
        }
        nodes[0] = BvhNode { bounds, first: offset as u32, count: order.len() as u32 };
        return;
    }
    let mut cbox = Aabb::EMPTY;
    for &i in order.iter() {
        cbox.add(centres[i as usize]);
    }
    let size = cbox.size();
    let axis = (0..3).max_by(|&a, &b| size[a].total_cmp(&size[b]).then(b.cmp(&a))).unwrap_or(0);
    let mid = order.len() / 2;
    // Median by centre along the axis; ties by index so the split does not depend on the sort.
    order.select_nth_unstable_by(mid, |&a, &b| {
        centres[a as usize][axis].total_cmp(&centres[b as usize][axis]).then(a.cmp(&b))
    });
    let (left, right) = order.split_at_mut(mid);
    let Some((node, below)) = nodes.split_first_mut() else { return };
    let (lnodes, rnodes) = below.split_at_mut(node_count(mid));
    let right_base = base + 1 + lnodes.len();
    let mut build_left = || split(boxes, centres, left, offset, lnodes, base + 1);
    let mut build_right = || split(boxes, centres, right, offset + mid, rnodes, right_base);
    if order_len_parallel(mid) {
        join(build_left, build_right);
    } else {
        build_left();
        build_right();
    }
    // A node's box is its children's.
    let (a, b) = (lnodes[0].bounds, rnodes[0].bounds);
    let mut bounds = a;
    bounds.add(b.min);
    bounds.add(b.max);
    *node = BvhNode { bounds, first: right_base as u32, count: 0 };
}

#[inline]
fn order_len_parallel(half: usize) -> bool {
    cfg!(feature = "parallel") && half >= PARALLEL_ITEMS
}

/// Runs `a` and `b`, in parallel when the crate is built so.
fn join(a: impl FnOnce() + Send, b: impl FnOnce() + Send) {
    #[cfg(feature = "parallel")]
    rayon::join(a, b);
    #[cfg(not(feature = "parallel"))]
    {
        a();
        b();
    }
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

/// The box's size as the sum of its sides (a volume would be zero for flat triangles' boxes).
#[inline]
fn extent(b: &Aabb) -> f64 {
    let s = b.size();
    s[0] + s[1] + s[2]
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

    /// The tree as the serial build made it before the parallel one: pushed depth first.
    fn reference_build(boxes: &[Aabb]) -> Vec<(Aabb, u32, u32)> {
        fn go(boxes: &[Aabb], c: &[[f64; 3]], order: &mut [u32], offset: usize, out: &mut Vec<(Aabb, u32, u32)>) {
            let mut bounds = Aabb::EMPTY;
            let mut cbox = Aabb::EMPTY;
            for &i in order.iter() {
                bounds.add(boxes[i as usize].min);
                bounds.add(boxes[i as usize].max);
                cbox.add(c[i as usize]);
            }
            let at = out.len();
            if order.len() <= LEAF_ITEMS {
                out.push((bounds, offset as u32, order.len() as u32));
                return;
            }
            out.push((bounds, 0, 0));
            let size = cbox.size();
            let axis = (0..3).max_by(|&a, &b| size[a].total_cmp(&size[b]).then(b.cmp(&a))).unwrap();
            let mid = order.len() / 2;
            order.select_nth_unstable_by(mid, |&a, &b| {
                c[a as usize][axis].total_cmp(&c[b as usize][axis]).then(a.cmp(&b))
            });
            let (l, r) = order.split_at_mut(mid);
            go(boxes, c, l, offset, out);
            out[at].1 = out.len() as u32;
            go(boxes, c, r, offset + mid, out);
        }
        let c: Vec<[f64; 3]> = boxes.iter().map(|b| [0, 1, 2].map(|a| 0.5 * (b.min[a] + b.max[a]))).collect();
        let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
        let mut out = Vec::new();
        if !boxes.is_empty() {
            go(boxes, &c, &mut order, 0, &mut out);
        }
        out
    }

    #[test]
    fn the_parallel_build_is_the_serial_tree() {
        for n in [0, 1, 4, 5, 9, 17, 1000, 3 * PARALLEL_ITEMS + 7] {
            let boxes = point_boxes(n);
            let bvh = Bvh::build(&boxes);
            let want = reference_build(&boxes);
            assert_eq!(bvh.nodes.len(), want.len(), "{n} items");
            assert_eq!(node_count(n), want.len(), "{n} items");
            for (k, (node, w)) in bvh.nodes.iter().zip(&want).enumerate() {
                assert_eq!((node.bounds, node.first, node.count), *w, "node {k} of {n}");
            }
        }
    }

    /// Every pair `(i, j)`, i < j, whose boxes overlap, from one `candidates` query per item (the
    /// self-join's reference).
    fn pairs_by_query(bvh: &Bvh, boxes: &[Aabb]) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        for (i, b) in boxes.iter().enumerate() {
            bvh.candidates(b, &mut |j| {
                if j as usize > i && overlaps(b, &boxes[j as usize]) {
                    out.push((i as u32, j));
                }
            });
        }
        out.sort_unstable();
        out
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(100))]
        /// Random boxes (points to long slivers, clusters and repeats): the self-join, cut into
        /// pieces of any size, yields each overlapping pair exactly once, the pairs one query per
        /// item finds.
        #[test]
        fn self_join_finds_the_pairs_of_per_item_queries(
            raw in proptest::collection::vec((0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0, 0.0f64..0.3, 0u8..4), 0..300),
            piece in 1usize..64,
        ) {
            let boxes: Vec<Aabb> = raw
                .iter()
                .map(|&(x, y, z, s, kind)| {
                    let min = [x, y, z];
                    let size = match kind { 0 => [0.0; 3], 1 => [s, s * 0.1, 0.0], 2 => [s; 3], _ => [0.01, 0.01, s] };
                    Aabb { min, max: [0, 1, 2].map(|a| min[a] + size[a]) }
                })
                .collect();
            let bvh = Bvh::build(&boxes);
            let mut got = Vec::new();
            for (a, b) in bvh.self_join_pieces(piece) {
                bvh.self_join(a, b, &mut |s, t| {
                    let (i, j) = (bvh.order()[s as usize], bvh.order()[t as usize]);
                    if overlaps(&boxes[i as usize], &boxes[j as usize]) {
                        got.push((i.min(j), i.max(j)));
                    }
                });
            }
            got.sort_unstable();
            let n = got.len();
            got.dedup();
            proptest::prop_assert_eq!(n, got.len(), "a pair was visited twice");
            proptest::prop_assert_eq!(got, pairs_by_query(&bvh, &boxes));
        }
    }
}
