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
    #[cfg(target_arch = "x86_64")]
    if let Some(done) = classify_int_avx2(row, th, out) {
        return done;
    }
    classify_generic(row, th, out)
}

/// 8- and 16-bit integer samples (CT data) with AVX2, when the CPU has it: `None` for other
/// types or thresholds, or without AVX2.
#[cfg(target_arch = "x86_64")]
#[inline]
fn classify_int_avx2<S: Sample>(row: &[S], th: Threshold<S>, out: &mut [u64]) -> Option<()> {
    use std::any::TypeId;
    let (t, less) = match th {
        Threshold::Less(t) => (t.to_f64(), true),
        Threshold::Greater(t) => (t.to_f64(), false),
        _ => return None,
    };
    let id = TypeId::of::<S>();
    // The type's values as signed lanes of its width: unsigned ones with the top bit flipped,
    // which keeps their order (so one signed compare decides).
    let (bytes, flip) = if id == TypeId::of::<i16>() {
        (2, 0)
    } else if id == TypeId::of::<u16>() {
        (2, 0x8000)
    } else if id == TypeId::of::<i8>() {
        (1, 0)
    } else if id == TypeId::of::<u8>() {
        (1, 0x80)
    } else {
        return None;
    };
    if !std::arch::is_x86_feature_detected!("avx2") {
        return None;
    }
    // `t` is a value of `S` (exact in f64); as raw bits of its width, flipped like the samples.
    let t = if flip == 0 { t as i64 } else { t as i64 - flip };
    if bytes == 2 {
        // SAFETY: `S` is i16 or u16 (TypeId above): 2-byte samples, reinterpreted as i16 bits.
        let row = unsafe { std::slice::from_raw_parts(row.as_ptr().cast::<i16>(), row.len()) };
        // SAFETY: AVX2 is available (checked above).
        unsafe { classify_i16_avx2(row, t as i16, flip as u16 as i16, less, out) };
    } else {
        // SAFETY: `S` is i8 or u8 (TypeId above): 1-byte samples, reinterpreted as i8 bits.
        let row = unsafe { std::slice::from_raw_parts(row.as_ptr().cast::<i8>(), row.len()) };
        // SAFETY: AVX2 is available (checked above).
        unsafe { classify_i8_avx2(row, t as i8, flip as u8 as i8, less, out) };
    }
    Some(())
}

/// Inside bits of 16-bit samples (`row` as i16 bits; `flip` xored into each, then compared
/// signed with `t`): 4 compares, 2 packs and 2 movemasks per 64 samples.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn classify_i16_avx2(row: &[i16], t: i16, flip: i16, less: bool, out: &mut [u64]) {
    use std::arch::x86_64::*;
    let (tv, fv) = (_mm256_set1_epi16(t), _mm256_set1_epi16(flip));
    let inside = |v: i16| if less { (v ^ flip) < t } else { (v ^ flip) > t };
    let mut chunks = row.chunks_exact(64);
    for (w, c) in out.iter_mut().zip(&mut chunks) {
        let mut m = 0u64;
        for g in 0..2 {
            // SAFETY: `c` has 64 elements: the loads at 32g and 32g + 16 read 16 each inside it.
            let (a, b) = unsafe {
                (
                    _mm256_loadu_si256(c.as_ptr().add(32 * g).cast()),
                    _mm256_loadu_si256(c.as_ptr().add(32 * g + 16).cast()),
                )
            };
            let (a, b) = (_mm256_xor_si256(a, fv), _mm256_xor_si256(b, fv));
            let (ma, mb) = if less {
                (_mm256_cmpgt_epi16(tv, a), _mm256_cmpgt_epi16(tv, b))
            } else {
                (_mm256_cmpgt_epi16(a, tv), _mm256_cmpgt_epi16(b, tv))
            };
            // Packing works per 128-bit lane (a0–7 b0–7 a8–15 b8–15): put the quarters in order.
            let p = _mm256_permute4x64_epi64::<0b11_01_10_00>(_mm256_packs_epi16(ma, mb));
            m |= (_mm256_movemask_epi8(p) as u32 as u64) << (32 * g);
        }
        *w = m;
    }
    let rem = chunks.remainder();
    if !rem.is_empty() {
        out[row.len() / 64] = rem.iter().enumerate().fold(0u64, |m, (b, &v)| m | ((inside(v) as u64) << b));
    }
}

/// Inside bits of 8-bit samples (as [`classify_i16_avx2`]): 2 compares and 2 movemasks per 64.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn classify_i8_avx2(row: &[i8], t: i8, flip: i8, less: bool, out: &mut [u64]) {
    use std::arch::x86_64::*;
    let (tv, fv) = (_mm256_set1_epi8(t), _mm256_set1_epi8(flip));
    let inside = |v: i8| if less { (v ^ flip) < t } else { (v ^ flip) > t };
    let mut chunks = row.chunks_exact(64);
    for (w, c) in out.iter_mut().zip(&mut chunks) {
        let mut m = 0u64;
        for g in 0..2 {
            // SAFETY: `c` has 64 elements: the load at 32g reads 32 inside it.
            let a = _mm256_xor_si256(unsafe { _mm256_loadu_si256(c.as_ptr().add(32 * g).cast()) }, fv);
            let r = if less { _mm256_cmpgt_epi8(tv, a) } else { _mm256_cmpgt_epi8(a, tv) };
            m |= (_mm256_movemask_epi8(r) as u32 as u64) << (32 * g);
        }
        *w = m;
    }
    let rem = chunks.remainder();
    if !rem.is_empty() {
        out[row.len() / 64] = rem.iter().enumerate().fold(0u64, |m, (b, &v)| m | ((inside(v) as u64) << b));
    }
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

    /// Every threshold of a type against samples spread over its range, rows of 1 to 200.
    fn int_path_equals_the_portable_one<S: Sample + std::fmt::Debug>(values: &[S], thresholds: &[S]) {
        for n in [1, 31, 64, 65, 130, 200] {
            let row: Vec<S> = (0..n).map(|i| values[(i * 37 + n) % values.len()]).collect();
            for &t in thresholds {
                for th in [Threshold::Less(t), Threshold::Greater(t)] {
                    let (mut a, mut b) = (vec![!0u64; n.div_ceil(64)], vec![0u64; n.div_ceil(64)]);
                    classify_row(&row, th, &mut a);
                    classify_generic(&row, th, &mut b);
                    assert_eq!(a, b, "{th:?} on {n} samples");
                }
            }
        }
    }

    #[test]
    fn the_8_and_16_bit_paths_equal_the_portable_one() {
        let u8s: Vec<u8> = (0..=255).collect();
        int_path_equals_the_portable_one(&u8s, &[0, 1, 46, 127, 128, 129, 200, 254, 255]);
        let i8s: Vec<i8> = (-128..=127).collect();
        int_path_equals_the_portable_one(&i8s, &[-128, -127, -1, 0, 1, 126, 127]);
        let u16s: Vec<u16> = (0..=65535u32).step_by(97).map(|v| v as u16).chain([0, 32767, 32768, 65535]).collect();
        int_path_equals_the_portable_one(&u16s, &[0, 1, 989, 32767, 32768, 40000, 65534, 65535]);
        let i16s: Vec<i16> =
            (-32768..=32767i32).step_by(89).map(|v| v as i16).chain([-32768, 0, 988, 989, 32767]).collect();
        int_path_equals_the_portable_one(&i16s, &[-32768, -2000, -1, 0, 989, 4095, 32767]);
    }
}
