"""isoforge's own API: extract (arrays, files, callables), Mesh.check/save, read_volume, errors."""

import math
from pathlib import Path

import numpy as np
import pytest

import isoforge

TESTDATA = Path(__file__).resolve().parents[2] / "testdata" / "volumes"


def ball(n=41, r=15.0):
    z, y, x = np.mgrid[:n, :n, :n].astype(np.float32) - (n - 1) / 2
    return np.sqrt(x**2 + y**2 + z**2)


@pytest.mark.parametrize("method", ["mc", "mc33", "mt6", "surface-nets", "dc", "emc"])
def test_ball_is_a_closed_sphere_of_the_right_size(method):
    r = 15.0
    mesh = isoforge.extract(ball(), r, method=method, spacing=(0.5, 0.5, 0.5))
    rep = mesh.check()
    assert rep["closed"] and rep["manifold"] and rep["oriented"]
    assert rep["genus"] == 0 and rep["components"] == 1 and rep["boundary_edges"] == 0
    # Spacing 0.5: the world radius is 7.5; outward faces give a positive volume.
    assert rep["area"] == pytest.approx(4 * math.pi * 7.5**2, rel=0.02)
    assert rep["volume"] == pytest.approx(4 / 3 * math.pi * 7.5**3, rel=0.02)
    assert mesh.vertices.dtype == np.float32 and mesh.faces.dtype == np.int64
    assert mesh.normals.shape == mesh.vertices.shape


def test_check_counts_self_intersections_when_asked():
    mesh = isoforge.extract(ball(21, 6.0), 6.0)
    assert mesh.check()["self_intersections"] is None
    assert mesh.check(self_intersections=True)["self_intersections"] == 0
    # Two triangles, the second piercing the first.
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.25, 0.2, -1], [0.25, 0.2, 1], [0.25, 0.9, 0]], np.float32)
    crossing = isoforge.Mesh(v, [[0, 1, 2], [3, 4, 5]])
    assert crossing.check(self_intersections=True)["self_intersections"] == 1


def test_origin_and_axis_order():
    # Values grow along x (the array's last axis) only: the plane x = 2.5 (index) crosses there.
    vol = np.broadcast_to(np.arange(6, dtype=np.float32), (4, 5, 6)).copy()
    mesh = isoforge.extract(vol, 2.5, method="mc", spacing=(2.0, 1.0, 1.0), origin=(10.0, 0.0, -1.0))
    np.testing.assert_allclose(mesh.vertices[:, 0], 10.0 + 2.0 * 2.5)
    assert mesh.vertices[:, 1].max() == pytest.approx(4.0) and mesh.vertices[:, 2].min() == pytest.approx(-1.0)
    assert mesh.check()["boundary_edges"] > 0  # an open plane


def test_callable_field_is_evaluated_on_the_lattice_points():
    calls = []

    def f(x, y, z):
        calls.append((x.shape, y.shape, z.shape))
        return x * x + y * y + z * z

    mesh = isoforge.extract(f, 1.0, shape=(33, 33, 33), spacing=(1 / 16,) * 3, origin=(-1.0, -1.0, -1.0))
    assert calls == [((1, 1, 33), (1, 33, 1), (33, 1, 1))]  # once, vectorised
    np.testing.assert_allclose(np.linalg.norm(mesh.vertices, axis=1), 1.0, atol=0.01)
    assert mesh.check()["genus"] == 0


def test_save_and_read_back(tmp_path):
    mesh = isoforge.extract(ball(21, 6.0), 6.0)
    for ext in ("ply", "obj", "stl", "off"):
        path = tmp_path / f"ball.{ext}"
        mesh.save(path)
        assert path.stat().st_size > 0
    text = (tmp_path / "ball.obj").read_text()
    assert text.count("\nf ") + text.startswith("f ") == len(mesh.faces)
    with pytest.raises(ValueError, match="xyz"):
        mesh.save(tmp_path / "ball.xyz")


def test_read_volume_keeps_the_dtype_and_geometry():
    arr, lat = isoforge.read_volume(TESTDATA / "i16_gzip.nrrd")
    assert arr.dtype == np.int16 and arr.ndim == 3
    nx, ny, nz = lat["dims"]
    assert arr.shape == (nz, ny, nx)
    assert len(lat["spacing"]) == 3 and len(lat["origin"]) == 3
    # The file through extract gives the same mesh as its array with its geometry.
    a = isoforge.extract(TESTDATA / "i16_gzip.nrrd", float(arr.mean()), method="mc")
    b = isoforge.extract(arr, float(arr.mean()), method="mc", spacing=lat["spacing"], origin=lat["origin"])
    np.testing.assert_allclose(a.vertices, b.vertices, atol=1e-5)
    np.testing.assert_array_equal(a.faces, b.faces)


