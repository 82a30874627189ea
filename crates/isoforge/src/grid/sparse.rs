//! A sparse grid: samples stored only in 8³ leaf blocks where the surface may pass, constant tiles
//! elsewhere; memory grows with the surface, not with the lattice.
//!
//! ```text
//!   root    node coordinate (point >> 7) → a node, or a tile of 128³ points with one value
//!   node    16³ children, each a leaf or a tile of 8³ points with one value       (128³ points)
//!   leaf    8³ samples, x fastest                                                 (8³ points)
//!   absent  the background value
//! ```
//! The layout of OpenVDB's tree with its two upper levels merged into a hash map (VDB: root →
//! 32³ → 16³ → 8³): O(1) random access (one hash lookup, two shifts), leaves in one flat array
//! (no allocation per leaf, parallel iteration by index), per-leaf and per-node bounds of the
//! values. Coordinates are the lattice's: a grid covers the points of its [`Lattice`] (dims up to
//! 2³²−1 per axis), and [`SparseGrid::index_origin`] says where lattice point 0 sits in a file's
//! signed index space (VDB's), so readers and writers keep it.
//!
//! What a sparse grid promises walkers: the sample at every lattice point is its leaf's value, its
//! tile's, or the background. Its constructors ([`SparseGrid::from_dense`],
//! [`SparseGrid::from_field`]) keep as leaves every block within [`SURFACE_MARGIN`] points of a
//! cell the surface crosses, so a walk reads leaf samples only: the mesh of a sparse grid is the
//! mesh of the same samples stored densely.

use std::collections::HashMap;
use std::hash::BuildHasherDefault;

use super::{DenseGrid, Lattice, Sample};
use crate::error::{Error, Result};
use crate::math::KeyHasher;

/// Points per leaf edge (a leaf holds `LEAF³` samples).
pub const LEAF: u32 = 8;
/// Leaves per node edge.
pub const NODE: u32 = 16;
/// Points per node edge.
pub const NODE_POINTS: u32 = LEAF * NODE;
/// Samples per leaf.
pub const LEAF_SAMPLES: usize = (LEAF * LEAF * LEAF) as usize;
/// Children per node.
const NODE_CHILDREN: usize = (NODE * NODE * NODE) as usize;

/// Points around a crossed cell that constructors keep in leaves: a walk reads the corners of the
/// cells it processes, one point further for gradients and two for the cells before a range
/// ([`CellRange::halo_points`](crate::cube::CellRange::halo_points)); three covers every corner of a
/// crossed cell within two points of a block.
pub const SURFACE_MARGIN: u32 = 3;

/// A child of a node: a leaf (index into the grid's leaves) or a tile of one value.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Child<S> {
    Tile(S),
    Leaf(u32),
}

/// An entry of the root: a node (index into the grid's nodes) or a tile of one value.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Entry<S> {
    Tile(S),
    Node(u32),
}

#[derive(Debug, Clone, PartialEq)]
struct Node<S> {
    /// Node coordinate (first point / [`NODE_POINTS`]).
    coord: [u32; 3],
    children: Box<[Child<S>]>,
}

/// Samples of a lattice stored by 8³ leaf blocks near the surface, constant tiles elsewhere
/// (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct SparseGrid<S> {
    lattice: Lattice,
    index_origin: [i32; 3],
    background: S,
    /// Root entries sorted by node coordinate (z, y, x): a deterministic order for walks.
    root: Vec<([u32; 3], Entry<S>)>,
    /// Node coordinate → position in `root`.
    lookup: HashMap<[u32; 3], u32, BuildHasherDefault<KeyHasher>>,
    nodes: Vec<Node<S>>,
    /// First point of each leaf.
    leaf_origins: Vec<[u32; 3]>,
    /// `LEAF_SAMPLES` per leaf, in leaf order, x fastest within a leaf.
    leaf_values: Vec<S>,
}

