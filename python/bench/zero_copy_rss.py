"""Peak RSS of isoforge.marching_cubes on a 256³ float32 ball, walked in place (C order) or copied
first (F order): `python python/bench/zero_copy_rss.py C` (or F), one process per run (issue 48)."""
import resource, sys, time
import numpy as np
import isoforge
n = 256
y, x = np.ogrid[:n, :n]
vol = np.empty((n, n, n), dtype=np.float32, order=sys.argv[1])
for k in range(n):  # plane by plane: no temporary larger than a plane
    vol[k] = np.sqrt((x - 127.5) ** 2 + (y - 127.5) ** 2 + (k - 127.5) ** 2)
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t = time.perf_counter()
v, f, nrm, val = isoforge.marching_cubes(vol, 100.0, threads=2)
dt = time.perf_counter() - t
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(sys.argv[1], "order: peak RSS over the input's", (peak - base) // 1024, "MiB;", len(f), "triangles;", f"{dt:.2f} s")
