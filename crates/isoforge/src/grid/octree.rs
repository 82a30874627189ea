//! A signed octree grid: PolyMender's SOG \[Ju04\] (the input of TopoMender): a cube of `dim³`
//! cells (`dim = 2^depth`) split into an octree whose leaves are finest-level cells holding the
//! signs of their 8 corners and one vertex; everything else is empty space of one sign.
//!
//! ```text
//!   internal   8 children, in the order c = 4x + 2y + z (x the slowest: the file's order)
//!   empty      a cube of one sign: every lattice point of its closed cube is inside or outside
//!   leaf       a finest-level cell: its corners' signs (bit c set = corner c outside,
//!              c = 4x + 2y + z) and a vertex (world coordinates, inside the cell)
//! ```
//! Nodes are stored flat in pre-order (the file's order), so reading and writing are a walk
//! along one array; internal nodes keep their children's indices, leaves their cell.
//! Outside is the positive side (isoforge's inside ⇔ value < iso): [`SignedOctree::to_sign_grid`]
//! gives −1 inside and +1 outside.
//!
//! **Signs at points** ([`SignedOctree::corner_outside`]): a lattice point may be touched by
//! several nodes (up to 8 cells). In a consistent tree (every real file seen) they agree. When
//! they do not, the sign is the one painting gives: every empty node paints its closed cube in
//! pre-order, then every leaf paints its 8 corners in pre-order, the last paint winning — i.e.
//! leaves before empty nodes, and among either the one latest in pre-order (the cell with the
//! largest Morton code). Points beyond the root cube are outside.

use super::{DenseGrid, Lattice};
use crate::error::{Error, Result};

/// One node of a tree in pre-order, as a file stores it: what
/// [`SignedOctree::from_preorder`] takes and [`SignedOctree::preorder`] gives back.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OctreeNode {
    /// Eight children follow, in the order `4x + 2y + z`.
    Internal,
    /// A cube of one sign.
    Empty {
        /// Every point of the cube is outside (else inside).
        outside: bool,
    },
    /// A finest-level cell.
    Leaf {
        /// Bit `c` set ⇔ corner `c` (= `4x + 2y + z`, [`sog_corner`]) is outside.
        signs: u8,
        /// The cell's vertex, in world coordinates.
        vertex: [f32; 3],
    },
}

/// A leaf of a [`SignedOctree`]: a finest-level cell with its corner signs and vertex.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OctreeLeaf {
    /// The cell (its lowest lattice point), each coordinate in `0..dim`.
    pub ijk: [u32; 3],
    /// Bit `c` set ⇔ corner `c` (= `4x + 2y + z`, [`sog_corner`]) is outside.
    pub signs: u8,
    /// The vertex, in world coordinates, inside the cell.
    pub vertex: [f32; 3],
}

impl OctreeLeaf {
    /// Whether the corner at `offset` (each 0 or 1) is outside.
    #[inline]
    pub fn corner_outside(&self, offset: [u32; 3]) -> bool {
        self.signs >> sog_corner(offset) & 1 == 1
    }

    /// Whether the cell has corners on both sides.
    #[inline]
    pub fn has_sign_change(&self) -> bool {
        self.signs != 0 && self.signs != 0xff
    }
}

/// The corner number of a cell corner at `offset` (each 0 or 1) in the SOG order, `4x + 2y + z`
/// (isoforge's own cube numbering, [`crate::cube`], is `x + 2y + 4z`).
#[inline]
pub const fn sog_corner(offset: [u32; 3]) -> u32 {
    (offset[0] & 1) << 2 | (offset[1] & 1) << 1 | (offset[2] & 1)
}

/// A stored node: what it is and where its data lives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Node {
    /// Index into `children`.
    Internal(u32),
    /// An empty cube.
    Empty { outside: bool },
    /// Index into `leaves`.
    Leaf(u32),
}

/// A signed octree grid (see the module doc): origin and edge of the root cube, `depth`, and
/// its nodes in pre-order.
#[derive(Debug, Clone, PartialEq)]
pub struct SignedOctree {
    origin: [f32; 3],
    edge: f32,
    depth: u32,
    /// Every node, in pre-order; the root first.
    nodes: Vec<Node>,
    /// For each internal node (in pre-order), its children's indices in `nodes`.
    children: Vec<[u32; 8]>,
    /// The leaves, in pre-order.
    leaves: Vec<OctreeLeaf>,
}

