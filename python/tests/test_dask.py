"""isoforge.dask: chunked extraction on Dask (threads and a 2-process LocalCluster) and Zarr
equals isoforge.extract on the whole array exactly: the same vertices bit for bit, the same
triangles up to renumbering, no seam vertex left unwelded (issue 48)."""

from pathlib import Path

import numpy as np
import pytest

dask = pytest.importorskip("dask")
da = pytest.importorskip("dask.array")

import isoforge  # noqa: E402
import isoforge.dask as idask  # noqa: E402
from isoforge import _isoforge  # noqa: E402

METHODS = ["mc", "mc33", "dc", "surface-nets"]
CT = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "volumes" / "vtk_headsq_quarter.nrrd"


def shapes(nz=41, ny=38, nx=47):
    """Two spheres and a torus (signed distances, float32), x the last axis."""
    z, y, x = np.mgrid[0:nz, 0:ny, 0:nx].astype(np.float64)
    s1 = np.sqrt((x - 12.3) ** 2 + (y - 17.1) ** 2 + (z - 19.6) ** 2) - 8.2
    s2 = np.sqrt((x - 31.5) ** 2 + (y - 19.4) ** 2 + (z - 21.2) ** 2) - 9.1
    ring = np.sqrt((x - 23.4) ** 2 + (y - 19.2) ** 2)
    torus = np.sqrt((ring - 12.6) ** 2 + (z - 4.5) ** 2) - 3.3
    return np.minimum(np.minimum(s1, s2), torus).astype(np.float32)


def canonical(mesh):
    """(sorted unique vertex bit patterns, their normals' bits, triangles as sorted rows of
    canonical vertex ids each rotated to start at its least id, orientation kept)."""
    v = np.ascontiguousarray(mesh.vertices).view(np.uint32).reshape(-1, 3)
    rows = v.view(np.dtype((np.void, 12))).ravel()
    uniq, first, inv = np.unique(rows, return_index=True, return_inverse=True)
    assert len(uniq) == len(rows), f"{len(rows) - len(uniq)} vertices share their coordinates (unwelded seams)"
    inv = inv.ravel()
    normals = np.ascontiguousarray(mesh.normals).view(np.uint32).reshape(-1, 3)[first]
    f = inv[mesh.faces]
    r = np.argmin(f, axis=1)
    f = np.stack([f[np.arange(len(f)), (r + k) % 3] for k in range(3)], axis=1)
    f = f[np.lexsort(f.T[::-1])]
    return v[first], normals, f


def assert_same_mesh(got, want, closed=True):
    """`got` equals `want` (canonical forms), and seams add no boundary edge: both watertight
    (`closed`), or the same boundary (a scan whose surface leaves the volume)."""
    assert len(got.vertices) == len(want.vertices)
    assert len(got.faces) == len(want.faces)
    gv, gn, gf = canonical(got)
    wv, wn, wf = canonical(want)
    np.testing.assert_array_equal(gv, wv)
    np.testing.assert_array_equal(gf, wf)
    np.testing.assert_array_equal(gn, wn)
    g, w = got.check(), want.check()
    assert g["boundary_edges"] == w["boundary_edges"] and g["watertight"] == w["watertight"], g
    if closed:
        assert g["watertight"] and g["boundary_edges"] == 0, g


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("chunks", [17, 32, (13, 20, 9)])
def test_threaded_dask_equals_the_whole_extraction(method, chunks):
    vol = shapes()
    want = isoforge.extract(vol, 0.0, method=method, spacing=(0.5, 0.7, 1.25), origin=(-3.0, 2.0, 0.5))
    assert len(want.faces) > 1000 and want.check()["components"] == 3
    with dask.config.set(scheduler="threads"):
        got = idask.extract(da.from_array(vol, chunks=chunks), 0.0, method=method, spacing=(0.5, 0.7, 1.25),
                            origin=(-3.0, 2.0, 0.5))
    assert_same_mesh(got, want)


def test_numpy_input_uneven_chunks_and_a_binary_stitch_tree():
    vol = (shapes() < 0.0).astype(np.uint8)
    want = isoforge.extract(vol, 0.5, method="mc33")
    with dask.config.set(scheduler="synchronous"):
        got = idask.extract(vol, 0.5, method="mc33", chunks=((20, 21), (5, 30, 3), (46, 1)), fan_in=2)
    assert_same_mesh(got, want)


