//! PolyMender's signed octree grids (`.sog`) \[Ju04\]: a [`SignedOctree`].
//!
//! ```text
//!   byte 0     "SOG.Format 1.0" and a NUL (15 bytes)
//!   byte 15    origin of the root cube: 3 × f32; its edge length: f32
//!   byte 31    padding to byte 128 (zeros in every file seen; not read)
//!   byte 128   dim = 2^depth: i32
//!   byte 132   the nodes in pre-order, each a type byte:
//!                0 internal: its 8 children follow, in the order 4x + 2y + z
//!                1 empty:    a sign byte (0 inside, 1 outside)
//!                2 leaf:     (finest level only) a corner-sign byte (bit c set = corner c outside,
//!                            c = 4x + 2y + z), then the vertex: 3 × f32, world coordinates
//! ```
//! All numbers little-endian. The four files of `../shared/data/sog` hold this exactly: vertices
//! in world coordinates inside their cells, leaves at the finest level only, zero padding,
//! nothing after the tree.
//!
//! Refused with a message naming the file, the byte, the field and the value: another magic, a
//! dim that is not a power of two from 1 to 2¹⁶, a non-finite origin or a non-positive edge, an
//! unknown node type, an empty node's sign other than 0 or 1, a leaf above the finest level, an
//! internal node at it (a tree deeper than `dim` says), a non-finite vertex or one outside its
//! cell by more than
//! [`VERTEX_SLACK`](isoforge::grid::octree::VERTEX_SLACK) of a cell (refused, not clamped: such a vertex says the
//! file is not what it claims), a tree that ends early and bytes after it. The tree's memory is
//! bounded by the file's length ([`TREE_BYTES_PER_FILE_BYTE`]) and checked against [`Limits`]
//! before reading; the time is linear in the file's length.
//!
//! The writer is [`crate::write::sog`].

use std::path::Path;

use isoforge::grid::octree::{OctreeNode, PreorderBuilder, SignedOctree};

use crate::error::{Ctx, Result};
use crate::limits::Limits;

/// The first 15 bytes of every file.
pub const MAGIC: &[u8; 15] = b"SOG.Format 1.0\0";
/// Where `dim` is stored.
pub const DIM_AT: usize = 128;
/// Where the nodes start.
pub const NODES_AT: usize = DIM_AT + 4;
/// The most memory one byte of nodes can take once read: an internal node (1 byte) is stored
/// in 8 bytes plus 32 for its children's indices.
pub const TREE_BYTES_PER_FILE_BYTE: u64 = 40;

/// Reads the `.sog` file at `path`.
///
/// # Errors
/// A [`crate::Error`] naming the file, the byte, the field and the value: see the module
/// documentation.
pub fn read_sog(path: &Path, limits: &Limits) -> Result<SignedOctree> {
    let ctx = Ctx::new(path, "SOG");
    let max_file = limits.max_bytes / TREE_BYTES_PER_FILE_BYTE + NODES_AT as u64;
    let bytes = crate::file::read_all(ctx, path, max_file)?;
    parse(ctx, &bytes, limits)
}

/// Reads a `.sog` file held in memory; `path_for_messages` is the name errors give.
///
/// # Errors
/// As [`read_sog`].
pub fn read_sog_bytes(path_for_messages: &Path, bytes: &[u8], limits: &Limits) -> Result<SignedOctree> {
    parse(Ctx::new(path_for_messages, "SOG"), bytes, limits)
}

/// The tree's signs as a volume ([`SignedOctree::to_sign_grid`]: −1 inside, +1 outside), its
/// size checked against `limits` first.
///
/// # Errors
/// [`crate::Error::Limit`] when the `(dim + 1)³` f32 samples exceed `limits`; the library's
/// limit, naming the file.
pub fn sign_grid(path: &Path, tree: &SignedOctree, limits: &Limits) -> Result<crate::read::stream::VolumeReader> {
    let ctx = Ctx::new(path, "SOG");
    let n = u64::from(tree.dim()) + 1;
    let bytes = n * n * n * 4;
    if bytes > limits.max_bytes {
        return Err(ctx.limit(format!("the sign grid of {n}³ points"), bytes, limits.max_bytes));
    }
    let grid = tree.to_sign_grid().map_err(|e| ctx.lib(e))?;
    Ok(crate::read::stream::VolumeReader::decoded(ctx, grid.into()))
}

