"""isoforge.marching_cubes against skimage.measure.marching_cubes on the same volumes."""

import numpy as np
import pytest

import isoforge

measure = pytest.importorskip("skimage.measure")


def ellipsoid(dtype=np.float32):
    z, y, x = np.mgrid[-10:11, -12:13, -14:15].astype(np.float64)
    return (100 - (x**2 / 1.3 + y**2 + z**2 * 1.5)).astype(dtype)


def signed_volume(v, f):
    p = v[f].astype(np.float64)
    return np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6


def sorted_rows(a):
    return a[np.lexsort(a.T)]


@pytest.mark.parametrize("method", ["lorensen", "lewiner"])
@pytest.mark.parametrize("spacing", [(1.0, 1.0, 1.0), (1.0, 2.0, 3.0)])
@pytest.mark.parametrize("direction", ["descent", "ascent"])
def test_same_vertices_and_winding_as_skimage(method, spacing, direction):
    vol = ellipsoid()
    a = measure.marching_cubes(vol, 40, spacing=spacing, method=method, gradient_direction=direction)
    b = isoforge.marching_cubes(vol, 40, spacing=spacing, method=method, gradient_direction=direction)
    assert a[0].shape == b[0].shape and a[1].shape == b[1].shape
    np.testing.assert_allclose(sorted_rows(a[0]), sorted_rows(b[0]), atol=1e-5)
    # Same winding: the signed volumes agree (sign and size).
    assert signed_volume(b[0], b[1]) == pytest.approx(signed_volume(a[0], a[1]), rel=1e-5)
    # Normals point the same way (skimage's are index-space gradients, isoforge's world ones).
    ia, ib = np.lexsort(a[0].T), np.lexsort(b[0].T)
    assert (a[2][ia] * b[2][ib]).sum(axis=1).min() > 0.8


def test_lorensen_mesh_equals_skimage_up_to_numbering():
    # Off every sample: at a sample equal to the level skimage makes degenerate triangles (both
    # crossings of the point kept), isoforge counts ties outside.
    vol = ellipsoid()
    a = measure.marching_cubes(vol, 40.25, method="lorensen")
    b = isoforge.marching_cubes(vol, 40.25, method="lorensen")

    def triangles(v, f):
        t = np.round(v[f], 4)
        # Each triangle rotated to start at its smallest vertex (winding kept), then sorted.
        keys = [tuple(map(tuple, np.roll(tri, -min(range(3), key=lambda k: tuple(tri[k])), axis=0))) for tri in t]
        return sorted(keys)

    assert triangles(*a[:2]) == triangles(*b[:2])


@pytest.mark.parametrize("dtype", [np.uint8, np.int16, np.uint16, np.float64])
def test_integer_and_double_volumes(dtype):
    vol = np.clip(ellipsoid(np.float64), 0, 120).astype(dtype)
    a = measure.marching_cubes(vol, 40.5, method="lorensen")
    b = isoforge.marching_cubes(vol, 40.5, method="lorensen")
    np.testing.assert_allclose(sorted_rows(a[0]), sorted_rows(b[0]), atol=1e-4)


def test_fortran_order_and_strided_views():
    vol = ellipsoid()
    ref = isoforge.marching_cubes(vol, 40)
    for v in (np.asfortranarray(vol), np.ascontiguousarray(vol[:, :, ::-1])[:, :, ::-1]):
        got = isoforge.marching_cubes(v, 40)
        np.testing.assert_allclose(sorted_rows(got[0]), sorted_rows(ref[0]), atol=1e-5)


def test_level_defaults_to_mid_range():
    vol = ellipsoid()
    a = measure.marching_cubes(vol, method="lorensen")
    b = isoforge.marching_cubes(vol, method="lorensen")
    assert a[0].shape == b[0].shape


@pytest.mark.parametrize(
    "args, kwargs, message",
    [
        ((np.zeros((4, 4)),), {}, "3D numpy array"),
        ((np.zeros((1, 4, 4)),), {}, "at least 2x2x2"),
        ((np.arange(27.0).reshape(3, 3, 3), 100), {}, "within volume data range"),
        ((np.arange(27.0).reshape(3, 3, 3), 5), {"method": "x"}, "'lewiner' or 'lorensen'"),
        ((np.arange(27.0).reshape(3, 3, 3), 5), {"spacing": (1, 1)}, "three floats"),
        ((np.arange(27.0).reshape(3, 3, 3), 5), {"step_size": 0}, "at least one"),
        ((np.arange(27.0).reshape(3, 3, 3), 5), {"gradient_direction": "up"}, "gradient_direction"),
    ],
)
def test_errors_as_skimage(args, kwargs, message):
    with pytest.raises(ValueError, match=message):
        measure.marching_cubes(*args, **kwargs)
    with pytest.raises(ValueError, match=message):
        isoforge.marching_cubes(*args, **kwargs)


def test_values_near_skimage():
    vol = ellipsoid()
    a = measure.marching_cubes(vol, 40)
    b = isoforge.marching_cubes(vol, 40)
    ia, ib = np.lexsort(a[0].T), np.lexsort(b[0].T)
    # The cell value ranges around each vertex's edge; a few vertices differ by one cell's range.
    assert np.mean(np.isclose(a[3][ia], b[3][ib])) > 0.9
