"""isoforge.dask on a LocalCluster (1 and 2 worker processes, loopback) against isoforge.extract on
one machine, on a 256³ float32 gyroid (or a volume file): medians of --repeat runs, the mesh
checked equal to the single-machine one (vertex count, watertight). BENCHMARKS.md §18.

    python python/bench/bench_dask.py [--n 256] [--chunks 64] [--repeat 3] [--volume FILE --iso V] [--steps]

--steps times the distributed run's steps in this process instead (no Dask): the halo reads from
the Zarr store, the chunk walks, the stitch levels.
"""

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import dask.array as da
import distributed
import zarr

import isoforge
import isoforge.dask
from isoforge import _isoforge


def gyroid(n):
    t = np.linspace(0.0, 4.0 * np.pi, n, dtype=np.float32)
    z, y, x = t[:, None, None], t[None, :, None], t[None, None, :]
    return np.sin(x) * np.cos(y) + np.sin(y) * np.cos(z) + np.sin(z) * np.cos(x)


def median_time(f, repeat):
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = f()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--chunks", type=int, default=64)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--method", default="mc33")
    ap.add_argument("--volume")
    ap.add_argument("--iso", type=float, default=0.0)
    ap.add_argument("--steps", action="store_true")
    a = ap.parse_args()
    if a.volume:
        volume, _ = isoforge.read_volume(a.volume)
    else:
        volume = gyroid(a.n)
    print(f"volume {volume.shape} {volume.dtype}, iso {a.iso}, {a.method}, chunks {a.chunks}³ points")
    t, whole = median_time(lambda: isoforge.extract(volume, a.iso, method=a.method, threads=2), a.repeat)
    print(f"isoforge.extract, 2 threads: {t:.3f} s ({len(whole.vertices)} vertices, {len(whole.faces)} triangles)")
    path = Path(tempfile.mkdtemp()) / "bench.zarr"
    store = zarr.open_array(str(path), mode="w", shape=volume.shape, chunks=(a.chunks,) * 3, dtype=volume.dtype)
    store[...] = volume
    store = zarr.open_array(str(path), mode="r")
    if a.steps:
        steps(store, volume, a)
        return
    for workers in (1, 2):
        with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                                      dashboard_address=None) as cluster, distributed.Client(cluster) as client:
            sources = (("zarr store", store, None), ("numpy array (scattered)", volume, a.chunks),
                       ("dask array (from_array)", da.from_array(volume, chunks=a.chunks), None))
            for name, src, chunks in sources:
                t, mesh = median_time(lambda: isoforge.dask.extract(src, a.iso, method=a.method, client=client,
                                                                    chunks=chunks), a.repeat)
                ok = len(mesh.vertices) == len(whole.vertices) and len(mesh.faces) == len(whole.faces)
                print(f"LocalCluster {workers} worker(s) × 1 thread, {name}: {t:.3f} s (equal counts: {ok})")


def steps(store, volume, a):
    nz, ny, nx = volume.shape
    sizes = [isoforge.dask._axis_sizes(n, a.chunks) for n in (nz, ny, nx)]
    bz, by, bx = (isoforge.dask._cell_bounds(n, c) for n, c in zip((nz, ny, nx), sizes))
    boxes = [((x0, y0, z0), (x1, y1, z1)) for z0, z1 in zip(bz, bz[1:]) for y0, y1 in zip(by, by[1:])
             for x0, x1 in zip(bx, bx[1:])]
    dims = (nx, ny, nz)
    t0 = time.perf_counter()
    for lo, hi in boxes:
        h_lo = [max(lo[i] - 2, 0) for i in range(3)]
        h_hi = [min(hi[i] + 2, dims[i]) for i in range(3)]
        store[h_lo[2]:h_hi[2], h_lo[1]:h_hi[1], h_lo[0]:h_hi[0]]
    t1 = time.perf_counter()
    parts = [isoforge.dask._chunk_task(volume, lo, hi, dims, a.iso, a.method, (1.0,) * 3, (0.0,) * 3, True, 1)
             for lo, hi in boxes]
    t2 = time.perf_counter()
    level = [_isoforge.stitch(parts[i:i + 8]) for i in range(0, len(parts), 8)]
    t3 = time.perf_counter()
    final = _isoforge.stitch(level)
    t4 = time.perf_counter()
    print(f"{len(boxes)} chunks: halo reads from the store {t1 - t0:.2f} s, walks (1 thread) {t2 - t1:.2f} s, "
          f"stitch level 1 {t3 - t2:.2f} s, level 2 {t4 - t3:.2f} s; keys {sum(len(p[3]) for p in parts)} in, "
          f"{len(final[3])} after; {len(final[0])} vertices")


if __name__ == "__main__":
    main()