@pytest.mark.skipif(not CT.exists(), reason="the shared CT volumes are not here")
@pytest.mark.parametrize("method", ["mc33", "dc"])
def test_real_ct_in_chunks(method):
    vol, lattice = isoforge.read_volume(CT)
    want = isoforge.extract(vol, 500.5, method=method, spacing=lattice["spacing"])
    with dask.config.set(scheduler="threads"):
        got = idask.extract(da.from_array(vol, chunks=(30, 25, 29)), 500.5, method=method,
                            spacing=lattice["spacing"])
    assert len(want.faces) > 50000
    assert_same_mesh(got, want, closed=False)


@pytest.fixture(scope="module")
def client():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as c:
        yield c


@pytest.mark.parametrize("method", METHODS)
def test_local_cluster_equals_the_whole_extraction(client, method):
    vol = shapes()
    want = isoforge.extract(vol, 0.0, method=method)
    got = idask.extract(da.from_array(vol, chunks=(17, 32, 17)), 0.0, method=method, client=client)
    assert_same_mesh(got, want)
    # Both workers ran chunk tasks.
    assert len(client.scheduler_info()["workers"]) == 2


def test_local_cluster_numpy_array_scattered_once(client):
    vol = shapes()
    want = isoforge.extract(vol, 0.0, method="mc33")
    assert_same_mesh(idask.extract(vol, 0.0, method="mc33", chunks=(20, 16, 25), client=client), want)


def zarr_store(path, vol, chunks, zarr_format=None):
    zarr = pytest.importorskip("zarr")
    fmt = {} if zarr_format is None else {"zarr_format": zarr_format}
    z = zarr.open_array(str(path), mode="w", shape=vol.shape, chunks=chunks, dtype=vol.dtype, **fmt)
    z[...] = vol
    return zarr.open_array(str(path), mode="r")


@pytest.mark.parametrize("zarr_format", [2, 3])
def test_zarr_store_on_disk_read_region_by_region(tmp_path, client, zarr_format):
    if int(pytest.importorskip("zarr").__version__.split(".")[0]) < 3:
        pytest.skip("written with zarr 3's API (zarr_format=)")
    vol = shapes()
    z = zarr_store(tmp_path / "shapes.zarr", vol, (16, 19, 13), zarr_format)
    assert z.metadata.zarr_format == zarr_format
    want = isoforge.extract(vol, 0.0, method="mc")
    # The store's own chunking, read by the cluster's workers from disk.
    assert_same_mesh(idask.extract(z, 0.0, method="mc", client=client), want)
    # As a dask array over the store, on threads, with other boxes than the store's chunks.
    with dask.config.set(scheduler="threads"):
        assert_same_mesh(idask.extract(da.from_zarr(z), 0.0, method="mc", chunks=23), want)


def test_a_chunk_task_reads_only_its_halo(tmp_path):
    vol = shapes()
    z = zarr_store(tmp_path / "halo.zarr", vol, (8, 8, 8))

    class Recording:
        def __init__(self, inner):
            self.inner, self.reads, self.shape, self.dtype = inner, [], inner.shape, inner.dtype

        def __getitem__(self, key):
            self.reads.append(key)
            return self.inner[key]

    rec = Recording(z)
    part = idask._chunk_task(rec, (10, 0, 20), (20, 9, 40), (47, 38, 41), 0.0, "mc", (1.0,) * 3, (0.0,) * 3, True, 1)
    assert rec.reads == [(slice(18, 41), slice(0, 11), slice(8, 22))]
    assert len(part[0]) > 0 and part[3].shape[1] == 8


