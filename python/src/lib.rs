//! The native module of the `isoforge` Python package: validates numpy arrays and delegates to
//! the library. scikit-image's conventions (axis order, winding, its argument errors) live in the
//! Python layer (`isoforge/__init__.py`); this module sees plain arrays.
//!
//! Axes: a C-ordered array of shape `(n0, n1, n2)` has its last axis fastest, so it is the
//! library's lattice `[n2, n1, n0]` (x fastest) and vertices come back as `(z, y, x)` =
//! `(i0, i1, i2)`.

mod chunks;
mod contours;

use std::borrow::Cow;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use isoforge::extract::PointMask;
use isoforge::grid::{AnyGrid, DenseGrid, Lattice, Sample};
use isoforge::mesh::{Mesh, Normals};
use isoforge::pipeline::{extract_grid, extract_request, extract_strided, Method, Options, Request, Source};
use isoforge::volume::{AnySamples, Iso, StridedSamples};
use isoforge::walk::Progress;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::{PyMemoryError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The array's samples, x (its last axis) fastest, in a grid on the swapped lattice.
/// `spacing` and `origin` are in the lattice's (x, y, z) order.
fn grid_of<T: Sample + numpy::Element>(
    a: PyReadonlyArray3<'_, T>,
    spacing: [f64; 3],
    origin: [f64; 3],
) -> PyResult<DenseGrid<T>> {
    let s = a.shape();
    let dims = [s[2], s[1], s[0]].map(|d| u32::try_from(d).unwrap_or(u32::MAX));
    let lattice = Lattice::with_geometry(dims, spacing, origin).map_err(value_error)?;
    // `as_slice` also accepts F-ordered arrays (their memory order), so ask for C order first.
    let data = match a.as_slice() {
        Ok(s) if a.is_c_contiguous() => s.to_vec(),
        _ => a.as_array().iter().copied().collect(),
    };
    DenseGrid::new(lattice, data).map_err(value_error)
}

/// The array's samples where numpy keeps them, in whatever layout (C or Fortran order, steps,
/// reversed axes, broadcasts), on the swapped lattice (x: the array's last axis; `spacing` in
/// (x, y, z) order). None when the layout cannot be read as samples in place (unaligned, a
/// stride that is not a whole number of samples, no samples): the caller copies then.
///
/// The samples are read while the GIL is released: another Python thread writing the array
/// meanwhile is a data race (documented in `marching_cubes` and `extract`).
fn strided_of<'a, T: Sample + numpy::Element>(
    a: &'a PyReadonlyArray3<'_, T>,
    spacing: [f64; 3],
    origin: [f64; 3],
) -> PyResult<Option<StridedSamples<'a, T>>> {
    let (shape, bytes, size) = (a.shape(), a.strides(), std::mem::size_of::<T>() as isize);
    if !a.is_aligned() || shape.contains(&0) || bytes.iter().any(|b| b % size != 0) {
        return Ok(None);
    }
    let dims = [shape[2], shape[1], shape[0]].map(|d| u32::try_from(d).unwrap_or(u32::MAX));
    let lattice = Lattice::with_geometry(dims, spacing, origin).map_err(value_error)?;
    let strides = [bytes[2] / size, bytes[1] / size, bytes[0] / size];
    // The lowest and highest sample any point reaches, from the first point.
    let (mut lo, mut hi) = (0isize, 0isize);
    for axis in 0..3 {
        let reach = (dims[axis] as isize - 1) * strides[axis];
        lo += reach.min(0);
        hi += reach.max(0);
    }
    // SAFETY: numpy keeps every element of a view inside one allocation, so the samples from
    // the lowest to the highest one a point reaches are readable, aligned `T`s (checked above);
    // they live as long as the borrowed array `a`, which also keeps Rust from writing them. A
    // Python thread writing them meanwhile is the documented race.
    let samples = unsafe { std::slice::from_raw_parts(a.data().offset(lo).cast_const(), (hi - lo + 1) as usize) };
    StridedSamples::new(lattice, samples, (-lo) as usize, strides).map(Some).map_err(value_error)
}

/// Cancels a walk once the watcher has seen a signal handler raise (Ctrl-C).
struct Interrupt(AtomicBool);

