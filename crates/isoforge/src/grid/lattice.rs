use crate::error::{Error, Result};

/// A regular sampling lattice: `dims` points per axis, `spacing` between them, the world
/// position of point (0, 0, 0) and the world direction of each index axis. Point `ijk` is at
/// `origin + Σₐ direction[a] · spacing[a] · ijk[a]`, x (i) fastest in memory.
///
/// A lattice of `n` points per axis has `n - 1` cells per axis (ranges are half-open).
/// Directions are orthonormal; a left-handed frame (negative determinant) mirrors the lattice,
/// and walkers then reverse the triangle winding so normals still point outward.
#[derive(Debug, Clone, PartialEq)]
pub struct Lattice {
    dims: [u32; 3],
    spacing: [f64; 3],
    origin: [f64; 3],
    direction: [[f64; 3]; 3],
    /// `direction == IDENTITY`, cached: `to_world` runs once per vertex.
    axis_aligned: bool,
    /// The anatomical frame of the world coordinates, when the file says.
    space: Option<WorldSpace>,
}

/// The anatomical frame of world coordinates: where +x, +y, +z point on the patient.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WorldSpace {
    /// +x left, +y posterior, +z superior: DICOM, ITK/MetaImage, most NRRD from DICOM.
    Lps,
    /// +x right, +y anterior, +z superior: NIfTI, FreeSurfer, Slicer's display frame.
    Ras,
}

impl WorldSpace {
    /// The short name (`LPS`, `RAS`).
    pub fn name(self) -> &'static str {
        match self {
            WorldSpace::Lps => "LPS",
            WorldSpace::Ras => "RAS",
        }
    }
}

/// The identity direction matrix (index axes along world axes).
pub const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// How far from orthonormal a direction matrix may be (dot products and lengths).
const ORTHONORMAL_TOLERANCE: f64 = 1e-4;

/// The largest world coordinate a lattice may reach: mesh vertices are `f32`.
const MAX_COORDINATE: f64 = f32::MAX as f64;

/// The smallest spacing: below it `f32` vertices collapse and gradients overflow.
const MIN_SPACING: f64 = f32::MIN_POSITIVE as f64;

impl Lattice {
    /// Largest number of points a lattice may have: linear indices must fit `usize` and `u64`.
    pub const MAX_POINTS: u64 = 1 << 40;

    /// A lattice with unit spacing at the origin.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when a dimension is below 1; [`Error::Limit`] when the point count
    /// overflows [`Lattice::MAX_POINTS`].
    pub fn new(dims: [u32; 3]) -> Result<Self> {
        Self::with_geometry(dims, [1.0; 3], [0.0; 3])
    }

    /// A lattice with the given spacing and origin.
    ///
    /// # Errors
    /// As [`Lattice::new`], and [`Error::InvalidInput`] when a spacing is not finite and positive
    /// (at least `f32::MIN_POSITIVE`), an origin is not finite, or the lattice reaches world
    /// coordinates beyond `f32::MAX` (mesh vertices are `f32`): no lattice, whichever reader
    /// made it, yields non-finite vertices.
    pub fn with_geometry(dims: [u32; 3], spacing: [f64; 3], origin: [f64; 3]) -> Result<Self> {
        if dims.contains(&0) {
            return Err(Error::InvalidInput(format!(
                "lattice dims {}x{}x{}: every dimension must be at least 1",
                dims[0], dims[1], dims[2]
            )));
        }
        let Some(n) = (dims[0] as u64).checked_mul(dims[1] as u64).and_then(|n| n.checked_mul(dims[2] as u64)) else {
            return Err(Error::InvalidInput(format!(
                "lattice dims {}x{}x{}: the point count overflows 64 bits",
                dims[0], dims[1], dims[2]
            )));
        };
        if n > Self::MAX_POINTS {
            return Err(Error::Limit { what: "lattice points", requested: n, allowed: Self::MAX_POINTS });
        }
        if let Some(s) = spacing.iter().find(|s| !(s.is_finite() && **s > 0.0)) {
            return Err(Error::InvalidInput(format!("lattice spacing {s}: must be finite and positive")));
        }
        if let Some(s) = spacing.iter().find(|s| **s < MIN_SPACING) {
            return Err(Error::InvalidInput(format!(
                "lattice spacing {s:e}: below {MIN_SPACING:.2e}, the smallest a mesh vertex (f32) resolves"
            )));
        }
        if let Some(o) = origin.iter().find(|o| !o.is_finite()) {
            return Err(Error::InvalidInput(format!("lattice origin {o}: must be finite")));
        }
        // Directions are orthonormal, so no coordinate of a point exceeds this in magnitude.
        let extent: f64 = (0..3).map(|a| spacing[a] * (dims[a] as f64 - 1.0)).sum();
        let reach = origin.iter().fold(0.0f64, |m, o| m.max(o.abs())) + extent;
        if !(reach <= MAX_COORDINATE) {
            return Err(Error::InvalidInput(format!(
                "lattice of {}x{}x{} points, spacing {spacing:?}, origin {origin:?}: world coordinates reach {reach:.2e}, beyond the {MAX_COORDINATE:.1e} a mesh vertex (f32) holds",
                dims[0], dims[1], dims[2]
            )));
        }
        Ok(Lattice { dims, spacing, origin, direction: IDENTITY, axis_aligned: true, space: None })
    }

