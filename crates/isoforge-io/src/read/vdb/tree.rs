//! One grid's tree: the standard OpenVDB layout root → 32³ internal → 16³ internal → 8³ leaf
//! (`Tree_float_5_4_3`, `Tree_double_5_4_3`), read in two passes as OpenVDB writes it.
//!
//! ```text
//! topology  background, root tiles (origin, value, active), root children:
//!             32³ node: child mask, value mask, its 32³ values (compressed, below), children:
//!               16³ node: child mask, value mask, its 16³ values, children:
//!                 leaf: value mask (64 bytes)
//! buffers   for each root child in origin order (x, then y, then z), depth first:
//!             leaf: value mask again (ignored when the file has grid offsets), 8³ values
//! ```
//!
//! Values (a node's tiles or a leaf's points) are stored as OpenVDB's `readCompressedValues`
//! reads them: a mode byte saying which inactive values were left out and how to restore them
//! (from the background, its negation, one or two stored values and an optional selection
//! mask), then the stored values, optionally as 16-bit halves, raw or in a zip or blosc chunk.

use std::ops::Range;

use super::input::{Fail, Res, Src};
use super::{blosc, VdbLeaf, VdbLeaves, VdbTile};

/// Per-grid compression flags (`io::COMPRESS_*`).
pub(super) const COMPRESS_ZIP: u32 = 0x1;
pub(super) const COMPRESS_ACTIVE_MASK: u32 = 0x2;
pub(super) const COMPRESS_BLOSC: u32 = 0x4;

/// The per-node modes of active-mask compression (OpenVDB `io::NO_MASK_OR_INACTIVE_VALS` …):
/// which inactive values were left out and how they come back. Mode 1, `NO_MASK_AND_MINUS_BG`
/// (all are -background), needs no constant: every mode but 0 starts from -background.
const NO_MASK_OR_INACTIVE_VALS: u8 = 0;
const NO_MASK_AND_ONE_INACTIVE_VAL: u8 = 2;
const MASK_AND_NO_INACTIVE_VALS: u8 = 3;
const MASK_AND_ONE_INACTIVE_VAL: u8 = 4;
const MASK_AND_TWO_INACTIVE_VALS: u8 = 5;
const NO_MASK_AND_ALL_VALS: u8 = 6;

/// Points per leaf, and the log2 of the three node sizes.
const LEAF_VALUES: usize = 512;
const LOG2_LEAF: u32 = 3;
const LOG2_LOWER: u32 = 4;
const LOG2_UPPER: u32 = 5;
/// The edge of a root child (a 32³ node of 16³ nodes of leaves), in points.
const ROOT_CHILD_DIM: i32 = 1 << (LOG2_LEAF + LOG2_LOWER + LOG2_UPPER);

/// A stored value type.
pub(super) trait Value: Copy + PartialEq + Default + std::fmt::Display {
    /// Bytes per value.
    const SIZE: usize;
    /// Decodes little-endian values: `out.len()` of them from `bytes`.
    fn decode(bytes: &[u8], out: &mut [Self]);
    /// A 16-bit half converted exactly.
    fn from_half(bits: u16) -> Self;
    /// `-self` (OpenVDB's `math::negative`).
    fn negate(self) -> Self;
    /// Widened exactly.
    fn to_f64(self) -> f64;
    /// Finite (neither NaN nor infinite).
    fn finite(self) -> bool;
    /// The grid's leaves.
    fn wrap(leaves: Vec<VdbLeaf<Self>>) -> VdbLeaves;
}

impl Value for f32 {
    const SIZE: usize = 4;
    fn decode(bytes: &[u8], out: &mut [f32]) {
        for (o, b) in out.iter_mut().zip(bytes.as_chunks::<4>().0) {
            *o = f32::from_le_bytes(*b);
        }
    }
    fn from_half(bits: u16) -> f32 {
        half_to_f32(bits)
    }
    fn negate(self) -> f32 {
        -self
    }
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
    fn finite(self) -> bool {
        self.is_finite()
    }
    fn wrap(leaves: Vec<VdbLeaf<f32>>) -> VdbLeaves {
        VdbLeaves::Float(leaves)
    }
}

