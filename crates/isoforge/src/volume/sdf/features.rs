//! How well a mesh keeps an analytic shape's sharp features ([`Features`]), in cell widths h:
//! the measurement of issue 45 (the `feature_error` tool, `tests/sharp_features.rs`).

use glam::DVec3;

use super::sharp::Features;
use crate::math::{Aabb, Vec3};
use crate::mesh::bvh::Bvh;
use crate::mesh::Mesh;
use crate::volume::Field;

/// Feature errors of a mesh, in cell widths; `None` where the shape has no such feature (or the
/// mesh no vertex).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FeatureErrors {
    /// Max over the corners of the distance to the nearest mesh vertex.
    pub corner: Option<f64>,
    /// The same over the convex corners only ([`super::sharp::Corner::convex`]).
    pub convex_corner: Option<f64>,
    /// Max over the crease sample points of the distance to the nearest point of a mesh edge.
    pub crease: Option<f64>,
    /// Max over the vertices of |field(vertex)|.
    pub field: Option<f64>,
}

fn point_box(p: DVec3) -> Aabb {
    Aabb { min: p.to_array(), max: p.to_array() }
}

/// Squared distance from `p` to the segment `a b`.
fn segment_d2(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 { ((p - a).dot(ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    (a + ab * t - p).length_squared()
}

/// Measures `mesh` against `features` and `field` (iso 0), with cell width `h` (world units).
pub fn measure<F: Field + ?Sized>(mesh: &Mesh, features: &Features, field: &F, h: f64) -> FeatureErrors {
    let pos: Vec<DVec3> = mesh.positions.iter().map(|p| DVec3::from_array(p.map(f64::from))).collect();
    if pos.is_empty() {
        return FeatureErrors::default();
    }
    let vertices = Bvh::build(&pos.iter().map(|&p| point_box(p)).collect::<Vec<_>>());
    let nearest_vertex = |c: Vec3| -> f64 {
        let c = c.as_dvec3();
        let found = vertices.nearest(c.to_array(), f64::INFINITY, &mut |i| (pos[i as usize] - c).length_squared());
        found.map_or(f64::INFINITY, |(_, d2)| d2.sqrt()) / h
    };
    let max = |it: &mut dyn Iterator<Item = f64>| it.fold(None, |m: Option<f64>, d| Some(m.map_or(d, |m| m.max(d))));
    let corner = max(&mut features.corners.iter().map(|c| nearest_vertex(c.point)));
    let convex_corner = max(&mut features.corners.iter().filter(|c| c.convex).map(|c| nearest_vertex(c.point)));

    let mut edges: Vec<[u32; 2]> = mesh
        .all_triangles()
        .flat_map(|t| [0, 1, 2].map(|k| [t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3])]))
        .collect();
    edges.sort_unstable();
    edges.dedup();
    let boxes: Vec<Aabb> = edges
        .iter()
        .map(|&[a, b]| {
            let (a, b) = (pos[a as usize], pos[b as usize]);
            Aabb { min: a.min(b).to_array(), max: a.max(b).to_array() }
        })
        .collect();
    let edge_bvh = Bvh::build(&boxes);
    let crease = max(&mut features.crease_points.iter().map(|&p| {
        let p = p.as_dvec3();
        let found = edge_bvh.nearest(p.to_array(), f64::INFINITY, &mut |i| {
            let [a, b] = edges[i as usize];
            segment_d2(p, pos[a as usize], pos[b as usize])
        });
        found.map_or(f64::INFINITY, |(_, d2)| d2.sqrt()) / h
    }));
    let field = max(&mut mesh.positions.iter().map(|&p| f64::from(field.value(Vec3::from_array(p)).abs()) / h));
    FeatureErrors { corner, convex_corner, crease, field }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::sdf::sharp::{Corner, Features};

    #[test]
    fn distances_to_vertices_and_edges() {
        let mesh = Mesh {
            positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            triangles: vec![[0, 1, 2]],
            ..Default::default()
        };
        let features = Features {
            corners: vec![
                Corner { point: Vec3::new(0.0, 0.0, 0.5), convex: true },
                Corner { point: Vec3::new(1.0, 0.0, 2.0), convex: false },
            ],
            crease_points: vec![Vec3::new(0.5, -0.25, 0.0), Vec3::new(0.5, 0.5, 0.0)],
        };
        let e = measure(&mesh, &features, &|p: Vec3| p.z - 0.1, 0.5);
        assert_eq!(e.convex_corner, Some(1.0));
        assert_eq!(e.corner, Some(4.0));
        assert_eq!(e.crease, Some(0.5));
        assert!((e.field.unwrap() - 0.2).abs() < 1e-7);
        assert_eq!(measure(&Mesh::default(), &features, &|p: Vec3| p.z, 1.0), FeatureErrors::default());
    }
}
