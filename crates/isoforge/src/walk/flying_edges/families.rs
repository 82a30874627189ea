//! Families of lattice segments whose crossings a row numbers: its x-, y- and z-edges, the split
//! diagonals of the faces starting at its points (tetrahedral methods), and its cells' main
//! diagonals. A family's crossings in a row are one bit mask, so they are counted by popcount
//! and numbered by rank exactly as edges are.
//!
//! ```text
//!   family  segment from point (i, j, k) of row A = (j, k)      needs
//!   X       → (i+1, j, k)                                        i + 1 < nx
//!   Y       → (i, j+1, k)                                        j + 1 < ny
//!   Z       → (i, j, k+1)                                        k + 1 < nz
//!   FZ      diagonal of the face (i..i+1, j..j+1, k)            i + 1 < nx, j + 1 < ny
//!   FY      diagonal of the face (i..i+1, j, k..k+1)            i + 1 < nx, k + 1 < nz
//!   FX      diagonal of the face (i, j..j+1, k..k+1)            j + 1 < ny, k + 1 < nz
//!   MAIN    → (i+1, j+1, k+1)                                    all three
//! ```
//! A face's diagonal is its low–high one ((0,0)–(1,1) in the face) or the other, as
//! [`Diagonals`] says (for `OddCorners`: low–high where i + j + k is odd).

use super::bits::{mask_tail, Bits};
use crate::cube::{Diagonals, EdgeKey, SegmentKey, VertexKey, CASE_EDGES, MAIN_DIAGONAL};
use crate::extract::Segments;

pub(super) const X: usize = 0;
pub(super) const Y: usize = 1;
pub(super) const Z: usize = 2;
pub(super) const FZ: usize = 3;
pub(super) const FY: usize = 4;
pub(super) const FX: usize = 5;
pub(super) const MAIN: usize = 6;
/// Families, in the order a row numbers their vertices.
pub(super) const FAMILIES: usize = 7;

/// Which families a walk numbers, and where the odd points of each row are.
#[derive(Debug, Clone, Copy)]
pub(super) struct Walked {
    pub(super) segments: Segments,
    /// Parity of the box's first point's coordinate sum.
    pub(super) parity0: usize,
}

impl Walked {
    /// The families `segments` name, for a box whose first point is `lo`.
    pub(super) fn new(segments: Segments, lo: [u32; 3]) -> Self {
        Walked { segments, parity0: ((lo[0] + lo[1] + lo[2]) % 2) as usize }
    }

    /// For each case and parity (even, odd), the cell segments that cross: the case's edges,
    /// and the numbered diagonals whose two corners differ in class.
    pub(super) fn crossed(&self) -> [[u32; 2]; 256] {
        std::array::from_fn(|case| {
            [false, true].map(|odd| {
                let differ = |[a, b]: [u8; 2]| (case >> a & 1) != (case >> b & 1);
                let mut m = u32::from(CASE_EDGES[case]);
                if let Some(d) = self.segments.diagonals {
                    for f in 0..6u8 {
                        if differ(d.of_face(f, odd)) {
                            m |= 1 << (12 + f);
                        }
                    }
                }
                if self.segments.main_diagonal && differ([0, 7]) {
                    m |= 1 << MAIN_DIAGONAL;
                }
                m
            })
        })
    }

    /// Whether family `f` is numbered.
    #[inline(always)]
    pub(super) fn has(&self, f: usize) -> bool {
        match f {
            X | Y | Z => true,
            MAIN => self.segments.main_diagonal,
            _ => self.segments.diagonals.is_some(),
        }
    }

    /// Whether only the axis edges are numbered (no diagonals): marching cubes and the like.
    #[inline(always)]
    pub(super) fn edges_only(&self) -> bool {
        self.segments.diagonals.is_none() && !self.segments.main_diagonal
    }

    /// The bits of the row (j, k) whose point has an odd coordinate sum.
    #[inline]
    fn odd_bits(&self, j: usize, k: usize) -> u64 {
        if (self.parity0 + j + k).is_multiple_of(2) {
            0xAAAA_AAAA_AAAA_AAAA
        } else {
            0x5555_5555_5555_5555
        }
    }

