//! Mesh → volume: a broken triangle mesh made into a signed distance grid (sparse, negative
//! inside) whose zero level set is the repaired solid.
//!
//! ```text
//! Mesh ─Solid::new (weld, dedupe, orient patches, outward, nested shells)─▶ Solid
//!      ─bin triangles into 8³ blocks (box + band)─▶ exact distances in the band (mesh/distance.rs)
//!      ─fast winding numbers (winding.rs) decide the side─▶ SparseGrid<f32>
//! ```
//!
//! Signs: a point is inside when the generalised winding number of the repaired surface is
//! above ½. Orienting every patch consistently first is what makes winding numbers robust to
//! flipped faces (they would cancel otherwise); holes only blur the winding number near their
//! rims, and duplicated faces are dropped before they could count twice. Distances: the exact
//! distance to the nearest triangle for every point within `band` cells of the surface
//! (every triangle is tested against every point of the blocks its box plus the band touches, so
//! nothing nearer is missed); `±band` elsewhere, as OpenVDB's narrow-band level sets.

mod solid;
mod winding;

pub use solid::{Repairs, Solid};
pub use winding::{solid_angle, Winding};

use glam::DVec3;

use crate::error::{Error, Result};
use crate::grid::sparse::{SparseGrid, SparseNode, LEAF, LEAF_SAMPLES, NODE_POINTS};
use crate::grid::Lattice;
use crate::math::{Aabb, UnionFind};
use crate::mesh::distance::{closest_point, distance_squared};
use crate::mesh::Mesh;

/// The most nodes of 128³ points a lattice may have (a 16,384³ lattice has 2²¹).
const MAX_NODES: u64 = 1 << 22;

/// Points of a group of same-side points that ask the winding number (see [`voxelize`]).
const PROBES: usize = 8;

/// How fine the lattice is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Resolution {
    /// Cells along the longest side of the mesh's box.
    Cells(u32),
    /// The spacing of the lattice, in world units.
    Spacing(f64),
}

impl Resolution {
    /// The cell count, for [`Resolution::Cells`].
    pub fn cells(self) -> Option<u32> {
        match self {
            Resolution::Cells(n) => Some(n),
            Resolution::Spacing(_) => None,
        }
    }
}

/// What [`voxelize`] computes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VoxelizeOptions {
    /// The narrow band's half-width in cells: exact distances within it, `±band` beyond.
    pub band: f64,
    /// The most the grid's leaves may take, in bytes: checked before they are allocated.
    pub max_bytes: u64,
}

impl Default for VoxelizeOptions {
    fn default() -> Self {
        VoxelizeOptions { band: 3.0, max_bytes: u64::MAX }
    }
}

/// What a voxelized mesh is written as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Output {
    /// Signed distances (`f32`, negative inside): mesh it at iso 0.
    Sdf,
    /// `u8` occupancy: 1 inside, 0 outside (mesh it at iso 0.5 with the inside above).
    Occupancy,
}

/// A voxelized mesh: the signed distance grid and what was repaired on the way.
pub struct Voxelized {
    /// Signed distances in world units, negative inside; `±band · spacing` beyond the band.
    pub grid: SparseGrid<f32>,
    /// What cleaning changed in the input.
    pub repairs: Repairs,
}

impl Voxelized {
    /// The grid as PolyMender's signed octree: signs at the points (inside ⇔ value < 0), and in
    /// each cell whose corners differ the mean of its edges' linear zero crossings (the cell's
    /// dual contouring vertex without normals). The lattice must be a cube of `2^depth` cells
    /// ([`lattice_for_octree`]).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for another lattice, or as [`SignedOctree::from_cells`](crate::grid::SignedOctree::from_cells).
    pub fn to_signed_octree(&self) -> Result<crate::grid::SignedOctree> {
        crate::grid::SignedOctree::from_values(self.grid.lattice(), &|p| self.grid.get(p), None)
    }

