use crate::math::Vec3;
use crate::volume::Field;

/// Union of two signed distance fields: `min(a, b)`.
#[derive(Debug, Clone, Copy)]
pub struct Union<A, B>(pub A, pub B);

/// Intersection: `max(a, b)`.
#[derive(Debug, Clone, Copy)]
pub struct Intersection<A, B>(pub A, pub B);

/// Difference `a − b`: `max(a, −b)`.
#[derive(Debug, Clone, Copy)]
pub struct Difference<A, B>(pub A, pub B);

/// Smooth union with blend radius `k` (polynomial smooth minimum; `k = 0` is [`Union`]).
#[derive(Debug, Clone, Copy)]
pub struct SmoothUnion<A, B> {
    /// First operand.
    pub a: A,
    /// Second operand.
    pub b: B,
    /// Blend radius in world units.
    pub k: f32,
}

/// The negated field: swaps inside and outside.
#[derive(Debug, Clone, Copy)]
pub struct Negate<F>(pub F);

impl<A: Field, B: Field> Field for Union<A, B> {
    #[inline]
    fn value(&self, p: Vec3) -> f32 {
        self.0.value(p).min(self.1.value(p))
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        if self.0.value(p) <= self.1.value(p) {
            self.0.gradient(p)
        } else {
            self.1.gradient(p)
        }
    }
}

impl<A: Field, B: Field> Field for Intersection<A, B> {
    #[inline]
    fn value(&self, p: Vec3) -> f32 {
        self.0.value(p).max(self.1.value(p))
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        if self.0.value(p) >= self.1.value(p) {
            self.0.gradient(p)
        } else {
            self.1.gradient(p)
        }
    }
}

impl<A: Field, B: Field> Field for Difference<A, B> {
    #[inline]
    fn value(&self, p: Vec3) -> f32 {
        self.0.value(p).max(-self.1.value(p))
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        if self.0.value(p) >= -self.1.value(p) {
            self.0.gradient(p)
        } else {
            -self.1.gradient(p)
        }
    }
}

impl<A: Field, B: Field> Field for SmoothUnion<A, B> {
    #[inline]
    fn value(&self, p: Vec3) -> f32 {
        let (a, b) = (self.a.value(p), self.b.value(p));
        if self.k <= 0.0 {
            return a.min(b);
        }
        let h = (0.5 + 0.5 * (b - a) / self.k).clamp(0.0, 1.0);
        b + (a - b) * h - self.k * h * (1.0 - h)
    }
}

impl<F: Field> Field for Negate<F> {
    #[inline]
    fn value(&self, p: Vec3) -> f32 {
        -self.0.value(p)
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        -self.0.gradient(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::sdf::Sphere;

    #[test]
    fn csg_values() {
        let a = Sphere { center: Vec3::new(-0.5, 0.0, 0.0), radius: 1.0 };
        let b = Sphere { center: Vec3::new(0.5, 0.0, 0.0), radius: 1.0 };
        let p = Vec3::new(-1.2, 0.0, 0.0); // inside a only
        assert!(Union(a, b).value(p) < 0.0);
        assert!(Intersection(a, b).value(p) > 0.0);
        assert!(Difference(a, b).value(p) < 0.0);
        assert!(Difference(a, b).value(Vec3::ZERO) > 0.0);
        let s = SmoothUnion { a, b, k: 0.3 };
        assert!(s.value(Vec3::ZERO) <= Union(a, b).value(Vec3::ZERO));
        assert_eq!(SmoothUnion { a, b, k: 0.0 }.value(p), Union(a, b).value(p));
        assert_eq!(Negate(a).value(p), -a.value(p));
    }
}
