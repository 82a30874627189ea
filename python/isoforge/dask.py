"""Distributed extraction on Dask: volumes beyond one machine (issue 48).

The lattice's cells are cut into boxes (by the array's chunks, or ``chunks``); one task per box
reads only the box's halo (two points before its cells, one after: what every method and the
gradient normals read) from the Dask array or the Zarr store, walks exactly the box's cells in
global indices (``_isoforge.extract_chunk``) and returns plain numpy arrays with the keys of the
vertices on the box's boundary; a tree of stitch tasks (``fan_in`` parts each) joins them by key,
never by coordinates. The result is the mesh :func:`isoforge.extract` makes of the whole array:
the same vertices (bit for bit) and triangles, numbered differently.
"""

import numpy as np

from . import Mesh, _isoforge

__all__ = ["extract"]


def _cell_bounds(n, sizes):
    """Cell boundaries along an axis of ``n`` points cut into chunks of ``sizes`` points (the
    cells of a chunk start at its first point; the last cell is ``n - 2``)."""
    bounds = [0]
    for s in sizes[:-1]:
        b = bounds[-1] + int(s)
        if b < n - 1:
            bounds.append(b)
    bounds.append(n - 1)
    return bounds


def _axis_sizes(n, c):
    c = int(c)
    if c < 1:
        raise ValueError(f"chunks: {c} points, at least 1 per chunk")
    return [c] * (n // c) + ([n % c] if n % c else [])


def _chunk_sizes(array, chunks):
    """Chunk sizes per array axis ``(z, y, x)``: ``chunks`` (an int or three ints, or Dask's
    tuple of tuples), else the array's own (Dask's chunks, Zarr's chunk shape)."""
    shape = array.shape
    if chunks is None:
        chunks = getattr(array, "chunks", None)
        if chunks is None:
            raise ValueError("extract: a numpy array needs chunks=(cz, cy, cx) points per chunk")
    if isinstance(chunks, (int, np.integer)):
        chunks = (int(chunks),) * 3
    if len(chunks) != 3:
        raise ValueError(f"chunks {chunks!r}: three sizes (z, y, x) expected")
    out = []
    for n, c in zip(shape, chunks):
        if isinstance(c, (tuple, list)):
            sizes = [int(s) for s in c]
            if sum(sizes) != n or min(sizes) < 1:
                raise ValueError(f"chunks {c!r}: sizes must be positive and sum to the axis's {n} points")
            out.append(sizes)
        else:
            out.append(_axis_sizes(n, c))
    return out


def _chunk_task(source, lo, hi, shape_xyz, iso, method, spacing, origin, normals, threads):
    """One box: reads its halo from ``source`` (a numpy array already sliced by Dask, or a Zarr
    array sliced here, lazily) and walks its cells. ``lo``, ``hi``: cells (x, y, z)."""
    h_lo = [max(lo[a] - 2, 0) for a in range(3)]
    h_hi = [min(hi[a] + 2, shape_xyz[a]) for a in range(3)]
    if isinstance(source, np.ndarray) and source.shape == (h_hi[2] - h_lo[2], h_hi[1] - h_lo[1], h_hi[0] - h_lo[0]):
        block = source
    else:
        block = source[h_lo[2]:h_hi[2], h_lo[1]:h_hi[1], h_lo[0]:h_hi[0]]
    block = np.asarray(block)
    if block.dtype == bool:
        block = block.astype(np.uint8)
    return _isoforge.extract_chunk(block, tuple(h_lo), tuple(shape_xyz), tuple(lo), tuple(hi), iso, method,
                                   spacing, origin, normals, threads)


def _stitch_task(*parts):
    return _isoforge.stitch(list(parts))


def _is_zarr(array):
    return type(array).__module__.split(".")[0] == "zarr"


def extract(array, iso, *, method="mc33", spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0), chunks=None,
            client=None, normals=True, fan_in=8, threads=1):
    """The isosurface at ``iso`` (inside ⇔ value < iso) of a chunked volume, extracted by Dask, as
    a :class:`~isoforge.Mesh` equal to ``isoforge.extract(whole_array, …)``.

    ``array`` is a ``dask.array.Array``, a ``zarr.Array`` (each task reads its own region of the
    store) or a numpy array, of shape ``(nz, ny, nx)`` (x its last axis). ``chunks`` (points per
    chunk: an int, ``(cz, cy, cx)``, or Dask's tuple of tuples) overrides the array's own chunking
    for the boxes of cells the tasks walk (a numpy array needs it). ``spacing``, ``origin``:
    ``(x, y, z)``. ``client``: a ``distributed.Client`` to run on; ``None`` uses Dask's current
    scheduler. ``fan_in``: parts per stitch task. ``threads``: threads per chunk task (``None``:
    all cores of its worker).

    Raises ValueError for bad arguments (as :func:`isoforge.extract` does).
    """
    import dask

    if _is_zarr(array):
        source = array
    elif hasattr(array, "dask") and hasattr(array, "chunks"):
        source = array
    elif isinstance(array, np.ndarray):
        if chunks is None:
            raise ValueError("extract: a numpy array needs chunks=(cz, cy, cx) points per chunk")
        # Sent once (scattered to the cluster, or one node of the graph), sliced by each task.
        # Unhashed, so a call never reuses the key of an earlier call's future (a benchmark run
        # with hashed scatters hung once; the cause is not pinned down).
        if client is not None:
            source = client.scatter(array, hash=False)
        else:
            source = dask.delayed(array, pure=True, traverse=False)
    else:
        raise ValueError(f"extract: array of type {type(array).__name__}: expected a dask, zarr or numpy array")
    if len(array.shape) != 3:
        raise ValueError(f"array: {len(array.shape)} dimensions, expected 3")
    nz, ny, nx = (int(n) for n in array.shape)
    if min(nx, ny, nz) < 2:
        raise ValueError(f"array of shape {tuple(array.shape)}: at least 2 points per axis")
    spacing = tuple(float(s) for s in spacing)
    origin = tuple(float(o) for o in origin)
    if len(spacing) != 3 or len(origin) != 3:
        raise ValueError("spacing and origin: three numbers each (x, y, z)")
    iso = float(iso)
    if not np.isfinite(iso):
        raise ValueError(f"iso {iso}: must be a finite number")
    fan_in = int(fan_in)
    if fan_in < 2:
        raise ValueError(f"fan_in {fan_in}: at least 2")
    whole = _is_zarr(array) or isinstance(array, np.ndarray)  # tasks slice the source themselves
    sz, sy, sx = _chunk_sizes(array, chunks)
    bx, by, bz = _cell_bounds(nx, sx), _cell_bounds(ny, sy), _cell_bounds(nz, sz)
    shape_xyz = (nx, ny, nz)
    chunk = dask.delayed(_chunk_task, pure=True)
    parts = []
    for z0, z1 in zip(bz, bz[1:]):
        for y0, y1 in zip(by, by[1:]):
            for x0, x1 in zip(bx, bx[1:]):
                lo, hi = (x0, y0, z0), (x1, y1, z1)
                if whole:
                    data = source
                else:
                    # The halo as a Dask array: its task graph reads only the source chunks it overlaps.
                    data = source[max(z0 - 2, 0):min(z1 + 2, nz), max(y0 - 2, 0):min(y1 + 2, ny),
                                  max(x0 - 2, 0):min(x1 + 2, nx)]
                parts.append(chunk(data, lo, hi, shape_xyz, iso, method, spacing, origin, normals, threads))
    stitch = dask.delayed(_stitch_task, pure=True)
    while len(parts) > 1:
        parts = [stitch(*parts[i:i + fan_in]) for i in range(0, len(parts), fan_in)]
    if client is not None:
        part = client.compute(parts[0]).result()
    else:
        (part,) = dask.compute(parts[0])
    vertices, faces, normals_out, _ = part
    return Mesh(vertices, faces.astype(np.int64), normals_out)
