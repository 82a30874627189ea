"""isoforge: isosurface extraction, with scikit-image's ``marching_cubes`` and ``find_contours``
as drop-ins and isoforge's own API (``extract``, ``Mesh``, ``read_volume``)."""

import os

import numpy as np

from . import _isoforge
from ._isoforge import contour_array, extract_array

__all__ = ["Mesh", "extract", "find_contours", "marching_cubes", "read_volume", "repair", "voxelize"]


def marching_cubes(volume, level=None, *, spacing=(1.0, 1.0, 1.0), gradient_direction="descent",
                   step_size=1, allow_degenerate=True, method="lewiner", mask=None, threads=None):
    """Marching cubes with ``skimage.measure.marching_cubes``'s arguments and results.

    Returns ``(verts, faces, normals, values)``: vertices in array index order ``(i0, i1, i2)``
    times ``spacing``; ``method='lorensen'`` is classic marching cubes, ``'lewiner'`` is isoforge's
    MC33 (the topology of the trilinear interpolant). The object is ``volume > level`` for
    ``gradient_direction='descent'``. Integer volumes are not converted to float32.

    The array is not copied, whatever its layout (C or Fortran order, steps, reversed axes): it
    is read where numpy keeps it, without the GIL and without a lock. Another thread writing
    the array (or a view of its memory) during the call is a data race: the result may mix old
    and new values, or the walk may fail with RuntimeError; pass ``volume.copy()`` then.
    """
    if method == "lorensen":
        name = "mc"
    elif method == "lewiner":
        name = "mc33"
    else:
        raise ValueError("method should be either 'lewiner' or 'lorensen'")
    if not isinstance(volume, np.ndarray) or volume.ndim != 3:
        raise ValueError("Input volume should be a 3D numpy array.")
    if min(volume.shape) < 2:
        raise ValueError("Input array must be at least 2x2x2.")
    if volume.dtype.kind not in "uif" or volume.dtype.itemsize > 8:
        volume = volume.astype(np.float32)
    vmin, vmax = volume.min(), volume.max()
    if level is None:
        level = 0.5 * (float(vmin) + float(vmax))
    else:
        level = float(level)
        if level < vmin or level > vmax:
            raise ValueError("Surface level must be within volume data range.")
    if len(spacing) != 3:
        raise ValueError("`spacing` must consist of three floats.")
    step_size = int(step_size)
    if step_size < 1:
        raise ValueError("step_size must be at least one.")
    if gradient_direction not in ("descent", "ascent"):
        raise ValueError(f"Incorrect input {gradient_direction} in `gradient_direction`, see docstring.")
    cells = None
    if mask is not None:
        if mask.shape != volume.shape:
            raise ValueError("volume and mask must have the same shape.")
        # scikit-image keeps a cell iff the mask holds at its far corner (i0+1, i1+1, i2+1) (in
        # steps of step_size); the native side takes one flag per cell.
        st = step_size
        cells = np.ascontiguousarray(np.asarray(mask, dtype=bool)[st::st, st::st, st::st])
    sampled = volume[::step_size, ::step_size, ::step_size] if step_size > 1 else volume
    step = np.asarray([float(s) * step_size for s in spacing])
    verts, faces, normals, values = extract_array(sampled, level, tuple(step), name, True, threads, cells)
    if len(verts) == 0:
        raise RuntimeError("No surface found at the given iso value.")
    if gradient_direction == "ascent":
        faces = faces[:, ::-1]
    else:
        # skimage's normals point towards lower values for 'descent' (they are the gradient,
        # flipped with the faces); isoforge's point outside the object (values > level).
        pass
    if not allow_degenerate:
        verts, faces = _drop_degenerate(verts, faces)
    return verts, np.ascontiguousarray(faces), normals, values


def _drop_degenerate(verts, faces):
    p = verts[faces]
    keep = ~(np.all(p[:, 0] == p[:, 1], axis=1) | np.all(p[:, 1] == p[:, 2], axis=1)
             | np.all(p[:, 0] == p[:, 2], axis=1))
    faces = faces[keep]
    used, inverse = np.unique(faces, return_inverse=True)
    return verts[used], inverse.reshape(-1, 3)