impl Value for f64 {
    const SIZE: usize = 8;
    fn decode(bytes: &[u8], out: &mut [f64]) {
        for (o, b) in out.iter_mut().zip(bytes.as_chunks::<8>().0) {
            *o = f64::from_le_bytes(*b);
        }
    }
    fn from_half(bits: u16) -> f64 {
        f64::from(half_to_f32(bits))
    }
    fn negate(self) -> f64 {
        -self
    }
    fn to_f64(self) -> f64 {
        self
    }
    fn finite(self) -> bool {
        self.is_finite()
    }
    fn wrap(leaves: Vec<VdbLeaf<f64>>) -> VdbLeaves {
        VdbLeaves::Double(leaves)
    }
}

/// IEEE 754 binary16 → binary32, exact (subnormals, infinities and NaN included).
pub(super) fn half_to_f32(h: u16) -> f32 {
    let sign = u32::from(h >> 15) << 31;
    let exp = u32::from((h >> 10) & 0x1f);
    let man = u32::from(h & 0x3ff);
    let bits = match (exp, man) {
        (0, 0) => sign,
        (0, m) => {
            // Subnormal: m · 2^-24, exact in f32 (m < 1024).
            let v = m as f32 * f32::powi(2.0, -24);
            return if sign != 0 { -v } else { v };
        }
        (0x1f, 0) => sign | 0x7f80_0000,
        (0x1f, m) => sign | 0x7fc0_0000 | (m << 13),
        (e, m) => sign | ((e + 127 - 15) << 23) | (m << 13),
    };
    f32::from_bits(bits)
}

/// How this grid's values are stored.
#[derive(Clone, Copy)]
pub(super) struct Storage {
    /// `COMPRESS_*` flags.
    pub compression: u32,
    /// Values saved as 16-bit halves.
    pub half: bool,
    /// The file has grid offsets: OpenVDB then reads a leaf's mask from the topology and skips
    /// the copy before its values (a stream without offsets takes the copy).
    pub offsets: bool,
}

/// The memory the grids read so far may still take.
pub(super) struct Budget {
    pub used: u64,
    pub allowed: u64,
}

impl Budget {
    /// Takes `bytes` more, or fails naming `what` (formatted only then).
    pub fn take(&mut self, bytes: u64, what: impl FnOnce() -> String) -> Res<()> {
        let used = self.used.saturating_add(bytes);
        if used > self.allowed {
            return Err(Fail::limit(what(), used, self.allowed));
        }
        self.used = used;
        Ok(())
    }
}

/// What one leaf costs in the output.
pub(super) fn leaf_bytes<T: Value>() -> u64 {
    (std::mem::size_of::<VdbLeaf<T>>() + LEAF_VALUES * T::SIZE) as u64
}

/// What one tile costs in the output.
pub(super) fn tile_bytes() -> u64 {
    std::mem::size_of::<VdbTile>() as u64
}

/// A tree as read: its background, leaves (in file order) and tiles.
pub(super) struct Tree<T> {
    pub background: T,
    pub leaves: Vec<VdbLeaf<T>>,
    pub tiles: Vec<VdbTile>,
}

/// A leaf as the topology describes it (its values come in the second pass).
struct LeafTopo {
    origin: [i32; 3],
    mask: [u64; 8],
}

/// Reusable buffers for decoding values.
struct Scratch<T> {
    bytes: Vec<u8>,
    packed: Vec<u8>,
    block: Vec<u8>,
    values: Vec<T>,
    selection: Vec<u64>,
}