/// A constant region of a [`SparseGrid`] whose value is not the background: `size³` points from
/// `origin` (a multiple of `size`: [`LEAF`] for a node's child, [`NODE_POINTS`] for a root entry).
/// Points of a tile past the lattice's end have no meaning.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SparseTile<S> {
    /// The point with the smallest coordinates.
    pub origin: [u32; 3],
    /// Points per edge.
    pub size: u32,
    /// The value of every point of the tile.
    pub value: S,
}

/// What a sparse grid holds, for reports (`isoforge info`) and the memory figures of
/// docs/BENCHMARKS.md.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SparseStats {
    /// Leaves (8³ blocks of stored samples).
    pub leaves: u64,
    /// Samples stored in leaves.
    pub stored_samples: u64,
    /// Nodes (16³ children each).
    pub nodes: u64,
    /// Root entries that are tiles (128³ points of one value).
    pub root_tiles: u64,
    /// Child tiles (8³ points of one value) other than the background.
    pub child_tiles: u64,
    /// Bytes held by the grid's arrays.
    pub bytes: u64,
}

impl<S: Sample> SparseGrid<S> {
    /// An empty grid: every point has the `background` value.
    pub fn new(lattice: Lattice, background: S) -> Self {
        SparseGrid {
            lattice,
            index_origin: [0; 3],
            background,
            root: Vec::new(),
            lookup: HashMap::default(),
            nodes: Vec::new(),
            leaf_origins: Vec::new(),
            leaf_values: Vec::new(),
        }
    }

    /// The lattice the grid samples.
    #[inline]
    pub fn lattice(&self) -> &Lattice {
        &self.lattice
    }

    /// The value of every point no leaf or tile covers.
    #[inline]
    pub fn background(&self) -> S {
        self.background
    }

    /// Where lattice point 0 sits in the signed index space of the file the grid came from
    /// (OpenVDB's coordinates); zero for grids made here.
    #[inline]
    pub fn index_origin(&self) -> [i32; 3] {
        self.index_origin
    }

    /// Sets [`index_origin`](SparseGrid::index_origin).
    pub fn with_index_origin(mut self, origin: [i32; 3]) -> Self {
        self.index_origin = origin;
        self
    }

    /// Replaces the lattice geometry (spacing, origin, direction) keeping dims.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when `lattice` has other dims.
    pub fn set_lattice(&mut self, lattice: Lattice) -> Result<()> {
        if lattice.dims() != self.lattice.dims() {
            return Err(Error::InvalidInput(format!(
                "new lattice dims {:?} differ from the sparse grid's {:?}",
                lattice.dims(),
                self.lattice.dims()
            )));
        }
        self.lattice = lattice;
        Ok(())
    }

    /// Number of leaves.
    #[inline]
    pub fn num_leaves(&self) -> usize {
        self.leaf_origins.len()
    }

    /// The first point of leaf `n`.
    #[inline]
    pub fn leaf_origin(&self, n: usize) -> [u32; 3] {
        self.leaf_origins[n]
    }

    /// The samples of leaf `n`, x fastest ([`LEAF_SAMPLES`] of them; points past the lattice's
    /// end hold the background).
    #[inline]
    pub fn leaf_values(&self, n: usize) -> &[S] {
        &self.leaf_values[n * LEAF_SAMPLES..(n + 1) * LEAF_SAMPLES]
    }

    /// Every tile whose value is not the background, root entries first then each node's
    /// children, in root order (what a writer stores besides the leaves; memory ∝ tiles).
    pub fn tiles(&self) -> Vec<SparseTile<S>> {
        let dims = self.lattice.dims();
        let mut out = Vec::new();
        for (coord, e) in &self.root {
            let base = coord.map(|c| c * NODE_POINTS);
            match *e {
                Entry::Tile(value) => out.push(SparseTile { origin: base, size: NODE_POINTS, value }),
                Entry::Node(n) => {
                    for (c, child) in (0u32..).zip(self.nodes[n as usize].children.iter()) {
                        let o = [
                            base[0] + LEAF * (c % NODE),
                            base[1] + LEAF * (c / NODE % NODE),
                            base[2] + LEAF * (c / (NODE * NODE)),
                        ];
                        match *child {
                            Child::Tile(value) if value != self.background && (0..3).all(|a| o[a] < dims[a]) => {
                                out.push(SparseTile { origin: o, size: LEAF, value });
                            }
                            _ => {}
                        }
                    }
                }
            }
        }
        out
    }

