//! OpenVDB `.vdb` files from sparse grids: one grid, file format version 224 (what OpenVDB 6.1
//! to 10 write; OpenVDB 3.0 to 13 read it), with grid offsets, tree `Tree_float_5_4_3` or
//! `Tree_double_5_4_3`, values uncompressed (compression flags 0, every node's values stored
//! whole: mode `NO_MASK_AND_ALL_VALS`). The layout is the one [`crate::read::vdb`] documents.
//!
//! ```text
//!   lattice point p (u32)  →  VDB index q = p + index_origin  →  world (ScaleTranslateMap, or
//!                                                                 AffineMap for a rotated lattice)
//! ```
//! The inverse of [`crate::read::sparse`]: a grid read back has every lattice point's value at
//! the same VDB index and world position (its lattice is re-derived: it may start earlier and
//! end later, the added points hold the background). Leaves are written as leaves: their points
//! inside the lattice are active, the points past its end inactive (background). Every tile other
//! than the background is written as an inactive tile (a 128³ tile of a 32³ node when the index
//! origin keeps it aligned, else 8³ tiles), so file size and memory follow the leaves, as
//! OpenVDB's narrow-band level sets do. Geometry is exact when the index origin is 0 (grids made
//! from dense volumes); otherwise the translation carries one rounding.

use std::collections::BTreeMap;
use std::io::{self, Write};

use isoforge::grid::{Lattice, Sample, SparseGrid};

use crate::read::vdb::VdbValueType;

/// The file format version written (`OPENVDB_FILE_VERSION_MULTIPASS_IO`).
const FILE_VERSION: u32 = 224;
/// The library version the header names: the one whose files this writer reproduces.
const LIBRARY_VERSION: (u32, u32) = (10, 0);
const MAGIC: i64 = 0x5644_4220;
/// Points per leaf edge.
const LEAF_POINTS: u32 = 8;
/// `NO_MASK_AND_ALL_VALS`: every value stored, no mask, no inactive constants.
const ALL_VALUES: u8 = 6;
/// log2 of the edge (in points) of a 16³ node's children (8) and of a 32³ node's (128), and of
/// a 32³ node itself (4096).
const LOG2_LEAF: u32 = 3;
const LOG2_LOWER_CHILD: u32 = 7;
const LOG2_UPPER_CHILD: u32 = 12;
/// Slots of a 32³ and of a 16³ node.
const UPPER_SLOTS: usize = 1 << 15;
const LOWER_SLOTS: usize = 1 << 12;
/// Longest grid name (the reader's limit).
const MAX_NAME: usize = 1 << 16;

/// What OpenVDB calls a grid's class (its `class` metadata).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GridClass {
    /// `unknown`: a scalar field.
    #[default]
    Unknown,
    /// `level set`: a signed distance, negative inside.
    LevelSet,
    /// `fog volume`: a density, 0 outside.
    FogVolume,
}

impl GridClass {
    /// OpenVDB's name of the class.
    pub fn name(self) -> &'static str {
        match self {
            GridClass::Unknown => "unknown",
            GridClass::LevelSet => "level set",
            GridClass::FogVolume => "fog volume",
        }
    }
}

/// How to write a grid.
#[derive(Debug, Clone, PartialEq)]
pub struct VdbWriteOptions {
    /// The grid's name (no control character U+001E, at most 64 KiB).
    pub name: String,
    /// The `class` metadata.
    pub class: GridClass,
    /// Values as 32-bit floats (`Tree_float_5_4_3`) or 64-bit (`Tree_double_5_4_3`); samples of
    /// other types are converted (`as`).
    pub value_type: VdbValueType,
}

impl Default for VdbWriteOptions {
    fn default() -> Self {
        VdbWriteOptions { name: "density".to_string(), class: GridClass::Unknown, value_type: VdbValueType::Float }
    }
}