fn f32_at(b: &[u8], at: usize) -> f32 {
    let mut w = [0u8; 4];
    w.copy_from_slice(&b[at..at + 4]);
    f32::from_le_bytes(w)
}

fn parse(ctx: Ctx, b: &[u8], limits: &Limits) -> Result<SignedOctree> {
    // PASS 1: the header.
    if b.len() < NODES_AT {
        return Err(ctx.bad(format!(
            "the header needs {NODES_AT} bytes, the file has {} (truncated or not a SOG file?)",
            b.len()
        )));
    }
    if &b[..MAGIC.len()] != MAGIC {
        return Err(ctx.bad(format!(
            "byte 0: magic \"{}\": expected \"SOG.Format 1.0\" and a NUL byte (not a SOG file?)",
            b[..MAGIC.len()].escape_ascii()
        )));
    }
    let body = (b.len() - NODES_AT) as u64;
    let need = body.saturating_mul(TREE_BYTES_PER_FILE_BYTE);
    if need > limits.max_bytes {
        return Err(ctx.limit(format!("a tree of {body} bytes of nodes"), need, limits.max_bytes));
    }
    let origin = [0, 1, 2].map(|a| f32_at(b, 15 + 4 * a));
    let edge = f32_at(b, 27);
    let mut w = [0u8; 4];
    w.copy_from_slice(&b[DIM_AT..NODES_AT]);
    let dim = i32::from_le_bytes(w);
    let max_dim = 1i64 << SignedOctree::MAX_DEPTH;
    if dim <= 0 || i64::from(dim) > max_dim || dim & (dim - 1) != 0 {
        return Err(ctx.bad(format!("byte {DIM_AT}: dim {dim}: must be a power of two from 1 to {max_dim}")));
    }
    let depth = dim.trailing_zeros();
    let mut tree = PreorderBuilder::new(depth, origin, edge).map_err(|e| ctx.bad(format!("byte 15: {e}")))?;

    // PASS 2: the nodes, checked one by one by the builder.
    let mut at = NODES_AT;
    while at < b.len() && !tree.is_complete() {
        let start = at;
        let need = |n: usize, what: &str| {
            if start + n <= b.len() {
                Ok(())
            } else {
                Err(ctx.bad(format!(
                    "byte {start}: {what} needs {n} bytes, only {} are left (truncated file?)",
                    b.len() - start
                )))
            }
        };
        let node = match b[at] {
            0 => {
                at += 1;
                OctreeNode::Internal
            }
            1 => {
                need(2, "an empty node")?;
                at += 2;
                match b[start + 1] {
                    s @ (0 | 1) => OctreeNode::Empty { outside: s == 1 },
                    s => {
                        return Err(ctx.bad(format!(
                            "byte {}: empty node sign {s}: expected 0 (inside) or 1 (outside)",
                            start + 1
                        )))
                    }
                }
            }
            2 => {
                need(14, "a leaf")?;
                at += 14;
                OctreeNode::Leaf { signs: b[start + 1], vertex: [0, 1, 2].map(|a| f32_at(b, start + 2 + 4 * a)) }
            }
            t => {
                return Err(
                    ctx.bad(format!("byte {start}: node type {t}: expected 0 (internal), 1 (empty) or 2 (leaf)"))
                )
            }
        };
        tree.push(node).map_err(|e| ctx.bad(format!("byte {start}: {e}")))?;
    }
    if tree.is_complete() && at < b.len() {
        return Err(ctx.bad(format!(
            "byte {at}: {} bytes after the end of the tree (not a SOG file of dim {dim}?)",
            b.len() - at
        )));
    }
    tree.finish().map_err(|e| ctx.bad(format!("byte {at}: {e} (truncated file?)")))
}