/// How far a vertex may lie beyond its cell, in cells: rounding of the writer's arithmetic.
pub const VERTEX_SLACK: f64 = 1e-4;

impl SignedOctree {
    /// The deepest tree accepted: `dim` = 2¹⁶ cells per axis (cell coordinates and the Morton
    /// codes of [`SignedOctree::corner_outside`] fit their integers; a file's node count, not
    /// its depth, bounds the memory).
    pub const MAX_DEPTH: u32 = 16;

    /// The most points [`SignedOctree::to_sign_grid`] makes: `(dim + 1)³` at depth 10.
    pub const MAX_SIGN_GRID_POINTS: u64 = 1025 * 1025 * 1025;

    /// Builds a tree from its nodes in pre-order; the root cube at `origin` with edge `edge`,
    /// `2^depth` cells per axis.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] naming the node (its index in pre-order, level and cell) for a
    /// depth above [`SignedOctree::MAX_DEPTH`], a non-finite or non-positive edge or origin, an
    /// internal node at the finest level, a leaf above it, a non-finite vertex or one outside
    /// its cell (by more than [`VERTEX_SLACK`]), nodes after the tree is complete, or a tree
    /// that ends early.
    pub fn from_preorder(
        depth: u32,
        origin: [f32; 3],
        edge: f32,
        nodes: impl IntoIterator<Item = OctreeNode>,
    ) -> Result<Self> {
        let mut b = PreorderBuilder::new(depth, origin, edge)?;
        for n in nodes {
            b.push(n)?;
        }
        b.finish()
    }

    /// The tree of the values `value` gives on `lattice` (a cube of `2^depth` cells with one
    /// spacing): outside where `value ≥ 0`; a crossed cell's vertex is `keep`'s when `keep` has
    /// a leaf there with the same signs, else the mean of its edges' linear crossings (kept a hair
    /// inside the cell).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when the lattice is not such a cube; as
    /// [`SignedOctree::from_cells`].
    pub fn from_values(
        lattice: &Lattice,
        value: &dyn Fn([u32; 3]) -> f32,
        keep: Option<&SignedOctree>,
    ) -> Result<Self> {
        let d = lattice.dims();
        let cells = d[0].saturating_sub(1);
        let s = lattice.spacing();
        if d.iter().any(|&n| n != d[0]) || !cells.is_power_of_two() || cells < 2 || s.iter().any(|&v| v != s[0]) {
            return Err(Error::InvalidInput(format!(
                "a signed octree needs a cube of 2^depth cells with one spacing; the grid has {} x {} x {} points",
                d[0], d[1], d[2]
            )));
        }
        let depth = cells.trailing_zeros();
        let keep = keep.filter(|t| t.depth() == depth);
        let o = lattice.origin();
        let outside = |p: [u32; 3]| value(p) >= 0.0;
        let vertex = |c: [u32; 3]| -> Option<[f32; 3]> {
            let v: [f32; 8] = std::array::from_fn(|k| value([0, 1, 2].map(|a| c[a] + (k as u32 >> a & 1))));
            if v.iter().all(|&x| x >= 0.0) || v.iter().all(|&x| x < 0.0) {
                return None;
            }
            if let Some(leaf) = keep.and_then(|t| t.leaf_at(c)) {
                let same =
                    (0..8u32).all(|k| leaf.corner_outside([k & 1, k >> 1 & 1, k >> 2 & 1]) == (v[k as usize] >= 0.0));
                if same {
                    return Some(leaf.vertex);
                }
            }
            let (mut sum, mut n) = ([0.0f64; 3], 0.0);
            for k in 0..8usize {
                for a in 0..3 {
                    let m = k | 1 << a;
                    if m == k || (v[k] < 0.0) == (v[m] < 0.0) {
                        continue;
                    }
                    let t = (v[k] / (v[k] - v[m])) as f64;
                    for b in 0..3 {
                        let at = (k >> b & 1) as f64 + if b == a { t } else { 0.0 };
                        sum[b] += at;
                    }
                    n += 1.0;
                }
            }
            // In the cell, a hair inside its faces (the file's vertices must lie in their cells).
            Some([0, 1, 2].map(|b| (o[b] + s[0] * (c[b] as f64 + (sum[b] / n).clamp(1e-6, 1.0 - 1e-6))) as f32))
        };
        Self::from_cells(depth, o.map(|v| v as f32), (s[0] * cells as f64) as f32, &outside, &vertex)
    }

