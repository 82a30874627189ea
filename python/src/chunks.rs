//! Distributed extraction's native half (`isoforge.dask`): one chunk of a lattice walked over its
//! cell range, and meshes of chunks stitched by vertex key. Everything crosses processes as plain
//! numpy arrays (picklable, no Python objects):
//!
//! ```text
//!   part      (vertices (n, 3) float32 world (x, y, z), faces (m, 3) uint32,
//!              normals (n, 3) float32 or (0, 3), keys (k, 8) uint32)
//!   keys row  [vertex, VertexKey::to_words()…] for the vertices neighbouring chunks may share,
//!             vertex increasing
//! ```
//! The chunk is a window of the global lattice (`GridVolume::window`) holding at least its range's
//! halo (`CellRange::halo_points`); its walk records the keys of its boundary vertices
//! (`KeyRecord::Boundary`), and `stitch_keyed` joins parts (a tree of stitches too: the stitched
//! part keeps every key its parts had) into exactly the mesh of one walk of the whole lattice.

use isoforge::cube::{CellRange, VertexKey};
use isoforge::grid::Lattice;
use isoforge::mesh::{KeyRecord, Mesh, MeshBuilder, Normals};
use isoforge::pipeline::{run, Method, Options};
use isoforge::volume::{GridVolume, Iso};
use isoforge::walk::{stitch_keyed, FlyingEdgesWalker, KeyedMesh};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Columns of a keys row: the vertex, then the key's words.
const KEY_COLUMNS: usize = 1 + VertexKey::WORDS;

type Part<'py> = (Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>);

/// A part as [`stitch`] receives it: vertices, faces, normals, keys.
type PartIn<'py> =
    (PyReadonlyArray2<'py, f32>, PyReadonlyArray2<'py, u32>, PyReadonlyArray2<'py, f32>, PyReadonlyArray2<'py, u32>);

fn bad(msg: String) -> PyErr {
    PyValueError::new_err(msg)
}

/// The surface at `iso` (inside ⇔ value < iso) in the cells `range_lo .. range_hi` (global cell
/// indices, (x, y, z)) of a lattice of `global_dims` points with `spacing` and `origin`, from
/// `array`: the points from global index `offset` on (shape `(nz, ny, nx)`, x its last axis),
/// which must hold the range's halo (`CellRange::halo_points`). Returns the part (module doc).
/// The GIL is released during the walk.
#[pyfunction]
#[pyo3(signature = (array, offset, global_dims, range_lo, range_hi, iso, method, spacing, origin, normals=true, threads=None))]
#[allow(clippy::too_many_arguments)]
fn extract_chunk<'py>(
    py: Python<'py>,
    array: &Bound<'py, PyUntypedArray>,
    offset: [u32; 3],
    global_dims: [u32; 3],
    range_lo: [u32; 3],
    range_hi: [u32; 3],
    iso: f64,
    method: &str,
    spacing: [f64; 3],
    origin: [f64; 3],
    normals: bool,
    threads: Option<usize>,
) -> PyResult<Part<'py>> {
    let method = Method::parse(method).ok_or_else(|| bad(format!("method {method:?}: unknown")))?;
    if !iso.is_finite() {
        return Err(bad(format!("iso {iso}: must be a finite number")));
    }
    let global = Lattice::with_geometry(global_dims, spacing, origin).map_err(super::value_error)?;
    let cells = CellRange::all(global_dims);
    if (0..3).any(|a| range_lo[a] >= range_hi[a] || range_hi[a] > cells.hi[a]) {
        return Err(bad(format!(
            "range {range_lo:?}..{range_hi:?}: not a non-empty box of the {:?} cells of a lattice of {global_dims:?} \
             points",
            cells.hi
        )));
    }
    let range = CellRange { lo: range_lo, hi: range_hi };
    if array.ndim() != 3 {
        return Err(bad(format!("array: {} dimensions, expected 3", array.ndim())));
    }
    let s = array.shape();
    let dims = [s[2], s[1], s[0]];
    let (h_lo, h_hi) = range.halo_points(global_dims);
    let fits = (0..3).all(|a| {
        let end = offset[a] as u64 + dims[a] as u64;
        offset[a] <= h_lo[a] && end >= u64::from(h_hi[a]) && end <= u64::from(global_dims[a])
    });
    if !fits {
        return Err(bad(format!(
            "array of shape {s:?} at offset {offset:?} (x, y, z): must hold the range's halo points {h_lo:?}..{h_hi:?} \
             inside the lattice of {global_dims:?} points",
        )));
    }
    let grid = super::any_grid(array, [1.0; 3], [0.0; 3])?;
    let opts = Options { method, ..Options::default() };
    let normals = if normals { Normals::Gradient } else { Normals::None };
    let mut part = super::cancellable(py, |progress| {
        super::in_threads(threads, || {
            isoforge::with_grid!(&grid, g => {
                let vol = GridVolume::window(g, offset, global.clone())?;
                let mut out = MeshBuilder::new(normals).with_keys(KeyRecord::Boundary(range));
                let mut walker = FlyingEdgesWalker::new().with_range(range).with_progress(progress);
                run(&mut walker, &vol, Iso::below(iso), &opts, &mut out)?;
                KeyedMesh::from_builder(out)
            })
        })
    })?;
    part.mesh.triangulate();
    part_arrays(py, part)
}