impl Progress for Interrupt {
    fn advance(&self, _: u64, _: u64) {}
    fn cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

/// Runs `f` on a worker thread with the GIL released; meanwhile this thread takes the GIL every
/// 20 ms to run Python's signal handlers. When one raises (KeyboardInterrupt on Ctrl-C), the walk
/// is cancelled and that exception is returned once the worker has stopped.
fn cancellable<T: Send>(py: Python<'_>, f: impl FnOnce(&dyn Progress) -> isoforge::Result<T> + Send) -> PyResult<T> {
    let stop = Interrupt(AtomicBool::new(false));
    let (result, raised) = py.detach(|| {
        std::thread::scope(|s| {
            let worker = s.spawn(|| f(&stop));
            let mut raised = None;
            while !worker.is_finished() {
                std::thread::sleep(Duration::from_millis(20));
                if raised.is_none() {
                    if let Err(e) = Python::attach(|py| py.check_signals()) {
                        stop.0.store(true, Ordering::Relaxed);
                        raised = Some(e);
                    }
                }
            }
            (worker.join(), raised)
        })
    });
    if let Some(e) = raised {
        return Err(e);
    }
    match result {
        Ok(r) => r.map_err(library_error),
        Err(_) => Err(PyRuntimeError::new_err("isoforge: the extraction panicked (a bug, please report it)")),
    }
}

/// `f` on a pool of `threads` (all cores when None, or when the pool cannot be built).
fn in_threads<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> T {
    match threads.map(|n| rayon::ThreadPoolBuilder::new().num_threads(n).build()) {
        Some(Ok(pool)) => pool.install(f),
        _ => f(),
    }
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

/// The array as a grid; `spacing` and `origin` in (x, y, z) order (x: the array's last axis).
fn any_grid(volume: &Bound<'_, PyUntypedArray>, spacing: [f64; 3], origin: [f64; 3]) -> PyResult<AnyGrid> {
    if volume.ndim() != 3 {
        return Err(PyValueError::new_err(format!("volume: {} dimensions, expected 3", volume.ndim())));
    }
    macro_rules! try_dtype {
        ($($t:ty => $v:ident),*) => {
            $(if let Ok(a) = volume.extract::<PyReadonlyArray3<'_, $t>>() {
                return Ok(AnyGrid::$v(grid_of(a, spacing, origin)?));
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
fn spreads(l: &Lattice, get: &(impl Fn([u32; 3]) -> f64 + Sync), positions: &[[f32; 3]]) -> Vec<f32> {
    let (dims, spacing) = (l.dims(), l.spacing());
    use rayon::prelude::*;
    // One vertex's value reads its cells only: in parallel over vertices (serial, this was a
    // quarter of `marching_cubes` at 256³).
    positions
        .par_iter()
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
                    let v = get(q);
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
/// float32, values (n,) float32 as scikit-image's)` of the surface at `level` with inside ⇔ value
/// > level; `mask`, of shape `volume.shape − 1`, keeps the cells whose flag is set. The GIL is
/// released during the extraction.
#[pyfunction]
#[pyo3(signature = (volume, level, spacing, method, normals, threads=None, mask=None))]
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
fn extract_array<'py>(
    py: Python<'py>,
    volume: &Bound<'py, PyUntypedArray>,
    level: f64,
    spacing: [f64; 3],
    method: &str,
    normals: bool,
    threads: Option<usize>,
    mask: Option<PyReadonlyArray3<'py, bool>>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let method = Method::parse(method).ok_or_else(|| PyValueError::new_err(format!("method {method:?}: unknown")))?;
    let xyz = [spacing[2], spacing[1], spacing[0]];
    let options = |dims: [u32; 3]| -> PyResult<Options> {
        let mask = match &mask {
            None => None,
            Some(m) => {
                let flags: Vec<bool> = m.as_array().iter().copied().collect();
                Some(Arc::new(PointMask::of_cells(dims, flags).map_err(value_error)?))
            }
        };
        Ok(Options {
            method,
            normals: if normals { Normals::Gradient } else { Normals::None },
            threads,
            mask,
            ..Options::default()
        })
    };
    let iso = Iso::above(level);
    // Arrays are walked where numpy keeps them, in any layout (issue 48: C order in place,
    // others slab by slab); only an unaligned array, or one whose strides are not whole samples,
    // is copied into a grid first.
    let mut borrowed = None;
    if volume.ndim() == 3 {
        macro_rules! walk_in_place {
            ($($t:ty),*) => {
                $(if let Ok(a) = volume.extract::<PyReadonlyArray3<'py, $t>>() {
                    if let Some(s) = strided_of(&a, xyz, [0.0; 3])? {
                        let dims = s.lattice().dims();
                        let opts = options(dims)?;
                        let mut ex = cancellable(py, |p| extract_strided(&s, iso, &opts, Some(p)))?;
                        ex.mesh.triangulate();
                        let m = ex.mesh;
                        let get = |q: [u32; 3]| s.get(q).to_f64();
                        let values = py.detach(|| in_threads(threads, || spreads(s.lattice(), &get, &m.positions)));
                        borrowed = Some((m, values));
                    }
                })*
            };
        }
        walk_in_place!(u8, i8, u16, i16, u32, i32, f32, f64);
    }
    let (m, values) = match borrowed {
        Some(done) => done,
        None => {
            let grid = any_grid(volume, xyz, [0.0; 3])?;
            let opts = options(grid.lattice().dims())?;
            let mut ex = cancellable(py, |p| extract_grid(&grid, iso, &opts, Some(p)))?;
            ex.mesh.triangulate();
            let m = ex.mesh;
            let values = py.detach(|| {
                in_threads(threads, || {
                    isoforge::with_grid!(&grid, g => {
                        let get = |q: [u32; 3]| g.data()[g.lattice().linear(q)].to_f64();
                        spreads(g.lattice(), &get, &m.positions)
                    })
                })
            });
            (m, values)
        }
    };
    let swap = |p: &[[f32; 3]]| -> Vec<f32> { p.iter().flat_map(|v| [v[2], v[1], v[0]]).collect() };
    let n = m.positions.len();
    let verts = PyArray1::from_vec(py, swap(&m.positions)).reshape([n, 3])?;
    let nrm = PyArray1::from_vec(py, swap(&m.normals)).reshape([m.normals.len(), 3])?;
    let tris: Vec<i64> = m.triangles.iter().flat_map(|t| t.map(i64::from)).collect();
    let faces = PyArray1::from_vec(py, tris).reshape([m.triangles.len(), 3])?;
    let values = PyArray1::from_vec(py, values);
    Ok((verts.into_any(), faces.into_any(), nrm.into_any(), values.into_any()))
}

/// scikit-image's `find_contours` on a float64 image: a list of `(n, 2)` float64 arrays of
/// `(row, col)` points, low values on the left (before `positive_orientation`); squares with a
/// corner out of `mask` or NaN are skipped. The GIL is released while tracing.
#[pyfunction]
#[pyo3(signature = (image, level, connect_high, mask=None))]
fn contour_array<'py>(
    py: Python<'py>,
    image: PyReadonlyArray2<'py, f64>,
    level: f64,
    connect_high: bool,
    mask: Option<PyReadonlyArray2<'py, bool>>,
) -> PyResult<Vec<Bound<'py, PyAny>>> {
    let s = image.shape();
    let (rows, cols) = (s[0], s[1]);
    let values: Vec<f64> = image.as_array().iter().copied().collect();
    let mask: Option<Vec<bool>> = mask.map(|m| m.as_array().iter().copied().collect());
    if mask.as_ref().is_some_and(|m| m.len() != values.len()) {
        return Err(PyValueError::new_err("mask: shape differs from the image's"));
    }
    let lines = py.detach(|| {
        let segs = contours::segments(&values, rows, cols, level, connect_high, mask.as_deref());
        contours::assemble(&segs)
    });
    lines
        .into_iter()
        .map(|l| {
            let n = l.len();
            let flat: Vec<f64> = l.into_iter().flatten().collect();
            Ok(PyArray1::from_vec(py, flat).reshape([n, 2])?.into_any())
        })
        .collect()
}

fn io_error(e: isoforge_io::Error) -> PyErr {
    match e {
        isoforge_io::Error::Limit { .. } => PyMemoryError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// `(vertices (n, 3) float32 world (x, y, z), faces (m, 3) int64, normals (n, 3) float32)`.
fn mesh_arrays<'py>(py: Python<'py>, m: Mesh) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let (n, nn, nt) = (m.positions.len(), m.normals.len(), m.triangles.len());
    let verts = PyArray1::from_vec(py, m.positions.into_iter().flatten().collect::<Vec<f32>>()).reshape([n, 3])?;
    let nrm = PyArray1::from_vec(py, m.normals.into_iter().flatten().collect::<Vec<f32>>()).reshape([nn, 3])?;
    let tris: Vec<i64> = m.triangles.iter().flat_map(|t| t.map(i64::from)).collect();
    let faces = PyArray1::from_vec(py, tris).reshape([nt, 3])?;
    Ok((verts.into_any(), faces.into_any(), nrm.into_any()))
}

/// isoforge's own extraction: the surface at `iso` (inside ⇔ value < iso) of an array (x its last
/// axis; `spacing`, `origin` in (x, y, z) order) or of a volume file (`path`; its own geometry),
/// as `(vertices, faces, normals)` in world (x, y, z). The GIL is released during the extraction.
#[pyfunction]
#[pyo3(signature = (volume, path, iso, method, spacing, origin, threads=None, normals=true))]
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
fn extract_mesh<'py>(
    py: Python<'py>,
    volume: Option<&Bound<'py, PyUntypedArray>>,
    path: Option<std::path::PathBuf>,
    iso: f64,
    method: &str,
    spacing: [f64; 3],
    origin: [f64; 3],
    threads: Option<usize>,
    normals: bool,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let method = Method::parse(method).ok_or_else(|| PyValueError::new_err(format!("method {method:?}: unknown")))?;
    let options = Options {
        method,
        normals: if normals { Normals::Gradient } else { Normals::None },
        threads,
        ..Options::default()
    };
    // The library's one entry point, as the CLI's `extract`: the iso checked against the values,
    // no surface refused with the same sentence.
    let request: Request = Request { isos: vec![iso], options, ..Request::default() };
    let extract = |source: Source<'_>| -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let surfaces = cancellable(py, |p| extract_request(&request, source, None, Some(p)))?;
        let mut mesh = surfaces.into_iter().next().map(|s| s.extraction.mesh).unwrap_or_default();
        mesh.triangulate();
        mesh_arrays(py, mesh)
    };
    match (volume, path) {
        (Some(v), None) => {
            if v.ndim() != 3 {
                return Err(PyValueError::new_err(format!("volume: {} dimensions, expected 3", v.ndim())));
            }
            // Walked where numpy keeps the array, in any layout (issue 48); copied only when
            // unaligned or strided by parts of a sample.
            macro_rules! in_place {
                ($($t:ty => $v:ident),*) => {
                    $(if let Ok(a) = v.extract::<PyReadonlyArray3<'py, $t>>() {
                        if let Some(s) = strided_of(&a, spacing, origin)? {
                            return extract(Source::Samples(AnySamples::$v(s)));
                        }
                    })*
                };
            }
            in_place!(u8 => U8, i8 => I8, u16 => U16, i16 => I16, u32 => U32, i32 => I32, f32 => F32, f64 => F64);
            let grid = any_grid(v, spacing, origin)?;
            extract(Source::Grid(Cow::Borrowed(&grid)))
        }
        (None, Some(p)) => {
            let grid = py.detach(|| isoforge_io::read_volume(&p, &isoforge_io::Limits::default())).map_err(io_error)?;
            extract(Source::Grid(Cow::Borrowed(&grid)))
        }
        _ => Err(PyValueError::new_err("extract: pass an array or a path")),
    }
}

