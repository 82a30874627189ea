"""Peak RSS of isoforge.marching_cubes on a 256³ float32 ball in one layout, one process per run
(issue 48): `python python/bench/zero_copy_rss.py LAYOUT` with LAYOUT one of
C (C order: walked in place), F (Fortran order), strided (every other plane of a 512×256×256
array), reversed (x and z reversed: negative strides) — the last three are read slab by slab —
or copy (the F-ordered array copied to C order by numpy first: what a copy costs). A second
argument `extract` measures isoforge.extract (mc33, normals) instead of marching_cubes."""
import resource, sys, time
import numpy as np
import isoforge

n = 256
layout = sys.argv[1]
y, x = np.ogrid[:n, :n]
shape = (2 * n, n, n) if layout == "strided" else (n, n, n)
order = "F" if layout in ("F", "copy") else "C"
store = np.empty(shape, dtype=np.float32, order=order)
for k in range(n):  # plane by plane: no temporary larger than a plane
    plane = np.sqrt((x - 127.5) ** 2 + (y - 127.5) ** 2 + (k - 127.5) ** 2)
    if layout == "strided":
        store[2 * k] = plane
    elif layout == "reversed":
        store[n - 1 - k] = plane[:, ::-1]
    else:
        store[k] = plane
vol = {"strided": store[::2], "reversed": store[::-1, :, ::-1]}.get(layout, store)
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t = time.perf_counter()
if layout == "copy":
    vol = np.ascontiguousarray(vol)
if sys.argv[2:] == ["extract"]:
    f = isoforge.extract(vol, 100.0, threads=2).faces
else:
    v, f, nrm, val = isoforge.marching_cubes(vol, 100.0, threads=2)
dt = time.perf_counter() - t
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(layout, " ".join(sys.argv[2:]), "layout: peak RSS over the input's", (peak - base) // 1024, "MiB;", len(f), "triangles;", f"{dt:.2f} s")