    /// Builds the tree of a sign function as PolyMender does: a finest-level cell is a leaf when
    /// `vertex` gives it a vertex, and every other node whose cube holds no leaf is empty.
    ///
    /// `outside(ijk)` is the sign at lattice point `ijk` (each in `0..=dim`); `vertex(ijk)` the
    /// vertex of cell `ijk` (world coordinates, in the cell), which every cell whose corners
    /// differ must have, and which a cell of one sign may have (PolyMender keeps the cells the
    /// surface crosses without changing a corner's sign: such leaves are in its files). An empty
    /// cube then has one sign at all its points. Calls `outside` 8 times per cell: O(dim³).
    ///
    /// # Errors
    /// As [`SignedOctree::from_preorder`]; [`Error::InvalidInput`] naming the cell whose corners
    /// differ without a vertex.
    pub fn from_cells(
        depth: u32,
        origin: [f32; 3],
        edge: f32,
        outside: &dyn Fn([u32; 3]) -> bool,
        vertex: &dyn Fn([u32; 3]) -> Option<[f32; 3]>,
    ) -> Result<Self> {
        // Validates the header; the nodes are then built directly (and checked as they go).
        let b = PreorderBuilder::new(depth, origin, edge)?;
        let mut tree = b.tree;
        tree.build(0, [0; 3], outside, vertex)?;
        Ok(tree)
    }

    /// Appends the subtree of the node at `level` with lowest cell `ijk`, collapsing it into an
    /// empty node when it holds no leaf.
    fn build(
        &mut self,
        level: u32,
        ijk: [u32; 3],
        outside: &dyn Fn([u32; 3]) -> bool,
        vertex: &dyn Fn([u32; 3]) -> Option<[f32; 3]>,
    ) -> Result<()> {
        if level == self.depth {
            let mut signs = 0u8;
            for c in 0..8u32 {
                let o = [c >> 2 & 1, c >> 1 & 1, c & 1];
                if outside([ijk[0] + o[0], ijk[1] + o[1], ijk[2] + o[2]]) {
                    signs |= 1 << c;
                }
            }
            let node = match vertex(ijk) {
                Some(v) => OctreeNode::Leaf { signs, vertex: v },
                None if signs == 0 || signs == 0xff => OctreeNode::Empty { outside: signs == 0xff },
                None => {
                    return Err(Error::InvalidInput(format!(
                        "cell {ijk:?}: corners on both sides (signs {signs:#04x}) but no vertex"
                    )))
                }
            };
            return self.append(level, ijk, node);
        }
        let (start_nodes, start_children) = (self.nodes.len(), self.children.len());
        let (start_leaves, half) = (self.leaves.len(), 1u32 << (self.depth - level - 1));
        self.append(level, ijk, OctreeNode::Internal)?;
        let mut sign = None;
        for c in 0..8u32 {
            let child = [ijk[0] + (c >> 2 & 1) * half, ijk[1] + (c >> 1 & 1) * half, ijk[2] + (c & 1) * half];
            let at = self.nodes.len() as u32;
            self.children[start_children][c as usize] = at;
            self.build(level + 1, child, outside, vertex)?;
            sign = match (c, sign, self.nodes[at as usize]) {
                (0, _, Node::Empty { outside }) => Some(Some(outside)),
                (_, Some(Some(s)), Node::Empty { outside }) if s == outside => Some(Some(s)),
                _ => Some(None),
            };
        }
        if let (Some(Some(outside)), true) = (sign, self.leaves.len() == start_leaves) {
            self.nodes.truncate(start_nodes);
            self.children.truncate(start_children);
            self.nodes.push(Node::Empty { outside });
        }
        Ok(())
    }