/// A volume file through isoforge-io's readers: `(array of shape (nz, ny, nx) in the file's
/// dtype, {"dims": (nx, ny, nz), "spacing": (sx, sy, sz), "origin": (ox, oy, oz)})`.
#[pyfunction]
fn read_volume<'py>(py: Python<'py>, path: std::path::PathBuf) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    let grid = py.detach(|| isoforge_io::read_volume(&path, &isoforge_io::Limits::default())).map_err(io_error)?;
    grid_array(py, grid)
}

/// A grid as `(array (nz, ny, nx) of its dtype, {"dims", "spacing", "origin"})`.
fn grid_array<'py>(py: Python<'py>, grid: AnyGrid) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    let lattice = grid.lattice().clone();
    let [nx, ny, nz] = lattice.dims().map(|d| d as usize);
    macro_rules! arr {
        ($g:expr) => {{
            let (_, data) = $g.into_parts();
            PyArray1::from_vec(py, data).reshape([nz, ny, nx])?.into_any()
        }};
    }
    let array = match grid {
        AnyGrid::U8(g) => arr!(g),
        AnyGrid::I8(g) => arr!(g),
        AnyGrid::U16(g) => arr!(g),
        AnyGrid::I16(g) => arr!(g),
        AnyGrid::U32(g) => arr!(g),
        AnyGrid::I32(g) => arr!(g),
        AnyGrid::F32(g) => arr!(g),
        AnyGrid::F64(g) => arr!(g),
    };
    let info = PyDict::new(py);
    info.set_item("dims", (nx, ny, nz))?;
    info.set_item("spacing", lattice.spacing())?;
    info.set_item("origin", lattice.origin())?;
    Ok((array, info))
}