/// Reads a tree (topology, then buffers) of value type `T`.
pub(super) fn read_tree<T: Value>(src: &mut Src, storage: Storage, budget: &mut Budget) -> Res<Tree<T>> {
    let mut scratch =
        Scratch { bytes: Vec::new(), packed: Vec::new(), block: Vec::new(), values: Vec::new(), selection: Vec::new() };
    let at = src.pos();
    let background = read_value::<T>(src, "background")?;
    if !background.finite() {
        return Err(Fail::bad(format!("byte {at}: background {background} is not finite")));
    }
    let at = src.pos();
    let num_tiles = src.u32("root tile count")?;
    let num_children = src.u32("root child count")?;
    // A tile is an origin, a value and a flag; a child at least an origin and two 32³ masks.
    let tile_size = 12 + T::SIZE as u64 + 1;
    let child_min = 12 + 2 * 4096;
    if u64::from(num_tiles) * tile_size + u64::from(num_children) * child_min > src.left() {
        return Err(Fail::bad(format!(
            "byte {at}: root: {num_tiles} tiles and {num_children} children do not fit in the {} bytes left",
            src.left()
        )));
    }

    // PASS 1: topology. Root tiles, then each root child's subtree with its leaves' masks.
    let mut tiles = Vec::new();
    let mut keys: Vec<[i32; 3]> = Vec::new();
    for n in 0..num_tiles {
        let at = src.pos();
        let origin = src.coord("root tile origin")?;
        aligned(origin, ROOT_CHILD_DIM).map_err(|f| f.within(format!("byte {at}: root tile {n}")))?;
        let value = read_value::<T>(src, "root tile value")?;
        let active = match src.u8("root tile active flag")? {
            0 => false,
            1 => true,
            f => return Err(Fail::bad(format!("byte {at}: root tile {n}: active flag {f} (expected 0 or 1)"))),
        };
        keys.push(origin);
        keep_tile(&mut tiles, origin, ROOT_CHILD_DIM, value, active, background, budget)
            .map_err(|f| f.within(format!("byte {at}: root tile {n}")))?;
    }
    let mut leaves_topo: Vec<LeafTopo> = Vec::new();
    let mut children: Vec<([i32; 3], Range<usize>)> = Vec::new();
    for n in 0..num_children {
        let at = src.pos();
        let origin = src.coord("root child origin")?;
        aligned(origin, ROOT_CHILD_DIM).map_err(|f| f.within(format!("byte {at}: root child {n}")))?;
        keys.push(origin);
        let first = leaves_topo.len();
        read_node(src, storage, LOG2_UPPER, origin, background, &mut tiles, &mut leaves_topo, budget, &mut scratch)
            .map_err(|f| f.within(format!("root child {n} at {origin:?}")))?;
        children.push((origin, first..leaves_topo.len()));
    }
    keys.sort_unstable();
    if let Some(w) = keys.windows(2).find(|w| w[0] == w[1]) {
        return Err(Fail::bad(format!("root: two tiles or children at origin {:?}", w[0])));
    }

    // PASS 2: buffers, root children in origin order as OpenVDB's sorted root table.
    children.sort_unstable_by_key(|c| c.0);
    let mut leaves = Vec::with_capacity(leaves_topo.len());
    for (_, range) in children {
        for topo in leaves_topo.get(range).unwrap_or_default() {
            let leaf = read_leaf(src, storage, topo, background, &mut scratch)
                .map_err(|f| f.within(format!("leaf at {:?}", topo.origin)))?;
            leaves.push(leaf);
        }
    }
    Ok(Tree { background, leaves, tiles })
}

/// Fails unless every coordinate of `origin` is a multiple of `dim`.
fn aligned(origin: [i32; 3], dim: i32) -> Res<()> {
    if origin.iter().all(|c| c.rem_euclid(dim) == 0) {
        return Ok(());
    }
    Err(Fail::bad(format!("origin {origin:?} is not a multiple of {dim}")))
}