def test_errors_are_value_and_memory_errors(tmp_path):
    with pytest.raises(ValueError, match="nope.nrrd"):
        isoforge.read_volume(tmp_path / "nope.nrrd")
    with pytest.raises(ValueError, match="method"):
        isoforge.extract(ball(9, 3.0), 3.0, method="nope")
    with pytest.raises(ValueError, match="3 dimensions|expected 3"):
        isoforge.extract(np.zeros((4, 4)), 0.5)
    with pytest.raises(ValueError, match="shape"):
        isoforge.extract(lambda x, y, z: x, 0.5)
    # A header claiming far more samples than the size limit: refused before allocating.
    big = tmp_path / "big.nrrd"
    big.write_bytes(b"NRRD0004\ntype: float\ndimension: 3\nsizes: 100000 100000 100000\nendian: little\nencoding: raw\n\n")
    with pytest.raises(MemoryError):
        isoforge.read_volume(big)
    with pytest.raises(ValueError, match="faces"):
        isoforge.Mesh(np.zeros((3, 3)), [[0, 1, 5]]).check()


def test_extract_refuses_an_iso_without_surface_as_the_cli_does():
    # isoforge.extract goes through the library's one entry point (pipeline::extract_request):
    # an iso outside the values, or one every point is outside of, is the CLI's sentence.
    vol = ball(9, 3.0)
    with pytest.raises(ValueError, match=r"iso 1000 is outside the value range \["):
        isoforge.extract(vol, 1000.0)
    with pytest.raises(ValueError, match="gives no surface: every lattice point is outside"):
        isoforge.extract(vol, float(vol.min()))


def test_marching_cubes_mask_keeps_the_cells_of_skimage():
    measure = pytest.importorskip("skimage.measure")
    vol = ball(25, 9.0)
    mask = np.ones(vol.shape, bool)
    mask[:12] = False
    mask[:, :, 18:] = False
    for step in (1, 2):
        a = measure.marching_cubes(vol, 9.0, mask=mask, step_size=step, method="lorensen")
        b = isoforge.marching_cubes(vol, 9.0, mask=mask, step_size=step, method="lorensen")
        assert a[0].shape == b[0].shape and a[1].shape == b[1].shape
        np.testing.assert_allclose(a[0][np.lexsort(a[0].T)], b[0][np.lexsort(b[0].T)], atol=1e-5)


def test_find_contours_same_points_in_the_same_order_as_skimage():
    measure = pytest.importorskip("skimage.measure")
    rng = np.random.default_rng(3)
    image = rng.random((30, 40))
    image[rng.random(image.shape) < 0.05] = np.nan
    mask = rng.random(image.shape) > 0.05
    for fc in ("low", "high"):
        for po in ("low", "high"):
            for m in (None, mask):
                a = measure.find_contours(image, 0.5, fc, po, mask=m)
                b = isoforge.find_contours(image, 0.5, fc, po, mask=m)
                assert len(a) == len(b) > 10
                for x, y in zip(a, b):
                    np.testing.assert_array_equal(x, y)


def test_sharp_methods_come_closer_to_a_cubes_corners_and_stay_manifold():
    # A cube as a grid: emc and dc place vertices where the crossings' tangent planes meet, closer
    # to the corners than mc's edge crossings (mc: 0.99 cells, emc and dc: 0.58 here); on a grid
    # the normals are central differences, which blur a corner's three planes within a cell of
    # it (fields with exact gradients put the corners on the mesh: tests/dual_contouring.rs).
    # Both closed, manifold, genus 0 (MC33's topology).
    n, h = 40, 9.5
    z, y, x = np.mgrid[:n, :n, :n].astype(np.float32) - (n - 1) / 2 + 0.3
    cube = np.maximum(np.maximum(np.abs(x), np.abs(y)), np.abs(z))
    corners = np.array([[sx, sy, sz] for sx in (-h, h) for sy in (-h, h) for sz in (-h, h)]) + (n - 1) / 2 - 0.3
    worst = {}
    for method in ["mc", "emc", "dc"]:
        mesh = isoforge.extract(cube, h, method=method)
        rep = mesh.check()
        assert rep["closed"] and rep["manifold"] and rep["oriented"] and rep["genus"] == 0, method
        v = mesh.vertices
        worst[method] = max(np.min(np.linalg.norm(v - c, axis=1)) for c in corners)
    assert worst["emc"] < 0.7 * worst["mc"] and worst["dc"] < 0.7 * worst["mc"] and worst["mc"] > 0.5, worst


