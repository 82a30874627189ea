"""isoforge.marching_cubes against skimage.measure.marching_cubes from Python, in one process:
median wall time of 5 runs each, rounds interleaved, on a 256³ float32 volume of sines (the same
1.7 M triangles from both). A first slice of issue 48's table (PyMCubes, VTK, 512³, the real CTs and
peak RSS are not measured yet).

    python bench/peers/python_vs_skimage.py [n] [threads]
"""

import statistics
import sys
import time

import numpy as np
from skimage import measure

import isoforge

n = int(sys.argv[1]) if len(sys.argv) > 1 else 256
threads = int(sys.argv[2]) if len(sys.argv) > 2 else 2
z, y, x = np.ogrid[:n, :n, :n]
f = lambda a: a * 2 * np.pi / n  # noqa: E731
vol = (np.sin(f(x) * 3) * np.cos(f(y) * 2) + np.sin(f(z) * 4) * 0.7).astype(np.float32)
runs = {}
for _ in range(5):
    for m in ("lorensen", "lewiner"):
        for lib, fn in (("skimage", measure.marching_cubes), ("isoforge", isoforge.marching_cubes)):
            kw = {"threads": threads} if lib == "isoforge" else {}
            s = time.perf_counter()
            out = fn(vol, 0.1, method=m, **kw)
            runs.setdefault((m, lib), []).append(time.perf_counter() - s)
            runs[(m, lib, "tris")] = len(out[1])
print(f"| method | scikit-image (ms) | isoforge, {threads} threads (ms) | ratio | triangles |")
print("|---|---|---|---|---|")
for m in ("lorensen", "lewiner"):
    a, b = statistics.median(runs[(m, "skimage")]), statistics.median(runs[(m, "isoforge")])
    print(f"| {m} | {a * 1e3:.0f} | {b * 1e3:.0f} | {a / b:.1f}x | {runs[(m, 'isoforge', 'tris')]:,} |")
