//! ① Volume: a field or a grid on a lattice that gives values and exact edge crossings.
//!
//! In: a [`Field`] (any closure `Fn(Vec3) -> f32`) or a [`DenseGrid`](crate::grid::DenseGrid).
//! Out: the [`Volume`] that walkers consume — slabs of values offset by iso, the crossing on an
//! edge ([`GridVolume`]: linear interpolation, exact for the trilinear interpolant; [`Sampled`]:
//! root finding by an [`Oracle`]), the gradient there, and bounds of the values over blocks so
//! walkers can skip what the surface cannot cross. Volumes whose samples are stored in a native
//! type also offer them slab by slab ([`SampleSlabs`]); streamed volumes arrive through a
//! [`SlabSource`].

pub mod catalog;
pub mod classic;
mod field;
mod grid_volume;
mod oracle;
mod prefetch;
mod sampled;
pub mod sdf;
mod source;
mod sparse;
mod strided;
mod tabulated;
pub mod texture;

pub use field::{central_difference, widened, Field, FieldVisitor};
pub use grid_volume::{
    edge_gradient, grid_crossing, grid_segment_crossing, point_gradient, point_gradient_at, trilinear_value, GridVolume,
};
pub use oracle::{Bisection, Illinois, Linear, Oracle};
pub use prefetch::Prefetch;
pub use sampled::Sampled;
pub use source::SlabSource;
pub use sparse::SparseVolume;
pub use strided::{AnySamples, StridedSamples, StridedSlabs};
pub use tabulated::Tabulated;

use crate::cube::EdgeKey;
use crate::grid::{Lattice, Sample};
use crate::math::Vec3;

/// Which side of the iso value is *inside*.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Inside {
    /// Inside ⇔ value < iso (the project's convention; signed distance fields, ties outside).
    #[default]
    Below,
    /// Inside ⇔ value > iso (densities such as CT bone or metaball potentials; ties outside).
    Above,
}

impl Inside {
    /// `below` or `above` (the CLI's word; parsed by `str::parse`).
    pub fn name(self) -> &'static str {
        match self {
            Inside::Below => "below",
            Inside::Above => "above",
        }
    }
}

/// An iso value and the side that counts as inside.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Iso {
    /// The iso value.
    pub value: f64,
    /// Which side is inside.
    pub inside: Inside,
}

impl Iso {
    /// Inside ⇔ value < `iso`.
    pub fn below(iso: f64) -> Self {
        Iso { value: iso, inside: Inside::Below }
    }

    /// Inside ⇔ value > `iso`.
    pub fn above(iso: f64) -> Self {
        Iso { value: iso, inside: Inside::Above }
    }

    /// The value offset so that inside ⇔ result < 0 and ties give 0 (outside).
    ///
    /// The sign is exact for every sample type: the difference is taken in `f64` (exact sign for
    /// finite operands) and a negative difference too small for `f32` is kept negative.
    #[inline(always)]
    pub fn offset(&self, v: f64) -> f32 {
        narrow(self.exact_offset(v))
    }

    /// The offsets of a cell's eight values: [`offset`](Iso::offset) of each, unless one lies
    /// beyond `f32`'s normal range (a value too far from iso or too close to it for `f32`); then
    /// all eight are first scaled by one power of two (exactly) that brings the largest near 1, so
    /// that what extractors compute from their ratios (crossings, MC33's decisions) survives the
    /// rounding to `f32`. The signs are [`offset`](Iso::offset)'s either way.
    #[inline]
    pub fn cell_offsets(&self, values: [f64; 8]) -> [f32; 8] {
        let d = values.map(|v| self.exact_offset(v));
        // All eight tested without branching (vectorised): the values of a cell are rarely abnormal.
        let abnormal = d.iter().fold(false, |m, &x| {
            let a = x.abs();
            m | ((a < f32::MIN_POSITIVE as f64) & (x != 0.0)) | !(a <= f32::MAX as f64)
            // NaN too
        });
        if abnormal {
            return scaled_offsets(d);
        }
        d.map(narrow)
    }

    /// The offset of [`offset`](Iso::offset) unrounded, in `f64`: exact for every sample type but
    /// `f64` (rounded once there, with the exact sign).
    #[inline]
    pub fn exact_offset(&self, v: f64) -> f64 {
        match self.inside {
            Inside::Below => v - self.value,
            Inside::Above => self.value - v,
        }
    }