/// Why a grid cannot be written (checked before any byte is).
///
/// # Errors
/// A message naming the field and the value: a grid name with U+001E or longer than 64 KiB, an
/// index origin that is not a multiple of 8, or lattice points whose index overflows `i32`.
pub fn check_vdb<S: Sample>(grid: &SparseGrid<S>, opts: &VdbWriteOptions) -> Result<(), String> {
    if opts.name.contains('\u{1e}') || opts.name.len() > MAX_NAME {
        return Err(format!(
            "grid name {:?}: names hold no U+001E and at most {MAX_NAME} bytes",
            opts.name.chars().take(40).collect::<String>()
        ));
    }
    let io = grid.index_origin();
    if io.iter().any(|c| c.rem_euclid(LEAF_POINTS as i32) != 0) {
        return Err(format!("index origin {io:?}: not a multiple of 8 (leaves would not align)"));
    }
    let dims = grid.lattice().dims();
    // The last point of the last node (leaves and tiles end there) must be an i32 index.
    let node = 1u32 << LOG2_LOWER_CHILD;
    let reach = [0, 1, 2].map(|a| i64::from(io[a]) + i64::from(dims[a].div_ceil(node)) * i64::from(node));
    if reach.iter().any(|&r| r > i64::from(i32::MAX)) {
        return Err(format!(
            "index origin {io:?} + dims {dims:?}: indices past {} (OpenVDB indices are i32)",
            i32::MAX
        ));
    }
    Ok(())
}

/// Writes `grid` as a one-grid OpenVDB file.
///
/// # Errors
/// [`check_vdb`]'s findings as [`io::ErrorKind::InvalidInput`]; the writer's errors.
pub fn write_vdb<S: Sample>(w: &mut dyn Write, grid: &SparseGrid<S>, opts: &VdbWriteOptions) -> io::Result<()> {
    check_vdb(grid, opts).map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))?;
    match opts.value_type {
        VdbValueType::Float => write_typed::<S, f32>(w, grid, opts),
        VdbValueType::Double => write_typed::<S, f64>(w, grid, opts),
    }
}

/// A value type of the file.
trait Out: Copy + PartialEq {
    const TREE: &'static str;
    const SIZE: u64;
    const ZERO: Self;
    fn from_f64(v: f64) -> Self;
    fn put(self, out: &mut Vec<u8>);
}

impl Out for f32 {
    const TREE: &'static str = "Tree_float_5_4_3";
    const SIZE: u64 = 4;
    const ZERO: f32 = 0.0;
    fn from_f64(v: f64) -> f32 {
        v as f32
    }
    fn put(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
}

impl Out for f64 {
    const TREE: &'static str = "Tree_double_5_4_3";
    const SIZE: u64 = 8;
    const ZERO: f64 = 0.0;
    fn from_f64(v: f64) -> f64 {
        v
    }
    fn put(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
}

/// A 16³ node: its 8³ tiles and leaves (grid leaf numbers) by slot.
struct Lower<T> {
    tiles: Vec<(usize, T)>,
    leaves: Vec<(usize, usize)>,
}

/// A 32³ node: its 128³ tiles and 16³ nodes by slot.
struct Upper<T> {
    tiles: Vec<(usize, T)>,
    lowers: BTreeMap<usize, Lower<T>>,
}

/// The tree in VDB index space: 32³ nodes by origin, in OpenVDB's root order (x, then y, then z).
struct Plan<T> {
    uppers: BTreeMap<[i32; 3], Upper<T>>,
    leaves: usize,
    lowers: usize,
}

/// The slot of the child holding `q` in the node of `log2` children per axis of `2^child` points.
fn slot(q: [i32; 3], log2: u32, child: u32) -> usize {
    let side = (1i32 << log2) - 1;
    let l = q.map(|c| ((c >> child) & side) as usize);
    (l[0] << (2 * log2)) | (l[1] << log2) | l[2]
}

impl<T: Out> Plan<T> {
    fn upper(&mut self, q: [i32; 3]) -> &mut Upper<T> {
        let o = q.map(|c| c & !((1 << LOG2_UPPER_CHILD) - 1));
        self.uppers.entry(o).or_insert_with(|| Upper { tiles: Vec::new(), lowers: BTreeMap::new() })
    }

