//! PASS 1: every x-row of samples → one bit per point (set = inside), in the sample's own type.

use super::PointBox;
use crate::grid::{Sample, Threshold};
use crate::volume::{Iso, SampleSlabs};

/// Classifies the rows of point plane `k` (global) of `bx` into `out` (`ny` rows of `words`).
/// Blocks whose bounds lie on one side of the iso are set without reading their samples.
pub(super) fn classify_plane<V: SampleSlabs>(vol: &V, bx: &PointBox, k: u32, iso: Iso, out: &mut [u64]) {
    let th = iso.threshold::<V::Sample>();
    let (s_lo, s_dims) = vol.sample_box();
    let slab = vol.slab(k);
    let words = out.len() / bx.dims[1];
    let bounds = vol.block_bounds();
    for (j, row_bits) in out.chunks_mut(words).enumerate() {
        let gj = bx.lo[1] + j as u32;
        let start = (gj - s_lo[1]) as usize * s_dims[0] as usize + (bx.lo[0] - s_lo[0]) as usize;
        let row = &slab[start..start + bx.dims[0]];
        let Some(bb) = bounds else {
            classify_row(row, th, row_bits);
            continue;
        };
        // Local indices in the sample box, where the block bounds live.
        let (lj, lk) = (gj - s_lo[1], k - s_lo[2]);
        for (w, word) in row_bits.iter_mut().enumerate() {
            let (i0, i1) = (64 * w, (64 * w + 64).min(bx.dims[0]));
            let li = bx.lo[0] - s_lo[0] + i0 as u32;
            let [min, max] = bb.of_points([li, lj, lk], [li + (i1 - i0 - 1) as u32, lj, lk]);
            let (a, b) = (iso.offset(min), iso.offset(max));
            let valid = if i1 - i0 == 64 { !0 } else { (1u64 << (i1 - i0)) - 1 };
            *word = if a < 0.0 && b < 0.0 {
                valid
            } else if a >= 0.0 && b >= 0.0 {
                0
            } else {
                let mut one = [0u64];
                classify_row(&row[i0..i1], th, &mut one);
                one[0]
            };
        }
    }
}

/// Sets bit `i` of `out` (64 per word) for each `row[i]` that passes `th`; `out` has
/// `row.len().div_ceil(64)` words and bits past the row are cleared. AVX2 for `f32` when the CPU
/// has it (chosen at run time).
#[inline]
pub(super) fn classify_row<S: Sample>(row: &[S], th: Threshold<S>, out: &mut [u64]) {
    #[cfg(target_arch = "x86_64")]
    if std::any::TypeId::of::<S>() == std::any::TypeId::of::<f32>() {
        // SAFETY: `S` is `f32` (same TypeId), so the slice has the same layout and length.
        let row = unsafe { std::slice::from_raw_parts(row.as_ptr().cast::<f32>(), row.len()) };
        let th = match th {
            Threshold::Less(t) => Threshold::Less(t.to_f64() as f32),
            Threshold::Greater(t) => Threshold::Greater(t.to_f64() as f32),
            Threshold::All => Threshold::All,
            Threshold::None => Threshold::None,
        };
        return classify_f32(row, th, out);
    }
    classify_generic(row, th, out)
}

#[inline(always)]
fn classify_generic<S: Sample>(row: &[S], th: Threshold<S>, out: &mut [u64]) {
    let fill = match th {
        Threshold::All => Some(!0u64),
        Threshold::None => Some(0),
        _ => None,
    };
    let mut chunks = row.chunks_exact(64);
    for (w, c) in out.iter_mut().zip(&mut chunks) {
        *w = match fill {
            Some(f) => f,
            // Bytes of 8 lanes, then one word: this shape vectorises on baseline x86-64.
            None => (0..8).fold(0u64, |m, g| {
                let b = (0..8).fold(0u8, |b, l| b | ((th.inside(c[g * 8 + l]) as u8) << l));
                m | ((b as u64) << (8 * g))
            }),
        };
    }
    let rem = chunks.remainder();
    if !rem.is_empty() {
        let m = rem.iter().enumerate().fold(0u64, |m, (b, &v)| m | ((th.inside(v) as u64) << b));
        out[row.len() / 64] = m;
    }
}

#[cfg(target_arch = "x86_64")]
fn classify_f32(row: &[f32], th: Threshold<f32>, out: &mut [u64]) {
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: AVX2 is available (checked just above).
        unsafe { classify_f32_avx2(row, th, out) }
    } else {
        classify_generic(row, th, out)
    }
}

/// AVX2 classification: 8 compares and one movemask per 8 samples (the bandwidth floor on 256³;
/// 2.5× the portable loop).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn classify_f32_avx2(row: &[f32], th: Threshold<f32>, out: &mut [u64]) {
    use std::arch::x86_64::*;
    let (t, less) = match th {
        Threshold::Less(t) => (t, true),
        Threshold::Greater(t) => (t, false),
        _ => return classify_generic(row, th, out),
    };
    let tv = _mm256_set1_ps(t);
    let mut chunks = row.chunks_exact(64);
    for (w, c) in out.iter_mut().zip(&mut chunks) {
        let mut m = 0u64;
        for g in 0..8 {
            // SAFETY: `c` has 64 elements, so `g * 8 + 8 <= 64` stays inside it.
            let v = unsafe { _mm256_loadu_ps(c.as_ptr().add(g * 8)) };
            let r = if less { _mm256_cmp_ps::<_CMP_LT_OQ>(v, tv) } else { _mm256_cmp_ps::<_CMP_GT_OQ>(v, tv) };
            m |= (_mm256_movemask_ps(r) as u32 as u64) << (8 * g);
        }
        *w = m;
    }
    let rem = chunks.remainder();
    if !rem.is_empty() {
        out[row.len() / 64] = rem.iter().enumerate().fold(0u64, |m, (b, &v)| m | ((th.inside(v) as u64) << b));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_f32_path_equals_the_portable_one() {
        let row: Vec<f32> = (0..200).map(|i| ((i * 37) % 23) as f32 - 11.0).collect();
        for th in [Threshold::Less(0.5f32), Threshold::Greater(-3.0), Threshold::All, Threshold::None] {
            let (mut a, mut b) = (vec![0u64; 4], vec![0u64; 4]);
            classify_row(&row, th, &mut a);
            classify_generic(&row, th, &mut b);
            assert_eq!(a, b, "{th:?}");
        }
    }
}