/// Records a tile when it says something: active, or inactive with another value than the
/// background.
fn keep_tile<T: Value>(
    tiles: &mut Vec<VdbTile>,
    origin: [i32; 3],
    size: i32,
    value: T,
    active: bool,
    background: T,
    budget: &mut Budget,
) -> Res<()> {
    if !active && value == background {
        return Ok(());
    }
    if !value.finite() {
        return Err(Fail::bad(format!("tile at {origin:?}: value {value} is not finite")));
    }
    budget.take(tile_bytes(), || "the tiles of the grids read".to_string())?;
    tiles.push(VdbTile { origin, size: size.unsigned_abs(), value: value.to_f64(), active });
    Ok(())
}

/// Reads the topology of an internal node of 2^log2 children per axis at `origin`: its masks,
/// its tile values, then its children (16³ nodes, or leaves' masks).
#[allow(clippy::too_many_arguments)]
fn read_node<T: Value>(
    src: &mut Src,
    storage: Storage,
    log2: u32,
    origin: [i32; 3],
    background: T,
    tiles: &mut Vec<VdbTile>,
    leaves: &mut Vec<LeafTopo>,
    budget: &mut Budget,
    scratch: &mut Scratch<T>,
) -> Res<()> {
    let slots = 1usize << (3 * log2);
    let child_log2 = if log2 == LOG2_UPPER { LOG2_LOWER + LOG2_LEAF } else { LOG2_LEAF };
    let child_dim = 1i32 << child_log2;
    let mut child_mask = vec![0u64; slots / 64];
    let mut value_mask = vec![0u64; slots / 64];
    src.words(&mut child_mask, "child mask")?;
    src.words(&mut value_mask, "value mask")?;
    let mut values = std::mem::take(&mut scratch.values);
    values.clear();
    values.resize(slots, T::default());
    let read =
        read_values(src, storage, background, &value_mask, &mut values, scratch).map_err(|f| f.within("tile values"));
    let kept = read.and_then(|()| {
        // 64 slots at a time: most are children or inactive background.
        for (w, (chunk, (&children, &active))) in
            values.chunks_exact(64).zip(child_mask.iter().zip(&value_mask)).enumerate()
        {
            for (b, &value) in chunk.iter().enumerate() {
                let is_active = active >> b & 1 == 1;
                if children >> b & 1 == 0 && (is_active || value != background) {
                    let at = child_origin(origin, w * 64 + b, log2, child_log2);
                    keep_tile(tiles, at, child_dim, value, is_active, background, budget)?;
                }
            }
        }
        Ok(())
    });
    scratch.values = values;
    kept?;
    for n in set_bits(&child_mask) {
        let at = child_origin(origin, n, log2, child_log2);
        if log2 == LOG2_UPPER {
            read_node(src, storage, LOG2_LOWER, at, background, tiles, leaves, budget, scratch)
                .map_err(|f| f.within(format!("16³ node at {at:?}")))?;
        } else {
            let mut mask = [0u64; 8];
            src.words(&mut mask, "leaf value mask").map_err(|f| f.within(format!("leaf at {at:?}")))?;
            budget.take(leaf_bytes::<T>(), || "the leaves of the grids read".to_string())?;
            leaves.push(LeafTopo { origin: at, mask });
        }
    }
    Ok(())
}

/// The origin of child (or tile) `n` of the node at `origin`: `n` = x·4^log2 + y·2^log2 + z.
fn child_origin(origin: [i32; 3], n: usize, log2: u32, child_log2: u32) -> [i32; 3] {
    let side = (1usize << log2) - 1;
    let local = [n >> (2 * log2), (n >> log2) & side, n & side];
    // Each local coordinate is below 32 and the node lies within its aligned root child, so
    // none of this overflows.
    let [x, y, z] = local.map(|c| (c as i32) << child_log2);
    [origin[0] + x, origin[1] + y, origin[2] + z]
}