    fn lower(&mut self, q: [i32; 3]) -> &mut Lower<T> {
        let s = slot(q, 5, LOG2_LOWER_CHILD);
        self.upper(q).lowers.entry(s).or_insert_with(|| Lower { tiles: Vec::new(), leaves: Vec::new() })
    }
}

/// Where the grid's points go, as [`Plan`].
fn plan<S: Sample, T: Out>(grid: &SparseGrid<S>) -> Plan<T> {
    let io = grid.index_origin();
    // In range: check_vdb bounds every point a leaf or tile holds.
    let at = |p: [u32; 3]| [0, 1, 2].map(|a| (i64::from(io[a]) + i64::from(p[a])) as i32);
    let mut plan = Plan { uppers: BTreeMap::new(), leaves: grid.num_leaves(), lowers: 0 };
    for n in 0..grid.num_leaves() {
        let q = at(grid.leaf_origin(n));
        plan.lower(q).leaves.push((slot(q, 4, LOG2_LEAF), n));
    }
    let aligned = io.iter().all(|c| c % (1 << LOG2_LOWER_CHILD) == 0);
    for t in grid.tiles() {
        let v = T::from_f64(t.value.to_f64());
        let q = at(t.origin);
        if t.size == LEAF_POINTS {
            plan.lower(q).tiles.push((slot(q, 4, LOG2_LEAF), v));
        } else if aligned {
            plan.upper(q).tiles.push((slot(q, 5, LOG2_LOWER_CHILD), v));
        } else {
            let k = t.size / LEAF_POINTS;
            for z in 0..k {
                for y in 0..k {
                    for x in 0..k {
                        let b = [x, y, z].map(|c| (c * LEAF_POINTS) as i32);
                        let q = [q[0] + b[0], q[1] + b[1], q[2] + b[2]];
                        plan.lower(q).tiles.push((slot(q, 4, LOG2_LEAF), v));
                    }
                }
            }
        }
    }
    for up in plan.uppers.values_mut() {
        up.tiles.sort_unstable_by_key(|t| t.0);
        for low in up.lowers.values_mut() {
            low.tiles.sort_unstable_by_key(|t| t.0);
            low.leaves.sort_unstable_by_key(|t| t.0);
        }
    }
    plan.lowers = plan.uppers.values().map(|u| u.lowers.len()).sum();
    plan
}

/// The active bits of a leaf at lattice point `o` (OpenVDB's numbering `(x << 6) | (y << 3) | z`):
/// its points inside the lattice.
fn leaf_mask(o: [u32; 3], dims: [u32; 3]) -> [u64; 8] {
    let mut mask = [0u64; 8];
    let inside = |a: usize, d: u32| o[a] + d < dims[a];
    for n in 0..512u32 {
        if inside(0, n >> 6) && inside(1, (n >> 3) & 7) && inside(2, n & 7) {
            mask[(n / 64) as usize] |= 1 << (n % 64);
        }
    }
    mask
}

fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_string(out: &mut Vec<u8>, s: &str) {
    put_u32(out, s.len() as u32);
    out.extend_from_slice(s.as_bytes());
}

fn put_meta(out: &mut Vec<u8>, name: &str, type_name: &str, value: &[u8]) {
    put_string(out, name);
    put_string(out, type_name);
    put_u32(out, value.len() as u32);
    out.extend_from_slice(value);
}

fn put_words(out: &mut Vec<u8>, words: &[u64]) {
    for w in words {
        out.extend_from_slice(&w.to_le_bytes());
    }
}

/// The index → world map of VDB index `q = p + index_origin`: its type and parameters.
fn transform(l: &Lattice, io: [i32; 3]) -> Vec<u8> {
    let (s, d) = (l.spacing(), l.direction());
    // The world vector of each index step, and the world position of index 0.
    let axes = [0, 1, 2].map(|a| d[a].map(|x| x * s[a]));
    let mut t = l.origin();
    for a in 0..3 {
        for (ti, v) in t.iter_mut().zip(axes[a]) {
            *ti -= v * f64::from(io[a]);
        }
    }
    let mut out = Vec::new();
    let vec3 = |out: &mut Vec<u8>, v: [f64; 3]| v.iter().for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
    let identity = (0..3).all(|a| (0..3).all(|b| d[a][b] == if a == b { 1.0 } else { 0.0 }));
    if identity {
        // OpenVDB reads the derived vectors as stored: voxel size, 1/s, 1/s², 1/(2s).
        put_string(&mut out, "ScaleTranslateMap");
        vec3(&mut out, t);
        vec3(&mut out, s);
        vec3(&mut out, s.map(f64::abs));
        vec3(&mut out, s.map(|x| 1.0 / x));
        vec3(&mut out, s.map(|x| 1.0 / (x * x)));
        vec3(&mut out, s.map(|x| 0.5 / x));
    } else {
        // Row vectors: row a is index axis a's world step, row 3 the translation.
        put_string(&mut out, "AffineMap");
        for row in axes {
            vec3(&mut out, row);
            out.extend_from_slice(&0f64.to_le_bytes());
        }
        vec3(&mut out, t);
        out.extend_from_slice(&1f64.to_le_bytes());
    }
    out
}

/// A deterministic UUID for the file header (OpenVDB parses 36 characters 8-4-4-4-12).
fn uuid(seed: &[u8]) -> String {
    let mut h: u128 = 0x6c62_272e_07bb_0142_62b8_2175_6295_c58d;
    for &b in seed {
        h ^= u128::from(b);
        h = h.wrapping_mul(0x0000_0000_0100_0000_0000_0000_0000_013b);
    }
    let x = format!("{h:032x}");
    format!("{}-{}-{}-{}-{}", &x[..8], &x[8..12], &x[12..16], &x[16..20], &x[20..])
}

/// Counts what goes through, to check the planned offsets.
struct Counted<'a> {
    w: &'a mut dyn Write,
    n: u64,
}

impl Write for Counted<'_> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let k = self.w.write(buf)?;
        self.n += k as u64;
        Ok(k)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.w.flush()
    }
}

