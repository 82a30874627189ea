#!/usr/bin/env python3
"""VTK's file-to-file pipeline, the peer of `isoforge extract CT.nrrd --iso V -o out.ply`.

vtkNrrdReader -> vtkFlyingEdges3D (iso V; normals, gradients and scalars off) -> vtkPLYWriter
(binary; vtkSTLWriter (binary) for an .stl output, vtkOBJWriter for .obj), with vtkSMPTools'
STDThread backend at --threads N. One run per process (end_to_end.py
starts a fresh process for every repetition). Prints one JSON line on stdout: the stage times
(read, extract, write, seconds from process start to the end of the write), points and triangles.

    $PY bench/peers/e2e_vtk.py CT.nrrd --iso 988.37 -o out.ply --threads 1
"""
import time

T0 = time.perf_counter()  # before the VTK imports: they are part of the pipeline's cost

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402

from vtkmodules.vtkCommonCore import vtkSMPTools  # noqa: E402
from vtkmodules.vtkFiltersCore import vtkFlyingEdges3D  # noqa: E402
from vtkmodules.vtkIOImage import vtkNrrdReader  # noqa: E402
from vtkmodules.vtkIOPLY import vtkPLYWriter  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("input")
    ap.add_argument("--iso", type=float, required=True)
    ap.add_argument("-o", "--output", required=True)
    ap.add_argument("--threads", type=int, default=1)
    a = ap.parse_args()

    smp = vtkSMPTools()
    if not smp.SetBackend("STDThread"):
        sys.exit("VTK lacks the STDThread SMP backend")
    smp.Initialize(a.threads)
    t_import = time.perf_counter()

    reader = vtkNrrdReader()
    reader.SetFileName(a.input)
    reader.Update()
    img = reader.GetOutput()
    if img.GetNumberOfPoints() == 0:
        sys.exit(f"{a.input}: vtkNrrdReader read no points")
    t_read = time.perf_counter()

    fe = vtkFlyingEdges3D()
    fe.SetInputData(img)
    fe.SetValue(0, a.iso)
    fe.ComputeNormalsOff()
    fe.ComputeGradientsOff()
    fe.ComputeScalarsOff()
    fe.Update()
    mesh = fe.GetOutput()
    t_extract = time.perf_counter()

    ext = a.output.rsplit(".", 1)[-1].lower()
    if ext == "stl":
        from vtkmodules.vtkIOGeometry import vtkSTLWriter
        w = vtkSTLWriter()
        w.SetFileTypeToBinary()
    elif ext == "obj":
        from vtkmodules.vtkIOGeometry import vtkOBJWriter
        w = vtkOBJWriter()
    else:
        w = vtkPLYWriter()
        w.SetFileTypeToBinary()
    w.SetInputData(mesh)
    w.SetFileName(a.output)
    if w.Write() != 1:
        sys.exit(f"{a.output}: {w.GetClassName()} failed")
    t_write = time.perf_counter()

    print(json.dumps({
        "import_s": t_import - T0,
        "read_s": t_read - t_import,
        "extract_s": t_extract - t_read,
        "write_s": t_write - t_extract,
        "total_s": t_write - T0,
        "points": mesh.GetNumberOfPoints(),
        "triangles": mesh.GetNumberOfCells(),
        "smp_threads": smp.GetEstimatedNumberOfThreads(),
    }))


if __name__ == "__main__":
    try:
        main()
    except SystemExit as e:
        if isinstance(e.code, str):  # one-line errors exit 2, as isoforge's
            print(e.code, file=sys.stderr)
            sys.exit(2)
        raise