    /// The samples of the points `lo .. hi` (half-open, lattice coordinates that may reach past
    /// the lattice on any side: those points hold the background) as a dense grid placed where
    /// these points lie in the world.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for an empty box or one wider than 2³²−1 points on an axis;
    /// [`Error::Limit`] above 2³¹ points (callers check their byte limits first).
    pub fn dense_region(&self, lo: [i64; 3], hi: [i64; 3]) -> Result<DenseGrid<S>> {
        let size = [0, 1, 2].map(|a| hi[a].saturating_sub(lo[a]));
        if size.iter().any(|&d| d <= 0 || d > i64::from(u32::MAX)) {
            return Err(Error::InvalidInput(format!(
                "region {lo:?} .. {hi:?}: every axis must hold 1 to 2³²−1 points (half-open ranges)"
            )));
        }
        let n = size.iter().map(|&d| d as u64).product::<u64>();
        const MAX: u64 = 1 << 31;
        if n > MAX {
            return Err(Error::Limit { what: "dense points", requested: n, allowed: MAX });
        }
        let dims = size.map(|d| d as u32);
        let src = &self.lattice;
        let origin = src.to_world(lo.map(|v| v as f64));
        let lattice = Lattice::with_geometry(dims, src.spacing(), origin)?
            .with_direction(src.direction())?
            .with_space(src.space());
        let mut data = vec![self.background; n as usize];
        // The part of the box inside the lattice, copied slab by slab.
        let ld = src.dims().map(i64::from);
        let (a, b) = ([0, 1, 2].map(|k| lo[k].clamp(0, ld[k])), [0, 1, 2].map(|k| hi[k].clamp(0, ld[k])));
        if (0..3).all(|k| a[k] < b[k]) {
            let mut slab = Vec::new();
            let row = (b[0] - a[0]) as usize;
            for z in a[2]..b[2] {
                self.fill_box(
                    [a[0] as u32, a[1] as u32, z as u32],
                    [b[0] as u32, b[1] as u32, z as u32 + 1],
                    &mut slab,
                );
                for (y, src_row) in (a[1]..b[1]).zip(slab.chunks_exact(row)) {
                    let at = (((z - lo[2]) * size[1] + (y - lo[1])) * size[0] + (a[0] - lo[0])) as usize;
                    data[at..at + row].copy_from_slice(src_row);
                }
            }
        }
        DenseGrid::new(lattice, data)
    }

    /// Counts and bytes (see [`SparseStats`]).
    pub fn stats(&self) -> SparseStats {
        let child_tiles = self
            .nodes
            .iter()
            .flat_map(|n| n.children.iter())
            .filter(|c| matches!(c, Child::Tile(v) if *v != self.background))
            .count();
        let root_tiles = self.root.iter().filter(|(_, e)| matches!(e, Entry::Tile(_))).count();
        let bytes = self.leaf_values.capacity() * std::mem::size_of::<S>()
            + self.leaf_origins.capacity() * 12
            + self.nodes.len() * (NODE_CHILDREN * std::mem::size_of::<Child<S>>() + std::mem::size_of::<Node<S>>())
            + self.root.capacity() * std::mem::size_of::<([u32; 3], Entry<S>)>()
            + self.lookup.capacity() * (12 + 4 + 8);
        SparseStats {
            leaves: self.num_leaves() as u64,
            stored_samples: (self.num_leaves() * LEAF_SAMPLES) as u64,
            nodes: self.nodes.len() as u64,
            root_tiles: root_tiles as u64,
            child_tiles: child_tiles as u64,
            bytes: bytes as u64,
        }
    }