fn mesh_of(
    vertices: PyReadonlyArray2<'_, f32>,
    faces: PyReadonlyArray2<'_, i64>,
    normals: Option<PyReadonlyArray2<'_, f32>>,
) -> PyResult<Mesh> {
    let rows3 = |shape: &[usize], what: &str| {
        if shape[1] != 3 {
            return Err(PyValueError::new_err(format!("{what}: shape {shape:?}, expected (n, 3)")));
        }
        Ok(())
    };
    rows3(vertices.shape(), "vertices")?;
    rows3(faces.shape(), "faces")?;
    let positions: Vec<[f32; 3]> = vertices.as_array().rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect();
    let n = positions.len() as i64;
    let mut triangles = Vec::with_capacity(faces.shape()[0]);
    for (t, r) in faces.as_array().rows().into_iter().enumerate() {
        let tri = [r[0], r[1], r[2]];
        if let Some(&bad) = tri.iter().find(|&&i| i < 0 || i >= n) {
            return Err(PyValueError::new_err(format!("faces[{t}]: vertex {bad} out of 0..{n}")));
        }
        triangles.push(tri.map(|i| i as u32));
    }
    let normals: Vec<[f32; 3]> = match normals {
        Some(a) if a.shape()[0] > 0 => {
            rows3(a.shape(), "normals")?;
            if a.shape()[0] != positions.len() {
                return Err(PyValueError::new_err(format!("normals: {} rows for {n} vertices", a.shape()[0])));
            }
            a.as_array().rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect()
        }
        _ => Vec::new(),
    };
    Ok(Mesh { positions, normals, triangles, quads: Vec::new() })
}

