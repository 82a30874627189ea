//! How far two meshes are apart: the Hausdorff distance measured from each one's vertices to the
//! other's surface (exact point–triangle distances; vertices, not every surface point, so it is
//! a lower bound that is tight for meshes finer than their distance).

use glam::DVec3;

use crate::mesh::distance::TriangleIndex;
use crate::mesh::Mesh;

/// Both one-sided distances from vertices to surfaces, in world units.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Hausdorff {
    /// The largest distance from a vertex of the first mesh to the second's surface.
    pub forward: f64,
    /// The largest distance from a vertex of the second mesh to the first's surface.
    pub backward: f64,
    /// The mean of both sides' vertex distances.
    pub mean: f64,
}

impl Hausdorff {
    /// The symmetric distance: the larger side.
    pub fn max(&self) -> f64 {
        self.forward.max(self.backward)
    }
}

/// The vertex-to-surface Hausdorff distance between `a` and `b` (0 when either has no polygon).
pub fn hausdorff(a: &Mesh, b: &Mesh) -> Hausdorff {
    if a.is_empty() || b.is_empty() {
        return Hausdorff::default();
    }
    let (ia, ib) = (TriangleIndex::new(a), TriangleIndex::new(b));
    let (fmax, fsum, fn_) = vertex_distances(a, &ib);
    let (bmax, bsum, bn) = vertex_distances(b, &ia);
    Hausdorff { forward: fmax, backward: bmax, mean: (fsum + bsum) / (fn_ + bn).max(1) as f64 }
}

/// (max, sum, count) of the distances from the used vertices of `from` to `to`.
fn vertex_distances(from: &Mesh, to: &TriangleIndex) -> (f64, f64, usize) {
    let mut used = vec![false; from.positions.len()];
    for p in from.polygons() {
        p.iter().for_each(|&v| used[v as usize] = true);
    }
    let points: Vec<DVec3> = from
        .positions
        .iter()
        .zip(&used)
        .filter(|(_, &u)| u)
        .map(|(p, _)| DVec3::from_array(p.map(f64::from)))
        .collect();
    let distance = |p: &DVec3| to.nearest(*p).map_or(0.0, |(_, d)| d);
    #[cfg(feature = "parallel")]
    let d: Vec<f64> = {
        use rayon::prelude::*;
        points.par_iter().map(distance).collect()
    };
    #[cfg(not(feature = "parallel"))]
    let d: Vec<f64> = points.iter().map(distance).collect();
    (d.iter().cloned().fold(0.0, f64::max), d.iter().sum(), d.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(z: f32, size: f32) -> Mesh {
        Mesh {
            positions: vec![[0.0, 0.0, z], [size, 0.0, z], [size, size, z], [0.0, size, z]],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            ..Mesh::default()
        }
    }

    #[test]
    fn parallel_squares_are_their_gap_apart_and_a_larger_one_farther_back() {
        let h = hausdorff(&square(0.0, 1.0), &square(0.5, 1.0));
        assert!((h.forward - 0.5).abs() < 1e-7 && (h.backward - 0.5).abs() < 1e-7, "{h:?}");
        // The bigger square's far corner (2, 2, 0) is √2 from the small one's corner (1, 1).
        let h = hausdorff(&square(0.0, 1.0), &square(0.0, 2.0));
        assert!(h.forward < 1e-7);
        assert!((h.backward - 2f64.sqrt()).abs() < 1e-6, "{h:?}");
        assert_eq!(hausdorff(&Mesh::default(), &square(0.0, 1.0)), Hausdorff::default());
    }
}
