//! Test shapes for the mesh stages: surfaces extracted from binary (0/1) volumes, whose
//! marching-cubes meshes are the staircases smoothing and decimation are for.

use crate::grid::{AnyGrid, DenseGrid, Lattice};
use crate::mesh::Mesh;
use crate::pipeline::{extract_grid, Options};
use crate::volume::Iso;

/// A solid given by its signed distance (negative inside) in index coordinates.
pub type Distance = fn([f64; 3]) -> f64;

/// Sphere of radius 11 about the centre of a 32³ lattice.
pub fn sphere(p: [f64; 3]) -> f64 {
    let c = 15.5;
    ((p[0] - c).powi(2) + (p[1] - c).powi(2) + (p[2] - c).powi(2)).sqrt() - 11.0
}

/// Torus about z through the centre of a 32³ lattice: radii 9 and 4.
pub fn torus(p: [f64; 3]) -> f64 {
    let c = 15.5;
    let ring = ((p[0] - c).powi(2) + (p[1] - c).powi(2)).sqrt() - 9.0;
    (ring * ring + (p[2] - c).powi(2)).sqrt() - 4.0
}

/// Two tori side by side along x, overlapping: a genus-2 solid in a 48×32×32 lattice.
pub fn double_torus(p: [f64; 3]) -> f64 {
    let one = |cx: f64| {
        let ring = ((p[0] - cx).powi(2) + (p[1] - 15.5).powi(2)).sqrt() - 8.0;
        (ring * ring + (p[2] - 15.5).powi(2)).sqrt() - 3.5
    };
    one(15.5).min(one(31.5))
}

/// The surface of the points inside `shape` in a lattice of `dims` points (spacing 1, origin 0),
/// marched at 0.5 on the 0/1 indicator: a closed staircase.
pub fn binary(dims: [u32; 3], shape: Distance) -> Mesh {
    let lattice = Lattice::new(dims).expect("lattice");
    let g = DenseGrid::from_fn(lattice, |ijk| u8::from(shape(ijk.map(f64::from)) < 0.0));
    let mut mesh = extract_grid(&AnyGrid::U8(g), Iso::above(0.5), &Options::default(), None).expect("extract").mesh;
    mesh.triangulate();
    mesh
}

/// Mean over the vertices of the distance to the analytic surface.
pub fn mean_distance(mesh: &Mesh, shape: Distance) -> f64 {
    let sum: f64 = mesh.positions.iter().map(|p| shape(p.map(f64::from)).abs()).sum();
    sum / mesh.positions.len().max(1) as f64
}