    /// Stores one node (children indices of an internal node are filled in by the caller).
    fn append(&mut self, level: u32, ijk: [u32; 3], node: OctreeNode) -> Result<()> {
        let at = self.nodes.len();
        let bad = |what: String| Err(Error::InvalidInput(format!("node {at} (level {level}, cell {ijk:?}): {what}")));
        let stored = match node {
            OctreeNode::Internal if level == self.depth => {
                return bad(format!("an internal node at the finest level (depth {})", self.depth))
            }
            OctreeNode::Internal => {
                self.children.push([0; 8]);
                Node::Internal(self.children.len() as u32 - 1)
            }
            OctreeNode::Empty { outside } => Node::Empty { outside },
            OctreeNode::Leaf { .. } if level < self.depth => {
                return bad(format!("a leaf above the finest level (level {level} of {})", self.depth))
            }
            OctreeNode::Leaf { signs, vertex } => {
                if let Some(v) = vertex.iter().find(|v| !v.is_finite()) {
                    return bad(format!("vertex coordinate {v} is not finite"));
                }
                let h = self.spacing();
                for a in 0..3 {
                    let lo = self.origin[a] as f64 + ijk[a] as f64 * h;
                    let t = (vertex[a] as f64 - lo) / h;
                    if !(-VERTEX_SLACK..=1.0 + VERTEX_SLACK).contains(&t) {
                        return bad(format!(
                            "vertex {vertex:?} lies outside the cell: its {} is {t:.4} cells from the cell's low face (0 to 1)",
                            ["x", "y", "z"][a]
                        ));
                    }
                }
                self.leaves.push(OctreeLeaf { ijk, signs, vertex });
                Node::Leaf(self.leaves.len() as u32 - 1)
            }
        };
        self.nodes.push(stored);
        Ok(())
    }

    /// The depth: `dim = 2^depth` cells per axis.
    #[inline]
    pub fn depth(&self) -> u32 {
        self.depth
    }

    /// Cells per axis, `2^depth`.
    #[inline]
    pub fn dim(&self) -> u32 {
        1 << self.depth
    }

    /// The root cube's lowest corner, in world coordinates.
    #[inline]
    pub fn origin(&self) -> [f32; 3] {
        self.origin
    }

    /// The root cube's edge length.
    #[inline]
    pub fn edge(&self) -> f32 {
        self.edge
    }

    /// The edge of a finest-level cell, `edge / dim`.
    #[inline]
    pub fn spacing(&self) -> f64 {
        self.edge as f64 / self.dim() as f64
    }