    /// The root entry holding point `p`'s node, if any.
    #[inline]
    fn entry(&self, node: [u32; 3]) -> Option<Entry<S>> {
        self.lookup.get(&node).map(|&at| self.root[at as usize].1)
    }

    /// The sample at lattice point `ijk` (the background past the lattice).
    #[inline]
    pub fn get(&self, ijk: [u32; 3]) -> S {
        match self.entry(ijk.map(|v| v / NODE_POINTS)) {
            None => self.background,
            Some(Entry::Tile(v)) => v,
            Some(Entry::Node(n)) => match self.nodes[n as usize].children[child_index(ijk)] {
                Child::Tile(v) => v,
                Child::Leaf(l) => self.leaf_values[l as usize * LEAF_SAMPLES + in_leaf(ijk)],
            },
        }
    }

    /// The value of the block of 8³ points starting at `origin` (a multiple of [`LEAF`]): its
    /// leaf's index, or the one value of all its points.
    #[inline]
    fn block(&self, origin: [u32; 3]) -> Child<S> {
        match self.entry(origin.map(|v| v / NODE_POINTS)) {
            None => Child::Tile(self.background),
            Some(Entry::Tile(v)) => Child::Tile(v),
            Some(Entry::Node(n)) => self.nodes[n as usize].children[child_index(origin)],
        }
    }

    /// The block of 8³ points starting at `origin` (a multiple of [`LEAF`]): `Ok(v)` when all its
    /// points have the value `v` (a tile, or the background), `Err(n)` when it is leaf `n`.
    #[inline]
    pub fn block_at(&self, origin: [u32; 3]) -> std::result::Result<S, usize> {
        match self.block(origin) {
            Child::Tile(v) => Ok(v),
            Child::Leaf(l) => Err(l as usize),
        }
    }

    /// The blocks of 8³ points (origins) that are tiles (or background) with a face neighbour
    /// block that is a tile of the other side (`inside` tells the sides): where a surface runs
    /// between constant regions, with no leaf to show it. Each node's child tiles are checked
    /// across their six faces, each root tile across the blocks of its six faces.
    pub fn tile_boundary_blocks(&self, inside: &dyn Fn(S) -> bool) -> Vec<[u32; 3]> {
        let dims = self.lattice.dims();
        let mut out = Vec::new();
        let check = |o: [u32; 3], v: S, out: &mut Vec<[u32; 3]>| {
            for a in 0..3 {
                for up in [false, true] {
                    let mut n = o;
                    if up {
                        n[a] += LEAF;
                        if n[a] >= dims[a] {
                            continue;
                        }
                    } else if let Some(x) = n[a].checked_sub(LEAF) {
                        n[a] = x;
                    } else {
                        continue;
                    }
                    if let Child::Tile(w) = self.block(n) {
                        if inside(w) != inside(v) {
                            out.push(o);
                            out.push(n);
                        }
                    }
                }
            }
        };
        for node in &self.nodes {
            let base = node.coord.map(|c| c * NODE_POINTS);
            for (c, child) in node.children.iter().enumerate() {
                if let Child::Tile(v) = *child {
                    let c = c as u32;
                    let o = [
                        base[0] + LEAF * (c % NODE),
                        base[1] + LEAF * (c / NODE % NODE),
                        base[2] + LEAF * (c / (NODE * NODE)),
                    ];
                    if (0..3).all(|a| o[a] < dims[a]) {
                        check(o, v, &mut out);
                    }
                }
            }
        }
        let nodes = dims.map(|d| d.div_ceil(NODE_POINTS));
        for (coord, entry) in &self.root {
            let Entry::Tile(v) = *entry else { continue };
            let base = coord.map(|c| c * NODE_POINTS);
            // The blocks on the tile's faces, but for faces against a root tile of the same side
            // or the lattice's end (a tile of 4096³ points is 32768 of these).
            for a in 0..3 {
                for side in [0, NODE - 1] {
                    let mut n = *coord;
                    if side == 0 {
                        let Some(x) = n[a].checked_sub(1) else { continue };
                        n[a] = x;
                    } else {
                        n[a] += 1;
                        if n[a] >= nodes[a] {
                            continue;
                        }
                    }
                    let across = match self.entry(n) {
                        None => Some(self.background),
                        Some(Entry::Tile(w)) => Some(w),
                        Some(Entry::Node(_)) => None,
                    };
                    if across.is_some_and(|w| inside(w) == inside(v)) {
                        continue;
                    }
                    for u in 0..NODE {
                        for w in 0..NODE {
                            let mut o = base;
                            o[a] += LEAF * side;
                            o[(a + 1) % 3] += LEAF * u;
                            o[(a + 2) % 3] += LEAF * w;
                            if (0..3).all(|x| o[x] < dims[x]) {
                                check(o, v, &mut out);
                            }
                        }
                    }
                }
            }
        }
        out
    }