/// The parts (as [`extract_chunk`] returns them) joined into one by vertex key, in order: a
/// part in the same form, keeping every key its parts had (so stitched parts can be stitched
/// again). The GIL is released while joining.
#[pyfunction]
fn stitch<'py>(py: Python<'py>, parts: Vec<PartIn<'py>>) -> PyResult<Part<'py>> {
    let meshes =
        parts.iter().enumerate().map(|(i, (v, f, n, k))| keyed_mesh(i, v, f, n, k)).collect::<PyResult<Vec<_>>>()?;
    let joined = py.detach(|| stitch_keyed(&meshes)).map_err(super::library_error)?;
    part_arrays(py, joined)
}

/// Part `i`'s arrays as a keyed mesh, every index and key checked.
fn keyed_mesh(
    i: usize,
    vertices: &PyReadonlyArray2<'_, f32>,
    faces: &PyReadonlyArray2<'_, u32>,
    normals: &PyReadonlyArray2<'_, f32>,
    keys: &PyReadonlyArray2<'_, u32>,
) -> PyResult<KeyedMesh> {
    let cols = |shape: &[usize], want: usize, what: &str| {
        if shape[1] != want {
            return Err(bad(format!("parts[{i}] {what}: shape {shape:?}, expected (n, {want})")));
        }
        Ok(())
    };
    cols(vertices.shape(), 3, "vertices")?;
    cols(faces.shape(), 3, "faces")?;
    cols(normals.shape(), 3, "normals")?;
    cols(keys.shape(), KEY_COLUMNS, "keys")?;
    let rows3 = |a: &PyReadonlyArray2<'_, f32>| -> Vec<[f32; 3]> {
        a.as_array().rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect()
    };
    let positions = rows3(vertices);
    let n = positions.len();
    let normals = rows3(normals);
    if !normals.is_empty() && normals.len() != n {
        return Err(bad(format!("parts[{i}] normals: {} rows for {n} vertices", normals.len())));
    }
    let mut triangles = Vec::with_capacity(faces.shape()[0]);
    for (t, r) in faces.as_array().rows().into_iter().enumerate() {
        let tri = [r[0], r[1], r[2]];
        if let Some(&v) = tri.iter().find(|&&v| v as usize >= n) {
            return Err(bad(format!("parts[{i}] faces[{t}]: vertex {v} out of 0..{n}")));
        }
        triangles.push(tri);
    }
    let mut out = Vec::with_capacity(keys.shape()[0]);
    for (r, row) in keys.as_array().rows().into_iter().enumerate() {
        let v = row[0];
        let words: [u32; VertexKey::WORDS] = std::array::from_fn(|w| row[w + 1]);
        let key = VertexKey::from_words(words)
            .ok_or_else(|| bad(format!("parts[{i}] keys[{r}]: {words:?} is no vertex key")))?;
        if v as usize >= n || out.last().is_some_and(|&(last, _)| last >= v) {
            return Err(bad(format!("parts[{i}] keys[{r}]: vertex {v} out of 0..{n} or not increasing")));
        }
        out.push((v, key));
    }
    Ok(KeyedMesh { mesh: Mesh { positions, normals, triangles, quads: Vec::new() }, keys: out })
}

/// A keyed triangle mesh as a part's four arrays.
fn part_arrays(py: Python<'_>, part: KeyedMesh) -> PyResult<Part<'_>> {
    let KeyedMesh { mesh, keys } = part;
    let (n, nn, nt, nk) = (mesh.positions.len(), mesh.normals.len(), mesh.triangles.len(), keys.len());
    let flat3 = |v: Vec<[f32; 3]>| v.into_iter().flatten().collect::<Vec<f32>>();
    let verts = PyArray1::from_vec(py, flat3(mesh.positions)).reshape([n, 3])?;
    let nrm = PyArray1::from_vec(py, flat3(mesh.normals)).reshape([nn, 3])?;
    let faces = PyArray1::from_vec(py, mesh.triangles.into_iter().flatten().collect::<Vec<u32>>()).reshape([nt, 3])?;
    let rows: Vec<u32> = keys.into_iter().flat_map(|(v, k)| std::iter::once(v).chain(k.to_words())).collect();
    let keys = PyArray1::from_vec(py, rows).reshape([nk, KEY_COLUMNS])?;
    Ok((verts.into_any(), faces.into_any(), nrm.into_any(), keys.into_any()))
}

/// Adds the chunk functions to the native module.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(extract_chunk, m)?)?;
    m.add_function(wrap_pyfunction!(stitch, m)?)?;
    Ok(())
}
