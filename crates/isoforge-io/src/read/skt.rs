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
//! Little-endian, no header (the lattice comes from the SOG file beside it); the writer is
//! [`crate::write::skt`]. An empty file holds no skeleton.
//!
//! Refused with a message naming the file, the byte, the field and the value: a type byte other
//! than 0–3 and 255, a record cut short, a weight that is NaN or negative, a position with bits
//! 60–63 set, a pass mixing the solid's records (0, 1) with the outside's (2, 3), the solid's
//! pass after the outside's, a third pass, and a file ending inside a pass (records after the
//! last 255). The records' memory is checked against [`Limits`] before the file is read.

use std::path::Path;

use isoforge::mend::LoopKind;

use crate::error::{Ctx, Result};
use crate::limits::Limits;

/// Bytes of one record in the file.
pub const RECORD_BYTES: usize = 21;
/// The byte after each pass.
pub const END_OF_PASS: u8 = 0xff;

/// One edge of a skeleton file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SktRecord {
    /// The pass: the solid's skeleton (handles) or the outside's (tunnels).
    pub kind: LoopKind,
    /// Whether the edge was cut (a handle) or filled (a tunnel): types 1 and 3.
    pub removed: bool,
    /// The size of what retracted onto the edge, squared model units (+inf while it bounds a face).
    pub weight: f32,
    /// Its two ends as `[x, y, z]` in units of 2^-20 of the root cube's edge.
    pub ends: [[u32; 3]; 2],
}

impl SktRecord {
    /// The type byte: 0 kept / 1 cut on the solid, 2 kept / 3 filled on the outside.
    pub fn type_byte(&self) -> u8 {
        match (self.kind, self.removed) {
            (LoopKind::Handle, false) => 0,
            (LoopKind::Handle, true) => 1,
            (LoopKind::Tunnel, false) => 2,
            (LoopKind::Tunnel, true) => 3,
        }
    }
}

/// A skeleton file's records, in file order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Skeleton {
    /// The records, the solid's pass first.
    pub records: Vec<SktRecord>,
    /// Passes the file closes with a 255 (0, 1 or 2; a pass may be empty).
    pub passes: u32,
}

impl Skeleton {
    /// Records of each type (0–3).
    pub fn counts(&self) -> [u64; 4] {
        let mut c = [0; 4];
        for r in &self.records {
            c[r.type_byte() as usize] += 1;
        }
        c
    }

    /// The smallest and largest finite weights, if any.
    pub fn weight_range(&self) -> Option<(f32, f32)> {
        self.records.iter().map(|r| r.weight).filter(|w| w.is_finite()).fold(None, |acc, w| match acc {
            None => Some((w, w)),
            Some((lo, hi)) => Some((lo.min(w), hi.max(w))),
        })
    }

    /// Records of infinite weight (edges that still bounded a face).
    pub fn unbounded(&self) -> u64 {
        self.records.iter().filter(|r| r.weight.is_infinite()).count() as u64
    }
}

/// Reads the `.skt` file at `path`.
///
/// # Errors
/// A [`crate::Error`] naming the file, the byte, the field and the value: see the module
/// documentation; [`crate::Error::Limit`] when its records would exceed `limits`.
pub fn read_skt(path: &Path, limits: &Limits) -> Result<Skeleton> {
    let ctx = Ctx::new(path, "SKT");
    // The largest file whose records fit: each 21 bytes becomes one `SktRecord`.
    let per_record = std::mem::size_of::<SktRecord>() as u64;
    let max_file = (limits.max_bytes / per_record).saturating_mul(RECORD_BYTES as u64).saturating_add(2);
    let bytes = crate::file::read_all(ctx, path, max_file)?;
    parse(ctx, &bytes, limits)
}

/// Reads a `.skt` file held in memory; `path_for_messages` is the name errors give.
///
/// # Errors
/// As [`read_skt`].
pub fn read_skt_bytes(path_for_messages: &Path, bytes: &[u8], limits: &Limits) -> Result<Skeleton> {
    parse(Ctx::new(path_for_messages, "SKT"), bytes, limits)
}

/// The `N` bytes at `at` (the caller has checked they are there).
fn bytes_at<const N: usize>(b: &[u8], at: usize) -> [u8; N] {
    let mut w = [0u8; N];
    w.copy_from_slice(&b[at..at + N]);
    w
}

