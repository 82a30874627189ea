"""isoforge.voxelize and isoforge.repair (issue 46's library API from Python): a torus mesh with
holes and flipped faces voxelizes with every point away from the surface on the right side, and
repairs to a closed, manifold, oriented genus-1 mesh."""

import numpy as np
import pytest

import isoforge

R, r = 0.55, 0.25


def torus_distance(x, y, z):
    return np.sqrt((np.sqrt(x * x + y * y) - R) ** 2 + z * z) - r


def damaged_torus():
    m = isoforge.extract(torus_distance, 0.0, shape=(40, 40, 40), spacing=(0.05,) * 3, origin=(-1.0,) * 3)
    rng = np.random.default_rng(7)
    faces = m.faces.copy()
    keep = rng.random(len(faces)) > 0.05  # 5 % holes
    faces = faces[keep]
    flip = rng.random(len(faces)) < 0.05  # 5 % flipped
    faces[flip] = faces[flip][:, ::-1]
    return m.vertices, faces


def test_voxelize_puts_every_point_away_from_the_surface_on_its_side():
    v, f = damaged_torus()
    occupancy, lattice = isoforge.voxelize(v, f, resolution=48, values="occupancy")
    assert occupancy.dtype == np.uint8
    nx, ny, nz = lattice["dims"]
    assert occupancy.shape == (nz, ny, nx)
    h = lattice["spacing"][0]
    ox, oy, oz = lattice["origin"]
    z, y, x = np.meshgrid(oz + h * np.arange(nz), oy + h * np.arange(ny), ox + h * np.arange(nx), indexing="ij")
    d = torus_distance(x, y, z)
    far = np.abs(d) > 1.5 * h
    assert far.sum() > 10_000
    assert np.array_equal(occupancy[far] == 1, d[far] < 0)
    sdf, same = isoforge.voxelize(v, f, resolution=48)
    assert sdf.dtype == np.float32 and same == lattice
    assert np.array_equal(sdf[far] < 0, d[far] < 0)


def test_repair_closes_the_torus_with_its_genus():
    v, f = damaged_torus()
    before = isoforge.Mesh(v, f).check()
    assert not before["closed"]
    fixed = isoforge.repair(isoforge.Mesh(v, f), resolution=64)
    report = fixed.check()
    assert report["closed"] and report["manifold"] and report["oriented"], report
    assert report["genus"] == 1 and report["components"] == 1, report


def test_bad_arguments_are_value_errors():
    v, f = damaged_torus()
    with pytest.raises(ValueError, match="values"):
        isoforge.voxelize(v, f, values="density")
    with pytest.raises(ValueError, match="band"):
        isoforge.voxelize(v, f, band=0.0)
    with pytest.raises(ValueError):
        isoforge.voxelize(v, f[:0])
    with pytest.raises(ValueError, match="Mesh, or vertices and faces"):
        isoforge.repair(v)