    /// The native-type test equivalent to `self.offset(v) < 0` for samples of type `S`.
    pub fn threshold<S: crate::grid::Sample>(&self) -> crate::grid::Threshold<S> {
        S::threshold(self.value, self.inside == Inside::Below)
    }

    /// +1 when inside is below iso, -1 when above: multiplies gradients into outward normals.
    #[inline]
    pub fn sign(&self) -> f32 {
        match self.inside {
            Inside::Below => 1.0,
            Inside::Above => -1.0,
        }
    }
}

/// What walkers consume: a scalar function on a lattice with exact edge crossings.
///
/// Values reach walkers already offset by iso ([`Iso::offset`]), so one comparison with zero
/// classifies a point exactly whatever the sample type.
pub trait Volume {
    /// The lattice the volume is sampled on.
    fn lattice(&self) -> &Lattice;

    /// Writes `iso.offset(value)` for every point of z-slab `k`, x fastest (`out.len()` = nx·ny).
    fn fill_slab(&self, k: u32, iso: Iso, out: &mut [f32]);

    /// The crossing on edge `e` as a parameter `t` in [0, 1] from `e.origin`, given the offset
    /// values `d0` at the origin and `d1` at the end (one < 0, the other ≥ 0).
    fn crossing(&self, e: EdgeKey, d0: f32, d1: f32, iso: Iso) -> f32;

    /// The world-space gradient of the value at parameter `t` on edge `e` (not normalised; may
    /// be zero).
    fn gradient(&self, e: EdgeKey, t: f32) -> Vec3;

    /// The value offset by iso at index-space point `p` off the lattice points (a cell centre,
    /// a point on a diagonal): the field itself for fields, the trilinear interpolant for grids.
    fn value_at(&self, p: [f64; 3], iso: Iso) -> f32;

    /// The world-space gradient at index-space point `p` (not normalised; may be zero).
    fn gradient_at(&self, p: [f64; 3]) -> Vec3;

    /// The value offset by iso at lattice point `p`: [`value_at`](Volume::value_at) there,
    /// which sampled volumes answer with one sample instead of an interpolation.
    #[inline]
    fn value_at_point(&self, p: [u32; 3], iso: Iso) -> f32 {
        self.value_at(p.map(f64::from), iso)
    }

    /// [`value_at_point`](Volume::value_at_point)`(p, iso)` of every lattice point `p` of
    /// `lo .. hi` (half-open, inside the lattice), bit for bit, x fastest, into `out`
    /// (`out.len()` = the box's points). One call per box instead of one per point: fields
    /// override it with a loop their value inlines into (sparse sampling), sparse grids with
    /// copies of leaf rows (surface following).
    fn fill_values(&self, lo: [u32; 3], hi: [u32; 3], iso: Iso, out: &mut [f32]) {
        let mut at = 0;
        for z in lo[2]..hi[2] {
            for y in lo[1]..hi[1] {
                for x in lo[0]..hi[0] {
                    out[at] = self.value_at_point([x, y, z], iso);
                    at += 1;
                }
            }
        }
    }

    /// The crossing on the segment `p0` → `p1` (index space; a diagonal or a segment to a cell
    /// centre) as a parameter in [0, 1], given the offset values at its ends (one < 0, the other
    /// ≥ 0). Linear by default; fields refine it with their oracle.
    fn segment_crossing(&self, p0: [f64; 3], p1: [f64; 3], d0: f32, d1: f32, iso: Iso) -> f32 {
        let _ = (p0, p1, iso);
        linear_crossing(d0, d1)
    }

    /// Bounds `(min, max)` of the value offset by iso wherever walkers may evaluate it in the
    /// closed box of index points `lo ..= hi` (corners, centres, diagonals: for grids the samples'
    /// range, which bounds the trilinear interpolant), or `None` when unknown. A walker skips the
    /// cells of a box whose bounds lie on one side of 0 (`max < 0`: all inside; `min ≥ 0`: all
    /// outside).
    fn value_bounds(&self, lo: [u32; 3], hi: [u32; 3], iso: Iso) -> Option<(f32, f32)> {
        let _ = (lo, hi, iso);
        None
    }

    /// Whether every value off the lattice points lies between the smallest and largest of its
    /// cell's corners (the trilinear interpolant of a grid): then a cell whose corners agree has
    /// no crossing anywhere inside, centres included, and walkers need not visit it even for
    /// extractors that sample off the lattice. False for fields (a thin feature can pass between
    /// samples).
    fn bounded_by_corners(&self) -> bool {
        false
    }