fn parse(ctx: Ctx, b: &[u8], limits: &Limits) -> Result<Skeleton> {
    let most = b.len() / RECORD_BYTES;
    let need = (most as u64).saturating_mul(std::mem::size_of::<SktRecord>() as u64);
    if need > limits.max_bytes {
        return Err(ctx.limit(format!("up to {most} skeleton records"), need, limits.max_bytes));
    }
    let mut out = Skeleton { records: Vec::with_capacity(most), passes: 0 };
    // The kind of the pass being read (None before its first record) and of the last pass closed.
    let (mut pass, mut closed): (Option<LoopKind>, Option<LoopKind>) = (None, None);
    let mut open_records = 0usize;
    let mut at = 0;
    while at < b.len() {
        let t = b[at];
        if t == END_OF_PASS {
            out.passes += 1;
            if out.passes > 2 {
                return Err(ctx.bad(format!(
                    "byte {at}: end of pass 3: a skeleton file holds at most two passes (the solid's, then the outside's)"
                )));
            }
            closed = pass.or(closed);
            pass = None;
            open_records = 0;
            at += 1;
            continue;
        }
        let kind = match t {
            0 | 1 => LoopKind::Handle,
            2 | 3 => LoopKind::Tunnel,
            _ => {
                return Err(ctx.bad(format!(
                "byte {at}: record type {t}: expected 0, 1 (the solid's), 2, 3 (the outside's) or 255 (end of a pass)"
            )))
            }
        };
        if b.len() - at < RECORD_BYTES {
            return Err(ctx.bad(format!(
                "byte {at}: a record needs {RECORD_BYTES} bytes, only {} are left (truncated file?)",
                b.len() - at
            )));
        }
        match (pass, closed) {
            (Some(k), _) if k != kind => {
                return Err(ctx.bad(format!(
                    "byte {at}: record type {t} ({}) in a pass of {} records",
                    kind.name(),
                    k.name()
                )))
            }
            (None, Some(LoopKind::Tunnel)) if kind == LoopKind::Handle => {
                return Err(ctx.bad(format!(
                    "byte {at}: record type {t} (handle) after the outside's pass: the solid's pass comes first"
                )))
            }
            (None, Some(k)) if k == kind => {
                return Err(ctx.bad(format!(
                    "byte {at}: record type {t} ({}): a second pass of {} records",
                    kind.name(),
                    if kind == LoopKind::Handle { "the solid's" } else { "the outside's" }
                )))
            }
            _ => {}
        }
        pass = Some(kind);
        let weight = f32::from_le_bytes(bytes_at(b, at + 1));
        if weight.is_nan() || weight < 0.0 {
            return Err(ctx.bad(format!("byte {}: weight {weight}: expected a size ≥ 0 (or +inf)", at + 1)));
        }
        let mut ends = [[0u32; 3]; 2];
        for (k, end) in ends.iter_mut().enumerate() {
            let from = at + 5 + 8 * k;
            let v = u64::from_le_bytes(bytes_at(b, from));
            if v >> 60 != 0 {
                return Err(ctx.bad(format!(
                    "byte {from}: end position {v:#018x}: bits 60–63 set (a position is three 20-bit coordinates)"
                )));
            }
            let field = |shift: u32| ((v >> shift) & 0xf_ffff) as u32;
            *end = [field(40), field(20), field(0)];
        }
        out.records.push(SktRecord { kind, removed: t % 2 == 1, weight, ends });
        open_records += 1;
        at += RECORD_BYTES;
    }
    if open_records > 0 {
        return Err(ctx.bad(format!(
            "byte {at}: the file ends inside a pass ({open_records} records after the last 255; truncated file?)"
        )));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::write::skt::write_skt;
    use isoforge::mend::SkeletonRecord;

    fn read(b: &[u8]) -> Result<Skeleton> {
        read_skt_bytes(Path::new("s.skt"), b, &Limits::default())
    }

    fn err(b: &[u8]) -> String {
        let e = read(b).unwrap_err().to_string();
        assert!(e.starts_with("s.skt: ") && !e.contains('\n'), "{e}");
        e
    }

    #[test]
    fn what_the_writer_writes_reads_back() {
        // Records of both passes at depth 5, pseudo-random ends (doubled coordinates, some beyond
        // the grid: clamped by the writer), weights finite and infinite.
        let mut seed = 11u64;
        let mut next = |m: i64| {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 33) as i64 % m
        };
        let mut records = Vec::new();
        for k in 0..200 {
            let kind = if k < 120 { LoopKind::Handle } else { LoopKind::Tunnel };
            let ends = [[next(70) - 2, next(66), next(66)], [next(66), next(66), next(70) - 2]];
            let weight = if k % 17 == 0 { f64::INFINITY } else { next(1000) as f64 / 8.0 };
            records.push(SkeletonRecord { kind, weight, ends, removed: k % 9 == 0 });
        }
        let mut bytes = Vec::new();
        write_skt(&mut bytes, &records, 5).unwrap();
        let back = read(&bytes).unwrap();
        assert_eq!(back.passes, 2);
        assert_eq!(back.records.len(), records.len());
        for (r, s) in records.iter().zip(&back.records) {
            assert_eq!((r.kind, r.removed, r.weight as f32), (s.kind, s.removed, s.weight));
            for (e, f) in r.ends.iter().zip(&s.ends) {
                let want = e.map(|v| ((v.div_euclid(2).clamp(0, 32) as u32) << 15).min((1 << 20) - 1));
                assert_eq!(*f, want, "{e:?}");
            }
        }
        let c = back.counts();
        assert_eq!(c.iter().sum::<u64>(), 200);
        assert_eq!(c[1] + c[3], records.iter().filter(|r| r.removed).count() as u64);
        assert_eq!(back.unbounded(), 12);
        let (lo, hi) = back.weight_range().unwrap();
        assert!(lo >= 0.0 && hi <= 999.0 / 8.0 && lo < hi);
        // One pass alone (the outside's), and no skeleton at all.
        let mut one = Vec::new();
        write_skt(&mut one, &records[120..], 5).unwrap();
        let back = read(&one).unwrap();
        assert_eq!((back.passes, back.records.len(), back.counts()[0]), (1, 80, 0));
        assert_eq!(read(&[]).unwrap(), Skeleton::default());
    }

    #[test]
    fn damaged_files_are_refused_naming_byte_field_and_value() {
        let r = SkeletonRecord { kind: LoopKind::Handle, weight: 2.0, ends: [[2, 4, 6], [4, 4, 6]], removed: false };
        let t = SkeletonRecord { kind: LoopKind::Tunnel, ..r };
        let mut good = Vec::new();
        write_skt(&mut good, &[r, r, t], 5).unwrap();
        assert_eq!(read(&good).unwrap().records.len(), 3);
        let with = |at: usize, v: &[u8]| {
            let mut b = good.clone();
            b[at..at + v.len()].copy_from_slice(v);
            b
        };
        assert!(err(&with(21, &[7])).contains("byte 21: record type 7: expected 0"));
        assert!(err(&good[..30]).contains("byte 21: a record needs 21 bytes, only 9 are left"));
        assert!(err(&good[..42]).contains("byte 42: the file ends inside a pass (2 records"));
        assert!(err(&with(22, &f32::NAN.to_le_bytes())).contains("byte 22: weight NaN"));
        assert!(err(&with(1, &(-1f32).to_le_bytes())).contains("byte 1: weight -1"));
        assert!(err(&with(5, &(1u64 << 62).to_le_bytes())).contains("byte 5: end position 0x4000000000000000"));
        assert!(err(&with(21, &[2])).contains("byte 21: record type 2 (tunnel) in a pass of handle records"));
        // The solid's pass after the outside's, a second solid pass, a third pass.
        let mut b = Vec::new();
        write_skt(&mut b, &[t, r], 5).unwrap();
        assert!(err(&b).contains("byte 22: record type 0 (handle) after the outside's pass"));
        let b = [&good[..21], &[0xff], &good[..21], &[0xff]].concat();
        assert!(err(&b).contains("byte 22: record type 0 (handle): a second pass"));
        assert!(err(&[0xff, 0xff, 0xff]).contains("byte 2: end of pass 3"));
        assert_eq!(read(&[0xff, 0xff]).unwrap().passes, 2);
        // The limit, before anything is read into records.
        let e = read_skt_bytes(Path::new("s.skt"), &good, &Limits::new(64)).unwrap_err().to_string();
        assert!(e.contains("skeleton records") && e.contains("limit of 64"), "{e}");
    }
}