    /// The samples of the points `lo .. hi` (half-open, inside the lattice), x fastest, into
    /// `out` (resized): leaf rows copied, tiles filled.
    pub fn fill_box(&self, lo: [u32; 3], hi: [u32; 3], out: &mut Vec<S>) {
        let d = [0, 1, 2].map(|a| hi[a].saturating_sub(lo[a]) as usize);
        out.clear();
        out.resize(d[0] * d[1] * d[2], self.background);
        if out.is_empty() {
            return;
        }
        // Block by block: each block of 8³ points meeting the box, its part of every row.
        let first = lo.map(|v| v / LEAF * LEAF);
        for bz in (first[2]..hi[2]).step_by(LEAF as usize) {
            for by in (first[1]..hi[1]).step_by(LEAF as usize) {
                for bx in (first[0]..hi[0]).step_by(LEAF as usize) {
                    let b = [bx, by, bz];
                    let (s, e) = ([0, 1, 2].map(|a| b[a].max(lo[a])), [0, 1, 2].map(|a| (b[a] + LEAF).min(hi[a])));
                    let child = self.block(b);
                    for z in s[2]..e[2] {
                        for y in s[1]..e[1] {
                            let at =
                                ((z - lo[2]) as usize * d[1] + (y - lo[1]) as usize) * d[0] + (s[0] - lo[0]) as usize;
                            let row = &mut out[at..at + (e[0] - s[0]) as usize];
                            match child {
                                Child::Tile(v) => row.fill(v),
                                Child::Leaf(l) => {
                                    let base = l as usize * LEAF_SAMPLES + in_leaf([s[0], y, z]);
                                    row.copy_from_slice(&self.leaf_values[base..base + row.len()]);
                                }
                            }
                        }
                    }
                }
            }
        }
    }

    /// The grid stored densely (for tests and small grids).
    ///
    /// # Errors
    /// [`Error::Limit`] above 2³¹ points.
    pub fn to_dense(&self) -> Result<DenseGrid<S>> {
        let n = self.lattice.num_points();
        const MAX: u64 = 1 << 31;
        if n > MAX {
            return Err(Error::Limit { what: "dense points", requested: n, allowed: MAX });
        }
        let mut data = Vec::new();
        self.fill_box([0; 3], self.lattice.dims(), &mut data);
        DenseGrid::new(self.lattice.clone(), data)
    }