    /// Whether [`gradient`](Volume::gradient) is the field's own gradient rather than an estimate
    /// from samples (central differences): what lets a dual method trust tangent planes that meet
    /// outside a cell. Fields by default: exactly the volumes not
    /// [`bounded_by_corners`](Volume::bounded_by_corners) (sampled ones are).
    fn exact_gradients(&self) -> bool {
        !self.bounded_by_corners()
    }
}

/// A volume stored as samples of a native type, offered slab by slab: what the Flying Edges
/// walker classifies in the sample's own type (exactly, and at memory speed).
pub trait SampleSlabs: Volume {
    /// The sample type.
    type Sample: Sample;
    /// The box of points the samples cover: its first point (global lattice index) and its points
    /// per axis. The whole lattice for an in-memory grid; a chunk (with its halo) otherwise.
    fn sample_box(&self) -> ([u32; 3], [u32; 3]);
    /// The samples of the box's points at global z-index `k`, x fastest (box nx · ny of them).
    fn slab(&self, k: u32) -> &[Self::Sample];
    /// Bounds of the native samples over blocks, if the volume has them (see [`Volume::value_bounds`]).
    fn block_bounds(&self) -> Option<&crate::grid::BlockBounds> {
        None
    }
    /// Whether [`Volume::value_at`] at a cell's centre is the trilinear interpolant of these
    /// samples: `iso.offset` of the sum, in `f64` and corner order (x fastest), of each corner's
    /// sample times 1/8. A walker may then compute centre values from the samples it reads,
    /// bit for bit as `value_at` would. False unless the volume promises it (fields are not).
    fn centres_from_samples(&self) -> bool {
        false
    }
}

impl<V: Volume + ?Sized> Volume for &V {
    #[inline]
    fn lattice(&self) -> &Lattice {
        (**self).lattice()
    }
    #[inline]
    fn fill_slab(&self, k: u32, iso: Iso, out: &mut [f32]) {
        (**self).fill_slab(k, iso, out)
    }
    #[inline]
    fn crossing(&self, e: EdgeKey, d0: f32, d1: f32, iso: Iso) -> f32 {
        (**self).crossing(e, d0, d1, iso)
    }
    #[inline]
    fn gradient(&self, e: EdgeKey, t: f32) -> Vec3 {
        (**self).gradient(e, t)
    }
    #[inline]
    fn value_at(&self, p: [f64; 3], iso: Iso) -> f32 {
        (**self).value_at(p, iso)
    }
    #[inline]
    fn gradient_at(&self, p: [f64; 3]) -> Vec3 {
        (**self).gradient_at(p)
    }
    #[inline]
    fn value_at_point(&self, p: [u32; 3], iso: Iso) -> f32 {
        (**self).value_at_point(p, iso)
    }
    #[inline]
    fn segment_crossing(&self, p0: [f64; 3], p1: [f64; 3], d0: f32, d1: f32, iso: Iso) -> f32 {
        (**self).segment_crossing(p0, p1, d0, d1, iso)
    }
    #[inline]
    fn fill_values(&self, lo: [u32; 3], hi: [u32; 3], iso: Iso, out: &mut [f32]) {
        (**self).fill_values(lo, hi, iso, out)
    }
    fn value_bounds(&self, lo: [u32; 3], hi: [u32; 3], iso: Iso) -> Option<(f32, f32)> {
        (**self).value_bounds(lo, hi, iso)
    }
    fn bounded_by_corners(&self) -> bool {
        (**self).bounded_by_corners()
    }
}

/// [`Iso::cell_offsets`] of a cell with a value beyond `f32`'s normal range: the offsets `d`
/// scaled by the power of two that brings the largest near 1, then rounded.
#[cold]
fn scaled_offsets(d: [f64; 8]) -> [f32; 8] {
    let largest = d.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    // 2^-e in two factors, each within f64's range for any finite `largest`.
    let e = largest.log2().floor() as i32;
    let (a, b) = (-e / 2, -e - -e / 2);
    d.map(|x| narrow(x * 2f64.powi(a) * 2f64.powi(b)))
}