    /// The grid as a dense volume of `output`'s kind.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when the dense grid's samples exceed `max_bytes` (checked first).
    pub fn to_dense(&self, output: Output, max_bytes: u64) -> Result<crate::grid::AnyGrid> {
        let lattice = self.grid.lattice();
        let per = if output == Output::Sdf { 4 } else { 1 };
        let bytes = lattice.num_points().saturating_mul(per);
        if bytes > max_bytes {
            let d = lattice.dims();
            return Err(Error::InvalidInput(format!(
                "a dense {} x {} x {} grid needs {bytes} bytes, over the limit of {max_bytes}",
                d[0], d[1], d[2]
            )));
        }
        let sdf = self.grid.to_dense()?;
        Ok(match output {
            Output::Sdf => crate::grid::AnyGrid::F32(sdf),
            Output::Occupancy => {
                let (lattice, values) = sdf.into_parts();
                let inside = values.into_iter().map(|v| u8::from(v < 0.0)).collect();
                crate::grid::AnyGrid::U8(crate::grid::DenseGrid::new(lattice, inside)?)
            }
        })
    }
}

/// The cubic lattice of `2^depth` cells per axis covering `mesh` with `margin` cells around its
/// box: the lattice of a [`SignedOctree`](crate::grid::SignedOctree) (see
/// [`Voxelized::to_signed_octree`]).
///
/// # Errors
/// [`Error::InvalidInput`] for an empty mesh, non-finite positions, a depth outside 1..=10 or
/// one that leaves no cell inside the margins.
pub fn lattice_for_octree(mesh: &Mesh, depth: u32, margin: u32) -> Result<Lattice> {
    if !(1..=10).contains(&depth) {
        return Err(Error::InvalidInput(format!("octree depth {depth} is not from 1 to 10")));
    }
    let cells = 1u32 << depth;
    if cells <= 2 * margin + 1 {
        return Err(Error::InvalidInput(format!(
            "octree depth {depth} ({cells} cells) leaves no cell inside a margin of {margin}"
        )));
    }
    let loose = lattice_for(mesh, Resolution::Cells(1), 0)?;
    let (lo, hi) = loose.world_bounds();
    let longest = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max);
    let h = if longest > 0.0 { longest / (cells - 2 * margin) as f64 } else { 1.0 };
    let origin = [0, 1, 2].map(|a| 0.5 * (lo[a] + hi[a]) - 0.5 * cells as f64 * h);
    Lattice::with_geometry([cells + 1; 3], [h; 3], origin)
}

/// The lattice covering `mesh` at `resolution`, with `margin` cells around its box (so the
/// surface never touches the lattice's faces and the band fits).
///
/// # Errors
/// [`Error::InvalidInput`] for an empty mesh, non-finite positions, a resolution below 1 or a
/// lattice of more than 2³² − 1 points per axis.
pub fn lattice_for(mesh: &Mesh, resolution: Resolution, margin: u32) -> Result<Lattice> {
    let mut b = Aabb::EMPTY;
    for p in &mesh.positions {
        if p.iter().any(|v| !v.is_finite()) {
            return Err(Error::InvalidInput(format!("vertex position {p:?} is not finite")));
        }
    }
    for t in mesh.all_triangles() {
        t.iter().for_each(|&v| b.add(mesh.positions[v as usize].map(f64::from)));
    }
    if b.is_empty() {
        return Err(Error::InvalidInput("the mesh has no triangles to voxelize".into()));
    }
    let size = b.size();
    let longest = size.iter().cloned().fold(0.0, f64::max);
    let h = match resolution {
        Resolution::Cells(n) if n >= 1 => longest / n as f64,
        Resolution::Spacing(h) if h > 0.0 && h.is_finite() => h,
        Resolution::Cells(n) => {
            return Err(Error::InvalidInput(format!("resolution {n} is not a positive cell count")))
        }
        Resolution::Spacing(h) => return Err(Error::InvalidInput(format!("voxel size {h} is not a positive length"))),
    };
    // A flat mesh (a plate of zero thickness) still gets a lattice: one cell for a zero extent.
    let h = if h > 0.0 { h } else { 1.0 };
    let mut dims = [0u32; 3];
    let mut origin = [0.0; 3];
    for a in 0..3 {
        let cells = (size[a] / h).ceil() + 2.0 * margin as f64;
        if cells + 1.0 > u32::MAX as f64 {
            return Err(Error::InvalidInput(format!(
                "a lattice of {cells} cells along axis {a} does not fit (spacing {h})"
            )));
        }
        dims[a] = cells as u32 + 1;
        // Centre the box in the lattice.
        origin[a] = b.min[a] - 0.5 * ((cells - 2.0 * margin as f64) * h - size[a]) - margin as f64 * h;
    }
    Lattice::with_geometry(dims, [h; 3], origin)
}

