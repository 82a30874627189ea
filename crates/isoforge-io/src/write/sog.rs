//! A [`SignedOctree`] as a PolyMender `.sog` file (the layout is in [`crate::read::sog`]):
//! magic, origin and edge, zero padding to byte 128, `dim`, then the nodes in pre-order. A file
//! read and written again is the same bytes (every real file: `tests/sog.rs`).

use std::io::{self, Write};

use isoforge::grid::{OctreeNode, SignedOctree};

use crate::read::sog::{DIM_AT, MAGIC};

/// Writes `tree` as a `.sog` file.
///
/// # Errors
/// The writer's errors.
pub fn write_sog(w: &mut dyn Write, tree: &SignedOctree) -> io::Result<()> {
    let mut header = [0u8; DIM_AT + 4];
    header[..MAGIC.len()].copy_from_slice(MAGIC);
    let numbers = tree.origin().into_iter().chain([tree.edge()]);
    for (i, v) in numbers.enumerate() {
        let at = MAGIC.len() + 4 * i;
        header[at..at + 4].copy_from_slice(&v.to_le_bytes());
    }
    header[DIM_AT..].copy_from_slice(&(tree.dim() as i32).to_le_bytes());
    w.write_all(&header)?;
    let mut buf = Vec::with_capacity(64 << 10);
    for node in tree.preorder() {
        match node {
            OctreeNode::Internal => buf.push(0),
            OctreeNode::Empty { outside } => buf.extend([1, u8::from(outside)]),
            OctreeNode::Leaf { signs, vertex } => {
                buf.extend([2, signs]);
                for v in vertex {
                    buf.extend(v.to_le_bytes());
                }
            }
        }
        if buf.len() >= 60 << 10 {
            w.write_all(&buf)?;
            buf.clear();
        }
    }
    w.write_all(&buf)
}
