//! Extended marching cubes \[Kobbelt01\]: marching cubes with a feature vertex in the cells where
//! the surface bends sharply, so corners and creases are kept instead of cut.
//!
//! In: a cell's MC33 loops and the Hermite data of their crossings ([`Cell::hermite`]: exact
//! normals for fields, central differences for grids). Out: MC33's triangles, except that a loop
//! whose normals spread wider than the feature angle is a fan from a vertex fitted to its tangent
//! planes, and fans of neighbouring feature loops are flipped to meet vertex to vertex (the
//! construction, and why it keeps MC33's guarantees, is in the `fans` module).

use super::fans::LoopFans;
use super::{DualContouring, Extractor};
use crate::extract::Cell;

/// The feature angle [`ExtendedMarchingCubes`] uses by default, in degrees: a loop is a feature
/// when two of its crossings' normals are more than this apart. Kobbelt et al. suggest
/// cos θ ≈ 0.9 (25.8°); 30° keeps a sphere of radius 5 cells or more feature-free (neighbouring
/// crossings' normals differ by about a cell width over the radius) and catches every crease of
/// the CSG test shapes.
pub const DEFAULT_FEATURE_ANGLE: f32 = 30.0;

/// Extended marching cubes: MC33's mesh with a feature vertex in each loop whose normals spread
/// wider than [`feature_angle`](ExtendedMarchingCubes::feature_angle), placed at the minimiser of
/// the quadratic error of its tangent planes (SVD with truncation, the mass point where they
/// disagree, kept inside the cell: [`DualContouring::fit`]), and edge flips so that feature
/// vertices of neighbouring cells are joined and creases run continuously.
///
/// **Guarantees**: MC33's — closed (surface inside the lattice), edge- and vertex-manifold,
/// consistently oriented, the components and genus of the trilinear interpolant — because a fan
/// re-triangulates a disk and a flip never doubles an edge. Vertices: MC33's, plus one per
/// feature loop, inside its cell.
///
/// **Limits**: a feature whose planes meet outside the cell is clamped to the cell; a feature
/// vertex far from its loop's plane can fold a triangle (no guard against self-intersections);
/// loops in a tunnel keep MC33's band.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExtendedMarchingCubes {
    /// Degrees between two crossings' normals above which a loop is a feature.
    pub feature_angle: f32,
    /// Relative truncation of the QEF's singular values (see
    /// [`DEFAULT_TRUNCATION`](super::dual_contouring::DEFAULT_TRUNCATION)).
    pub truncation: f32,
}

impl Default for ExtendedMarchingCubes {
    fn default() -> Self {
        ExtendedMarchingCubes {
            feature_angle: DEFAULT_FEATURE_ANGLE,
            truncation: super::dual_contouring::DEFAULT_TRUNCATION,
        }
    }
}

impl ExtendedMarchingCubes {
    fn fans(&self) -> LoopFans {
        LoopFans {
            fit: DualContouring { truncation: self.truncation, ..DualContouring::default() },
            feature_cos: Some(self.feature_angle.to_radians().cos()),
            merge: false,
            quads: false,
        }
    }
}

impl Extractor for ExtendedMarchingCubes {
    const PLACES_VERTICES: bool = true;

    fn place<C: Cell>(&self, cell: &mut C) {
        self.fans().place(cell);
    }

    fn process<C: Cell>(&self, cell: &mut C) {
        self.fans().process(cell);
    }
}
