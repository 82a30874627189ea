use crate::math::Vec3;

/// A continuous scalar function of world position: what users implement. Closures are fields.
pub trait Field {
    /// The value at world point `p`.
    fn value(&self, p: Vec3) -> f32;

    /// The gradient at `p`; central differences unless the field knows better.
    fn gradient(&self, p: Vec3) -> Vec3 {
        central_difference(self, p)
    }

    /// A bound L on how fast the value changes, |f(p) − f(q)| ≤ L·|p − q| (world units), when the
    /// field knows one (1 for a signed distance): sparse sampling then skips every box the
    /// surface cannot reach ([`SparseGrid::from_field`](crate::grid::SparseGrid::from_field)).
    fn lipschitz(&self) -> Option<f64> {
        None
    }

    /// Bounds `(min, max)` of the value over the world box `lo ..= hi`, when the field can tell
    /// (interval arithmetic): sparse sampling skips a box whose bounds exclude the iso, and
    /// walkers skip its cells. They must hold for the values [`value`](Field::value) computes,
    /// rounding included (widen them by a few ulps of the values' size).
    fn bounds(&self, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
        let _ = (lo, hi);
        None
    }
}

/// `(min, max)` widened by `REL` of their size plus `ABS`: room for `f32` rounding in a field's
/// [`Field::bounds`] (its computed values may differ from the exact ones by a few ulps).
pub fn widened((lo, hi): (f32, f32)) -> (f32, f32) {
    const REL: f32 = 1e-5;
    const ABS: f32 = 1e-6;
    let pad = REL * lo.abs().max(hi.abs()) + ABS;
    (lo - pad, hi + pad)
}

impl<F: Fn(Vec3) -> f32> Field for F {
    #[inline]
    fn value(&self, p: Vec3) -> f32 {
        self(p)
    }
}

/// Relative step of [`central_difference`]: `h = STEP · max(1, |p|)` keeps f32 quotients accurate.
const CENTRAL_DIFFERENCE_STEP: f32 = 1e-3;

/// The gradient of `f` at `p` by central differences.
pub fn central_difference<F: Field + ?Sized>(f: &F, p: Vec3) -> Vec3 {
    let h = CENTRAL_DIFFERENCE_STEP * p.abs().max_element().max(1.0);
    let d = |e: Vec3| f.value(p + e * h) - f.value(p - e * h);
    Vec3::new(d(Vec3::X), d(Vec3::Y), d(Vec3::Z)) / (2.0 * h)
}

/// Receives a concrete field type from a runtime choice (the enum is matched once, then
/// everything below is monomorphised for the field).
pub trait FieldVisitor {
    /// What the visit returns.
    type Output;
    /// Called with the concrete field.
    fn visit<F: Field + Clone + Sync>(self, field: &F) -> Self::Output;
}