    /// The smallest and largest sample of each leaf, in leaf order (as `f64`).
    pub fn leaf_bounds(&self) -> Vec<[f64; 2]> {
        self.leaf_values
            .chunks_exact(LEAF_SAMPLES)
            .map(|v| {
                v.iter().fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], s| {
                    let s = s.to_f64();
                    [lo.min(s), hi.max(s)]
                })
            })
            .collect()
    }

    /// The value range of the samples: every leaf's, every tile's and the background's when some
    /// point has it. `None` for a lattice without points.
    pub fn value_range(&self) -> Option<super::ValueRange> {
        if self.lattice.num_points() == 0 {
            return None;
        }
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        let mut take = |v: f64| {
            lo = lo.min(v);
            hi = hi.max(v);
        };
        for [a, b] in self.leaf_bounds() {
            take(a);
            take(b);
        }
        for (_, e) in &self.root {
            if let Entry::Tile(v) = e {
                take(v.to_f64());
            }
        }
        for n in &self.nodes {
            for c in n.children.iter() {
                if let Child::Tile(v) = c {
                    take(v.to_f64());
                }
            }
        }
        // The background, when the root does not cover the lattice.
        let nodes = self.lattice.dims().map(|d| d.div_ceil(NODE_POINTS) as u64);
        if (self.root.len() as u64) < nodes.iter().product::<u64>() {
            take(self.background.to_f64());
        }
        Some(super::ValueRange { min: lo, max: hi })
    }

    /// Builds a grid node by node (in parallel, in a deterministic order): `node(coord)` makes
    /// the node of 128³ points at node coordinate `coord` ([`SparseNode::tile`] when all its
    /// points have one value, [`SparseNode::blocks`] otherwise). Nodes that are tiles of the
    /// background are left out.
    pub fn build(lattice: Lattice, background: S, node: &(dyn Fn([u32; 3]) -> SparseNode<S> + Sync)) -> Self {
        let per_axis = lattice.dims().map(|d| d.div_ceil(NODE_POINTS));
        let coords: Vec<[u32; 3]> = (0..per_axis[2])
            .flat_map(|z| (0..per_axis[1]).flat_map(move |y| (0..per_axis[0]).map(move |x| [x, y, z])))
            .collect();
        Self::build_nodes(lattice, background, coords, node)
    }

    /// [`build`](SparseGrid::build) visiting only the nodes at `coords` (node coordinates, any
    /// order, inside the lattice); every other point has the background. For sources that know
    /// where their data is (a file's leaves and tiles).
    pub fn build_nodes(
        lattice: Lattice,
        background: S,
        mut coords: Vec<[u32; 3]>,
        node: &(dyn Fn([u32; 3]) -> SparseNode<S> + Sync),
    ) -> Self {
        let per_axis = lattice.dims().map(|d| d.div_ceil(NODE_POINTS));
        coords.retain(|c| (0..3).all(|a| c[a] < per_axis[a]));
        coords.sort_unstable_by_key(|c| (c[2], c[1], c[0]));
        coords.dedup();
        #[cfg(feature = "parallel")]
        let built: Vec<SparseNode<S>> = {
            use rayon::prelude::*;
            coords.par_iter().map(|&c| node(c)).collect()
        };
        #[cfg(not(feature = "parallel"))]
        let built: Vec<SparseNode<S>> = coords.iter().map(|&c| node(c)).collect();
        let mut grid = SparseGrid::new(lattice, background);
        // One allocation of the final size: no copies while growing, no pages touched twice.
        let (leaves, samples) = built.iter().fold((0, 0), |(l, s), n| match &n.0 {
            Built::Children { origins, values, .. } => (l + origins.len(), s + values.len()),
            Built::Tile(_) => (l, s),
        });
        grid.leaf_origins.reserve_exact(leaves);
        grid.leaf_values.reserve_exact(samples);
        for (coord, node) in coords.into_iter().zip(built) {
            let entry = match node.0 {
                Built::Tile(v) if v == background => continue,
                Built::Tile(v) => Entry::Tile(v),
                Built::Children { mut children, origins, values } => {
                    let first = grid.leaf_origins.len() as u32;
                    for c in children.iter_mut() {
                        if let Child::Leaf(l) = c {
                            *l += first;
                        }
                    }
                    grid.leaf_origins.extend_from_slice(&origins);
                    grid.leaf_values.extend_from_slice(&values);
                    grid.nodes.push(Node { coord, children });
                    Entry::Node((grid.nodes.len() - 1) as u32)
                }
            };
            grid.lookup.insert(coord, grid.root.len() as u32);
            grid.root.push((coord, entry));
        }
        grid.leaf_values.shrink_to_fit();
        grid.leaf_origins.shrink_to_fit();
        grid
    }
}

