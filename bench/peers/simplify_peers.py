#!/usr/bin/env python3
"""isoforge's decimation and smoothing beside VTK, pymeshlab, MeshLib and fast-simplification (issue 49).

For each CT (extracted once by `isoforge extract`, mc33): isoforge decimates within an error bound of
half the smallest spacing (`simplify --max-error`); MeshLib decimates with the same bound (its
`maxError`); VTK's vtkQuadricDecimation, pymeshlab's quadric edge collapse and fast-simplification
are asked for isoforge's triangle count. Every result is written as PLY and measured the same way:
triangles, Hausdorff distance to the undecimated mesh (MeshLib's exact two-sided and one-sided
distances, original → decimated), smallest and mean of the triangles' smallest angles, and
`isoforge check` (manifold, closed, genus, components). Times are the decimation calls alone
(isoforge: its own reported seconds, the file I/O excluded; peers: in process). Smoothing:
isoforge's windowed sinc beside vtkWindowedSincPolyDataFilter (20 iterations, pass band 0.1),
enclosed volume change and time.

    python3 -m venv /tmp/post-venv
    /tmp/post-venv/bin/pip install vtk pymeshlab meshlib fast-simplification trimesh
    /tmp/post-venv/bin/python bench/peers/simplify_peers.py --isoforge target/release/isoforge [--data ../shared/data/volumes]
"""
import argparse
import json
import os
import re
import subprocess
import tempfile
import time

import numpy as np

CTS = [
    ("stanford_bunny_ct_512x512x361.nrrd", "988.37"),
    ("vhp_shoulder_ct_512x512x450.nrrd", "46.3"),
]


def read_ply(path):
    import trimesh
    m = trimesh.load(path, process=False)
    return np.asarray(m.vertices, dtype=np.float64), np.asarray(m.faces, dtype=np.int64)


