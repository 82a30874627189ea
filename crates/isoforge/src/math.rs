//! Small geometry types: `Vec3` for computation, `[f32; 3]` at API boundaries, and [`Aabb`].

pub use glam::Vec3;

/// An axis-aligned box, `min` and `max` inclusive; empty when `min > max` on any axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: [f64; 3],
    /// Upper corner.
    pub max: [f64; 3],
}

impl Aabb {
    /// The empty box: grows to the first point added.
    pub const EMPTY: Aabb = Aabb { min: [f64::INFINITY; 3], max: [f64::NEG_INFINITY; 3] };

    /// Grows the box to contain `p`.
    #[inline]
    pub fn add(&mut self, p: [f64; 3]) {
        for a in 0..3 {
            self.min[a] = self.min[a].min(p[a]);
            self.max[a] = self.max[a].max(p[a]);
        }
    }

    /// True when no point was added.
    pub fn is_empty(&self) -> bool {
        (0..3).any(|a| self.min[a] > self.max[a])
    }

    /// `max - min` per axis (zero for an empty box).
    pub fn size(&self) -> [f64; 3] {
        if self.is_empty() {
            return [0.0; 3];
        }
        [self.max[0] - self.min[0], self.max[1] - self.min[1], self.max[2] - self.min[2]]
    }
}

/// Converts a `[f32; 3]` to `Vec3`.
#[inline]
pub fn v3(p: [f32; 3]) -> Vec3 {
    Vec3::from_array(p)
}
