//! Generalised winding numbers (Jacobson et al. 2013) evaluated fast (Barill et al. 2018): exact
//! solid angles for triangles near the query, and one dipole per hierarchy node far from it.
//!
//! The winding number of a closed, outward-oriented surface is 1 inside and 0 outside; with holes
//! it varies smoothly between them, so `w > 0.5` stays a good inside test away from the holes.

use std::f64::consts::PI;

use glam::DVec3;

use crate::mesh::bvh::Bvh;

/// How far, in node radii, a node must be from the query for its dipole to stand for its
/// triangles (Barill et al. use 2; the error of the first-order term falls as `(r / d)²`).
const ACCURACY: f64 = 2.5;

/// A triangle soup's winding number, ready to evaluate anywhere.
pub struct Winding<'a> {
    triangles: &'a [[DVec3; 3]],
    bvh: &'a Bvh,
    /// Per node: the sum of its triangles' area vectors (½ (b − a) × (c − a)).
    area: Vec<DVec3>,
    /// Per node: the area-weighted centre of its triangles.
    centre: Vec<DVec3>,
    /// Per node: the squared radius of a ball around `centre` holding its triangles.
    radius2: Vec<f64>,
}

impl<'a> Winding<'a> {
    /// The per-node sums of `triangles` over `bvh` (built over the same triangles' boxes).
    pub fn new(triangles: &'a [[DVec3; 3]], bvh: &'a Bvh) -> Self {
        let n = bvh.nodes().len();
        let (mut area, mut centre, mut radius2) = (vec![DVec3::ZERO; n], vec![DVec3::ZERO; n], vec![0.0; n]);
        for (k, node) in bvh.nodes().iter().enumerate() {
            let (mut sum, mut weighted, mut weight) = (DVec3::ZERO, DVec3::ZERO, 0.0);
            for &i in bvh.items_below(k) {
                let [a, b, c] = triangles[i as usize];
                let v = 0.5 * (b - a).cross(c - a);
                let w = v.length();
                sum += v;
                weighted += w * (a + b + c) / 3.0;
                weight += w;
            }
            let lo = DVec3::from_array(node.bounds.min);
            let hi = DVec3::from_array(node.bounds.max);
            let mid = if weight > 0.0 { weighted / weight } else { 0.5 * (lo + hi) };
            // The farthest box corner bounds every triangle's distance from the centre.
            let far = DVec3::new(
                (mid.x - lo.x).abs().max((hi.x - mid.x).abs()),
                (mid.y - lo.y).abs().max((hi.y - mid.y).abs()),
                (mid.z - lo.z).abs().max((hi.z - mid.z).abs()),
            );
            area[k] = sum;
            centre[k] = mid;
            radius2[k] = far.length_squared();
        }
        Winding { triangles, bvh, area, centre, radius2 }
    }

    /// The winding number at `q`.
    pub fn at(&self, q: DVec3) -> f64 {
        if self.bvh.nodes().is_empty() {
            return 0.0;
        }
        let mut sum = 0.0;
        let mut stack = [0usize; 128];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let n = stack[top];
            let d = self.centre[n] - q;
            let d2 = d.length_squared();
            if d2 > ACCURACY * ACCURACY * self.radius2[n] {
                // The dipole: Ω ≈ (c − q)·A / |c − q|³.
                sum += d.dot(self.area[n]) / (d2 * d2.sqrt());
                continue;
            }
            if self.bvh.nodes()[n].is_leaf() {
                for &i in self.bvh.items(n) {
                    sum += solid_angle(&self.triangles[i as usize], q);
                }
                continue;
            }
            let [a, b] = self.bvh.children(n);
            if top + 2 > stack.len() {
                // Deeper than any balanced tree of 2⁶⁴ items: evaluate the rest exactly.
                for &i in self.bvh.items_below(n) {
                    sum += solid_angle(&self.triangles[i as usize], q);
                }
                continue;
            }
            stack[top] = a;
            stack[top + 1] = b;
            top += 2;
        }
        sum / (4.0 * PI)
    }
}

/// The signed solid angle of triangle `t` seen from `q` (Van Oosterom and Strackee 1983):
/// positive when `q` is behind the triangle (on the side its counter-clockwise normal points
/// away from), so an outward-oriented closed surface sums to 4π inside.
pub fn solid_angle(t: &[DVec3; 3], q: DVec3) -> f64 {
    let (a, b, c) = (t[0] - q, t[1] - q, t[2] - q);
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let det = a.dot(b.cross(c));
    let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    2.0 * det.atan2(den)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::distance::boxes;

    /// An octahedron (outward), subdivided `n` times onto the unit sphere.
    pub(crate) fn sphere(n: usize) -> Vec<[DVec3; 3]> {
        let v = [DVec3::X, DVec3::NEG_X, DVec3::Y, DVec3::NEG_Y, DVec3::Z, DVec3::NEG_Z];
        let mut tris: Vec<[DVec3; 3]> = Vec::new();
        for (x, y, z) in [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)] {
            tris.push([v[x], v[y], v[z]]);
        }
        for _ in 0..n {
            tris = tris
                .iter()
                .flat_map(|&[a, b, c]| {
                    let (ab, bc, ca) = ((a + b).normalize(), (b + c).normalize(), (c + a).normalize());
                    [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
                })
                .collect();
        }
        tris
    }

    #[test]
    fn a_closed_sphere_winds_once_inside_and_never_outside() {
        let tris = sphere(4);
        let bvh = Bvh::build(&boxes(&tris));
        let w = Winding::new(&tris, &bvh);
        for k in 0..300 {
            let g = [0.618_033_99, 0.754_877_67, 0.569_840_29].map(|g| (k as f64 * g).fract() * 2.0 - 1.0);
            let q = DVec3::from_array(g) * 1.6;
            let r = q.length();
            if (r - 1.0).abs() < 0.05 {
                continue;
            }
            let want = if r < 1.0 { 1.0 } else { 0.0 };
            // The polyhedron is inscribed in the sphere: points just inside r < 1 may be outside it.
            if r < 1.0 && r > 0.98 {
                continue;
            }
            let fast = w.at(q);
            let exact: f64 = tris.iter().map(|t| solid_angle(t, q)).sum::<f64>() / (4.0 * PI);
            assert!((exact - want).abs() < 1e-9, "{q}: exact {exact}");
            assert!((fast - want).abs() < 0.02, "{q}: fast {fast}");
        }
    }

    #[test]
    fn a_reversed_triangle_negates_its_solid_angle() {
        let t = [DVec3::X, DVec3::Y, DVec3::Z];
        let q = DVec3::ZERO;
        let r = [t[0], t[2], t[1]];
        assert!(solid_angle(&t, q) > 0.0);
        assert!((solid_angle(&t, q) + solid_angle(&r, q)).abs() < 1e-15);
        // One eighth of the sphere.
        assert!((solid_angle(&t, q) - PI / 2.0).abs() < 1e-12);
    }
}
