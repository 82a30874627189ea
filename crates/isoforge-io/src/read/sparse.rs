//! Sparse volumes from files: an OpenVDB grid as a [`SparseGrid`] on a lattice that spans its
//! leaves and tiles, its transform as the lattice's geometry.
//!
//! ```text
//!   VDB index space (i32)     lattice (u32)           world
//!   p                    →    p − index_origin   →    the grid's index → world map
//! ```
//! `index_origin` is one less than the smallest coordinate of a leaf or tile, rounded down to a
//! multiple of 128 (so VDB's 128³ tiles stay whole nodes), and the lattice ends one point past the
//! largest: a point of background on every side closes surfaces that reach the data's edge.
//! Points past the leaves and tiles hold the background.

use std::collections::HashMap;
use std::path::Path;

use isoforge::grid::{AnySparse, Lattice, Sample, SparseGrid, SparseNode};

use super::vdb::{read_vdb, shown, VdbFile, VdbGrid, VdbLeaf, VdbLeaves, VdbTransform};
use crate::error::{Error, Result};
use crate::limits::Limits;

/// A sparse grid read from a file, with what the file said of it.
#[derive(Debug, Clone)]
pub struct SparseFile {
    /// The grid.
    pub grid: AnySparse,
    /// The grid's name in the file.
    pub name: String,
    /// The grid's class (`level set`, `fog volume`), when the file says.
    pub class: Option<String>,
    /// Points the file marks active (leaf bits and active tiles' points).
    pub active_points: u64,
    /// The other grids of the file (names), not read.
    pub others: Vec<String>,
    /// The smallest and largest active points (inclusive), in the file's index space; `None`
    /// when no point is active.
    pub active_bounds: Option<[[i32; 3]; 2]>,
}

/// Points per node of the sparse grid (its leaves 8, its nodes 16 leaves).
const NODE_POINTS: i64 = 128;

/// Reads the grid `name` (the first float or double grid when `None`) of the OpenVDB file at
/// `path` as a sparse grid.
///
/// # Errors
/// The reader's; [`Error::Read`] when the file holds no float or double grid, or no grid of that
/// name; [`Error::Unsupported`] for a transform that is not a rotation and scale (shear,
/// projection) or a grid wider than a lattice can index.
pub fn read_sparse(path: &Path, name: Option<&str>, limits: &Limits) -> Result<SparseFile> {
    let file = read_vdb(path, limits)?;
    sparse_from_vdb(path, file, name)
}

/// [`read_sparse`] on a file already read.
///
/// # Errors
/// As [`read_sparse`].
pub fn sparse_from_vdb(path: &Path, file: VdbFile, name: Option<&str>) -> Result<SparseFile> {
    let read_err = |detail: String| Error::Read { path: path.to_path_buf(), format: "VDB", detail };
    let names: Vec<String> = file.grids.iter().map(|g| g.name.clone()).collect();
    let at = match name {
        Some(n) => names.iter().position(|g| g == n).ok_or_else(|| {
            read_err(format!(
                "no float or double grid named {} (grids: {})",
                shown(n),
                listed(&names.iter().map(|g| shown(g)).collect::<Vec<_>>())
            ))
        })?,
        None if names.is_empty() => {
            let skipped: Vec<String> =
                file.skipped.iter().map(|(n, t)| format!("{} ({})", shown(n), shown(t))).collect();
            return Err(read_err(format!(
                "no float or double grid{}",
                if skipped.is_empty() { String::new() } else { format!(" (skipped: {})", listed(&skipped)) }
            )));
        }
        None => 0,
    };
    let mut grids = file.grids;
    let g = grids.swap_remove(at);
    let others = names.into_iter().filter(|n| *n != g.name).collect();
    let active_points = active_points(&g);
    let active_bounds = g.active_bounds();
    let grid = match &g.leaves {
        VdbLeaves::Float(l) => AnySparse::F32(convert(path, &g, l, |v| v)?),
        VdbLeaves::Double(l) => AnySparse::F64(convert(path, &g, l, |v| v)?),
    };
    Ok(SparseFile { grid, name: g.name, class: g.class, active_points, others, active_bounds })
}

