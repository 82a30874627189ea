"""isoforge: isosurface extraction, with scikit-image's ``marching_cubes`` as a drop-in."""

import numpy as np

from ._isoforge import contour_array, extract_array

__all__ = ["find_contours", "marching_cubes"]


def marching_cubes(volume, level=None, *, spacing=(1.0, 1.0, 1.0), gradient_direction="descent",
                   step_size=1, allow_degenerate=True, method="lewiner", mask=None, threads=None):
    """Marching cubes with ``skimage.measure.marching_cubes``'s arguments and results.

    Returns ``(verts, faces, normals, values)``: vertices in array index order ``(i0, i1, i2)``
    times ``spacing``; ``method='lorensen'`` is classic marching cubes, ``'lewiner'`` is isoforge's
    MC33 (the topology of the trilinear interpolant). The object is ``volume > level`` for
    ``gradient_direction='descent'``. Integer volumes are not converted to float32.
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
    if mask is not None:
        if mask.shape != volume.shape:
            raise ValueError("volume and mask must have the same shape.")
        raise NotImplementedError("mask: not yet supported by isoforge.marching_cubes")
    sampled = volume[::step_size, ::step_size, ::step_size] if step_size > 1 else volume
    step = np.asarray([float(s) * step_size for s in spacing])
    verts, faces, normals, values = extract_array(sampled, level, tuple(step), name, True, threads)
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

    Returns a list of ``(n, 2)`` arrays of ``(row, col)`` points; a closed contour repeats its
    first point at its end.
    """
    image = np.asarray(image)
    if image.ndim != 2:
        raise ValueError("Only 2D arrays are supported.")
    if fully_connected not in ("low", "high"):
        raise ValueError('Parameters "fully_connected" must be either "high" or "low".')
    if positive_orientation not in ("low", "high"):
        raise ValueError('Parameters "positive_orientation" must be either "high" or "low".')
    if mask is not None:
        raise NotImplementedError("mask: not yet supported by isoforge.find_contours")
    image = np.asarray(image, dtype=np.float64)
    if level is None:
        level = (np.nanmin(image) + np.nanmax(image)) / 2.0
    out = []
    for points, closed in contour_array(image, float(level), fully_connected == "low"):
        if closed and len(points):
            points = np.vstack([points, points[:1]])
        # isoforge runs counter-clockwise around low values with rows up, which is clockwise in
        # (row, col); skimage's 'low' is counter-clockwise around low values in (row, col).
        if positive_orientation == "low":
            points = points[::-1]
        out.append(np.ascontiguousarray(points))
    return out
