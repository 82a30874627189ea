//! Exact point–triangle distances (f64), and a [`TriangleIndex`] answering "which triangle of a
//! mesh is nearest, and how far": the voxelizer's narrow band and the Hausdorff distances of
//! the mesh reports.

use glam::DVec3;

use super::bvh::Bvh;
use super::Mesh;
use crate::math::Aabb;

/// A mesh's triangles (f64) and their hierarchy.
pub struct TriangleIndex {
    /// The triangles, in the mesh's order (quads split).
    pub triangles: Vec<[DVec3; 3]>,
    /// The hierarchy over `triangles`.
    pub bvh: Bvh,
}

impl TriangleIndex {
    /// Indexes the polygons of `mesh`.
    pub fn new(mesh: &Mesh) -> Self {
        let triangles: Vec<[DVec3; 3]> = mesh
            .all_triangles()
            .map(|t| t.map(|v| DVec3::from_array(mesh.positions[v as usize].map(f64::from))))
            .collect();
        Self::from_triangles(triangles)
    }

    /// Indexes `triangles`.
    pub fn from_triangles(triangles: Vec<[DVec3; 3]>) -> Self {
        let bvh = Bvh::build(&boxes(&triangles));
        TriangleIndex { triangles, bvh }
    }

    /// The nearest triangle to `p` and the distance to it (`None` for no triangle).
    pub fn nearest(&self, p: DVec3) -> Option<(u32, f64)> {
        self.bvh
            .nearest(p.to_array(), f64::INFINITY, &mut |i| distance_squared(p, &self.triangles[i as usize]))
            .map(|(i, d2)| (i, d2.sqrt()))
    }
}

/// The boxes of `triangles`.
pub fn boxes(triangles: &[[DVec3; 3]]) -> Vec<Aabb> {
    triangles
        .iter()
        .map(|t| {
            let mut b = Aabb::EMPTY;
            t.iter().for_each(|p| b.add(p.to_array()));
            b
        })
        .collect()
}

/// The point of triangle `t` nearest to `p` (Ericson, *Real-Time Collision Detection* §5.1.5:
/// the Voronoi regions of the vertices, edges and face). Degenerate triangles are handled: the
/// regions' tests fall through to an edge or a vertex.
pub fn closest_point(p: DVec3, t: &[DVec3; 3]) -> DVec3 {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if denom.abs() <= f64::MIN_POSITIVE || !denom.is_finite() {
        // A degenerate triangle whose tests all failed (collinear corners): its edges' nearest.
        return [(a, b), (b, c), (c, a)]
            .map(|(u, v)| segment_closest(p, u, v))
            .into_iter()
            .min_by(|x, y| (*x - p).length_squared().total_cmp(&(*y - p).length_squared()))
            .unwrap_or(a);
    }
    a + ab * (vb / denom) + ac * (vc / denom)
}

/// Squared distance from `p` to triangle `t`.
#[inline]
pub fn distance_squared(p: DVec3, t: &[DVec3; 3]) -> f64 {
    (closest_point(p, t) - p).length_squared()
}

fn segment_closest(p: DVec3, u: DVec3, v: DVec3) -> DVec3 {
    let d = v - u;
    let len2 = d.length_squared();
    if len2 == 0.0 {
        return u;
    }
    u + d * ((p - u).dot(d) / len2).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Independent check: the minimum over a fine barycentric sampling of the triangle.
    fn sampled_d2(p: DVec3, t: &[DVec3; 3]) -> f64 {
        let n = 400;
        let mut best = f64::INFINITY;
        for i in 0..=n {
            for j in 0..=n - i {
                let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                let q = t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v;
                best = best.min((q - p).length_squared());
            }
        }
        best
    }

    #[test]
    fn every_voronoi_region_agrees_with_sampling() {
        let t = [DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.1, 0.0), DVec3::new(0.2, 0.9, 0.3)];
        let mut worst = 0.0f64;
        for k in 0..200 {
            let g = [0.618_033_99, 0.754_877_67, 0.569_840_29].map(|g| (k as f64 * g).fract() * 3.0 - 1.0);
            let p = DVec3::from_array(g);
            let exact = distance_squared(p, &t).sqrt();
            let sampled = sampled_d2(p, &t).sqrt();
            // Sampling can only overestimate, by at most the sampling step.
            assert!(exact <= sampled + 1e-12, "{p}: {exact} > {sampled}");
            worst = worst.max(sampled - exact);
        }
        assert!(worst < 4e-3, "{worst}");
    }

    #[test]
    fn degenerate_triangles_give_their_segment_distance() {
        let line = [DVec3::ZERO, DVec3::X, DVec3::X * 2.0];
        assert!((distance_squared(DVec3::new(1.5, 1.0, 0.0), &line) - 1.0).abs() < 1e-12);
        let point = [DVec3::ONE; 3];
        assert!((distance_squared(DVec3::ZERO, &point) - 3.0).abs() < 1e-12);
    }
}