impl<S: Sample> SparseGrid<S> {
    /// The next level of the multiresolution pyramid: each point the mean of a 2³ block of this
    /// grid's points, at the block's centre (spacing doubled; trailing points that fill no block
    /// dropped), as [`downsample_mean`](super::downsample_mean) does for dense grids. A coarse
    /// block whose eight fine blocks are tiles of one value stays a tile; the others are leaves.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when an axis has fewer than 2 points.
    pub fn downsample(&self) -> Result<SparseGrid<f32>> {
        let lat = &self.lattice;
        let dims = lat.dims();
        if dims.iter().any(|&n| n < 2) {
            return Err(Error::InvalidInput(format!("a sparse grid of {dims:?} points has no coarser level")));
        }
        let coarse = dims.map(|n| n / 2);
        let lattice = Lattice::with_geometry(coarse, lat.spacing().map(|s| s * 2.0), lat.to_world([0.5; 3]))?
            .with_direction(lat.direction())?
            .with_space(lat.space());
        let background = self.background.to_f64() as f32;
        let node = |coord: [u32; 3]| {
            let mut fine = Vec::new();
            SparseNode::blocks(coord, coarse, background, &mut |o: [u32; 3], out: &mut [f32]| {
                // The eight fine blocks under this coarse block: one value, or means.
                let mut one: Option<Option<S>> = None;
                for c in 0..8u32 {
                    let f = [0, 1, 2].map(|a| 2 * o[a] + LEAF * (c >> a & 1));
                    if (0..3).any(|a| f[a] >= 2 * coarse[a]) {
                        continue;
                    }
                    one = match (one, self.block_at(f)) {
                        (None, Ok(v)) => Some(Some(v)),
                        (Some(Some(u)), Ok(v)) if u == v => Some(Some(u)),
                        _ => Some(None),
                    };
                }
                if let Some(Some(v)) = one {
                    return Some(v.to_f64() as f32);
                }
                let hi = [0, 1, 2].map(|a| (2 * (o[a] + LEAF)).min(2 * coarse[a]));
                self.fill_box(o.map(|v| 2 * v), hi, &mut fine);
                let d = [0, 1, 2].map(|a| (hi[a] - 2 * o[a]) as usize);
                for z in 0..d[2] / 2 {
                    for y in 0..d[1] / 2 {
                        for x in 0..d[0] / 2 {
                            let mut sum = 0.0f64;
                            for c in 0..8usize {
                                let (i, j, k) = (2 * x + (c & 1), 2 * y + (c >> 1 & 1), 2 * z + (c >> 2 & 1));
                                sum += fine[(k * d[1] + j) * d[0] + i].to_f64();
                            }
                            out[in_leaf([x as u32, y as u32, z as u32])] = (sum / 8.0) as f32;
                        }
                    }
                }
                None
            })
        };
        Ok(SparseGrid::build(lattice, background, &node))
    }
}

/// How [`SparseNode::blocks`] asks for one block: its value, or its samples written.
pub type BlockFill<'a, S> = dyn FnMut([u32; 3], &mut [S]) -> Option<S> + 'a;

/// One node as a constructor makes it: see [`SparseGrid::build`].
pub struct SparseNode<S>(Built<S>);

enum Built<S> {
    Tile(S),
    Children { children: Box<[Child<S>]>, origins: Vec<[u32; 3]>, values: Vec<S> },
}

impl<S: Sample> SparseNode<S> {
    /// A node all of whose points have the value `v`.
    pub fn tile(v: S) -> Self {
        SparseNode(Built::Tile(v))
    }