def find_contours(image, level=None, fully_connected="low", positive_orientation="low", *, mask=None):
    """Marching squares with ``skimage.measure.find_contours``'s arguments and results.

    Returns a list of ``(n, 2)`` float64 arrays of ``(row, col)`` points, the same points in the
    same order as scikit-image (a closed contour repeats its first point at its end). Squares
    with a NaN corner, or a corner where ``mask`` is False, produce nothing.
    """
    image = np.asarray(image)
    if fully_connected not in ("low", "high"):
        raise ValueError('Parameters "fully_connected" must be either "high" or "low".')
    if positive_orientation not in ("low", "high"):
        raise ValueError('Parameters "positive_orientation" must be either "high" or "low".')
    if image.ndim != 2:
        raise ValueError("Only 2D arrays are supported.")
    if image.shape[0] < 2 or image.shape[1] < 2:
        raise ValueError("Input array must be at least 2x2.")
    if mask is not None:
        mask = np.asarray(mask)
        if mask.shape != image.shape:
            raise ValueError('Parameters "array" and "mask" must have same shape.')
        if not np.can_cast(mask.dtype, bool, casting="safe"):
            raise TypeError('Parameter "mask" must be a binary array.')
        mask = np.ascontiguousarray(mask, dtype=bool)
    image = np.ascontiguousarray(image, dtype=np.float64)
    if level is None:
        level = (np.nanmin(image) + np.nanmax(image)) / 2.0
    contours = contour_array(image, float(level), fully_connected == "high", mask)
    if positive_orientation == "high":
        contours = [np.ascontiguousarray(c[::-1]) for c in contours]
    return contours


class Mesh:
    """A triangle mesh from :func:`extract`: ``vertices`` ``(n, 3)`` float32 in world ``(x, y, z)``,
    ``faces`` ``(m, 3)`` int64 (counter-clockwise seen from outside, where values are ≥ iso),
    ``normals`` ``(n, 3)`` float32 unit normals pointing outside (empty when not computed)."""

    def __init__(self, vertices, faces, normals=None):
        """A mesh from arrays (``faces`` index ``vertices``); ``normals`` optional."""
        self.vertices = np.ascontiguousarray(vertices, dtype=np.float32).reshape(-1, 3)
        self.faces = np.ascontiguousarray(faces, dtype=np.int64).reshape(-1, 3)
        if normals is None:
            normals = np.zeros((0, 3), np.float32)
        self.normals = np.ascontiguousarray(normals, dtype=np.float32).reshape(-1, 3)

    def __repr__(self):
        return f"Mesh({len(self.vertices)} vertices, {len(self.faces)} faces)"

    def check(self, self_intersections=False):
        """The library's topology report as a dict: ``closed``, ``manifold``, ``oriented``,
        ``watertight``, ``genus`` (None unless closed, manifold and oriented), ``components``,
        ``euler``, counts of ``boundary_edges``, ``non_manifold_edges``,
        ``non_manifold_vertices``, ``inconsistent_edges``, ``isolated_vertices``,
        ``collapsed_triangles``, ``zero_area_triangles``, ``duplicate_triangles``, and ``area``,
        ``volume``, ``vertices``, ``triangles``, ``edges``; ``self_intersections``: with
        ``self_intersections=True`` the exact count of pairs of triangles that meet other than at
        the vertices or the edge they share (about doubles the time), else None."""
        return _isoforge.mesh_check(self.vertices, self.faces, bool(self_intersections))

    def save(self, path):
        """Writes the mesh with isoforge's writer for the extension of ``path`` (``.ply``,
        ``.obj``, ``.stl``, ``.off``, ``.glb``/``.gltf``); ValueError on an unknown extension or
        an unwritable path."""
        _isoforge.mesh_save(os.fspath(path), self.vertices, self.faces, self.normals)


