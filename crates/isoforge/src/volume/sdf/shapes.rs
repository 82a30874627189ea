use crate::math::Vec3;
use crate::volume::{widened, Field};

/// The nearest and farthest distances from `c` to the box `lo ..= hi`.
fn distance_range(c: Vec3, lo: Vec3, hi: Vec3) -> (f32, f32) {
    let near = (c.clamp(lo, hi) - c).length();
    let far = (c - lo).abs().max((c - hi).abs()).length();
    (near, far)
}

/// A sphere: exact signed distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius.
    pub radius: f32,
}

impl Field for Sphere {
    #[inline]
    fn value(&self, p: Vec3) -> f32 {
        (p - self.center).length() - self.radius
    }
    #[inline]
    fn gradient(&self, p: Vec3) -> Vec3 {
        (p - self.center).normalize_or_zero()
    }
    fn lipschitz(&self) -> Option<f64> {
        Some(1.0)
    }
    fn bounds(&self, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
        let (near, far) = distance_range(self.center, lo, hi);
        Some(widened((near - self.radius, far - self.radius)))
    }
}

/// A torus around the z axis through `center`: exact signed distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Torus {
    /// Centre.
    pub center: Vec3,
    /// Distance from the centre to the tube's centre line.
    pub major: f32,
    /// Tube radius.
    pub minor: f32,
}

impl Field for Torus {
    #[inline]
    fn value(&self, p: Vec3) -> f32 {
        let q = p - self.center;
        let ring = (q.x * q.x + q.y * q.y).sqrt() - self.major;
        (ring * ring + q.z * q.z).sqrt() - self.minor
    }
    fn lipschitz(&self) -> Option<f64> {
        Some(1.0)
    }
}

/// An axis-aligned box: exact signed distance (inside too).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cuboid {
    /// Centre.
    pub center: Vec3,
    /// Half the edge lengths.
    pub half: Vec3,
}

impl Field for Cuboid {
    #[inline]
    fn value(&self, p: Vec3) -> f32 {
        let q = (p - self.center).abs() - self.half;
        q.max(Vec3::ZERO).length() + q.max_element().min(0.0)
    }
    fn lipschitz(&self) -> Option<f64> {
        Some(1.0)
    }
}

/// The gyroid `sin ωx cos ωy + sin ωy cos ωz + sin ωz cos ωx` (a triply periodic surface at 0;
/// not a distance), optionally clipped to a ball of radius `clip` around the origin (the larger of
/// the gyroid and the ball's signed distance: the gyroid's inside within the ball).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gyroid {
    /// Angular frequency ω (radians per world unit).
    pub frequency: f32,
    /// Radius of the ball the solid is clipped to, if any.
    pub clip: Option<f32>,
}

impl Gyroid {
    #[inline]
    fn unclipped(&self, p: Vec3) -> f32 {
        let q = p * self.frequency;
        let (s, c) = (Vec3::new(q.x.sin(), q.y.sin(), q.z.sin()), Vec3::new(q.x.cos(), q.y.cos(), q.z.cos()));
        s.x * c.y + s.y * c.z + s.z * c.x
    }
}

impl Field for Gyroid {
    #[inline]
    fn value(&self, p: Vec3) -> f32 {
        let g = self.unclipped(p);
        match self.clip {
            Some(r) => g.max(p.length() - r),
            None => g,
        }
    }
    #[inline]
    fn gradient(&self, p: Vec3) -> Vec3 {
        if let Some(r) = self.clip {
            if p.length() - r > self.unclipped(p) {
                return p.normalize_or_zero();
            }
        }
        let q = p * self.frequency;
        let (s, c) = (Vec3::new(q.x.sin(), q.y.sin(), q.z.sin()), Vec3::new(q.x.cos(), q.y.cos(), q.z.cos()));
        Vec3::new(c.x * c.y - s.z * s.x, c.y * c.z - s.x * s.y, c.z * c.x - s.y * s.z) * self.frequency
    }
    /// Each gradient component is a difference of two products of sines and cosines (at most 2 in
    /// size) times ω: |∇| ≤ 2√3·ω; the ball's distance adds slope 1 at most.
    fn lipschitz(&self) -> Option<f64> {
        Some((2.0 * 3f64.sqrt() * self.frequency as f64).max(1.0))
    }
    /// The gyroid lies in [−3, 3]; clipped, the larger of it and the ball's distance bounds.
    fn bounds(&self, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
        let g = (-3.0f32, 3.0f32);
        Some(match self.clip {
            None => widened(g),
            Some(r) => {
                let (near, far) = distance_range(Vec3::ZERO, lo, hi);
                widened((g.0.max(near - r), g.1.max(far - r)))
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::central_difference;

    #[test]
    fn analytic_gradients_match_central_differences() {
        let g = Gyroid { frequency: 3.0, clip: None };
        let s = Sphere { center: Vec3::new(0.1, 0.2, 0.3), radius: 0.5 };
        for p in [Vec3::new(0.3, -0.7, 0.2), Vec3::new(1.1, 0.4, -0.9)] {
            assert!((g.gradient(p) - central_difference(&g, p)).length() < 1e-2);
            assert!((s.gradient(p) - central_difference(&s, p)).length() < 1e-2);
        }
    }

    #[test]
    fn distances() {
        let b = Cuboid { center: Vec3::ZERO, half: Vec3::splat(1.0) };
        assert_eq!(b.value(Vec3::new(2.0, 0.0, 0.0)), 1.0);
        assert_eq!(b.value(Vec3::ZERO), -1.0);
        let t = Torus { center: Vec3::ZERO, major: 1.0, minor: 0.25 };
        assert!((t.value(Vec3::new(1.0, 0.0, 0.0)) + 0.25).abs() < 1e-6);
        assert!((t.value(Vec3::ZERO) - 0.75).abs() < 1e-6);
    }
}
