//! The native module of the `isoforge` Python package: validates numpy arrays and delegates to
//! the library. scikit-image's conventions (axis order, winding, its argument errors) live in the
//! Python layer (`isoforge/__init__.py`); this module sees plain arrays.
//!
//! Axes: a C-ordered array of shape `(n0, n1, n2)` has its last axis fastest, so it is the
//! library's lattice `[n2, n1, n0]` (x fastest) and vertices come back as `(z, y, x)` =
//! `(i0, i1, i2)`.

use isoforge::extract::{marching_squares, Saddle};
use isoforge::grid::{AnyGrid, DenseGrid, Lattice, Sample};
use isoforge::mesh::Normals;
use isoforge::pipeline::{extract_grid, Method, Options};
use isoforge::volume::Iso;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::{PyMemoryError, PyValueError};
use pyo3::prelude::*;

/// The array's samples, x (its last axis) fastest, in a grid on the swapped lattice.
fn grid_of<T: Sample + numpy::Element>(a: PyReadonlyArray3<'_, T>, spacing: [f64; 3]) -> PyResult<DenseGrid<T>> {
    let s = a.shape();
    let dims = [s[2], s[1], s[0]].map(|d| u32::try_from(d).unwrap_or(u32::MAX));
    let lattice = Lattice::with_geometry(dims, [spacing[2], spacing[1], spacing[0]], [0.0; 3]).map_err(value_error)?;
    // `as_slice` also accepts F-ordered arrays (their memory order), so ask for C order first.
    let data = match a.as_slice() {
        Ok(s) if a.is_c_contiguous() => s.to_vec(),
        _ => a.as_array().iter().copied().collect(),
    };
    DenseGrid::new(lattice, data).map_err(value_error)
}

fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

