#!/usr/bin/env python3
"""vtkFlyingEdges3D's warm loop alone, on a raw float32 cube: what one process pays per run.

    python bench/peers/vtk_warm_loop.py /tmp/peers-data/gyroid_256.raw 256 THREADS [ISO]

Prints the median and minimum of 15 timed runs (after one untimed) and the triangle count. Run it
once as is and once with glibc told to keep freed memory
(GLIBC_TUNABLES=glibc.malloc.arena_max=1:glibc.malloc.mmap_max=0:glibc.malloc.trim_threshold=1000000000000)
to see what first touch of the output costs VTK's warm runs (docs/BENCHMARKS.md §6.10).
"""
import sys
import time

import numpy as np
import vtk
from vtk.util import numpy_support


def main():
    path, n, threads = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    iso = float(sys.argv[4]) if len(sys.argv) > 4 else 0.0
    samples = np.fromfile(path, dtype="<f4")
    if samples.size != n**3:
        raise SystemExit(f"{path}: {samples.size} samples, expected {n}³")
    img = vtk.vtkImageData()
    img.SetDimensions(n, n, n)
    img.GetPointData().SetScalars(numpy_support.numpy_to_vtk(samples, deep=0))
    vtk.vtkSMPTools.SetBackend("STDThread")
    vtk.vtkSMPTools.Initialize(threads)
    fe = vtk.vtkFlyingEdges3D()
    fe.SetInputData(img)
    fe.SetValue(0, iso)
    fe.ComputeNormalsOff()
    fe.ComputeGradientsOff()
    fe.ComputeScalarsOff()
    times = []
    for _ in range(16):
        fe.Modified()
        t = time.perf_counter()
        fe.Update()
        times.append(time.perf_counter() - t)
    timed = sorted(times[1:])
    print(f"threads {threads}: median {timed[len(timed) // 2] * 1e3:.1f} ms, "
          f"min {timed[0] * 1e3:.1f} ms, {fe.GetOutput().GetNumberOfCells()} triangles")


if __name__ == "__main__":
    main()
