//! Lines of the text mesh formats (OBJ, OFF, ASCII PLY), formatted in parallel pieces and written
//! in order: the formatting (Rust's shortest float printing) is most of their cost.

use std::io::{self, Write};

use rayon::prelude::*;

/// Lines formatted per piece (pieces of one window are formatted in parallel, then written in
/// order).
pub(super) const LINES_PER_PIECE: usize = 1 << 14;
/// Pieces formatted at once: bounds the memory of the formatted text (a few MB).
pub(super) const PIECES_PER_WINDOW: usize = 8;

/// Writes the lines `format` makes of `items`, formatted in parallel pieces and written in order;
/// `format` also gets the index of its piece's first item.
pub(super) fn write_lines<T: Sync>(
    w: &mut dyn Write,
    items: &[T],
    format: impl Fn(&mut Vec<u8>, &[T], usize) + Sync,
) -> io::Result<()> {
    for (window, chunk) in items.chunks(LINES_PER_PIECE * PIECES_PER_WINDOW).enumerate() {
        let start = window * LINES_PER_PIECE * PIECES_PER_WINDOW;
        let pieces: Vec<Vec<u8>> = chunk
            .par_chunks(LINES_PER_PIECE)
            .enumerate()
            .map(|(i, piece)| {
                let mut buf = Vec::with_capacity(piece.len() * 32);
                format(&mut buf, piece, start + i * LINES_PER_PIECE);
                buf
            })
            .collect();
        for p in pieces {
            w.write_all(&p)?;
        }
    }
    Ok(())
}

/// Appends `N i j k …` lines, 0-based indices (OFF and ASCII PLY faces).
#[cfg(any(feature = "off", feature = "ply"))]
pub(super) fn face_lines<const N: usize>(buf: &mut Vec<u8>, faces: &[[u32; N]]) {
    let mut num = itoa::Buffer::new();
    for f in faces {
        buf.extend_from_slice(num.format(N).as_bytes());
        for &v in f {
            buf.push(b' ');
            buf.extend_from_slice(num.format(v).as_bytes());
        }
        buf.push(b'\n');
    }
}