    /// A copy with the world direction of each index axis (`direction[a]` for axis `a`).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when the directions are not orthonormal (shear is not supported).
    pub fn with_direction(mut self, direction: [[f64; 3]; 3]) -> Result<Self> {
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        for a in 0..3 {
            for b in 0..3 {
                let expect = if a == b { 1.0 } else { 0.0 };
                let d = dot(direction[a], direction[b]);
                if !((d - expect).abs() <= ORTHONORMAL_TOLERANCE) {
                    return Err(Error::InvalidInput(format!(
                        "direction matrix {direction:?}: axes must be orthonormal (axis {a} · axis {b} = {d})"
                    )));
                }
            }
        }
        self.direction = direction;
        self.axis_aligned = direction == IDENTITY;
        Ok(self)
    }

    /// A copy tagged with the anatomical frame its world coordinates are in.
    pub fn with_space(mut self, space: Option<WorldSpace>) -> Self {
        self.space = space;
        self
    }

    /// The anatomical frame of the world coordinates, when known.
    pub fn space(&self) -> Option<WorldSpace> {
        self.space
    }

    /// The same lattice expressed in `target` world coordinates: LPS ↔ RAS negates world x and
    /// y (a half turn about z, so handedness and triangle orientation are kept).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when this lattice's frame is unknown.
    pub fn in_space(&self, target: WorldSpace) -> Result<Self> {
        let Some(from) = self.space else {
            return Err(Error::InvalidInput(format!(
                "the file does not say whether its world coordinates are LPS or RAS: cannot express them in {}",
                target.name()
            )));
        };
        if from == target {
            return Ok(self.clone());
        }
        let flip = |v: [f64; 3]| [-v[0], -v[1], v[2]];
        let mut l = self.clone().with_direction(self.direction.map(flip))?;
        l.origin = flip(self.origin);
        l.space = Some(target);
        Ok(l)
    }

    /// World direction of each index axis.
    #[inline]
    pub fn direction(&self) -> [[f64; 3]; 3] {
        self.direction
    }