/// The samples of `region` (the file's index space, half-open `[lo, hi)` per axis; default: the
/// active points' bounding box) of a sparse file's grid as a dense grid at the same world place.
/// Points past the grid's leaves and tiles hold the background.
///
/// # Errors
/// [`Error::InvalidInput`] for an empty region, or no region and no active point;
/// [`Error::Limit`] when the region's samples exceed `limits` (checked before allocating).
pub fn dense_region(
    path: &Path,
    file: &SparseFile,
    region: Option<[[i64; 2]; 3]>,
    limits: &Limits,
) -> Result<isoforge::grid::AnyGrid> {
    let region = match (region, file.active_bounds) {
        (Some(r), _) => r,
        (None, Some([lo, hi])) => [0, 1, 2].map(|a| [i64::from(lo[a]), i64::from(hi[a]) + 1]),
        (None, None) => {
            return Err(Error::InvalidInput(format!(
                "{}: grid {}: no active point to bound the region: give one",
                path.display(),
                shown(&file.name)
            )))
        }
    };
    if let Some(a) = (0..3).find(|&a| region[a][0] >= region[a][1]) {
        return Err(Error::InvalidInput(format!(
            "{}: region axis {}: {}:{} holds no point (half-open ranges, start below end)",
            path.display(),
            ["x", "y", "z"][a],
            region[a][0],
            region[a][1]
        )));
    }
    let size = match &file.grid {
        AnySparse::F32(_) => 4u64,
        AnySparse::F64(_) => 8,
    };
    let bytes = region.iter().try_fold(size, |acc, r| acc.checked_mul(r[1].abs_diff(r[0])));
    if bytes.is_none_or(|b| b > limits.max_bytes) {
        let d = region.map(|r| r[1].abs_diff(r[0]));
        return Err(Error::Limit {
            path: path.to_path_buf(),
            what: format!("region of {} x {} x {} samples of {size} bytes", d[0], d[1], d[2]),
            requested: bytes.unwrap_or(u64::MAX),
            allowed: limits.max_bytes,
        });
    }
    let io = file.grid.index_origin();
    let lo = [0, 1, 2].map(|a| region[a][0] - i64::from(io[a]));
    let hi = [0, 1, 2].map(|a| region[a][1] - i64::from(io[a]));
    let err = |e: isoforge::Error| Error::InvalidInput(format!("{}: region {region:?}: {e}", path.display()));
    Ok(match &file.grid {
        AnySparse::F32(g) => isoforge::grid::AnyGrid::F32(g.dense_region(lo, hi).map_err(err)?),
        AnySparse::F64(g) => isoforge::grid::AnyGrid::F64(g.dense_region(lo, hi).map_err(err)?),
    })
}

/// The first few of `items`, and how many there are in all (a file may hold thousands of grids).
fn listed(items: &[String]) -> String {
    const SHOWN: usize = 8;
    let head: Vec<&str> = items.iter().take(SHOWN).map(String::as_str).collect();
    match items.len() {
        n if n > SHOWN => format!("{}, … ({n} in all)", head.join(", ")),
        _ => head.join(", "),
    }
}

/// Points the grid marks active.
fn active_points(g: &VdbGrid) -> u64 {
    let leaves: u64 = match &g.leaves {
        VdbLeaves::Float(l) => l.iter().map(|l| u64::from(l.active_count())).sum(),
        VdbLeaves::Double(l) => l.iter().map(|l| u64::from(l.active_count())).sum(),
    };
    leaves + g.tiles.iter().filter(|t| t.active).map(|t| u64::from(t.size).pow(3)).sum::<u64>()
}

/// The lattice of `dims` points whose point 0 is VDB index `origin`, placed by `t`.
fn lattice_of(path: &Path, t: &VdbTransform, origin: [i64; 3], dims: [u32; 3]) -> Result<Lattice> {
    let m = &t.matrix;
    let column = |a: usize| [m[0][a], m[1][a], m[2][a]];
    let spacing = [0, 1, 2].map(|a| column(a).iter().map(|x| x * x).sum::<f64>().sqrt());
    let unsupported = |why: String| Error::Unsupported { path: path.to_path_buf(), detail: why };
    if m[3] != [0.0, 0.0, 0.0, 1.0] || spacing.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return Err(unsupported(format!("transform {} {m:?}: not an affine map with a positive scale", t.map)));
    }
    let direction = [0, 1, 2].map(|a| column(a).map(|x| x / spacing[a]));
    let world0 = t.index_to_world(origin.map(|v| v as f64));
    Lattice::with_geometry(dims, spacing, world0)
        .and_then(|l| l.with_direction(direction))
        .map_err(|e| unsupported(format!("transform {} {m:?}: {e} (sheared grids are not read)", t.map)))
}