fn write_typed<S: Sample, T: Out>(w: &mut dyn Write, grid: &SparseGrid<S>, opts: &VdbWriteOptions) -> io::Result<()> {
    let plan = plan::<S, T>(grid);
    let dims = grid.lattice().dims();
    let io = grid.index_origin();
    let background = T::from_f64(grid.background().to_f64());

    // Active points: the leaves' points inside the lattice.
    let mut active = 0u64;
    let (mut lo, mut hi) = ([i32::MAX; 3], [i32::MIN; 3]);
    for n in 0..grid.num_leaves() {
        let o = grid.leaf_origin(n);
        let last = [0, 1, 2].map(|a| (o[a] + LEAF_POINTS).min(dims[a]) - 1);
        active += (0..3).map(|a| u64::from(last[a] - o[a] + 1)).product::<u64>();
        for a in 0..3 {
            lo[a] = lo[a].min((i64::from(io[a]) + i64::from(o[a])) as i32);
            hi[a] = hi[a].max((i64::from(io[a]) + i64::from(last[a])) as i32);
        }
    }

    // PASS 1: the grid's head (compression, metadata, transform), and every size.
    let mut head = Vec::new();
    put_u32(&mut head, 0); // compression flags: none
    let vec3i = |v: [i32; 3]| v.iter().flat_map(|c| c.to_le_bytes()).collect::<Vec<u8>>();
    let mut meta: Vec<(&str, &str, Vec<u8>)> = vec![
        ("class", "string", opts.class.name().as_bytes().to_vec()),
        ("creator", "string", b"isoforge".to_vec()),
        ("file_voxel_count", "int64", active.to_le_bytes().to_vec()),
        ("is_local_space", "bool", vec![0]),
        ("is_saved_as_half_float", "bool", vec![0]),
        ("name", "string", opts.name.as_bytes().to_vec()),
    ];
    if active > 0 {
        meta.push(("file_bbox_min", "vec3i", vec3i(lo)));
        meta.push(("file_bbox_max", "vec3i", vec3i(hi)));
    }
    meta.sort_by(|a, b| a.0.cmp(b.0)); // OpenVDB's metadata map is ordered by name
    put_u32(&mut head, meta.len() as u32);
    for (name, type_name, value) in &meta {
        put_meta(&mut head, name, type_name, value);
    }
    head.extend_from_slice(&transform(grid.lattice(), io));

    let uppers = plan.uppers.len() as u64;
    let topology = 4
        + T::SIZE
        + 8
        + uppers * (12 + 2 * (UPPER_SLOTS as u64 / 8) + 1 + UPPER_SLOTS as u64 * T::SIZE)
        + plan.lowers as u64 * (2 * (LOWER_SLOTS as u64 / 8) + 1 + LOWER_SLOTS as u64 * T::SIZE)
        + plan.leaves as u64 * 64;
    let buffers = plan.leaves as u64 * (64 + 1 + 512 * T::SIZE);

    let mut file = Vec::new();
    file.extend_from_slice(&MAGIC.to_le_bytes());
    put_u32(&mut file, FILE_VERSION);
    put_u32(&mut file, LIBRARY_VERSION.0);
    put_u32(&mut file, LIBRARY_VERSION.1);
    file.push(1); // grid offsets
    let seed = [opts.name.as_bytes(), &vec3i(io), &dims.map(|d| d as i32).map(i32::to_le_bytes).concat()].concat();
    file.extend_from_slice(uuid(&seed).as_bytes());
    put_u32(&mut file, 0); // file metadata: none
    put_u32(&mut file, 1); // one grid
    put_string(&mut file, &opts.name);
    put_string(&mut file, T::TREE);
    put_string(&mut file, ""); // not an instance
    let grid_pos = file.len() as u64 + 24;
    let block_pos = grid_pos + head.len() as u64 + topology;
    let end_pos = block_pos + buffers;
    for v in [grid_pos, block_pos, end_pos] {
        file.extend_from_slice(&v.to_le_bytes());
    }
    file.extend_from_slice(&head);

    let mut w = Counted { w, n: 0 };
    w.write_all(&file)?;

    // PASS 2: topology. Background, no root tiles, the 32³ nodes with their masks and values,
    // their 16³ nodes likewise, the leaves' masks.
    let mut buf = Vec::with_capacity(UPPER_SLOTS * 8 + 8192);
    buf.extend_from_slice(&1i32.to_le_bytes()); // buffer count
    background.put(&mut buf);
    put_u32(&mut buf, 0);
    put_u32(&mut buf, plan.uppers.len() as u32);
    w.write_all(&buf)?;
    let mut values: Vec<T> = Vec::new();
    for (origin, up) in &plan.uppers {
        buf.clear();
        buf.extend_from_slice(&vec3i(*origin));
        let mut children = vec![0u64; UPPER_SLOTS / 64];
        up.lowers.keys().for_each(|&s| children[s / 64] |= 1 << (s % 64));
        put_words(&mut buf, &children);
        put_words(&mut buf, &vec![0u64; UPPER_SLOTS / 64]); // tiles are inactive
        node_values(&mut buf, &mut values, UPPER_SLOTS, background, &up.tiles, up.lowers.keys().copied());
        w.write_all(&buf)?;
        for low in up.lowers.values() {
            buf.clear();
            let mut children = [0u64; LOWER_SLOTS / 64];
            low.leaves.iter().for_each(|&(s, _)| children[s / 64] |= 1 << (s % 64));
            put_words(&mut buf, &children);
            put_words(&mut buf, &[0u64; LOWER_SLOTS / 64]);
            node_values(&mut buf, &mut values, LOWER_SLOTS, background, &low.tiles, low.leaves.iter().map(|l| l.0));
            for &(_, n) in &low.leaves {
                put_words(&mut buf, &leaf_mask(grid.leaf_origin(n), dims));
            }
            w.write_all(&buf)?;
        }
    }
    if w.n != block_pos {
        return Err(planned("topology", w.n, block_pos));
    }

    // PASS 3: buffers, leaf by leaf in the same order: mask, mode, 512 values with z fastest.
    for up in plan.uppers.values() {
        for low in up.lowers.values() {
            buf.clear();
            for &(_, n) in &low.leaves {
                put_words(&mut buf, &leaf_mask(grid.leaf_origin(n), dims));
                buf.push(ALL_VALUES);
                let v = grid.leaf_values(n); // x fastest
                for x in 0..8 {
                    for y in 0..8 {
                        for z in 0..8 {
                            T::from_f64(v[x + 8 * (y + 8 * z)].to_f64()).put(&mut buf);
                        }
                    }
                }
            }
            w.write_all(&buf)?;
        }
    }
    if w.n != end_pos {
        return Err(planned("buffers", w.n, end_pos));
    }
    w.flush()
}