/// The numbers of the set bits of `mask`, in increasing order.
fn set_bits(mask: &[u64]) -> impl Iterator<Item = usize> + '_ {
    mask.iter().enumerate().flat_map(|(w, &word)| {
        let mut bits = word;
        std::iter::from_fn(move || {
            let b = bits.trailing_zeros() as usize;
            bits &= bits.wrapping_sub(1);
            (b < 64).then_some(w * 64 + b)
        })
    })
}

/// Reads a leaf's buffer: its mask copy and its 512 values.
fn read_leaf<T: Value>(
    src: &mut Src,
    storage: Storage,
    topo: &LeafTopo,
    background: T,
    scratch: &mut Scratch<T>,
) -> Res<VdbLeaf<T>> {
    let mut mask = topo.mask;
    if storage.offsets {
        src.skip(64, "leaf value mask")?;
    } else {
        src.words(&mut mask, "leaf value mask")?;
    }
    let mut values = Box::new([T::default(); LEAF_VALUES]);
    read_values(src, storage, background, &mask, &mut values[..], scratch)?;
    if let Some(n) = values.iter().position(|v| !v.finite()) {
        let p = child_origin(topo.origin, n, LOG2_LEAF, 0);
        return Err(Fail::bad(format!("point {p:?}: value {} is not finite", values[n])));
    }
    Ok(VdbLeaf { origin: topo.origin, values, active: mask })
}

/// One value stored at full precision.
fn read_value<T: Value>(src: &mut Src, what: &str) -> Res<T> {
    let mut bytes = [0u8; 8];
    let bytes = &mut bytes[..T::SIZE];
    src.fill(bytes, what)?;
    let mut v = [T::default()];
    T::decode(bytes, &mut v);
    let [v] = v;
    Ok(v)
}

/// Reads `out.len()` values (a leaf's or a node's, `mask` their active bits) as OpenVDB's
/// `readCompressedValues`: mode byte, inactive values, selection mask, stored values.
fn read_values<T: Value>(
    src: &mut Src,
    storage: Storage,
    background: T,
    mask: &[u64],
    out: &mut [T],
    scratch: &mut Scratch<T>,
) -> Res<()> {
    let n = out.len();
    let at = src.pos();
    let mode = src.u8("compression mode")?;
    if mode > NO_MASK_AND_ALL_VALS {
        return Err(Fail::bad(format!("byte {at}: compression mode {mode} (expected 0 to 6)")));
    }
    let mut inactive = [if mode == NO_MASK_OR_INACTIVE_VALS { background } else { background.negate() }, background];
    if matches!(mode, NO_MASK_AND_ONE_INACTIVE_VAL | MASK_AND_ONE_INACTIVE_VAL | MASK_AND_TWO_INACTIVE_VALS) {
        inactive[0] = read_value(src, "inactive value")?;
        if mode == MASK_AND_TWO_INACTIVE_VALS {
            inactive[1] = read_value(src, "second inactive value")?;
        }
    }
    let selected = matches!(mode, MASK_AND_NO_INACTIVE_VALS | MASK_AND_ONE_INACTIVE_VAL | MASK_AND_TWO_INACTIVE_VALS);
    scratch.selection.clear();
    if selected {
        scratch.selection.resize(n / 64, 0);
        src.words(&mut scratch.selection, "inactive value selection mask")?;
    }
    let stored = if storage.compression & COMPRESS_ACTIVE_MASK != 0 && mode != NO_MASK_AND_ALL_VALS {
        mask.iter().map(|w| w.count_ones() as usize).sum::<usize>().min(n)
    } else {
        n
    };
    // Halves: none at all when nothing is stored (OpenVDB writes no chunk then).
    let width = if storage.half { 2 } else { T::SIZE };
    if !(storage.half && stored == 0) {
        read_chunk(src, storage.compression, stored * width, scratch)?;
    } else {
        scratch.bytes.clear();
    }
    let Scratch { bytes, values, selection, .. } = scratch;
    let dest: &mut [T] = if stored == n {
        out
    } else {
        values.clear();
        values.resize(stored, T::default());
        values
    };
    if storage.half {
        for (d, h) in dest.iter_mut().zip(bytes.as_chunks::<2>().0) {
            *d = T::from_half(u16::from_le_bytes(*h));
        }
    } else {
        T::decode(bytes, dest);
    }
    if stored < n {
        // Restore the inactive values around the stored active ones, 64 at a time.
        let mut active = values.iter();
        for (w, (chunk, &on)) in out.chunks_exact_mut(64).zip(mask).enumerate() {
            let select = selection.get(w).copied().unwrap_or(0);
            for (b, o) in chunk.iter_mut().enumerate() {
                *o = if on >> b & 1 == 1 {
                    active.next().copied().unwrap_or(background)
                } else if select >> b & 1 == 1 {
                    inactive[1]
                } else {
                    inactive[0]
                };
            }
        }
    }
    Ok(())
}