/// Voxelizes `mesh` on `lattice` (axis-aligned): see the module's text.
///
/// # Errors
/// [`Error::InvalidInput`] for a rotated lattice, a band that is not positive or a mesh with no
/// triangle left after cleaning.
pub fn voxelize(mesh: &Mesh, lattice: Lattice, opts: &VoxelizeOptions) -> Result<Voxelized> {
    if lattice.direction() != [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] {
        return Err(Error::InvalidInput("voxelize needs an axis-aligned lattice".into()));
    }
    if !(opts.band > 0.0 && opts.band.is_finite()) {
        return Err(Error::InvalidInput(format!("band {} is not a positive number of cells", opts.band)));
    }
    let solid = Solid::new(mesh);
    if solid.triangles.is_empty() {
        return Err(Error::InvalidInput("the mesh has no triangle with an area to voxelize".into()));
    }
    let winding = solid.winding();
    let spacing = lattice.spacing();
    let h = spacing[0].min(spacing[1]).min(spacing[2]);
    let band = opts.band * h;
    let dims = lattice.dims();
    let nodes: u64 = dims.iter().map(|&d| d.div_ceil(NODE_POINTS) as u64).product();
    if nodes > MAX_NODES {
        return Err(Error::InvalidInput(format!(
            "a lattice of {} x {} x {} points is too large to voxelize ({nodes} nodes of 128³ points, at most {MAX_NODES})",
            dims[0], dims[1], dims[2]
        )));
    }
    let bins = Bins::new(&solid.triangles, &lattice, band, opts.max_bytes)?;
    let leaves = bins.blocks_touched() as u64;
    let leaf_bytes = leaves.saturating_mul((crate::grid::sparse::LEAF_SAMPLES * 4) as u64);
    if leaf_bytes > opts.max_bytes {
        return Err(Error::InvalidInput(format!(
            "the band's {leaves} blocks of 8³ samples need {leaf_bytes} bytes, over the limit of {}",
            opts.max_bytes
        )));
    }
    let origin = lattice.origin();
    let world = |ijk: [u32; 3]| DVec3::from_array([0, 1, 2].map(|a| origin[a] + ijk[a] as f64 * spacing[a]));
    let far = band as f32;
    let step = DVec3::from_array(spacing).length();
    let at = |o: [u32; 3], n: usize| {
        let n = n as u32;
        [o[0] + n % LEAF, o[1] + n / LEAF % LEAF, o[2] + n / (LEAF * LEAF)]
    };
    let node = |coord: [u32; 3]| {
        if !bins.node_touched(coord) {
            // No triangle near the node: one side, unless the winding number is undecided.
            let centre =
                world(coord.map(|c| c * NODE_POINTS)) + 0.5 * (NODE_POINTS - 1) as f64 * DVec3::from_array(spacing);
            let w = winding.at(centre);
            if (w - 0.5).abs() > 0.45 {
                return SparseNode::tile(if w > 0.5 { -far } else { far });
            }
        }
        SparseNode::blocks(coord, dims, far, &mut |o: [u32; 3], out: &mut [f32]| {
            let hi = o.map(|v| v + LEAF);
            if !bins.touches(o) {
                // No triangle within the band: one side, unless the winding number is undecided
                // (a hole's rim is near): then every point decides.
                let centre = world(o) + 0.5 * (LEAF - 1) as f64 * DVec3::from_array(spacing);
                let w = winding.at(centre);
                if (w - 0.5).abs() > 0.25 {
                    return Some(if w > 0.5 { -far } else { far });
                }
            }
            // Distances first. The previous point's distance bounds this one's
            // (d(p) ≤ d(q) + |p − q|): a tight first bound for the nearest-triangle search.
            let mut dist = [f64::NAN; LEAF_SAMPLES];
            // Which side of its nearest triangle's plane each point is (in front: true).
            let mut front = [true; LEAF_SAMPLES];
            let mut last: Option<f64> = None;
            for n in 0..LEAF_SAMPLES {
                let ijk = at(o, n);
                if (0..3).any(|a| ijk[a] >= dims[a].min(hi[a])) {
                    last = None;
                    continue;
                }
                let p = world(ijk);
                let exact = |d2: f64| {
                    solid.bvh.nearest(p.to_array(), d2, &mut |t| distance_squared(p, &solid.triangles[t as usize]))
                };
                let found = match last {
                    Some(d) if d + step < band => exact((d + step) * (d + step)).or_else(|| exact(band * band)),
                    _ => exact(band * band),
                };
                let d = found.map_or(band, |(_, d2)| d2.sqrt().min(band));
                if let Some((t, _)) = found {
                    let t = &solid.triangles[t as usize];
                    front[n] = (p - closest_point(p, t)).dot((t[1] - t[0]).cross(t[2] - t[0])) >= 0.0;
                }
                last = Some(d);
                dist[n] = d;
            }
            // Then sides. Neighbours whose distances add up to more than their gap have no
            // triangle between them, so they share a side of the surface; a group could still
            // reach around through a hole, which the side of the nearest triangle's plane (it
            // turns where a path passes through a hole's rim) keeps from happening. Each group
            // asks the winding number at up to `PROBES` of its points spread over it, and
            // takes the answer when they all agree clearly; otherwise every point asks.
            let mut groups = UnionFind::new(LEAF_SAMPLES);
            for (n, &d) in dist.iter().enumerate() {
                if d.is_nan() {
                    continue;
                }
                for (a, stride) in [(0, 1), (1, LEAF as usize), (2, (LEAF * LEAF) as usize)] {
                    let m = n + stride;
                    let next_in_block = (n / stride) % LEAF as usize + 1 < LEAF as usize;
                    if next_in_block
                        && !dist[m].is_nan()
                        && front[n] == front[m]
                        && d + dist[m] > spacing[a] * (1.0 + 1e-9)
                    {
                        groups.union(n, m);
                    }
                }
            }
            let mut members: Vec<Vec<u16>> = vec![Vec::new(); LEAF_SAMPLES];
            for (n, &d) in dist.iter().enumerate() {
                if !d.is_nan() {
                    members[groups.find(n)].push(n as u16);
                }
            }
            // Points whose own winding number decided, and it was close to ½.
            let mut undecided = Vec::new();
            for group in members.iter().filter(|g| !g.is_empty()) {
                let stride = group.len().div_ceil(PROBES);
                let mut agreed: Option<bool> = None;
                let mut clear = true;
                for &n in group.iter().step_by(stride) {
                    let w = winding.at(world(at(o, n as usize)));
                    let inside = w > 0.5;
                    clear &= (w - 0.5).abs() > 0.25 && agreed.is_none_or(|a| a == inside);
                    agreed = Some(inside);
                }
                for &n in group {
                    let n = n as usize;
                    let inside = match (clear, agreed) {
                        (true, Some(a)) => a,
                        _ => {
                            let w = winding.at(world(at(o, n)));
                            if (w - 0.5).abs() <= 0.25 {
                                undecided.push(n);
                            }
                            w > 0.5
                        }
                    };
                    out[n] = if inside { -dist[n] as f32 } else { dist[n] as f32 };
                }
            }
            // A lone point whose winding number was close to ½ and whose six neighbours all
            // took the other side is noise of the open surface around it (it would mesh as a
            // closed speck of 8 triangles): it joins its neighbours. Neighbours in other
            // blocks are asked directly.
            for n in undecided {
                let ijk = at(o, n);
                let lone = (0..6).all(|k| {
                    let (a, up) = (k / 2, k % 2 == 1);
                    let mut q = ijk;
                    if (!up && q[a] == 0) || (up && q[a] + 1 >= dims[a]) {
                        return false;
                    }
                    q[a] = if up { q[a] + 1 } else { q[a] - 1 };
                    let side = if (0..3).all(|b| q[b] >= o[b] && q[b] < hi[b]) {
                        let m = ((q[0] - o[0]) + LEAF * ((q[1] - o[1]) + LEAF * (q[2] - o[2]))) as usize;
                        out[m] < 0.0
                    } else {
                        winding.at(world(q)) > 0.5
                    };
                    side != (out[n] < 0.0)
                });
                if lone {
                    out[n] = -out[n];
                }
            }
            None
        })
    };
    let grid = SparseGrid::build(lattice, far, &node);
    Ok(Voxelized { grid, repairs: solid.repairs })
}

