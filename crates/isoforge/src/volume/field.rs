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