/// The most compressed bytes accepted for `raw` bytes: OpenVDB stores a chunk compressed only
/// when that is smaller (blosc: at most 16 bytes more); anything past twice is corrupt.
fn max_packed(raw: usize) -> u64 {
    2 * raw as u64 + 1024
}

/// Reads `nbytes` of stored values into `scratch.bytes`: raw, or one zip or blosc chunk
/// (an `i64` size, negative for a chunk stored raw, then the chunk).
fn read_chunk<T>(src: &mut Src, compression: u32, nbytes: usize, scratch: &mut Scratch<T>) -> Res<()> {
    let Scratch { bytes, packed, block, .. } = scratch;
    let codec = if compression & COMPRESS_BLOSC != 0 {
        "blosc"
    } else if compression & COMPRESS_ZIP != 0 {
        "zip"
    } else {
        return src.read_vec(nbytes as u64, bytes, "values");
    };
    let at = src.pos();
    let size = src.i64("compressed size")?;
    if size <= 0 {
        let raw = size.unsigned_abs();
        if raw != nbytes as u64 {
            return Err(Fail::bad(format!("byte {at}: a chunk of {raw} values bytes stored raw, expected {nbytes}")));
        }
        return src.read_vec(raw, bytes, "values");
    }
    let size = size.unsigned_abs();
    if size > max_packed(nbytes) {
        return Err(Fail::bad(format!(
            "byte {at}: {codec} chunk of {size} bytes for {nbytes} bytes of values (at most {} accepted)",
            max_packed(nbytes)
        )));
    }
    src.read_vec(size, packed, "compressed values")?;
    bytes.clear();
    bytes.resize(nbytes, 0);
    let done = if codec == "blosc" { blosc::decompress(packed, bytes, block) } else { blosc::zlib(packed, bytes) };
    done.map_err(|f| f.within(format!("byte {at}: {codec} chunk")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halves_convert_exactly() {
        assert_eq!(half_to_f32(0x3c00), 1.0);
        assert_eq!(half_to_f32(0xc000), -2.0);
        assert_eq!(half_to_f32(0x7bff), 65504.0);
        assert_eq!(half_to_f32(0x0001), 2f32.powi(-24));
        assert_eq!(half_to_f32(0x8001), -(2f32.powi(-24)));
        assert_eq!(half_to_f32(0x03ff), 1023.0 * 2f32.powi(-24));
        assert_eq!(half_to_f32(0x3555), 0.333_251_95);
        assert!(half_to_f32(0x7c00).is_infinite());
        assert!(half_to_f32(0x7e00).is_nan());
        assert_eq!(half_to_f32(0x8000).to_bits(), 0x8000_0000);
    }

    #[test]
    fn child_origins_are_x_major() {
        // n = x·32² + y·32 + z in a 32³ node of 128³ children.
        assert_eq!(child_origin([4096, 0, -4096], (1 << 10) | (1 << 5) | 2, LOG2_UPPER, 7), [4224, 128, -3840]);
        assert_eq!(child_origin([0, 0, 0], (3 << 6) | (2 << 3) | 1, LOG2_LEAF, 0), [3, 2, 1]);
    }
}
