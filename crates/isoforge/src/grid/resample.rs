//! Resampling a dense grid: onto a finer lattice covering the same world box, or onto a coarser
//! one by block means (previews).

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

/// The grid coarsened `factor` times along each axis: each output point is the mean of a
/// `factor`³ block of input points and sits at the block's centre (spacing times `factor`, same
/// direction). Trailing points that do not fill a block are dropped, so the result covers the
/// input's box less up to `factor − 1` points at the max faces. Used for quick previews of large
/// volumes (`isoforge view`).
///
/// # Errors
/// [`Error::InvalidInput`] for `factor` 0 or when an axis has fewer than `factor` points.
pub fn downsample_mean<S: Sample>(grid: &DenseGrid<S>, factor: u32) -> Result<DenseGrid<f32>> {
    let lat = grid.lattice();
    let dims = lat.dims();
    if factor == 0 || dims.iter().any(|&n| n < factor) {
        return Err(Error::InvalidInput(format!(
            "downsample factor {factor}: must be from 1 to the smallest dimension of {dims:?}"
        )));
    }
    let f = factor as usize;
    let coarse = dims.map(|n| n / factor);
    let [cx, cy, cz] = coarse.map(|n| n as usize);
    let [nx, ny, _] = dims.map(|n| n as usize);
    let centre = (factor - 1) as f64 / 2.0;
    let origin = lat.to_world([centre; 3]);
    let spacing = lat.spacing().map(|s| s * factor as f64);
    let lattice =
        Lattice::with_geometry(coarse, spacing, origin)?.with_direction(lat.direction())?.with_space(lat.space());
    let scale = 1.0 / (f * f * f) as f64;
    let data = grid.data();
    let mut out = Vec::with_capacity(cx * cy * cz);
    // One output slab at a time: sum its `f` input slabs row by row (contiguous reads).
    let mut sums = vec![0.0f64; cx * cy];
    for k in 0..cz {
        sums.fill(0.0);
        for z in k * f..(k + 1) * f {
            for y in 0..cy * f {
                let row = &data[(z * ny + y) * nx..][..cx * f];
                let sum_row = &mut sums[(y / f) * cx..][..cx];
                for (s, block) in sum_row.iter_mut().zip(row.chunks_exact(f)) {
                    *s += block.iter().map(|v| v.to_f64()).sum::<f64>();
                }
            }
        }
        out.extend(sums.iter().map(|s| (s * scale) as f32));
    }
    DenseGrid::new(lattice, out)
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

    #[test]
    fn downsampling_takes_block_means_at_block_centres() {
        // 5 x 4 x 4 points, value = i + 10 j + 100 k: a block mean is the value at its centre.
        let l = Lattice::with_geometry([5, 4, 4], [0.5, 1.0, 2.0], [1.0, 2.0, 3.0]).unwrap();
        let g = DenseGrid::from_fn(l, |p| (p[0] + 10 * p[1] + 100 * p[2]) as u16);
        let d = downsample_mean(&g, 2).unwrap();
        assert_eq!(d.lattice().dims(), [2, 2, 2], "the fifth x point fills no block");
        assert_eq!(d.lattice().spacing(), [1.0, 2.0, 4.0]);
        assert_eq!(d.lattice().origin(), [1.25, 2.5, 4.0]);
        assert_eq!(d.get([0, 0, 0]), 0.5 + 5.0 + 50.0);
        assert_eq!(d.get([1, 1, 1]), 2.5 + 25.0 + 250.0);
        assert_eq!(downsample_mean(&g, 1).unwrap().data(), g.data().iter().map(|&v| v as f32).collect::<Vec<_>>());
        assert!(downsample_mean(&g, 0).is_err());
        assert!(downsample_mean(&g, 6).is_err());
    }
}