/// The library's topology report of a triangle mesh, as a dict; with `self_intersections`, also
/// the exact count of self-intersecting triangle pairs (None otherwise).
#[pyfunction]
#[pyo3(signature = (vertices, faces, self_intersections=false))]
fn mesh_check<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f32>,
    faces: PyReadonlyArray2<'py, i64>,
    self_intersections: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let mesh = mesh_of(vertices, faces, None)?;
    let opts = isoforge::topo::CheckOptions { self_intersections, ..Default::default() };
    let r = py.detach(|| isoforge::topo::check_with(&mesh, &opts));
    let d = PyDict::new(py);
    d.set_item("vertices", r.vertices)?;
    d.set_item("triangles", r.triangles)?;
    d.set_item("edges", r.edges)?;
    d.set_item("closed", r.is_closed())?;
    d.set_item("manifold", r.is_manifold())?;
    d.set_item("oriented", r.is_oriented())?;
    d.set_item("watertight", r.is_watertight())?;
    d.set_item("genus", r.genus())?;
    d.set_item("euler", r.euler)?;
    d.set_item("components", r.components.len())?;
    d.set_item("boundary_edges", r.boundary_edges.count)?;
    d.set_item("non_manifold_edges", r.non_manifold_edges.count)?;
    d.set_item("non_manifold_vertices", r.non_manifold_vertices.count)?;
    d.set_item("inconsistent_edges", r.inconsistent_edges.count)?;
    d.set_item("isolated_vertices", r.isolated_vertices.count)?;
    d.set_item("collapsed_triangles", r.collapsed_triangles.count)?;
    d.set_item("zero_area_triangles", r.zero_area_triangles.count)?;
    d.set_item("duplicate_triangles", r.duplicate_triangles.count)?;
    d.set_item("self_intersections", r.self_intersection_count())?;
    d.set_item("area", r.area)?;
    d.set_item("volume", r.volume)?;
    Ok(d)
}