def test_bad_arguments_are_value_errors():
    z, y, x = np.mgrid[0:8, 0:9, 0:10].astype(np.float32)
    vol = np.sqrt((x - 5.0) ** 2 + (y - 4.5) ** 2 + (z - 4.0) ** 2) - 3.0
    ok = dict(iso=0.0, method="mc", spacing=(1.0,) * 3, origin=(0.0,) * 3)

    def chunk(array, offset, dims, lo, hi, **kw):
        args = {**ok, **kw}
        return _isoforge.extract_chunk(array, offset, dims, lo, hi, args["iso"], args["method"], args["spacing"],
                                       args["origin"])

    # The whole array holds every range's halo.
    v, f, n, k = chunk(vol, (0, 0, 0), (10, 9, 8), (0, 0, 0), (4, 8, 7))
    assert f.dtype == np.uint32 and k.dtype == np.uint32 and k.shape[1] == 8 and len(k) > 0
    with pytest.raises(ValueError, match="range"):
        chunk(vol, (0, 0, 0), (10, 9, 8), (0, 0, 0), (10, 8, 7))  # past the last cell
    with pytest.raises(ValueError, match="range"):
        chunk(vol, (0, 0, 0), (10, 9, 8), (3, 0, 0), (3, 8, 7))  # empty
    with pytest.raises(ValueError, match="halo"):
        chunk(vol[:, :, 2:], (2, 0, 0), (10, 9, 8), (0, 0, 0), (4, 8, 7))  # misses points 0, 1
    with pytest.raises(ValueError, match="halo"):
        chunk(vol, (1, 0, 0), (10, 9, 8), (0, 0, 0), (4, 8, 7))  # past the lattice
    with pytest.raises(ValueError, match="method"):
        chunk(vol, (0, 0, 0), (10, 9, 8), (0, 0, 0), (4, 8, 7), method="nope")
    with pytest.raises(ValueError, match="iso"):
        chunk(vol, (0, 0, 0), (10, 9, 8), (0, 0, 0), (4, 8, 7), iso=float("nan"))
    with pytest.raises(ValueError, match="dtype"):
        chunk(vol.astype(np.complex64), (0, 0, 0), (10, 9, 8), (0, 0, 0), (4, 8, 7))
    bad_key = k.copy()
    bad_key[0, 1] = 9
    with pytest.raises(ValueError, match="no vertex key"):
        _isoforge.stitch([(v, f, n, bad_key)])
    bad_face = f.copy()
    bad_face[0, 0] = len(v)
    with pytest.raises(ValueError, match="faces"):
        _isoforge.stitch([(v, bad_face, n, k)])
    with pytest.raises(ValueError, match="chunks"):
        idask.extract(vol, 0.0)
    with pytest.raises(ValueError, match="expected a dask"):
        idask.extract([[[0.0]]], 0.0)


def test_stitch_is_associative_on_parts():
    vol = shapes(20, 21, 22)
    dims = (22, 21, 20)
    parts = [_isoforge.extract_chunk(vol, (0, 0, 0), dims, (0, 0, z0), (21, 20, z1), 0.0, "mc33", (1.0,) * 3,
                                     (0.0,) * 3) for z0, z1 in [(0, 6), (6, 13), (13, 19)]]
    flat = _isoforge.stitch(parts)
    tree = _isoforge.stitch([_isoforge.stitch(parts[:2]), parts[2]])
    for a, b in zip(flat, tree):
        np.testing.assert_array_equal(a, b)
    want = isoforge.extract(vol, 0.0, method="mc33")
    assert_same_mesh(isoforge.Mesh(flat[0], flat[1], flat[2]), want, closed=False)



def label_volume():
    """Three labels in uint16 (x the last axis): two blobs touching each other and a slab on the
    volume's x = 0 face, 0 the background."""
    vol = shapes()
    z, y, x = np.mgrid[0:vol.shape[0], 0:vol.shape[1], 0:vol.shape[2]]
    lab = np.zeros(vol.shape, np.uint16)
    lab[vol < 0] = 7
    lab[(vol < 0) & (x > 23)] = 3
    lab[x < 4] = 12
    return lab


def whole_label_mesh(lab, label, method, spacing, origin):
    """The library's label surface (``extract_labels``): the indicator padded by one point of
    background, here negated below -0.5 (the same offsets and gradients as above 0.5)."""
    ind = np.pad(-(lab == label).astype(np.int8), 1)
    o = tuple(origin[a] - spacing[a] for a in range(3))
    return isoforge.extract(ind, -0.5, method=method, spacing=spacing, origin=o)