/// `g` (with leaves `leaves`) as a sparse grid of `S`.
fn convert<T: Copy + Sync, S: Sample>(
    path: &Path,
    g: &VdbGrid,
    leaves: &[VdbLeaf<T>],
    to: impl Fn(T) -> S + Sync,
) -> Result<SparseGrid<S>> {
    let background = S::from_f64(g.background);
    // The box of every leaf and tile, in VDB index space (i64: no overflow at i32's ends).
    let mut lo = [i64::MAX; 3];
    let mut hi = [i64::MIN; 3];
    let mut cover = |o: [i32; 3], size: u32| {
        for a in 0..3 {
            lo[a] = lo[a].min(o[a] as i64);
            hi[a] = hi[a].max(o[a] as i64 + size as i64 - 1);
        }
    };
    leaves.iter().for_each(|l| cover(l.origin, 8));
    g.tiles.iter().for_each(|t| cover(t.origin, t.size));
    if lo[0] > hi[0] {
        // Nothing but the background: a grid of one cell.
        let lattice = lattice_of(path, &g.transform, [0; 3], [2; 3])?;
        return Ok(SparseGrid::new(lattice, background));
    }
    // One point of background around the data, so surfaces reaching its edge close there.
    let origin = lo.map(|v| (v - 1).div_euclid(NODE_POINTS) * NODE_POINTS);
    let dims = [0, 1, 2].map(|a| hi[a] + 2 - origin[a]);
    if dims.iter().any(|&d| d > u32::MAX as i64) {
        return Err(Error::Unsupported {
            path: path.to_path_buf(),
            detail: format!("grid {:?} spans {dims:?} points: more than a lattice indexes per axis", g.name),
        });
    }
    let dims = dims.map(|d| d.max(2) as u32);
    let lattice = lattice_of(path, &g.transform, origin, dims)?;
    let index_origin = origin.map(|v| v as i32);
    let by_origin: HashMap<[i32; 3], usize> = leaves.iter().enumerate().map(|(n, l)| (l.origin, n)).collect();
    let tiles: HashMap<([i32; 3], u32), S> =
        g.tiles.iter().map(|t| ((t.origin, t.size), S::from_f64(t.value))).collect();
    // The value of every point of the block of 8³ at VDB origin `s` not held by a leaf.
    let tile_at = |s: [i32; 3]| -> S {
        for size in [8u32, 128, 4096] {
            let o = s.map(|c| c & !(size as i32 - 1));
            if let Some(&v) = tiles.get(&(o, size)) {
                return v;
            }
        }
        background
    };
    let node_of = |s: [i32; 3]| [0, 1, 2].map(|a| ((s[a] as i64 - origin[a]) / NODE_POINTS) as u32);
    let with_leaves: std::collections::HashSet<[u32; 3]> = leaves.iter().map(|l| node_of(l.origin)).collect();
    let node = |coord: [u32; 3]| {
        let base = [0, 1, 2].map(|a| (origin[a] + coord[a] as i64 * NODE_POINTS) as i32);
        // A node under one 128³ or 4096³ tile, with no leaf inside, is that tile.
        if !with_leaves.contains(&coord) {
            for size in [128u32, 4096] {
                if let Some(&v) = tiles.get(&(base.map(|c| c & !(size as i32 - 1)), size)) {
                    return SparseNode::tile(v);
                }
            }
        }
        SparseNode::blocks(coord, dims, background, &mut |o: [u32; 3], out: &mut [S]| {
            let s = [0, 1, 2].map(|a| (o[a] as i64 + origin[a]) as i32);
            match by_origin.get(&s) {
                None => Some(tile_at(s)),
                Some(&n) => {
                    let leaf = &leaves[n];
                    // VDB's order is z fastest; ours x fastest. Points past the lattice are
                    // left at the background.
                    for (at, v) in leaf.values.iter().enumerate() {
                        let (x, y, z) = (at >> 6, at >> 3 & 7, at & 7);
                        let p = [o[0] as usize + x, o[1] as usize + y, o[2] as usize + z];
                        if p.iter().zip(dims).all(|(&p, d)| p < d as usize) {
                            out[x + 8 * (y + 8 * z)] = to(*v);
                        }
                    }
                    None
                }
            }
        })
    };
    // Only the nodes a leaf or tile touches: the rest is background.
    let mut coords: Vec<[u32; 3]> = leaves.iter().map(|l| node_of(l.origin)).collect();
    for t in &g.tiles {
        let n = (t.size as i64 / NODE_POINTS).max(1) as u32;
        let first = node_of(t.origin);
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    coords.push([first[0] + x, first[1] + y, first[2] + z]);
                }
            }
        }
    }
    Ok(SparseGrid::build_nodes(lattice, background, coords, &node).with_index_origin(index_origin))
}
