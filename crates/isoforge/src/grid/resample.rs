//! Resampling a dense grid onto a finer lattice covering the same world box.

use super::{DenseGrid, Lattice, Sample};
use crate::error::{Error, Result};

/// The cell holding index point `p` (clamped to the lattice) and `p`'s coordinates inside it.
#[inline]
fn cell_of(dims: [u32; 3], p: [f64; 3]) -> ([u32; 3], [f64; 3]) {
    let mut cell = [0u32; 3];
    let mut local = [0.0; 3];
    for a in 0..3 {
        let max = dims[a].saturating_sub(2) as f64;
        let x = p[a].clamp(0.0, (dims[a] - 1) as f64);
        let c = x.floor().min(max).max(0.0);
        cell[a] = c as u32;
        local[a] = if dims[a] < 2 { 0.0 } else { x - c };
    }
    (cell, local)
}

/// Blends a quantity known at the eight corners of `p`'s cell with trilinear weights.
#[inline]
pub(crate) fn blend<const N: usize>(dims: [u32; 3], p: [f64; 3], at: impl Fn([u32; 3]) -> [f64; N]) -> [f64; N] {
    let (cell, l) = cell_of(dims, p);
    let mut out = [0.0; N];
    for c in 0..8u32 {
        let o = [c & 1, (c >> 1) & 1, (c >> 2) & 1];
        let q = [0, 1, 2].map(|a| (cell[a] + o[a]).min(dims[a] - 1));
        let w: f64 = (0..3).map(|a| if o[a] == 1 { l[a] } else { 1.0 - l[a] }).product();
        if w != 0.0 {
            let v = at(q);
            for (o, x) in out.iter_mut().zip(v) {
                *o += w * x;
            }
        }
    }
    out
}

/// The grid refined `factor` times along each axis, values from the trilinear interpolant
/// (lattice points of the original keep their exact values). The result covers the same world
/// box: spacing divided by `factor`, same origin and direction. Used to reconstruct the trilinear
/// interpolant's isosurface finely (the topology oracle of the MC33 tests) and for multiresolution.
///
/// # Errors
/// [`Error::InvalidInput`] for `factor` 0; [`Error::Limit`] when the refined lattice is too large.
pub fn upsample_trilinear<S: Sample>(grid: &DenseGrid<S>, factor: u32) -> Result<DenseGrid<f32>> {
    if factor == 0 {
        return Err(Error::InvalidInput("upsample factor 0: must be at least 1".into()));
    }
    let lat = grid.lattice();
    let dims = lat.dims();
    let fine = dims.map(|n| ((n as u64 - 1) * factor as u64 + 1).min(u32::MAX as u64) as u32);
    let points = fine.iter().map(|&n| n as u64).product::<u64>();
    const MAX_POINTS: u64 = 1 << 31;
    if points > MAX_POINTS {
        return Err(Error::Limit { what: "upsampled lattice points", requested: points, allowed: MAX_POINTS });
    }
    let spacing = lat.spacing().map(|s| s / factor as f64);
    let lattice =
        Lattice::with_geometry(fine, spacing, lat.origin())?.with_direction(lat.direction())?.with_space(lat.space());
    let f = factor as usize;
    // Per-axis source cell and weight of each fine index.
    let axis = |a: usize| -> Vec<(u32, f64)> {
        (0..fine[a])
            .map(|x| {
                let (c, r) = ((x as usize / f) as u32, (x as usize % f) as f64 / f as f64);
                if c + 1 >= dims[a] {
                    (dims[a].saturating_sub(2), if dims[a] < 2 { 0.0 } else { 1.0 })
                } else {
                    (c, r)
                }
            })
            .collect()
    };
    let (ax, ay, az) = (axis(0), axis(1), axis(2));
    let at = |i: u32, j: u32, k: u32| grid.get([i.min(dims[0] - 1), j.min(dims[1] - 1), k.min(dims[2] - 1)]).to_f64();
    let mut data = Vec::with_capacity(points as usize);
    for &(k, wz) in &az {
        for &(j, wy) in &ay {
            for &(i, wx) in &ax {
                let lerp = |a: f64, b: f64, w: f64| {
                    if w == 0.0 {
                        a
                    } else if w == 1.0 {
                        b
                    } else {
                        a + (b - a) * w
                    }
                };
                let c00 = lerp(at(i, j, k), at(i + 1, j, k), wx);
                let c10 = lerp(at(i, j + 1, k), at(i + 1, j + 1, k), wx);
                let c01 = lerp(at(i, j, k + 1), at(i + 1, j, k + 1), wx);
                let c11 = lerp(at(i, j + 1, k + 1), at(i + 1, j + 1, k + 1), wx);
                let v = lerp(lerp(c00, c10, wy), lerp(c01, c11, wy), wz);
                data.push(v as f32);
            }
        }
    }
    DenseGrid::new(lattice, data)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lattice_points_keep_their_values_and_midpoints_interpolate() {
        let g =
            DenseGrid::new(Lattice::new([2, 2, 2]).unwrap(), vec![0.0f32, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]).unwrap();
        let u = upsample_trilinear(&g, 4).unwrap();
        assert_eq!(u.lattice().dims(), [5, 5, 5]);
        assert_eq!(u.get([0, 0, 0]), 0.0);
        assert_eq!(u.get([4, 4, 4]), 7.0);
        assert_eq!(u.get([4, 0, 4]), 5.0);
        assert_eq!(u.get([2, 2, 2]), 3.5); // the centre: mean of the corners
        assert_eq!(u.lattice().spacing(), [0.25; 3]);
        assert!(upsample_trilinear(&g, 0).is_err());
    }
}