/// Writes a triangle mesh with isoforge-io's writer for `path`'s extension (.ply, .obj, .stl,
/// .off, .glb/.gltf).
#[pyfunction]
#[pyo3(signature = (path, vertices, faces, normals=None))]
fn mesh_save(
    py: Python<'_>,
    path: std::path::PathBuf,
    vertices: PyReadonlyArray2<'_, f32>,
    faces: PyReadonlyArray2<'_, i64>,
    normals: Option<PyReadonlyArray2<'_, f32>>,
) -> PyResult<()> {
    let mesh = mesh_of(vertices, faces, normals)?;
    let format = isoforge_io::MeshFormat::from_path(Path::new(&path))
        .ok_or_else(|| PyValueError::new_err(format!("{}: unknown mesh format (by extension)", path.display())))?;
    py.detach(|| isoforge_io::write_mesh(&path, &mesh, format)).map_err(io_error)
}

/// A mesh voxelized on the lattice of `resolution` cells along its longest side (or of spacing
/// `voxel_size`) with `band` cells of margin: the library's robust inside/outside (holes, flipped
/// and duplicated faces) and exact distances in the band.
fn voxelized(
    py: Python<'_>,
    vertices: PyReadonlyArray2<'_, f32>,
    faces: PyReadonlyArray2<'_, i64>,
    resolution: u32,
    voxel_size: Option<f64>,
    band: f64,
) -> PyResult<isoforge::voxelize::Voxelized> {
    use isoforge::voxelize::{self, Resolution, VoxelizeOptions};
    let mesh = mesh_of(vertices, faces, None)?;
    let resolution = match voxel_size {
        Some(h) => Resolution::Spacing(h),
        None => Resolution::Cells(resolution),
    };
    if !(band >= 1.0 && band.is_finite()) {
        return Err(PyValueError::new_err(format!("band {band}: at least 1 cell")));
    }
    let opts = VoxelizeOptions { band, max_bytes: isoforge_io::Limits::default().max_bytes };
    py.detach(|| {
        let lattice = voxelize::lattice_for(&mesh, resolution, band.ceil() as u32 + 1)?;
        voxelize::voxelize(&mesh, lattice, &opts)
    })
    .map_err(library_error)
}

/// `voxelized` as a dense grid: `values` "sdf" (float32 signed distances, negative inside) or
/// "occupancy" (uint8, 1 inside).
#[pyfunction]
#[pyo3(signature = (vertices, faces, resolution=128, voxel_size=None, band=3.0, values="sdf"))]
fn voxelize_mesh<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f32>,
    faces: PyReadonlyArray2<'py, i64>,
    resolution: u32,
    voxel_size: Option<f64>,
    band: f64,
    values: &str,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    let output: isoforge::voxelize::Output =
        values.parse().map_err(|e| PyValueError::new_err(format!("values {e}")))?;
    let v = voxelized(py, vertices, faces, resolution, voxel_size, band)?;
    let grid = py.detach(|| v.to_dense(output, isoforge_io::Limits::default().max_bytes)).map_err(library_error)?;
    grid_array(py, grid)
}

/// PolyMender's pipeline: the mesh voxelized, then its surface contoured by MC33 on the sparse
/// grid — a closed, manifold, oriented mesh near the input.
#[pyfunction]
#[pyo3(signature = (vertices, faces, resolution=128, voxel_size=None, band=3.0))]
fn repair_mesh<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f32>,
    faces: PyReadonlyArray2<'py, i64>,
    resolution: u32,
    voxel_size: Option<f64>,
    band: f64,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let v = voxelized(py, vertices, faces, resolution, voxel_size, band)?;
    let mut out = py
        .detach(|| isoforge::pipeline::extract_sparse(&v.grid, Iso::below(0.0), &Options::default()))
        .map_err(library_error)?;
    out.mesh.triangulate();
    mesh_arrays(py, out.mesh)
}

/// The native part of `isoforge`.
#[pymodule]
fn _isoforge(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(extract_array, m)?)?;
    m.add_function(wrap_pyfunction!(contour_array, m)?)?;
    m.add_function(wrap_pyfunction!(extract_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(read_volume, m)?)?;
    m.add_function(wrap_pyfunction!(voxelize_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(repair_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_check, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_save, m)?)?;
    chunks::register(m)?;
    Ok(())
}