    /// Writes into `out` the crossings of family `f` in row `r` = (j, k) of a box of `dims`
    /// points (its words past the family's segments cleared); false when the row has none of
    /// that family (it needs points the box does not have).
    pub(super) fn mask(
        &self,
        f: usize,
        bits: &Bits,
        r: usize,
        [j, k]: [usize; 2],
        dims: [usize; 3],
        out: &mut [u64],
    ) -> bool {
        let [nx, ny, nz] = dims;
        let (up, deep) = (j + 1 < ny, k + 1 < nz);
        let a = bits.row(r);
        let words = a.len();
        // x[i + 1] of a row, across words.
        let next = |x: &[u64], w: usize| (x[w] >> 1) | if w + 1 < words { x[w + 1] << 63 } else { 0 };
        let odd = self.odd_bits(j, k);
        let split = |low_high: u64, other: u64| match self.segments.diagonals {
            Some(Diagonals::MinToMax) | None => low_high,
            Some(Diagonals::OddCorners) => (low_high & odd) | (other & !odd),
        };
        let cells = match f {
            X => {
                for w in 0..words {
                    out[w] = a[w] ^ next(a, w);
                }
                nx - 1
            }
            Y if up => {
                let b = bits.row(r + 1);
                for w in 0..words {
                    out[w] = a[w] ^ b[w];
                }
                nx
            }
            Z if deep => {
                let c = bits.row(r + ny);
                for w in 0..words {
                    out[w] = a[w] ^ c[w];
                }
                nx
            }
            FZ | FY if (f == FZ && up) || (f == FY && deep) => {
                let b = if f == FZ { bits.row(r + 1) } else { bits.row(r + ny) };
                for w in 0..words {
                    out[w] = split(a[w] ^ next(b, w), next(a, w) ^ b[w]);
                }
                nx - 1
            }
            FX if up && deep => {
                let (b, c, e) = (bits.row(r + 1), bits.row(r + ny), bits.row(r + ny + 1));
                for w in 0..words {
                    out[w] = split(a[w] ^ e[w], b[w] ^ c[w]);
                }
                nx
            }
            MAIN if up && deep => {
                let e = bits.row(r + ny + 1);
                for w in 0..words {
                    out[w] = a[w] ^ next(e, w);
                }
                nx - 1
            }
            _ => return false,
        };
        mask_tail(out, cells);
        true
    }

    /// Family `f`'s segment starting at the row point with global index `g`: its two end points
    /// as offsets from `g` (the key's lower end first), and its key.
    #[inline]
    pub(super) fn segment(&self, f: usize, g: [u32; 3]) -> ([[usize; 3]; 2], VertexKey) {
        let axis_edge = |axis: crate::cube::Axis| {
            let u = axis.unit().map(|x| x as usize);
            ([[0; 3], u], VertexKey::Edge(EdgeKey { origin: g, axis }))
        };
        let low_high = || match self.segments.diagonals {
            Some(Diagonals::MinToMax) | None => true,
            Some(Diagonals::OddCorners) => (g[0] + g[1] + g[2]) % 2 == 1,
        };
        // The two other axes of a face normal, and the segment's two corner offsets.
        let ends: [[usize; 3]; 2] = match f {
            X => return axis_edge(crate::cube::Axis::X),
            Y => return axis_edge(crate::cube::Axis::Y),
            Z => return axis_edge(crate::cube::Axis::Z),
            FZ => {
                if low_high() {
                    [[0, 0, 0], [1, 1, 0]]
                } else {
                    [[1, 0, 0], [0, 1, 0]]
                }
            }
            FY => {
                if low_high() {
                    [[0, 0, 0], [1, 0, 1]]
                } else {
                    [[1, 0, 0], [0, 0, 1]]
                }
            }
            FX => {
                if low_high() {
                    [[0, 0, 0], [0, 1, 1]]
                } else {
                    [[0, 1, 0], [0, 0, 1]]
                }
            }
            _ => [[0, 0, 0], [1, 1, 1]],
        };
        let abs = |o: [usize; 3]| [0, 1, 2].map(|a| 2 * (g[a] + o[a] as u32));
        let (p, q) = (abs(ends[0]), abs(ends[1]));
        let key = if p <= q { SegmentKey { a: p, b: q } } else { SegmentKey { a: q, b: p } };
        let ends = if p <= q { ends } else { [ends[1], ends[0]] };
        (ends, VertexKey::Segment(key))
    }
}