/// The blocks of 8³ points that a triangle's box, grown by the band, touches: where distances
/// are computed point by point.
struct Bins {
    /// Block keys, sorted, each once.
    keys: Vec<u64>,
    /// Blocks per axis.
    blocks: [u64; 3],
    /// Node keys (node coordinates, x fastest) of the blocks, sorted, each once.
    nodes: Vec<u64>,
}

impl Bins {
    /// # Errors
    /// When the (block, triangle) pairs would take more than `max_bytes` (counted first).
    fn new(triangles: &[[DVec3; 3]], lattice: &Lattice, band: f64, max_bytes: u64) -> Result<Self> {
        let dims = lattice.dims();
        let blocks = dims.map(|d| d.div_ceil(LEAF) as u64);
        let ranges: Vec<[(u64, u64); 3]> = triangles
            .iter()
            .filter_map(|t| {
                let mut b = Aabb::EMPTY;
                for p in t {
                    b.add(p.to_array());
                }
                let lo = lattice.to_index(b.min.map(|v| v - band));
                let hi = lattice.to_index(b.max.map(|v| v + band));
                let range = [0, 1, 2].map(|a| {
                    let first = lo[a].ceil().max(0.0);
                    let last = hi[a].floor().min(dims[a] as f64 - 1.0);
                    (first as u64 / LEAF as u64, last as u64 / LEAF as u64, first <= last)
                });
                range.iter().all(|r| r.2).then(|| range.map(|r| (r.0, r.1)))
            })
            .collect();
        let pairs: u128 = ranges.iter().map(|r| r.iter().map(|&(a, b)| (b - a + 1) as u128).product::<u128>()).sum();
        if pairs.saturating_mul(8) > max_bytes as u128 {
            return Err(Error::InvalidInput(format!(
                "the triangles touch {pairs} blocks of 8³ points with the band, {} bytes to list, over the limit of {max_bytes}",
                pairs.saturating_mul(8)
            )));
        }
        let mut keys = Vec::with_capacity(pairs as usize);
        for range in ranges {
            for z in range[2].0..=range[2].1 {
                for y in range[1].0..=range[1].1 {
                    for x in range[0].0..=range[0].1 {
                        keys.push((z * blocks[1] + y) * blocks[0] + x);
                    }
                }
            }
        }
        keys.sort_unstable();
        keys.dedup();
        let per_node = (NODE_POINTS / LEAF) as u64;
        let node_axes = blocks.map(|b| b.div_ceil(per_node));
        let mut nodes: Vec<u64> = keys
            .iter()
            .map(|&k| {
                let b = [k % blocks[0], k / blocks[0] % blocks[1], k / (blocks[0] * blocks[1])];
                let n = b.map(|v| v / per_node);
                (n[2] * node_axes[1] + n[1]) * node_axes[0] + n[0]
            })
            .collect();
        nodes.sort_unstable();
        nodes.dedup();
        Ok(Bins { keys, blocks, nodes })
    }

    /// True when a triangle is near the node at node coordinate `c`.
    fn node_touched(&self, c: [u32; 3]) -> bool {
        let per_node = (NODE_POINTS / LEAF) as u64;
        let axes = self.blocks.map(|b| b.div_ceil(per_node));
        self.nodes.binary_search(&((c[2] as u64 * axes[1] + c[1] as u64) * axes[0] + c[0] as u64)).is_ok()
    }

    /// How many blocks have a triangle near.
    fn blocks_touched(&self) -> usize {
        self.keys.len()
    }

    /// True when a triangle is near the block at point `o`.
    fn touches(&self, o: [u32; 3]) -> bool {
        let b = o.map(|v| (v / LEAF) as u64);
        self.keys.binary_search(&((b[2] * self.blocks[1] + b[1]) * self.blocks[0] + b[0])).is_ok()
    }
}