    /// Nodes of every kind.
    #[inline]
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// The leaves, in pre-order.
    pub fn leaves(&self) -> impl ExactSizeIterator<Item = &OctreeLeaf> + '_ {
        self.leaves.iter()
    }

    /// The nodes in pre-order, as a file stores them.
    pub fn preorder(&self) -> impl ExactSizeIterator<Item = OctreeNode> + '_ {
        self.nodes.iter().map(|n| match *n {
            Node::Internal(_) => OctreeNode::Internal,
            Node::Empty { outside } => OctreeNode::Empty { outside },
            Node::Leaf(i) => {
                let l = &self.leaves[i as usize];
                OctreeNode::Leaf { signs: l.signs, vertex: l.vertex }
            }
        })
    }

    /// The leaf at finest-level cell `ijk`, if that cell is one.
    pub fn leaf_at(&self, ijk: [u32; 3]) -> Option<&OctreeLeaf> {
        match self.node_of(ijk)? {
            Node::Leaf(i) => Some(&self.leaves[i as usize]),
            _ => None,
        }
    }

    /// The node holding cell `ijk` (`None` beyond the root cube).
    fn node_of(&self, ijk: [u32; 3]) -> Option<Node> {
        if ijk.iter().any(|&c| c >= self.dim()) {
            return None;
        }
        let mut node = self.nodes[0];
        let mut bit = self.depth;
        while let Node::Internal(ci) = node {
            bit -= 1;
            let c = (ijk[0] >> bit & 1) << 2 | (ijk[1] >> bit & 1) << 1 | (ijk[2] >> bit & 1);
            node = self.nodes[self.children[ci as usize][c as usize] as usize];
        }
        Some(node)
    }

    /// The sign at lattice point `ijk` (each coordinate in `0..=dim`): whether it is outside.
    /// Where the nodes touching it disagree, leaves come first and among them (or among empty
    /// nodes) the latest in pre-order (module doc); points beyond the root cube are outside.
    pub fn corner_outside(&self, ijk: [u32; 3]) -> bool {
        let dim = self.dim();
        if ijk.iter().any(|&c| c > dim) {
            return true;
        }
        // The cells touching the point, latest in pre-order (largest Morton code) first.
        let mut cells = [([0u32; 3], 0u64); 8];
        let mut n = 0;
        for d in 0..8u32 {
            let o = [d >> 2 & 1, d >> 1 & 1, d & 1];
            if (0..3).any(|a| (o[a] == 1 && ijk[a] == 0) || (o[a] == 0 && ijk[a] == dim)) {
                continue;
            }
            let cell = [ijk[0] - o[0], ijk[1] - o[1], ijk[2] - o[2]];
            cells[n] = (cell, morton(cell, self.depth));
            n += 1;
        }
        let cells = &mut cells[..n];
        cells.sort_unstable_by_key(|c| std::cmp::Reverse(c.1));
        let mut last_empty = None;
        for &(cell, _) in cells.iter() {
            match self.node_of(cell) {
                Some(Node::Leaf(i)) => {
                    let l = &self.leaves[i as usize];
                    return l.corner_outside([ijk[0] - cell[0], ijk[1] - cell[1], ijk[2] - cell[2]]);
                }
                Some(Node::Empty { outside }) => {
                    last_empty.get_or_insert(outside);
                }
                _ => {}
            }
        }
        last_empty.unwrap_or(true)
    }

    /// The lattice of the tree's points: `(dim + 1)³` points from the root's origin, spacing
    /// `edge / dim`.
    ///
    /// # Errors
    /// As [`Lattice::with_geometry`] (a root cube reaching beyond what `f32` holds).
    pub fn lattice(&self) -> Result<Lattice> {
        let n = self.dim() + 1;
        Lattice::with_geometry([n; 3], [self.spacing(); 3], self.origin.map(f64::from))
    }

    /// The signs at every lattice point as values, −1 inside and +1 outside, on
    /// [`SignedOctree::lattice`]: extracting at iso 0 gives the surface between the signs.
    /// Painted node by node ([`SignedOctree::corner_outside`]'s rule), O(points).
    ///
    /// # Errors
    /// [`Error::Limit`] above [`SignedOctree::MAX_SIGN_GRID_POINTS`] points (checked before
    /// allocating); as [`SignedOctree::lattice`].
    pub fn to_sign_grid(&self) -> Result<DenseGrid<f32>> {
        let n = self.dim() as u64 + 1;
        let points = n * n * n;
        if points > Self::MAX_SIGN_GRID_POINTS {
            return Err(Error::Limit {
                what: "sign grid points",
                requested: points,
                allowed: Self::MAX_SIGN_GRID_POINTS,
            });
        }
        let lattice = self.lattice()?;
        let n = n as usize;
        let mut data = vec![1.0f32; points as usize];
        let value = |outside: bool| if outside { 1.0 } else { -1.0 };
        // PASS 1: empty nodes paint their closed cubes, in pre-order.
        self.for_each_empty(|lo, size, outside| {
            for k in lo[2]..=lo[2] + size {
                for j in lo[1]..=lo[1] + size {
                    let row = (k as usize * n + j as usize) * n;
                    data[row + lo[0] as usize..=row + (lo[0] + size) as usize].fill(value(outside));
                }
            }
        });
        // PASS 2: leaves paint their corners, in pre-order.
        for l in &self.leaves {
            for c in 0..8u32 {
                let o = [c >> 2 & 1, c >> 1 & 1, c & 1];
                let p = [0, 1, 2].map(|a| (l.ijk[a] + o[a]) as usize);
                data[(p[2] * n + p[1]) * n + p[0]] = value(l.signs >> c & 1 == 1);
            }
        }
        DenseGrid::new(lattice, data)
    }

    /// The box (lowest and highest point, inclusive) of the lattice points some node paints
    /// inside, or `None` when none does: from the tree alone, a bound on where
    /// [`to_sign_grid`](SignedOctree::to_sign_grid) puts its inside points (the same box for a
    /// consistent tree), for sizing what is built on the solid before building the grid.
    pub fn inside_box(&self) -> Option<([u32; 3], [u32; 3])> {
        let mut bounds: Option<([u32; 3], [u32; 3])> = None;
        let mut grow = |lo: [u32; 3], hi: [u32; 3]| {
            let b = bounds.get_or_insert((lo, hi));
            for a in 0..3 {
                b.0[a] = b.0[a].min(lo[a]);
                b.1[a] = b.1[a].max(hi[a]);
            }
        };
        self.for_each_empty(|lo, size, outside| {
            if !outside {
                grow(lo, lo.map(|v| v + size));
            }
        });
        for l in &self.leaves {
            for c in 0..8u32 {
                let o = [c >> 2 & 1, c >> 1 & 1, c & 1];
                if !l.corner_outside(o) {
                    let p = [0, 1, 2].map(|a| l.ijk[a] + o[a]);
                    grow(p, p);
                }
            }
        }
        bounds
    }

    /// Calls `f(lowest point, size in cells, outside)` for every empty node, in pre-order.
    fn for_each_empty(&self, mut f: impl FnMut([u32; 3], u32, bool)) {
        // (node index, lowest cell, level), children pushed in reverse to pop in pre-order.
        let mut stack = vec![(0u32, [0u32; 3], 0u32)];
        while let Some((at, ijk, level)) = stack.pop() {
            match self.nodes[at as usize] {
                Node::Internal(ci) => {
                    let half = 1u32 << (self.depth - level - 1);
                    for c in (0..8u32).rev() {
                        let child =
                            [ijk[0] + (c >> 2 & 1) * half, ijk[1] + (c >> 1 & 1) * half, ijk[2] + (c & 1) * half];
                        stack.push((self.children[ci as usize][c as usize], child, level + 1));
                    }
                }
                Node::Empty { outside } => f(ijk, 1 << (self.depth - level), outside),
                Node::Leaf(_) => {}
            }
        }
    }
}