def extract(source, iso, *, method="mc33", spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0),
            shape=None, threads=None, normals=True):
    """The isosurface at ``iso`` (inside ⇔ value < iso) as a :class:`Mesh`, by isoforge's walker.

    ``source`` is a 3D numpy array (``(nz, ny, nx)``: x is its last axis), a path to a volume
    file (read by isoforge's readers with the file's own spacing and origin; ``spacing`` and
    ``origin`` are then ignored), or a callable ``f(x, y, z) -> array`` evaluated once,
    vectorised, on the world coordinates of a lattice of ``shape = (nx, ny, nz)`` points.
    ``spacing`` and ``origin`` are ``(x, y, z)``. ``method`` is one of the CLI's method names
    (``mc``, ``mc33``, ``mt5``, ``mt6``, ``surface-nets``, ``dc``, ``emc``…); quads are split into
    triangles.
    ``threads=None`` uses every core. The GIL is released during the extraction.

    An array is not copied, whatever its layout: it is read where numpy keeps it, without the
    GIL and without a lock, so another thread writing it during the call is a data race (the
    mesh may mix old and new values, or the walk fail with RuntimeError); pass a copy then.

    Raises ValueError for bad arguments or files (the library's one-line message) and
    MemoryError for requests over the library's size limits.
    """
    spacing = tuple(float(s) for s in spacing)
    origin = tuple(float(o) for o in origin)
    if len(spacing) != 3 or len(origin) != 3:
        raise ValueError("spacing and origin: three numbers each (x, y, z)")
    if isinstance(source, (str, bytes, os.PathLike)):
        v, f, n = _isoforge.extract_mesh(None, os.fsdecode(source), float(iso), method, spacing, origin,
                                          threads, normals)
        return Mesh(v, f, n)
    if callable(source):
        if shape is None or len(shape) != 3:
            raise ValueError("extract: a callable needs shape=(nx, ny, nz)")
        nx, ny, nz = (int(s) for s in shape)
        if min(nx, ny, nz) < 2:
            raise ValueError(f"shape {tuple(shape)}: at least 2 points per axis")
        # One broadcast evaluation on the lattice's points (each axis a 1D array of coordinates).
        z = origin[2] + spacing[2] * np.arange(nz, dtype=np.float64)[:, None, None]
        y = origin[1] + spacing[1] * np.arange(ny, dtype=np.float64)[None, :, None]
        x = origin[0] + spacing[0] * np.arange(nx, dtype=np.float64)[None, None, :]
        values = np.broadcast_to(np.asarray(source(x, y, z)), (nz, ny, nx))
        source = np.ascontiguousarray(values, dtype=np.float32 if values.dtype != np.float64 else np.float64)
    if not isinstance(source, np.ndarray):
        raise ValueError(f"extract: source of type {type(source).__name__}: expected an array, a path or a callable")
    if source.dtype == bool:
        source = source.astype(np.uint8)
    v, f, n = _isoforge.extract_mesh(source, None, float(iso), method, spacing, origin, threads, normals)
    return Mesh(v, f, n)


def read_volume(path):
    """Reads a volume file with isoforge's readers (by extension: .nrrd, .nii(.gz), .mha/.mhd,
    .mrc, .vtk, .tif, .png stacks, DICOM…). Returns ``(array, lattice)``: the samples as an
    ``(nz, ny, nx)`` array in the file's dtype, and a dict with ``dims`` ``(nx, ny, nz)``,
    ``spacing`` and ``origin`` (``(x, y, z)``). ValueError for unreadable files, MemoryError over
    the size limit."""
    return _isoforge.read_volume(os.fspath(path))


def _mesh_arrays(mesh, faces):
    if isinstance(mesh, Mesh):
        if faces is not None:
            raise ValueError("pass a Mesh, or vertices and faces")
        return mesh.vertices, mesh.faces
    if faces is None:
        raise ValueError("pass a Mesh, or vertices and faces")
    vertices = np.ascontiguousarray(mesh, dtype=np.float32).reshape(-1, 3)
    return vertices, np.ascontiguousarray(faces, dtype=np.int64).reshape(-1, 3)


def voxelize(mesh, faces=None, *, resolution=128, voxel_size=None, band=3.0, values="sdf"):
    """A mesh (a :class:`Mesh`, or ``vertices`` and ``faces`` arrays) as a dense volume, robust to
    broken input: holes, flipped and duplicated faces, nested shells (generalised winding
    numbers after the mesh is cleaned and its patches oriented; exact distances within ``band``
    cells of the surface). The lattice has ``resolution`` cells along the mesh's longest side
    (or spacing ``voxel_size``) and ``band + 1`` cells of margin. ``values``: ``"sdf"`` (float32
    signed distances in world units, negative inside) or ``"occupancy"`` (uint8, 1 inside).
    Returns ``(array, lattice)`` as :func:`read_volume` does. ValueError for bad arguments or a
    mesh with nothing to voxelize, MemoryError over the size limits."""
    v, f = _mesh_arrays(mesh, faces)
    return _isoforge.voxelize_mesh(v, f, int(resolution), None if voxel_size is None else float(voxel_size),
                                   float(band), values)


def repair(mesh, faces=None, *, resolution=128, voxel_size=None, band=3.0):
    """PolyMender's repair: the mesh voxelized as :func:`voxelize` does, then contoured (MC33) into
    a closed, manifold, oriented :class:`Mesh` near the input (holes closed, flipped faces
    ignored)."""
    v, f = _mesh_arrays(mesh, faces)
    return Mesh(*_isoforge.repair_mesh(v, f, int(resolution), None if voxel_size is None else float(voxel_size),
                                       float(band)))