DTYPES = [np.uint8, np.int8, np.uint16, np.int16, np.uint32, np.int32, np.float32, np.float64]


def layouts(vol):
    """The same (z, y, x) values in every layout numpy makes: Fortran order, steps, negative
    strides, a transposed copy (read slab by slab from where they are), and an unaligned copy
    (copied into a grid first)."""
    big = np.zeros((2 * vol.shape[0], vol.shape[1], 2 * vol.shape[2]), vol.dtype)
    big[::2, :, ::2] = vol
    rev = np.ascontiguousarray(vol[::-1, :, ::-1])
    yield "F", np.asfortranarray(vol)
    yield "stepped", big[::2, :, ::2]
    yield "reversed", rev[::-1, :, ::-1]
    yield "transposed", np.ascontiguousarray(vol.transpose(1, 2, 0)).transpose(2, 0, 1)
    # Unaligned: the samples one byte into a buffer (uint8/int8 are always aligned).
    raw = np.zeros(vol.nbytes + 1, np.uint8)
    unaligned = np.frombuffer(raw.data, vol.dtype, vol.size, offset=1).reshape(vol.shape)
    unaligned[...] = vol
    yield "unaligned", unaligned


@pytest.mark.parametrize("dtype", DTYPES)
def test_marching_cubes_walks_every_layout_in_place_as_its_copy(dtype):
    # Issue 48's zero copy: C-ordered arrays are walked where numpy keeps them, other layouts
    # read slab by slab from where they are; all give exactly the arrays of the copy's walk.
    vol = (ball(23, 8.0) * 5).astype(dtype)
    level = 40.5
    assert vol.flags.c_contiguous
    for method in ("lewiner", "lorensen"):
        want = isoforge.marching_cubes(vol, level, spacing=(1.0, 0.5, 2.0), method=method)
        assert len(want[1]) > 0
        for name, view in layouts(vol):
            np.testing.assert_array_equal(view, vol)
            got = isoforge.marching_cubes(view, level, spacing=(1.0, 0.5, 2.0), method=method)
            for g, w, what in zip(got, want, ("verts", "faces", "normals", "values")):
                np.testing.assert_array_equal(g, w, err_msg=f"{name} {method} {what}")
    # A broadcast (stride 0 along z) against its copy, and a mask on a Fortran-ordered array.
    plane = (ball(23, 8.0)[11] * 5).astype(dtype)
    wide = np.broadcast_to(plane, (6,) + plane.shape)
    a = isoforge.marching_cubes(wide, level)
    b = isoforge.marching_cubes(np.ascontiguousarray(wide), level)
    assert len(b[1]) > 0
    for g, w in zip(a, b):
        np.testing.assert_array_equal(g, w)
    mask = np.zeros(vol.shape, bool)
    mask[:, :12] = True
    a = isoforge.marching_cubes(np.asfortranarray(vol), level, mask=mask)
    b = isoforge.marching_cubes(vol, level, mask=mask)
    assert 0 < len(b[1]) < len(want[1])
    for g, w in zip(a, b):
        np.testing.assert_array_equal(g, w)


@pytest.mark.parametrize("dtype", DTYPES)
def test_extract_walks_every_layout_in_place_as_its_copy(dtype):
    # Issue 48: `extract` reads arrays where numpy keeps them too (a borrowed-samples source of
    # the library's entry point): the same mesh in every layout, the same value-range refusal.
    vol = (ball(23, 8.0) * 5).astype(dtype)
    for method in ("mc33", "mt6", "dc"):
        want = isoforge.extract(vol, 40.5, method=method, spacing=(1.0, 0.5, 2.0), origin=(1.0, 2.0, 3.0))
        assert len(want.faces) > 0
        for name, view in layouts(vol):
            got = isoforge.extract(view, 40.5, method=method, spacing=(1.0, 0.5, 2.0), origin=(1.0, 2.0, 3.0))
            for what in ("vertices", "faces", "normals"):
                np.testing.assert_array_equal(getattr(got, what), getattr(want, what), err_msg=f"{name} {method}")
    with pytest.raises(ValueError) as c_order:
        isoforge.extract(vol, 500.0)
    with pytest.raises(ValueError) as fortran:
        isoforge.extract(np.asfortranarray(vol), 500.0)
    assert str(c_order.value) == str(fortran.value) and "500" in str(fortran.value)
