"""isoforge.dask on a LocalCluster (1 and 2 worker processes, loopback) against isoforge.extract on
one machine, on a 256³ float32 gyroid (or a volume file): medians of --repeat runs, the mesh
checked equal to the single-machine one (vertex count, watertight). BENCHMARKS.md §16.

    python python/bench/bench_dask.py [--n 256] [--chunks 64] [--repeat 3] [--volume FILE --iso V]
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


if __name__ == "__main__":
    main()