def read_ply(path):
    """A binary little-endian PLY of float x y z (nx ny nz) and int triangles, as a Mesh."""
    data = Path(path).read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().splitlines()
    nv = int(next(line.split()[2] for line in header if line.startswith("element vertex")))
    nf = int(next(line.split()[2] for line in header if line.startswith("element face")))
    cols = sum(line.startswith("property float") for line in header)
    v = np.frombuffer(data, "<f4", nv * cols, end).reshape(nv, cols)
    f = np.frombuffer(data, [("n", "u1"), ("v", "<i4", 3)], nf, end + v.nbytes)
    assert end + v.nbytes + f.nbytes == len(data) and np.all(f["n"] == 3)
    return isoforge.Mesh(v[:, :3].copy(), f["v"].astype(np.int64), v[:, 3:].copy() if cols == 6 else None)


# Not dc: on touching labels its vertices can coincide (in the whole mesh too), which the
# canonical comparison takes for unwelded seams.
@pytest.mark.parametrize("method", ["mc", "mc33", "mt6"])
def test_labels_each_equal_the_library_s_label_surface(method):
    lab = label_volume()
    spacing, origin = (0.5, 0.7, 1.25), (-3.0, 2.0, 0.5)
    with dask.config.set(scheduler="synchronous"):
        got = idask.extract(da.from_array(lab, chunks=(13, 20, 9)), labels=True, method=method, spacing=spacing,
                            origin=origin)
    assert sorted(got) == [3.0, 7.0, 12.0]
    for label, mesh in got.items():
        want = whole_label_mesh(lab, label, method, spacing, origin)
        assert len(want.faces) > 500
        assert_same_mesh(mesh, want)  # closed, seams welded (0 boundary edges)
    with dask.config.set(scheduler="synchronous"):
        only = idask.extract(lab, labels=[12], chunks=17, method=method)
        assert list(only) == [12.0]
        assert_same_mesh(only[12.0], whole_label_mesh(lab, 12, method, (1.0,) * 3, (0.0,) * 3))
        with pytest.raises(ValueError, match="label 5 does not occur"):
            idask.extract(lab, labels=[5, 7], chunks=17)
    with pytest.raises(ValueError, match="an iso or labels"):
        idask.extract(lab, 0.5, labels=True, chunks=17)
    with pytest.raises(ValueError, match="whole numbers"):
        idask.extract(lab, labels=[1.5], chunks=17)


def test_streamed_output_is_the_welded_mesh(tmp_path):
    vol = shapes()
    want = isoforge.extract(vol, 0.0, method="mc33", spacing=(0.5, 0.7, 1.25))
    with dask.config.set(scheduler="synchronous"):
        counts = idask.extract(da.from_array(vol, chunks=(13, 20, 9)), 0.0, method="mc33", spacing=(0.5, 0.7, 1.25),
                               out=tmp_path / "shapes.ply", fan_in=3)
    assert counts == {"vertices": len(want.vertices), "triangles": len(want.faces)}
    assert_same_mesh(read_ply(tmp_path / "shapes.ply"), want)
    # Labels: one file per label.
    lab = label_volume()
    with dask.config.set(scheduler="synchronous"):
        counts = idask.extract(lab, labels=True, chunks=(13, 20, 9), out=str(tmp_path / "label-{label}.ply"))
    assert sorted(counts) == [3.0, 7.0, 12.0]
    for label in counts:
        got = read_ply(tmp_path / f"label-{label:g}.ply")
        assert_same_mesh(got, whole_label_mesh(lab, label, "mc33", (1.0,) * 3, (0.0,) * 3))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["label-12.ply", "label-3.ply", "label-7.ply", "shapes.ply"]


def test_local_cluster_labels_and_streamed_output(client, tmp_path):
    lab = label_volume()
    got = idask.extract(da.from_array(lab, chunks=(17, 32, 17)), labels=True, client=client)
    for label, mesh in got.items():
        assert_same_mesh(mesh, whole_label_mesh(lab, label, "mc33", (1.0,) * 3, (0.0,) * 3))
    vol = shapes()
    idask.extract(da.from_array(vol, chunks=(17, 32, 17)), 0.0, client=client, out=tmp_path / "s.ply")
    assert_same_mesh(read_ply(tmp_path / "s.ply"), isoforge.extract(vol, 0.0))