    /// The node at node coordinate `coord` of a lattice with `dims` points, block by block:
    /// `block(origin, out)` returns `Some(v)` for a block of 8³ points that all have the value
    /// `v`, or `None` after writing its samples into `out` (x fastest, [`LEAF_SAMPLES`] of them,
    /// `fill` elsewhere: points past the lattice). A node whose blocks all have one value is a
    /// tile.
    pub fn blocks(coord: [u32; 3], dims: [u32; 3], fill: S, block: &mut BlockFill<'_, S>) -> Self {
        let base = coord.map(|c| c * NODE_POINTS);
        let mut children = vec![Child::Tile(fill); NODE_CHILDREN].into_boxed_slice();
        let (mut origins, mut values) = (Vec::new(), Vec::new());
        let mut one: Option<Option<S>> = None; // Some(Some(v)): every block so far a tile of v
        for c in 0..NODE_CHILDREN as u32 {
            let o =
                [base[0] + LEAF * (c % NODE), base[1] + LEAF * (c / NODE % NODE), base[2] + LEAF * (c / (NODE * NODE))];
            if (0..3).any(|a| o[a] >= dims[a]) {
                continue;
            }
            let at = values.len();
            values.resize(at + LEAF_SAMPLES, fill);
            let child = match block(o, &mut values[at..]) {
                Some(v) => {
                    values.truncate(at);
                    Child::Tile(v)
                }
                None => {
                    origins.push(o);
                    Child::Leaf((origins.len() - 1) as u32)
                }
            };
            one = match (one, child) {
                (None, Child::Tile(v)) => Some(Some(v)),
                (Some(Some(u)), Child::Tile(v)) if u == v => Some(Some(u)),
                _ => Some(None),
            };
            children[c as usize] = child;
        }
        match one {
            Some(Some(v)) => SparseNode(Built::Tile(v)),
            None => SparseNode(Built::Tile(fill)),
            Some(None) => SparseNode(Built::Children { children, origins, values }),
        }
    }
}

/// Writes the samples `get(p)` of the block of 8³ points at `o` into `out` (x fastest), leaving
/// the points past `dims` alone.
pub(crate) fn copy_block<S: Copy>(o: [u32; 3], dims: [u32; 3], out: &mut [S], get: impl Fn([u32; 3]) -> S) {
    for z in o[2]..(o[2] + LEAF).min(dims[2]) {
        for y in o[1]..(o[1] + LEAF).min(dims[1]) {
            for x in o[0]..(o[0] + LEAF).min(dims[0]) {
                out[in_leaf([x, y, z])] = get([x, y, z]);
            }
        }
    }
}

/// Index of the child holding point `p` in its node (x fastest).
#[inline]
fn child_index(p: [u32; 3]) -> usize {
    let c = p.map(|v| (v / LEAF) % NODE);
    (c[0] + NODE * (c[1] + NODE * c[2])) as usize
}

/// Index of point `p` in its leaf (x fastest).
#[inline]
pub(crate) fn in_leaf(p: [u32; 3]) -> usize {
    let c = p.map(|v| v % LEAF);
    (c[0] + LEAF * (c[1] + LEAF * c[2])) as usize
}

/// A sparse grid of either floating sample type (what sparse files hold: OpenVDB's float and
/// double grids), matched once at the top of a pipeline.
#[derive(Debug, Clone, PartialEq)]
pub enum AnySparse {
    /// 32-bit samples.
    F32(SparseGrid<f32>),
    /// 64-bit samples.
    F64(SparseGrid<f64>),
}

impl AnySparse {
    /// The lattice the grid samples.
    pub fn lattice(&self) -> &Lattice {
        match self {
            AnySparse::F32(g) => g.lattice(),
            AnySparse::F64(g) => g.lattice(),
        }
    }

    /// Counts and bytes.
    pub fn stats(&self) -> SparseStats {
        match self {
            AnySparse::F32(g) => g.stats(),
            AnySparse::F64(g) => g.stats(),
        }
    }

    /// The value range of the samples (see [`SparseGrid::value_range`]).
    pub fn value_range(&self) -> Option<super::ValueRange> {
        match self {
            AnySparse::F32(g) => g.value_range(),
            AnySparse::F64(g) => g.value_range(),
        }
    }

    /// Where lattice point 0 sits in the file's signed index space.
    pub fn index_origin(&self) -> [i32; 3] {
        match self {
            AnySparse::F32(g) => g.index_origin(),
            AnySparse::F64(g) => g.index_origin(),
        }
    }
}
