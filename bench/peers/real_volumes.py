#!/usr/bin/env python3
"""isoforge vs vtkFlyingEdges3D on the real volumes in ../shared/data/volumes.

For each NRRD (at its sidecar's first suggested iso, or --iso NAME=V): VTK's triangle and point
counts and world bounds (spacing and origin from the file), isoforge's counts, bounds and mesh check,
and both extraction times (1 thread, median of --repeats). Prints a markdown table.

    PY=${PEERS_VENV:-/tmp/peers-venv}/bin/python
    $PY bench/peers/real_volumes.py --isoforge target/release/isoforge [--data ../shared/data/volumes]
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

from nrrd_io import read_nrrd

def vtk_flying_edges(arr, spacing, origin, iso, repeats):
    from vtkmodules.util import numpy_support
    from vtkmodules.vtkCommonCore import vtkSMPTools
    from vtkmodules.vtkCommonDataModel import vtkImageData
    from vtkmodules.vtkFiltersCore import vtkFlyingEdges3D
    smp = vtkSMPTools()
    smp.SetBackend("STDThread")
    smp.Initialize(1)
    img = vtkImageData()
    img.SetDimensions(arr.shape[2], arr.shape[1], arr.shape[0])
    img.SetSpacing(*spacing)
    img.SetOrigin(*origin)
    img.GetPointData().SetScalars(numpy_support.numpy_to_vtk(np.ascontiguousarray(arr).ravel(), deep=True))
    times = []
    for _ in range(repeats):
        fe = vtkFlyingEdges3D()
        fe.SetInputData(img)
        fe.SetValue(0, iso)
        fe.ComputeNormalsOff()
        fe.ComputeGradientsOff()
        fe.ComputeScalarsOff()
        t = time.perf_counter()
        fe.Update()
        times.append(time.perf_counter() - t)
    out = fe.GetOutput()
    return out.GetNumberOfPoints(), out.GetNumberOfCells(), out.GetBounds(), statistics.median(times)


def isoforge_run(exe, path, iso, repeats, tmp):
    ply, tj = os.path.join(tmp, "m.ply"), os.path.join(tmp, "t.json")
    times = []
    for _ in range(repeats):
        subprocess.run([exe, "extract", "-i", path, "--iso", repr(iso), "-o", ply, "--time-json", tj,
                        "--normals", "none", "--threads", "1", "--method", "mc"], check=True, capture_output=True)
        times.append(json.load(open(tj))["seconds"])
    rep = json.loads(subprocess.run([exe, "check", ply, "--json", "--examples", "1000000"], capture_output=True, check=False).stdout)
    return rep, statistics.median(times)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser()
    ap.add_argument("--isoforge", required=True)
    ap.add_argument("--data", default=os.path.join(here, "../../../shared/data/volumes"))
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    if not os.path.isdir(args.data):
        print(f"skipping: {args.data} is absent", file=sys.stderr)
        return
    rows = []
    for name in sorted(os.listdir(args.data)):
        if not name.endswith(".nrrd"):
            continue
        path = os.path.join(args.data, name)
        side = json.load(open(path[:-5] + ".json"))
        sugg = side.get("iso_suggestions") or [{"value": round(side["otsu_threshold"], 2)}]
        iso = float(sugg[0]["value"])
        arr, spacing, origin = read_nrrd(path)
        vp, vt, vb, vs = vtk_flying_edges(arr, spacing, origin, iso, args.repeats)
        with tempfile.TemporaryDirectory() as tmp:
            rep, isec = isoforge_run(args.isoforge, path, iso, args.repeats, tmp)
        # Boundary edges on the lattice faces only (open@faces), as the peer harness defines it.
        lo = [origin[a] for a in range(3)]
        hi = [origin[a] + spacing[a] * (arr.shape[2 - a] - 1) for a in range(3)]
        inside = 0
        for e in rep["findings"]["boundary_edges"]["examples"]:
            m = e["midpoint"]
            if not any(abs(m[a] - lo[a]) < 1e-3 * spacing[a] or abs(m[a] - hi[a]) < 1e-3 * spacing[a] for a in range(3)):
                inside += 1
        closed = "yes" if rep["closed"] else ("open@faces" if inside == 0 else f"no ({inside} inside)")
        ib = rep["bounds"]
        dbound = max(max(abs(ib["min"][a] - vb[2 * a]), abs(ib["max"][a] - vb[2 * a + 1])) for a in range(3)) if ib else float("nan")
        rows.append((name, iso, vt, rep["triangles"], vp, rep["vertices"], dbound, closed, rep["manifold"], rep["oriented"], vs, isec))
        print(f"{name}: VTK {vt} tris, isoforge {rep['triangles']} tris", file=sys.stderr)
    print("| volume | iso | VTK FlyingEdges3D triangles | isoforge triangles | VTK points | isoforge vertices | max bounds diff | closed | manifold | oriented | VTK 1T ms | isoforge 1T ms |")
    print("|---|---:|---:|---:|---:|---:|---:|---|---|---|---:|---:|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]:,} | {r[3]:,}{'' if r[2] == r[3] else ' ≠'} | {r[4]:,} | {r[5]:,} | {r[6]:.2e} | {r[7]} | {r[8]} | {r[9]} | {r[10] * 1e3:.1f} | {r[11] * 1e3:.1f} |")


if __name__ == "__main__":
    main()