/// A node's values: mode byte, then every slot's value (tiles, zero under children,
/// background elsewhere).
fn node_values<T: Out>(
    buf: &mut Vec<u8>,
    values: &mut Vec<T>,
    slots: usize,
    background: T,
    tiles: &[(usize, T)],
    children: impl Iterator<Item = usize>,
) {
    values.clear();
    values.resize(slots, background);
    for &(s, v) in tiles {
        values[s] = v;
    }
    for s in children {
        values[s] = T::ZERO;
    }
    buf.push(ALL_VALUES);
    for v in values.iter() {
        v.put(buf);
    }
}

fn planned(what: &str, got: u64, want: u64) -> io::Error {
    io::Error::other(format!("internal: the {what} ended at byte {got}, planned {want} (this is a bug, please report)"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slots_are_x_major() {
        assert_eq!(slot([8, 16, 24], 4, LOG2_LEAF), (1 << 8) | (2 << 4) | 3);
        assert_eq!(slot([-128, 0, 128], 5, LOG2_LOWER_CHILD), (31 << 10) | 1);
    }

    #[test]
    fn leaf_masks_stop_at_the_lattice() {
        let m = leaf_mask([0, 0, 0], [8, 8, 8]);
        assert!(m.iter().all(|&w| w == u64::MAX));
        let m = leaf_mask([8, 0, 0], [9, 8, 8]);
        // Only x = 0 (n < 64) is inside.
        assert_eq!(m[0], u64::MAX);
        assert!(m[1..].iter().all(|&w| w == 0));
    }

    #[test]
    fn uuids_have_openvdb_shape() {
        let u = uuid(b"x");
        assert_eq!(u.len(), 36);
        assert_eq!(u.matches('-').count(), 4);
    }
}
