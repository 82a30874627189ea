//! The three sample fields of the classic marching-cubes demo (Bloyd's program accompanying the
//! Bourke article, design document `004`), on the unit cube, with their moving sources.
//!
//! All three are densities around their sources, so their natural inside is *above* iso
//! ([`Inside::Above`](super::Inside::Above)); the demo's iso is [`CLASSIC_ISO`].

use crate::math::Vec3;
use crate::volume::Field;

/// The iso value of the classic demo.
pub const CLASSIC_ISO: f64 = 48.0;

/// Source positions at animation time `t`: three points that start at the cube's centre and move
/// along x, y and z by the factor `1 + sin t`.
pub fn sources_at(t: f32) -> [Vec3; 3] {
    let f = 1.0 + t.sin();
    [Vec3::new(0.5 * f, 0.5, 0.5), Vec3::new(0.5, 0.5 * f, 0.5), Vec3::new(0.5, 0.5, 0.5 * f)]
}

/// Charges around three points: `Σ qᵢ / |p − sᵢ|²` (the demo's metaballs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChargePoints {
    /// Source points.
    pub sources: [Vec3; 3],
    /// Charges.
    pub charges: [f32; 3],
}

impl ChargePoints {
    /// The demo's charges (0.5, 1, 1.5) at animation time `t`.
    pub fn at_time(t: f32) -> Self {
        ChargePoints { sources: sources_at(t), charges: [0.5, 1.0, 1.5] }
    }
}

impl Field for ChargePoints {
    #[inline]
    fn value(&self, p: Vec3) -> f32 {
        self.sources.iter().zip(self.charges).map(|(s, q)| q / (p - *s).length_squared()).sum()
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        // d/dp q / r² = −2 q (p − s) / r⁴
        self.sources
            .iter()
            .zip(self.charges)
            .map(|(s, q)| {
                let d = p - *s;
                let r2 = d.length_squared();
                d * (-2.0 * q / (r2 * r2))
            })
            .sum()
    }
}

/// Charges around three lines: through source 0 along z, source 1 along y, source 2 along x.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChargeLines {
    /// One point on each line.
    pub sources: [Vec3; 3],
    /// Charges.
    pub charges: [f32; 3],
}

impl ChargeLines {
    /// The demo's charges (0.5, 0.75, 1) at animation time `t`.
    pub fn at_time(t: f32) -> Self {
        ChargeLines { sources: sources_at(t), charges: [0.5, 0.75, 1.0] }
    }
}

impl Field for ChargeLines {
    #[inline]
    fn value(&self, p: Vec3) -> f32 {
        let [a, b, c] = self.sources;
        let [qa, qb, qc] = self.charges;
        let d = |u: f32, v: f32| u * u + v * v;
        qa / d(p.x - a.x, p.y - a.y) + qb / d(p.x - b.x, p.z - b.z) + qc / d(p.y - c.y, p.z - c.z)
    }
}

/// A radial height field: `√((x − ½)² + (y − ½)²) + height − z` (a cone around the vertical
/// axis at iso `height`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeightField {
    /// Offset added to the radial distance (the demo's 48).
    pub height: f32,
}

impl Default for HeightField {
    fn default() -> Self {
        HeightField { height: CLASSIC_ISO as f32 }
    }
}

impl Field for HeightField {
    #[inline]
    fn value(&self, p: Vec3) -> f32 {
        ((0.5 - p.x) * (0.5 - p.x) + (0.5 - p.y) * (0.5 - p.y)).sqrt() + self.height - p.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::central_difference;

    #[test]
    fn charge_gradient_matches_central_differences() {
        let f = ChargePoints::at_time(0.5);
        let p = Vec3::new(0.2, 0.3, 0.4);
        let (a, b) = (f.gradient(p), central_difference(&f, p));
        assert!((a - b).length() < 1e-2 * a.length(), "{a} vs {b}");
    }

    #[test]
    fn sources_move_apart() {
        let s = sources_at(0.0);
        assert_eq!(s[0], s[1]);
        let s = sources_at(1.0);
        assert!(s[0].distance(s[1]) > 0.3);
    }
}
