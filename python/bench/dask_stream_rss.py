"""isoforge.dask with the welded mesh streamed to a PLY (out=) or stitched on the cluster and
returned: the caller's and each worker's peak RSS, and the time (issue 48, BENCHMARKS.md §24).

    python python/bench/dask_stream_rss.py prepare DIR [--n 256] [--chunks 64]   # the Zarr store
    python python/bench/dask_stream_rss.py stitched|out DIR                      # one run

A LocalCluster of 2 worker processes, 1 thread each, loopback; one process per run, the store
written beforehand so the caller never holds the volume.
"""

import argparse
import resource
import sys
import time
from pathlib import Path

import numpy as np


def peak_mib():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("mode", choices=["prepare", "stitched", "out"])
    ap.add_argument("dir")
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--chunks", type=int, default=64)
    a = ap.parse_args()
    store = Path(a.dir) / "gyroid.zarr"
    import zarr

    if a.mode == "prepare":
        Path(a.dir).mkdir(parents=True, exist_ok=True)
        z = zarr.open_array(str(store), mode="w", shape=(a.n,) * 3, chunks=(a.chunks,) * 3, dtype=np.float32)
        t = np.linspace(0.0, 4.0 * np.pi, a.n, dtype=np.float32)
        y, x = t[:, None], t[None, :]
        for k in range(a.n):
            z[k] = np.sin(x) * np.cos(y) + np.sin(y) * np.cos(t[k]) + np.sin(t[k]) * np.cos(x)
        return
    import distributed

    import isoforge.dask

    array = zarr.open_array(str(store), mode="r")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        base = peak_mib()
        t0 = time.perf_counter()
        if a.mode == "out":
            result = isoforge.dask.extract(array, 0.0, client=client, out=Path(a.dir) / "gyroid.ply")
        else:
            mesh = isoforge.dask.extract(array, 0.0, client=client)
            result = {"vertices": len(mesh.vertices), "triangles": len(mesh.faces)}
        dt = time.perf_counter() - t0
        workers = client.run(lambda: resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024)
    print(f"{a.mode}: {result}, {dt:.2f} s; caller peak RSS over its baseline {peak_mib() - base:.0f} MiB; "
          f"worker peaks {sorted(workers.values())} MiB", file=sys.stdout)


if __name__ == "__main__":
    main()