/// The Morton code of a cell: its path from the root, 3 bits per level (`4x + 2y + z`), so
/// that pre-order visits cells in increasing code.
pub(crate) fn morton(ijk: [u32; 3], depth: u32) -> u64 {
    (0..depth).rev().fold(0u64, |m, bit| {
        m << 3 | u64::from((ijk[0] >> bit & 1) << 2 | (ijk[1] >> bit & 1) << 1 | (ijk[2] >> bit & 1))
    })
}

/// Builds a [`SignedOctree`] from nodes arriving in pre-order (a reader's stream), checking each
/// as it comes: a reader names the byte of the node an error is about.
#[derive(Debug)]
pub struct PreorderBuilder {
    tree: SignedOctree,
    /// The open internal nodes: (their index in `children`, the next child, lowest cell).
    stack: Vec<(u32, u32, [u32; 3])>,
    /// Whether the root has arrived.
    started: bool,
}

impl PreorderBuilder {
    /// A builder for a tree of `2^depth` cells per axis on the root cube at `origin`, `edge` long.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for a depth above [`SignedOctree::MAX_DEPTH`], a non-finite
    /// origin, or an edge that is not finite and positive.
    pub fn new(depth: u32, origin: [f32; 3], edge: f32) -> Result<Self> {
        if depth > SignedOctree::MAX_DEPTH {
            return Err(Error::InvalidInput(format!(
                "depth {depth}: at most {} (dim 2^{})",
                SignedOctree::MAX_DEPTH,
                SignedOctree::MAX_DEPTH
            )));
        }
        if let Some(o) = origin.iter().find(|o| !o.is_finite()) {
            return Err(Error::InvalidInput(format!("origin coordinate {o}: must be finite")));
        }
        if !(edge.is_finite() && edge > 0.0) {
            return Err(Error::InvalidInput(format!("edge length {edge}: must be finite and positive")));
        }
        let tree = SignedOctree { origin, edge, depth, nodes: Vec::new(), children: Vec::new(), leaves: Vec::new() };
        Ok(PreorderBuilder { tree, stack: Vec::new(), started: false })
    }

    /// Whether the tree is complete (the root and all its descendants have arrived).
    pub fn is_complete(&self) -> bool {
        self.started && self.stack.is_empty()
    }

    /// Nodes received so far.
    pub fn node_count(&self) -> usize {
        self.tree.nodes.len()
    }

    /// The level (0 = root) and lowest cell of the node to come next; `None` once complete.
    pub fn next_place(&self) -> Option<(u32, [u32; 3])> {
        if !self.started {
            return Some((0, [0; 3]));
        }
        let &(_, c, ijk) = self.stack.last()?;
        let level = self.stack.len() as u32;
        let half = 1u32 << (self.tree.depth - level);
        Some((level, [ijk[0] + (c >> 2 & 1) * half, ijk[1] + (c >> 1 & 1) * half, ijk[2] + (c & 1) * half]))
    }

