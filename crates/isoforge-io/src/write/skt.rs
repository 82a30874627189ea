//! TopoMender's skeleton files (`.skt`): the skeletons a topology repair thinned, edge by edge.
//!
//! ```text
//!   record   u8 type   0 solid's skeleton edge kept, 1 cut (a handle),
//!                      2 outside's skeleton edge kept, 3 filled (a tunnel)
//!            f32 weight (the edge's size, squared model units; +inf while it bounds a face)
//!            u64 end, u64 end   positions: z in bits 0–19, y in 20–39, x in 40–59, in units
//!                               of 2^-20 of the root cube (a point, or a cell by its lowest corner)
//!   0xff     after each pass's records (the solid's first, then the outside's)
//! ```
//! Little-endian, no header: the lattice comes from the SOG file beside it. Read back by
//! [`crate::read::skt`].

use std::io::{self, Write};

use isoforge::mend::{LoopKind, SkeletonRecord};

/// Writes `records` (in pass order) for a root cube of `2^depth` cells per axis (`depth ≤ 20`).
pub fn write_skt(w: &mut dyn Write, records: &[SkeletonRecord], depth: u32) -> io::Result<()> {
    let shift = 20u32.saturating_sub(depth);
    let cells = 1i64 << depth.min(20);
    let position = |x: [i64; 3]| -> u64 {
        // Doubled coordinates to the point (or the cell's lowest corner), kept in the cube.
        let p = x.map(|v| (v.div_euclid(2)).clamp(0, cells) as u64);
        let p = p.map(|v| (v << shift).min((1 << 20) - 1));
        p[2] | p[1] << 20 | p[0] << 40
    };
    let mut pass = None;
    for r in records {
        if pass.is_some_and(|k| k != r.kind) {
            w.write_all(&[0xff])?;
        }
        pass = Some(r.kind);
        let ty = match (r.kind, r.removed) {
            (LoopKind::Handle, false) => 0u8,
            (LoopKind::Handle, true) => 1,
            (LoopKind::Tunnel, false) => 2,
            (LoopKind::Tunnel, true) => 3,
        };
        w.write_all(&[ty])?;
        w.write_all(&(r.weight as f32).to_le_bytes())?;
        for e in r.ends {
            w.write_all(&position(e).to_le_bytes())?;
        }
    }
    if pass.is_some() {
        w.write_all(&[0xff])?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_are_21_bytes_with_a_terminator_after_each_pass() {
        let r = |kind, removed| SkeletonRecord { kind, weight: 1.5, ends: [[2, 4, 6], [3, 4, 6]], removed };
        let mut out = Vec::new();
        write_skt(&mut out, &[r(LoopKind::Handle, false), r(LoopKind::Handle, true), r(LoopKind::Tunnel, true)], 5)
            .unwrap();
        assert_eq!(out.len(), 3 * 21 + 2);
        assert_eq!(out[0], 0);
        assert_eq!(f32::from_le_bytes(out[1..5].try_into().unwrap()), 1.5);
        // Point (1, 2, 3) at depth 5: each coordinate times 2^15.
        let p = u64::from_le_bytes(out[5..13].try_into().unwrap());
        assert_eq!(p, 3 << 15 | (2 << 15) << 20 | (1 << 15) << 40);
        assert_eq!(out[21], 1);
        assert_eq!(out[42], 0xff);
        assert_eq!(out[43], 3);
        assert_eq!(out[64], 0xff);
    }
}