fn library_error(e: isoforge::Error) -> PyErr {
    match e {
        isoforge::Error::Limit { .. } => PyMemoryError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

fn any_grid(volume: &Bound<'_, PyUntypedArray>, spacing: [f64; 3]) -> PyResult<AnyGrid> {
    if volume.ndim() != 3 {
        return Err(PyValueError::new_err(format!("volume: {} dimensions, expected 3", volume.ndim())));
    }
    macro_rules! try_dtype {
        ($($t:ty => $v:ident),*) => {
            $(if let Ok(a) = volume.extract::<PyReadonlyArray3<'_, $t>>() {
                return Ok(AnyGrid::$v(grid_of(a, spacing)?));
            })*
        };
    }
    try_dtype!(u8 => U8, i8 => I8, u16 => U16, i16 => I16, u32 => U32, i32 => I32, f32 => F32, f64 => F64);
    Err(PyValueError::new_err(format!(
        "volume: dtype {} is not supported (uint8/16/32, int8/16/32, float32/64)",
        volume.dtype()
    )))
}

/// scikit-image's per-vertex `values`: the largest range (max − min of the 8 corners) among the
/// cells sharing the vertex's edge (a vertex on a point: its cells).
fn spreads<S: Sample>(g: &DenseGrid<S>, positions: &[[f32; 3]]) -> Vec<f32> {
    let (dims, spacing) = (g.lattice().dims(), g.lattice().spacing());
    positions
        .iter()
        .map(|p| {
            let idx = [0, 1, 2].map(|a| p[a] as f64 / spacing[a]);
            let on_point = idx.map(|x| (x - x.round()).abs() < 1e-4);
            let base = [0, 1, 2].map(|a| if on_point[a] { idx[a].round() } else { idx[a].floor() } as i64);
            let mut best = 0.0f64;
            for o in 0..8u32 {
                let off = [o & 1, (o >> 1) & 1, (o >> 2) & 1].map(i64::from);
                if (0..3).any(|a| off[a] == 1 && !on_point[a]) {
                    continue;
                }
                let c = [0, 1, 2].map(|a| base[a] - off[a]);
                if (0..3).any(|a| c[a] < 0 || c[a] >= i64::from(dims[a]) - 1) {
                    continue;
                }
                let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
                for k in 0..8u32 {
                    let q = [0, 1, 2].map(|a| (c[a] + i64::from((k >> a) & 1)) as u32);
                    let v = g.get(q).to_f64();
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
                best = best.max(hi - lo);
            }
            best as f32
        })
        .collect()
}

/// `(vertices (n, 3) float32 as (i0, i1, i2) × spacing, triangles (m, 3) int64, normals (n, 3)
/// float32, values (n,) float32 as scikit-image's)` of the surface at `level` with inside ⇔ value > level; the GIL is released during
/// the extraction.
#[pyfunction]
#[pyo3(signature = (volume, level, spacing, method, normals, threads=None))]
#[allow(clippy::type_complexity)]
fn extract_array<'py>(
    py: Python<'py>,
    volume: &Bound<'py, PyUntypedArray>,
    level: f64,
    spacing: [f64; 3],
    method: &str,
    normals: bool,
    threads: Option<usize>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let method = Method::parse(method).ok_or_else(|| PyValueError::new_err(format!("method {method:?}: unknown")))?;
    let grid = any_grid(volume, spacing)?;
    let opts = Options {
        method,
        normals: if normals { Normals::Gradient } else { Normals::None },
        threads,
        ..Options::default()
    };
    let mut ex = py.detach(|| extract_grid(&grid, Iso::above(level), &opts, None)).map_err(library_error)?;
    ex.mesh.triangulate();
    let m = ex.mesh;
    let values = py.detach(|| isoforge::with_grid!(&grid, g => spreads(g, &m.positions)));
    let swap = |p: &[[f32; 3]]| -> Vec<f32> { p.iter().flat_map(|v| [v[2], v[1], v[0]]).collect() };
    let n = m.positions.len();
    let verts = PyArray1::from_vec(py, swap(&m.positions)).reshape([n, 3])?;
    let nrm = PyArray1::from_vec(py, swap(&m.normals)).reshape([m.normals.len(), 3])?;
    let tris: Vec<i64> = m.triangles.iter().flat_map(|t| t.map(i64::from)).collect();
    let faces = PyArray1::from_vec(py, tris).reshape([m.triangles.len(), 3])?;
    let values = PyArray1::from_vec(py, values);
    Ok((verts.into_any(), faces.into_any(), nrm.into_any(), values.into_any()))
}

/// The isolines of a 2D image at `level` (inside ⇔ value < level): a list of `(points (n, 2)
/// float64 as (row, col), closed)`; saddles join the inside corners when `join_inside`, the
/// outside ones otherwise. Counter-clockwise around the inside with rows pointing up.
#[pyfunction]
fn contour_array<'py>(
    py: Python<'py>,
    image: PyReadonlyArray2<'py, f64>,
    level: f64,
    join_inside: bool,
) -> PyResult<Vec<(Bound<'py, PyAny>, bool)>> {
    let s = image.shape();
    let dims = [s[1], s[0]].map(|d| u32::try_from(d).unwrap_or(u32::MAX));
    if dims.iter().zip([s[1], s[0]]).any(|(&d, n)| d as usize != n) {
        return Err(PyValueError::new_err(format!("image: shape {s:?} is too large")));
    }
    let values: Vec<f64> = image.as_array().iter().copied().collect();
    let saddle = if join_inside { Saddle::JoinInside } else { Saddle::JoinOutside };
    let lines = py.detach(|| marching_squares(dims, &values, Iso::below(level), saddle));
    lines
        .into_iter()
        .map(|l| {
            let n = l.points.len();
            let rc: Vec<f64> = l.points.iter().flat_map(|p| [p[1], p[0]]).collect();
            Ok((PyArray1::from_vec(py, rc).reshape([n, 2])?.into_any(), l.closed))
        })
        .collect()
}

/// The native part of `isoforge`.
#[pymodule]
fn _isoforge(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(extract_array, m)?)?;
    m.add_function(wrap_pyfunction!(contour_array, m)?)?;
    Ok(())
}