/// An offset rounded to `f32`, a negative one kept negative (at least `f32::MIN_POSITIVE` in
/// magnitude): inside stays inside.
///
/// Branch-free: the fills narrow the values at both ends of every crossing, where the sign
/// changes, so a branch on the sign was mispredicted about every other time. x86 has no
/// conditional move for floats, and LLVM lowered every scalar form of this select (even
/// `select_unpredictable`'s, and masks of the bits) to a branch; on x86-64 it is an SSE2
/// compare mask and `minss` instead.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn narrow(d: f64) -> f32 {
    use std::arch::x86_64::{
        _mm_and_ps, _mm_andnot_ps, _mm_castpd_ps, _mm_cmplt_sd, _mm_cvtsd_ss, _mm_cvtss_f32, _mm_min_ss, _mm_or_ps,
        _mm_set_sd, _mm_set_ss, _mm_setzero_pd, _mm_setzero_ps,
    };
    // SAFETY: SSE2 is part of x86-64.
    unsafe {
        let d = _mm_set_sd(d);
        // `d as f32` (both round to nearest).
        let f = _mm_cvtsd_ss(_mm_setzero_ps(), d);
        // The bound: −MIN_POSITIVE where d < 0 (false for −0 and NaN), else +∞.
        let negative = _mm_castpd_ps(_mm_cmplt_sd(d, _mm_setzero_pd()));
        let bound = _mm_or_ps(
            _mm_and_ps(negative, _mm_set_ss(-f32::MIN_POSITIVE)),
            _mm_andnot_ps(negative, _mm_set_ss(f32::INFINITY)),
        );
        // `minss bound, f`: bound where bound < f, else f (NaN included).
        _mm_cvtss_f32(_mm_min_ss(bound, f))
    }
}

/// See the x86-64 one.
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
fn narrow(d: f64) -> f32 {
    let f = d as f32;
    if d < 0.0 {
        f.min(-f32::MIN_POSITIVE)
    } else {
        f
    }
}

/// Linear interpolation parameter between two offset values of opposite class, clamped to [0, 1].
#[inline]
pub fn linear_crossing(d0: f32, d1: f32) -> f32 {
    let t = d0 / (d0 - d1);
    if t.is_nan() {
        0.5
    } else {
        t.clamp(0.0, 1.0)
    }
}

/// Whether two `f32` offsets of opposite class give the crossing between them to `f32`
/// precision: their span `|d0 − d1|` = `|d0| + |d1|` lies in [2^-100, 2^127). Below, both
/// offsets are tiny, and rounding to `f32` (or [`Iso::offset`]'s clamp to `±f32::MIN_POSITIVE`,
/// which keeps a sign) has changed their ratio; at or above, one is infinite or their difference
/// overflows. A single offset rounded off next to an ordinary one moves the crossing by less than
/// 2^-100 of the edge. One test per vertex, on a difference the crossing computes anyway.
#[inline(always)]
pub fn offsets_are_faithful(d0: f32, d1: f32) -> bool {
    const LO: f32 = f32::from_bits((127 - 100) << 23); // 2^-100
    const HI: f32 = f32::from_bits((127 + 127) << 23); // 2^127
    let span = (d0 - d1).abs();
    (LO..HI).contains(&span)
}