    /// Adds the next node in pre-order.
    ///
    /// # Errors
    /// As [`SignedOctree::from_preorder`], for this node.
    pub fn push(&mut self, node: OctreeNode) -> Result<()> {
        let Some((level, ijk)) = self.next_place() else {
            return Err(Error::InvalidInput(format!("node {}: the tree is already complete", self.tree.nodes.len())));
        };
        let at = self.tree.nodes.len() as u32;
        self.tree.append(level, ijk, node)?;
        if let Some((ci, c, _)) = self.stack.last_mut() {
            self.tree.children[*ci as usize][*c as usize] = at;
            *c += 1;
        }
        self.started = true;
        if node == OctreeNode::Internal {
            self.stack.push((self.tree.children.len() as u32 - 1, 0, ijk));
        }
        // Close every internal node whose eighth child just ended.
        while self.stack.last().is_some_and(|&(_, c, _)| c == 8) {
            self.stack.pop();
        }
        Ok(())
    }

    /// The tree, once complete.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] naming where the next node was due when the tree ends early.
    pub fn finish(self) -> Result<SignedOctree> {
        match self.next_place() {
            None => Ok(self.tree),
            Some((level, ijk)) => Err(Error::InvalidInput(format!(
                "the tree ends early: after {} nodes, the node at level {level}, cell {ijk:?} is missing",
                self.tree.nodes.len()
            ))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ball of radius `r` cells about the lattice's centre, vertices at cell centres.
    fn ball(depth: u32, r: f64) -> SignedOctree {
        let c = (1u32 << depth) as f64 / 2.0;
        let inside = move |p: [u32; 3]| p.iter().map(|&x| (x as f64 - c).powi(2)).sum::<f64>() < r * r;
        let outside = move |p: [u32; 3]| !inside(p);
        let vertex = move |ijk: [u32; 3]| {
            let s: u32 =
                (0..8).map(|c| inside([ijk[0] + (c >> 2 & 1), ijk[1] + (c >> 1 & 1), ijk[2] + (c & 1)]) as u32).sum();
            (s != 0 && s != 8).then(|| ijk.map(|x| x as f32 + 0.5))
        };
        SignedOctree::from_cells(depth, [0.0; 3], (1u32 << depth) as f32, &outside, &vertex).unwrap()
    }

    #[test]
    fn from_cells_collapses_uniform_cubes_and_keeps_every_sign() {
        let t = ball(4, 5.0);
        assert!(t.node_count() < 16 * 16 * 16 / 2, "{} nodes", t.node_count());
        assert!(t.leaves().all(|l| l.has_sign_change()));
        let c = 8.0f64;
        let g = t.to_sign_grid().unwrap();
        for k in 0..=16 {
            for j in 0..=16 {
                for i in 0..=16 {
                    let inside = [i, j, k].iter().map(|&x| (x as f64 - c).powi(2)).sum::<f64>() < 25.0;
                    assert_eq!(t.corner_outside([i, j, k]), !inside, "{:?}", [i, j, k]);
                    assert_eq!(g.get([i, j, k]), if inside { -1.0 } else { 1.0 });
                }
            }
        }
        assert!(t.corner_outside([17, 0, 0]), "beyond the root");
    }

    #[test]
    fn the_inside_box_is_the_sign_grids() {
        for (depth, r) in [(4, 5.0), (4, 2.2), (3, 0.4), (5, 9.5)] {
            let t = ball(depth, r);
            let g = t.to_sign_grid().unwrap();
            let n = g.lattice().dims();
            let mut expected: Option<([u32; 3], [u32; 3])> = None;
            for k in 0..n[2] {
                for j in 0..n[1] {
                    for i in 0..n[0] {
                        if g.get([i, j, k]) < 0.0 {
                            let b = expected.get_or_insert(([i, j, k], [i, j, k]));
                            for (a, v) in [i, j, k].into_iter().enumerate() {
                                b.0[a] = b.0[a].min(v);
                                b.1[a] = b.1[a].max(v);
                            }
                        }
                    }
                }
            }
            assert_eq!(t.inside_box(), expected, "depth {depth}, radius {r}");
        }
        // A tree painting inside with empty nodes only: their closed cubes.
        let (inside, outside) = (OctreeNode::Empty { outside: false }, OctreeNode::Empty { outside: true });
        let mut nodes = vec![OctreeNode::Internal, inside];
        nodes.extend([outside; 6]);
        nodes.push(inside);
        let t = SignedOctree::from_preorder(9, [0.0; 3], 1.0, nodes).unwrap();
        assert_eq!(t.inside_box(), Some(([0; 3], [512; 3])));
    }

    #[test]
    fn preorder_round_trips_through_the_builder() {
        let t = ball(3, 2.5);
        let back = SignedOctree::from_preorder(3, t.origin(), t.edge(), t.preorder()).unwrap();
        assert_eq!(back, t);
    }

    #[test]
    fn the_builder_names_what_is_wrong() {
        let err = |nodes: &[OctreeNode]| {
            SignedOctree::from_preorder(1, [0.0; 3], 2.0, nodes.iter().copied()).unwrap_err().to_string()
        };
        let leaf = OctreeNode::Leaf { signs: 1, vertex: [0.5; 3] };
        let empty = OctreeNode::Empty { outside: true };
        assert_eq!(err(&[leaf]), "node 0 (level 0, cell [0, 0, 0]): a leaf above the finest level (level 0 of 1)");
        assert_eq!(
            err(&[OctreeNode::Internal, OctreeNode::Internal]),
            "node 1 (level 1, cell [0, 0, 0]): an internal node at the finest level (depth 1)"
        );
        assert_eq!(
            err(&[OctreeNode::Internal, empty, empty]),
            "the tree ends early: after 3 nodes, the node at level 1, cell [0, 1, 0] is missing"
        );
        assert_eq!(err(&[empty, empty]), "node 1: the tree is already complete");
        let far = OctreeNode::Leaf { signs: 1, vertex: [0.5, 1.5, 0.5] };
        assert_eq!(
            err(&[OctreeNode::Internal, far]),
            "node 1 (level 1, cell [0, 0, 0]): vertex [0.5, 1.5, 0.5] lies outside the cell: its y is 1.5000 cells from the cell's low face (0 to 1)"
        );
        let nan = OctreeNode::Leaf { signs: 1, vertex: [f32::NAN, 0.5, 0.5] };
        assert_eq!(
            err(&[OctreeNode::Internal, nan]),
            "node 1 (level 1, cell [0, 0, 0]): vertex coordinate NaN is not finite"
        );
    }

    #[test]
    fn disagreeing_nodes_follow_the_painting_rule() {
        // Depth 1: cell 0 a leaf whose corner 7 ([1, 1, 1], shared by all 8 cells) is inside,
        // the other cells empty outside. Leaves come first: the centre is inside.
        let mut nodes = vec![OctreeNode::Internal, OctreeNode::Leaf { signs: 0x7f, vertex: [0.9; 3] }];
        nodes.extend([OctreeNode::Empty { outside: true }; 7]);
        let t = SignedOctree::from_preorder(1, [0.0; 3], 2.0, nodes.clone()).unwrap();
        assert!(!t.corner_outside([1, 1, 1]));
        // Two empty cells of different signs share face points: the later one (cell 7) wins.
        nodes[1] = OctreeNode::Empty { outside: false };
        let t = SignedOctree::from_preorder(1, [0.0; 3], 2.0, nodes).unwrap();
        let g = t.to_sign_grid().unwrap();
        for k in 0..=2 {
            for j in 0..=2 {
                for i in 0..=2 {
                    let p = [i, j, k];
                    assert_eq!(g.get(p) > 0.0, t.corner_outside(p), "{p:?}");
                }
            }
        }
        assert!(t.corner_outside([1, 1, 1]) && !t.corner_outside([0, 0, 0]));
    }

    #[test]
    fn huge_sign_grids_are_refused_before_allocating() {
        let t = SignedOctree::from_preorder(11, [0.0; 3], 1.0, [OctreeNode::Empty { outside: true }]).unwrap();
        assert!(matches!(t.to_sign_grid(), Err(Error::Limit { what: "sign grid points", .. })));
        assert!(t.corner_outside([2048, 0, 0]));
    }
}