def write_ply(path, v, f):
    """Binary little-endian PLY of float32 vertices and int32 triangles."""
    v = np.ascontiguousarray(v, dtype="<f4")
    f = np.ascontiguousarray(f, dtype="<i4")
    with open(path, "wb") as out:
        out.write((f"ply\nformat binary_little_endian 1.0\nelement vertex {len(v)}\n"
                   "property float x\nproperty float y\nproperty float z\n"
                   f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n").encode())
        rec = np.empty(len(f), dtype=[("n", "u1"), ("i", "<i4", 3)])
        rec["n"] = 3
        rec["i"] = f
        out.write(v.tobytes())
        out.write(rec.tobytes())


def angles(v, f):
    """Smallest and mean of each triangle's smallest angle, in degrees (zero-area triangles left out)."""
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    la, lb, lc = (np.linalg.norm(b - c, axis=1), np.linalg.norm(c - a, axis=1), np.linalg.norm(a - b, axis=1))
    area2 = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    ok = (area2 > 0) & (la > 0) & (lb > 0) & (lc > 0)
    la, lb, lc = la[ok], lb[ok], lc[ok]
    s = np.minimum(np.minimum(la, lb), lc)
    o1 = np.where(s == la, lb, la)
    o2 = np.where(s == lc, np.where(s == la, lc, lb), lc)
    cos = np.clip((o1 ** 2 + o2 ** 2 - s ** 2) / (2 * o1 * o2), -1, 1)
    ang = np.degrees(np.arccos(cos))
    return float(ang.min()), float(ang.mean())


def mrmesh(v, f):
    import meshlib.mrmeshnumpy as mn
    return mn.meshFromFacesVerts(np.ascontiguousarray(f, dtype=np.int32), np.ascontiguousarray(v, dtype=np.float32))


def hausdorff(ref, out):
    """(two-sided Hausdorff, one-sided original → decimated) by MeshLib's exact point–surface distances."""
    import meshlib.mrmeshpy as mr
    a, b = mrmesh(*ref), mrmesh(*out)
    # findMaxDistanceSqOneWay(A, B): the largest distance from a vertex of B to the surface of A.
    one = mr.findMaxDistanceSqOneWay(mr.MeshPart(b), mr.MeshPart(a)) ** 0.5
    two = mr.findMaxDistanceSq(mr.MeshPart(a), mr.MeshPart(b)) ** 0.5
    return float(two), float(one)


def check(exe, ply):
    r = json.loads(subprocess.run([exe, "check", ply, "--json", "--examples", "0"], capture_output=True).stdout)
    return r


def vtk_polydata(v, f):
    from vtkmodules.util import numpy_support
    from vtkmodules.vtkCommonCore import vtkPoints
    from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData
    pts = vtkPoints()
    pts.SetData(numpy_support.numpy_to_vtk(np.ascontiguousarray(v, dtype=np.float32), deep=True))
    cells = vtkCellArray()
    offsets = np.arange(0, 3 * len(f) + 1, 3, dtype=np.int64)
    cells.SetData(numpy_support.numpy_to_vtkIdTypeArray(offsets, deep=True),
                  numpy_support.numpy_to_vtkIdTypeArray(np.ascontiguousarray(f, dtype=np.int64).ravel(), deep=True))
    pd = vtkPolyData()
    pd.SetPoints(pts)
    pd.SetPolys(cells)
    return pd


def from_vtk(pd):
    from vtkmodules.util import numpy_support
    v = numpy_support.vtk_to_numpy(pd.GetPoints().GetData()).astype(np.float64)
    conn = numpy_support.vtk_to_numpy(pd.GetPolys().GetConnectivityArray()).reshape(-1, 3)
    return v, conn.astype(np.int64)


def vtk_decimate(v, f, target):
    from vtkmodules.vtkFiltersCore import vtkQuadricDecimation
    d = vtkQuadricDecimation()
    d.SetInputData(vtk_polydata(v, f))
    d.SetTargetReduction(1.0 - target / len(f))
    d.VolumePreservationOn()
    t = time.perf_counter()
    d.Update()
    return from_vtk(d.GetOutput()), time.perf_counter() - t


def pymeshlab_decimate(v, f, target):
    import pymeshlab
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(v, f))
    t = time.perf_counter()
    ms.meshing_decimation_quadric_edge_collapse(targetfacenum=int(target), preservetopology=True,
                                                 preserveboundary=True, preservenormal=True)
    dt = time.perf_counter() - t
    m = ms.current_mesh()
    return (m.vertex_matrix().astype(np.float64), m.face_matrix().astype(np.int64)), dt


def meshlib_decimate(v, f, max_error):
    import meshlib.mrmeshnumpy as mn
    import meshlib.mrmeshpy as mr
    m = mrmesh(v, f)
    s = mr.DecimateSettings()
    s.maxError = max_error
    s.packMesh = True
    t = time.perf_counter()
    mr.decimateMesh(m, s)
    dt = time.perf_counter() - t
    return (mn.getNumpyVerts(m).astype(np.float64), mn.getNumpyFaces(m.topology).astype(np.int64)), dt


def fast_simplification_decimate(v, f, target):
    import fast_simplification
    t = time.perf_counter()
    pts, faces = fast_simplification.simplify(v.astype(np.float32), f.astype(np.int32), 1.0 - target / len(f))
    return (np.asarray(pts, dtype=np.float64), np.asarray(faces, dtype=np.int64)), time.perf_counter() - t


def vtk_sinc(v, f):
    from vtkmodules.vtkFiltersCore import vtkWindowedSincPolyDataFilter
    s = vtkWindowedSincPolyDataFilter()
    s.SetInputData(vtk_polydata(v, f))
    s.SetNumberOfIterations(20)
    s.SetPassBand(0.1)
    s.BoundarySmoothingOff()
    s.NonManifoldSmoothingOn()
    s.NormalizeCoordinatesOn()
    t = time.perf_counter()
    s.Update()
    return from_vtk(s.GetOutput()), time.perf_counter() - t


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--isoforge", required=True)
    ap.add_argument("--data", default=os.path.join(os.path.dirname(__file__), "../../../shared/data/volumes"))
    ap.add_argument("--only", help="a substring of the volume names to run")
    ap.add_argument("--threads", default="2")
    args = ap.parse_args()
    exe = os.path.abspath(args.isoforge)
    rows, smooth_rows = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for name, iso in CTS:
            if args.only and args.only not in name:
                continue
            vol = os.path.join(args.data, name)
            meta = json.load(open(vol.replace(".nrrd", ".json")))
            bound = 0.5 * min(meta["spacing"])
            ref_ply = os.path.join(tmp, "ref.ply")
            subprocess.run([exe, "--threads", args.threads, "extract", "-i", vol, "--iso", iso, "-o", ref_ply],
                           check=True, capture_output=True)
            ref = read_ply(ref_ply)
            ref_check = check(exe, ref_ply)
            amin, amean = angles(*ref)
            rows.append((name, "undecimated", len(ref[1]), 0.0, 0.0, amin, amean, ref_check, 0.0))
            # isoforge within the bound.
            out_ply = os.path.join(tmp, "isoforge.ply")
            p = subprocess.run([exe, "--threads", args.threads, "simplify", ref_ply, "-o", out_ply,
                                "--max-error", repr(bound)], check=True, capture_output=True, text=True)
            secs = float(re.search(r"decimated .* in ([0-9.]+) s", p.stderr).group(1))
            results = [("isoforge --max-error", read_ply(out_ply), secs, out_ply)]
            target = len(results[0][1][1])
            for label, fn, arg in [
                ("MeshLib decimateMesh (maxError)", meshlib_decimate, bound),
                ("VTK vtkQuadricDecimation", vtk_decimate, target),
                ("pymeshlab quadric edge collapse", pymeshlab_decimate, target),
                ("fast-simplification", fast_simplification_decimate, target),
            ]:
                try:
                    mesh, dt = fn(*ref, arg)
                except Exception as e:  # a peer missing or failing is reported, not fatal
                    print(f"{name}: {label} failed: {e}")
                    continue
                ply = os.path.join(tmp, re.sub(r"\W+", "_", label) + ".ply")
                write_ply(ply, *mesh)
                results.append((label, mesh, dt, ply))
            for label, mesh, dt, ply in results:
                two, one = hausdorff(ref, mesh)
                amin, amean = angles(*mesh)
                rows.append((name, label, len(mesh[1]), two, one, amin, amean, check(exe, ply), dt))
            # Smoothing.
            sm_ply = os.path.join(tmp, "smooth.ply")
            p = subprocess.run([exe, "--threads", args.threads, "simplify", ref_ply, "-o", sm_ply, "--smooth", "sinc"],
                               check=True, capture_output=True, text=True)
            secs = float(re.search(r"smoothed .* in ([0-9.]+) s", p.stderr).group(1))
            smooth_rows.append((name, "isoforge --smooth sinc (40 terms)", ref_check, check(exe, sm_ply), secs))
            mesh, dt = vtk_sinc(*ref)
            vply = os.path.join(tmp, "vtk_sinc.ply")
            write_ply(vply, *mesh)
            smooth_rows.append((name, "vtkWindowedSincPolyDataFilter (20, 0.1)", ref_check, check(exe, vply), dt))

    print("| volume | tool | triangles | Hausdorff (two-sided) | original → decimated | min angle | mean min angle | manifold | closed | genus | components | seconds |")
    print("|---|---|---:|---:|---:|---:|---:|---|---|---:|---:|---:|")
    for name, label, tris, two, one, amin, amean, r, dt in rows:
        comps = len(r.get("components", []))
        print(f"| {name.split('_')[1]} | {label} | {tris} | {two:.4f} | {one:.4f} | {amin:.2f}° | {amean:.2f}° | "
              f"{'yes' if r['manifold'] else 'no'} | {'yes' if r['closed'] else 'no'} | {r['genus']} | {comps} | {dt:.2f} |")
    print()
    print("| volume | smoothing | volume change | manifold | genus | components | seconds |")
    print("|---|---|---:|---|---:|---:|---:|")
    for name, label, r0, r, dt in smooth_rows:
        dv = 100.0 * (r["volume"] / r0["volume"] - 1.0) if r0["volume"] else float("nan")
        print(f"| {name.split('_')[1]} | {label} | {dv:+.2f} % | {'yes' if r['manifold'] else 'no'} | {r['genus']} | "
              f"{len(r.get('components', []))} | {dt:.2f} |")


if __name__ == "__main__":
    main()