/// [`linear_crossing`] of the unrounded offsets ([`Iso::exact_offset`]) of two values, in `f64`:
/// for samples whose `f32` offsets are not [faithful](offsets_are_faithful), as VTK interpolates
/// in double. A difference past `f64`'s range is halved first.
#[inline]
pub fn exact_crossing(d0: f64, d1: f64) -> f32 {
    let span = d0 - d1;
    let t = if span.is_finite() { d0 / span } else { (d0 * 0.5) / (d0 * 0.5 - d1 * 0.5) };
    if t.is_nan() {
        0.5
    } else {
        t.clamp(0.0, 1.0) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_sign_is_exact() {
        let iso = Iso::below(1e-300);
        assert!(iso.offset(0.0) < 0.0, "0 < 1e-300 must be inside");
        assert_eq!(Iso::below(5.0).offset(5.0), 0.0, "ties are outside");
        assert!(!(Iso::below(5.0).offset(5.0) < 0.0));
        let big = 16_777_217.0; // not representable in f32
        assert!(Iso::below(big).offset(16_777_216.0) < 0.0);
        assert!(Iso::below(big).offset(16_777_218.0) > 0.0);
        assert!(Iso::above(3.0).offset(4.0) < 0.0);
        assert_eq!(Iso::above(3.0).offset(3.0), 0.0);
    }

    /// `narrow` (a select) against the branch it replaced, on every class of `f64`: signed zeros,
    /// NaN, infinities, values rounding to `f32` subnormals or zero, both sides of ±MIN_POSITIVE,
    /// and ordinary and huge values, bit for bit.
    #[test]
    fn narrow_keeps_negatives_negative_bit_for_bit() {
        let branch = |d: f64| {
            let f = d as f32;
            if d < 0.0 {
                f.min(-f32::MIN_POSITIVE)
            } else {
                f
            }
        };
        let m = f32::MIN_POSITIVE as f64;
        let mut cases = vec![0.0, -0.0, f64::NAN, -f64::NAN, f64::INFINITY, -f64::INFINITY, 1e-300, -1e-300];
        for x in [m, m / 2.0, m * 2.0, m / 3.0, 1e-45, 1.0, 0.1, 3.4e38, 1e39, 1e300, f64::MIN_POSITIVE] {
            cases.extend([x, -x, x * (1.0 + f64::EPSILON), -x * (1.0 - f64::EPSILON / 2.0)]);
        }
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..100_000 {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            cases.push(f64::from_bits(state));
        }
        for d in cases {
            assert_eq!(narrow(d).to_bits(), branch(d).to_bits(), "{d:e}");
            if d < 0.0 {
                assert!(narrow(d) < 0.0, "{d:e} stays inside");
            }
        }
    }

    #[test]
    fn linear_crossing_is_clamped() {
        assert_eq!(linear_crossing(-1.0, 1.0), 0.5);
        assert_eq!(linear_crossing(-1.0, 3.0), 0.25);
        assert_eq!(linear_crossing(-f32::INFINITY, f32::INFINITY), 0.5);
    }

    /// Offsets of values beyond `f32`'s range or below its normal range are not faithful, and the
    /// exact crossing of their values is the true one; ordinary offsets are faithful.
    #[test]
    fn crossings_of_values_f32_cannot_hold_are_exact() {
        let iso = Iso::below(0.0);
        for (a, b, t) in [(-1e300, 3e300, 0.25), (-1e-300, 3e-300, 0.25), (-4e38, 1.0, 1.0), (-1e-38, 3e-38, 0.25)] {
            let (d0, d1) = (iso.offset(a), iso.offset(b));
            assert!(!offsets_are_faithful(d0, d1), "{a} {b}");
            assert!((exact_crossing(iso.exact_offset(a), iso.exact_offset(b)) - t).abs() < 1e-6, "{a} {b}");
        }
        assert_eq!(exact_crossing(-f64::MAX, f64::MAX), 0.5);
        // A cell's offsets keep their ratios when scaled, and equal `offset`'s in f32's range.
        let cell = [-1.0, 3.0, 0.0, 2.0, -0.5, 1.0, 4.0, -2.0];
        let plain = iso.cell_offsets(cell);
        assert_eq!(plain, cell.map(|v| iso.offset(v)));
        for scale in [996, -996, -1030, 130, -130].map(|e| 2f64.powi(e / 2) * 2f64.powi(e - e / 2)) {
            let scaled = iso.cell_offsets(cell.map(|v| v * scale));
            let ratio = scaled[1] / plain[1];
            assert!(ratio.is_finite() && ratio > 0.0, "{scale}: {scaled:?}");
            for (s, p) in scaled.iter().zip(plain) {
                assert_eq!(*s, p * ratio, "{scale}: {scaled:?}");
            }
        }
        assert_eq!(exact_crossing(-2.0, 0.0), 1.0, "a tie at the far end");
        assert!(offsets_are_faithful(iso.offset(-1.0), iso.offset(3.0)));
        assert!(offsets_are_faithful(-1.0e38, 1.0e-37));
        assert!(offsets_are_faithful(-1.0, 0.0), "a tie next to an ordinary offset");
        assert!(!offsets_are_faithful(-f32::MIN_POSITIVE, 1.0e-39), "a clamped offset and a subnormal");
        assert!(!offsets_are_faithful(1.0, f32::INFINITY));
        assert!(!offsets_are_faithful(f32::NEG_INFINITY, f32::INFINITY));
        assert!(!offsets_are_faithful(3.2894996e38, -3.3813194e38), "their difference overflows f32");
        let big = Iso::below(1e37);
        let t = exact_crossing(big.exact_offset(3.2894996e38), big.exact_offset(-3.3813194e38));
        assert!((t as f64 - (3.2894996e38 - 1e37) / (3.2894996e38 + 3.3813194e38)).abs() < 1e-6);
    }
}