    /// True when the index frame is left-handed in world space (determinant of the directions < 0).
    pub fn is_mirrored(&self) -> bool {
        let [a, b, c] = self.direction;
        let det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0]);
        det < 0.0
    }

    /// A lattice of `dims` points spanning the world box `[min, max]` (both ends sampled).
    ///
    /// # Errors
    /// As [`Lattice::with_geometry`]; also when a dimension is below 2 or `max <= min`.
    pub fn spanning(dims: [u32; 3], min: [f64; 3], max: [f64; 3]) -> Result<Self> {
        let mut spacing = [0.0; 3];
        for a in 0..3 {
            if dims[a] < 2 {
                return Err(Error::InvalidInput(format!(
                    "lattice spanning a box needs at least 2 points per axis, got {}",
                    dims[a]
                )));
            }
            spacing[a] = (max[a] - min[a]) / (dims[a] - 1) as f64;
        }
        Self::with_geometry(dims, spacing, min)
    }

    /// Points per axis.
    #[inline]
    pub fn dims(&self) -> [u32; 3] {
        self.dims
    }

    /// World distance between neighbouring points, per axis.
    #[inline]
    pub fn spacing(&self) -> [f64; 3] {
        self.spacing
    }

    /// World position of point (0, 0, 0).
    #[inline]
    pub fn origin(&self) -> [f64; 3] {
        self.origin
    }

    /// Total number of points.
    #[inline]
    pub fn num_points(&self) -> u64 {
        self.dims.iter().map(|&d| d as u64).product()
    }

    /// Number of points in one z-slab (`nx · ny`).
    #[inline]
    pub fn slab_len(&self) -> usize {
        self.dims[0] as usize * self.dims[1] as usize
    }

    /// Linear index of point `ijk` (x fastest).
    #[inline]
    pub fn linear(&self, ijk: [u32; 3]) -> usize {
        (ijk[2] as usize * self.dims[1] as usize + ijk[1] as usize) * self.dims[0] as usize + ijk[0] as usize
    }

    /// The point of linear index `lin`.
    #[inline]
    pub fn ijk(&self, lin: usize) -> [u32; 3] {
        let nx = self.dims[0] as usize;
        let ny = self.dims[1] as usize;
        [(lin % nx) as u32, ((lin / nx) % ny) as u32, (lin / (nx * ny)) as u32]
    }

    /// World position of a (fractional) index-space point.
    #[inline]
    pub fn to_world(&self, p: [f64; 3]) -> [f64; 3] {
        if self.axis_aligned {
            // Same value as the general sum below (the other terms add exact zeros), in 3 operations.
            return [0, 1, 2].map(|a| self.origin[a] + self.spacing[a] * p[a]);
        }
        let mut w = self.origin;
        for a in 0..3 {
            let s = self.spacing[a] * p[a];
            for (wi, di) in w.iter_mut().zip(self.direction[a]) {
                *wi += di * s;
            }
        }
        w
    }

    /// Index-space position of a world point.
    #[inline]
    pub fn to_index(&self, p: [f64; 3]) -> [f64; 3] {
        let d = [p[0] - self.origin[0], p[1] - self.origin[1], p[2] - self.origin[2]];
        let dir = &self.direction;
        [0, 1, 2].map(|a| (dir[a][0] * d[0] + dir[a][1] * d[1] + dir[a][2] * d[2]) / self.spacing[a])
    }

    /// Converts an index-space gradient (per unit index step) to a world-space gradient.
    #[inline]
    pub fn gradient_to_world(&self, g: [f64; 3]) -> [f64; 3] {
        // Orthonormal directions: the inverse transpose is the matrix itself.
        let mut w = [0.0; 3];
        for a in 0..3 {
            let s = g[a] / self.spacing[a];
            for (wi, di) in w.iter_mut().zip(self.direction[a]) {
                *wi += di * s;
            }
        }
        w
    }

    /// World bounds of the lattice points: `(min, max)`.
    pub fn world_bounds(&self) -> ([f64; 3], [f64; 3]) {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for c in 0..8u32 {
            let p = [0, 1, 2].map(|a| if c >> a & 1 == 1 { self.dims[a] as f64 - 1.0 } else { 0.0 });
            let w = self.to_world(p);
            for a in 0..3 {
                lo[a] = lo[a].min(w[a]);
                hi[a] = hi[a].max(w[a]);
            }
        }
        (lo, hi)
    }

    /// True when every axis has at least two points, so the lattice has at least one cell.
    pub fn has_cells(&self) -> bool {
        self.dims.iter().all(|&d| d >= 2)
    }

    /// A copy of this lattice with other dims (same spacing and origin).
    ///
    /// # Errors
    /// As [`Lattice::new`].
    pub fn with_dims(&self, dims: [u32; 3]) -> Result<Self> {
        Ok(Self::with_geometry(dims, self.spacing, self.origin)?.with_direction(self.direction)?.with_space(self.space))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_and_ijk_round_trip() {
        let l = Lattice::new([3, 4, 5]).unwrap();
        for lin in 0..60 {
            assert_eq!(l.linear(l.ijk(lin)), lin);
        }
        assert_eq!(l.linear([1, 2, 3]), (3 * 4 + 2) * 3 + 1);
    }

    #[test]
    fn rejects_bad_geometry() {
        assert!(Lattice::new([0, 4, 4]).is_err());
        assert!(matches!(Lattice::new([1 << 20, 1 << 20, 2]), Err(Error::Limit { .. })));
        assert!(Lattice::with_geometry([2, 2, 2], [1.0, 0.0, 1.0], [0.0; 3]).is_err());
        assert!(Lattice::with_geometry([2, 2, 2], [1.0; 3], [f64::NAN, 0.0, 0.0]).is_err());
    }

    /// Issue 10: spacing 1e308 gave inf vertices and exit 0.
    #[test]
    fn issue_10_world_bounds_must_fit_mesh_vertices() {
        let e = Lattice::with_geometry([12, 12, 12], [1e308, 1.0, 1.0], [0.0; 3]).unwrap_err().to_string();
        assert!(e.contains("world coordinates reach inf, beyond the 3.4e38 a mesh vertex (f32) holds"), "{e}");
        let e = Lattice::with_geometry([12, 12, 12], [1e38, 1.0, 1.0], [0.0; 3]).unwrap_err().to_string();
        assert!(e.contains("reach 1.10e39"), "{e}");
        assert!(Lattice::with_geometry([2, 2, 2], [1e38, 1e38, 1e38], [0.0; 3]).is_ok());
        assert!(Lattice::with_geometry([2, 2, 2], [2e38; 3], [0.0; 3]).is_err());
        assert!(Lattice::with_geometry([2, 2, 2], [1.0; 3], [-3.3e38, 0.0, 0.0]).is_ok());
        assert!(Lattice::with_geometry([3, 2, 2], [1e38, 1.0, 1.0], [-3.3e38, 0.0, 0.0]).is_err());
        // One point along an axis: its spacing moves nothing.
        assert!(Lattice::with_geometry([1, 2, 2], [1e300, 1.0, 1.0], [0.0; 3]).is_ok());
        assert!(Lattice::with_geometry([2, 2, 2], [1e-300, 1.0, 1.0], [0.0; 3])
            .unwrap_err()
            .to_string()
            .contains("1e-300"));
        // Crops and pads go through the same check: a pad cannot push a lattice past the bound.
        let l = Lattice::with_geometry([2, 2, 2], [1e37; 3], [3.0e38, 0.0, 0.0]).unwrap();
        assert!(l.with_dims([4, 4, 4]).is_err());
    }

    #[test]
    fn world_mapping() {
        let l = Lattice::with_geometry([3, 3, 3], [0.5, 2.0, 1.0], [10.0, 0.0, -1.0]).unwrap();
        assert_eq!(l.to_world([2.0, 1.0, 0.5]), [11.0, 2.0, -0.5]);
        assert_eq!(l.to_index([11.0, 2.0, -0.5]), [2.0, 1.0, 0.5]);
        assert_eq!(l.world_bounds(), ([10.0, 0.0, -1.0], [11.0, 4.0, 1.0]));
    }

    #[test]
    fn directions_rotate_and_mirror() {
        // i along −x, j along +y, k along +z: a mirror (LPS vs RAS style flip).
        let flip = [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let l =
            Lattice::with_geometry([3, 3, 3], [2.0, 1.0, 1.0], [5.0, 0.0, 0.0]).unwrap().with_direction(flip).unwrap();
        assert!(l.is_mirrored());
        assert_eq!(l.to_world([1.0, 1.0, 0.0]), [3.0, 1.0, 0.0]);
        assert_eq!(l.to_index([3.0, 1.0, 0.0]), [1.0, 1.0, 0.0]);
        assert_eq!(l.world_bounds(), ([1.0, 0.0, 0.0], [5.0, 2.0, 2.0]));
        assert_eq!(l.gradient_to_world([2.0, 0.0, 0.0]), [-1.0, 0.0, 0.0]);
        let shear = [[1.0, 0.0, 0.0], [0.5, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert!(Lattice::new([2, 2, 2]).unwrap().with_direction(shear).is_err());
    }
}
