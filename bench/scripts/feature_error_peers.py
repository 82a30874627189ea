#!/usr/bin/python3
"""Sharp-feature errors of peers on issue 45's CSG shapes (docs/BENCHMARKS.md §16).

The grids are the ones isoforge samples: `feature_error --dump DIR` writes SHAPE-N.npy (f32,
[z][y][x], the lattice spanning [-1, 1]^3, h = 2/(N-1)) and SHAPE-N.json (the exact corners and
crease points of the analytic shape). Each peer meshes the grid at iso 0; the errors are measured
here as the `feature_error` tool measures isoforge's meshes, in cell widths h:
  corner = max over the corners of the distance to the nearest mesh vertex (all, and convex only),
  crease = max over the crease points of the distance to the nearest point of a mesh edge,
  field  = max |field(vertex)| / h, the field evaluated exactly by `feature_error --eval-points`.

Peers:
  openvdb  Debian's pyopenvdb (/usr/bin/python3): FloatGrid.copyFromArray, then
           convertToPolygons(isovalue=0, adaptivity=0) (volumeToMesh).
  skimage  scikit-image's marching_cubes(level=0) (the MC baseline), in --py's interpreter.
  isomesh  PyPI isomesh (0.1.1: manifold dual contouring on an octree), in --py's interpreter,
           skipped with a message if it does not import or run. It samples a function, not a
           grid: it gets the exact field (through `feature_error --eval-points`) on its own
           lattice of 2^depth cells per axis (depth = log2 N, uniform), and its errors are in its
           own cell width 2/2^depth.

  /usr/bin/python3 bench/scripts/feature_error_peers.py --bin target/release/feature_error \
      --dir /tmp/csg-grids --py /tmp/peers-venv/bin/python --n 32,64,128
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np

SHAPES = ["rotated-box", "cylinder", "box-minus-sphere", "fandisk", "plates", "two-spheres"]


def mesh_worker(peer, npy, out):
    """Runs in --py's interpreter: meshes npy, writes out (npz of verts in x,y,z index units, edges)."""
    vol = np.load(npy)  # [z][y][x]
    if peer == "skimage":
        from skimage.measure import marching_cubes

        verts, faces, _, _ = marching_cubes(vol, level=0.0)
        verts = verts[:, ::-1]  # (z, y, x) -> (x, y, z)
        polys = [faces]
    elif peer == "isomesh":
        import isomesh

        # isomesh takes a function, not a grid: the exact field (feature_error --eval-points),
        # gradients by its finite differences, on its octree of 2^depth cells across [-1, 1]^3
        # (depth = log2(N)), uniform (adaptive=False): its own h = 2 / 2^depth.
        meta = json.load(open(npy[:-4] + ".json"))
        depth = int(round(np.log2(meta["n"])))
        tmp = npy[:-4] + "-isomesh-q.f32"

        def field(p):
            np.asarray(p, dtype="<f4").tofile(tmp)
            subprocess.run([os.environ["FEATURE_ERROR_BIN"], "--shapes", meta["shape"], "--n", str(meta["n"]),
                            "--eval-points", tmp], check=True)
            return np.fromfile(tmp + ".values", dtype="<f4").astype(np.float64), None

        v, faces = isomesh.extract(field, min_depth=3, max_depth=depth, fd_step=1e-3, adaptive=False)
        h_own = 2.0 / 2**depth
        verts = (np.asarray(v, dtype=np.float64) + 1.0) / meta["h"]  # as index units of the grid
        polys = [np.asarray(faces)]
        np.save(npy[:-4] + "-isomesh-h.npy", np.array([h_own]))
    elif peer == "openvdb":
        import pyopenvdb as vdb

        grid = vdb.FloatGrid(float(np.abs(vol).max()) + 1.0)
        grid.copyFromArray(vol.transpose(2, 1, 0).copy(), ijk=(0, 0, 0), tolerance=0.0)
        pts, tris, quads = grid.convertToPolygons(isovalue=0.0, adaptivity=0.0)
        verts = np.asarray(pts, dtype=np.float64)
        polys = [np.asarray(tris), np.asarray(quads)]
    else:
        raise ValueError(peer)
    edges = []
    triangles = 0
    for p in polys:
        if len(p) == 0:
            continue
        k = p.shape[1]
        triangles += len(p) * (k - 2)
        for i in range(k):
            edges.append(np.stack([p[:, i], p[:, (i + 1) % k]], axis=1))
    edges = np.sort(np.concatenate(edges), axis=1) if edges else np.zeros((0, 2), int)
    edges = np.unique(edges, axis=0)
    np.savez(out, verts=verts, edges=edges, triangles=triangles)


def nearest_point_d(points, verts):
    best = np.full(len(points), np.inf)
    chunk = max(1, 4_000_000 // max(1, len(points)))
    for s in range(0, len(verts), chunk):
        v = verts[s : s + chunk]
        d = np.sqrt(((points[:, None, :] - v[None, :, :]) ** 2).sum(-1)).min(1)
        best = np.minimum(best, d)
    return best


def nearest_edge_d(points, a, b):
    """Distance from each point to the nearest segment a[i] b[i] (brute force in chunks of about
    4 M point-segment pairs)."""
    chunk = max(1, 4_000_000 // max(1, len(points)))
    ab = b - a
    len2 = np.maximum((ab**2).sum(-1), 1e-30)
    best = np.full(len(points), np.inf)
    for s in range(0, len(a), chunk):
        aa, dd, ll = a[s : s + chunk], ab[s : s + chunk], len2[s : s + chunk]
        rel = points[:, None, :] - aa[None]
        t = np.clip((rel * dd[None]).sum(-1) / ll[None], 0.0, 1.0)
        d = np.sqrt(((rel - t[..., None] * dd[None]) ** 2).sum(-1)).min(1)
        best = np.minimum(best, d)
    return best


def measure(meta, verts, edges, field_values):
    h = meta["h"]
    out = {}
    corners = np.asarray(meta["corners"], dtype=np.float64).reshape(-1, 3)
    convex = np.asarray(meta["convex"], dtype=bool)
    if len(corners) and len(verts):
        d = nearest_point_d(corners, verts) / h
        out["corner"] = d.max()
        out["convex"] = d[convex].max() if convex.any() else None
    crease = np.asarray(meta["crease_points"], dtype=np.float64).reshape(-1, 3)
    if len(crease) and len(edges):
        a, b = verts[edges[:, 0]], verts[edges[:, 1]]
        # Only edges near the creases (midpoint within 3 h of a crease point's box), all if none.
        lo, hi = crease.min(0) - 3 * h, crease.max(0) + 3 * h
        mid = (a + b) / 2
        keep = np.all((mid >= lo) & (mid <= hi), axis=1)
        out["crease"] = nearest_edge_d(crease, a[keep], b[keep]).max() / h
    out["field"] = np.abs(field_values).max() / h if len(field_values) else None
    return out


def fmt(x):
    return "–" if x is None else f"{x:.3f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default="target/release/feature_error")
    ap.add_argument("--dir", default="/tmp/csg-grids")
    ap.add_argument("--py", default="/tmp/peers-venv/bin/python", help="interpreter with scikit-image (and isomesh)")
    ap.add_argument("--n", default="32,64,128")
    ap.add_argument("--shapes", default=",".join(SHAPES))
    ap.add_argument("--peers", default="openvdb,skimage,isomesh")
    ap.add_argument("--worker", nargs=3, metavar=("PEER", "NPY", "OUT"), help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        mesh_worker(*a.worker)
        return
    ns = [int(n) for n in a.n.split(",")]
    shapes = a.shapes.split(",")
    os.makedirs(a.dir, exist_ok=True)
    os.environ["FEATURE_ERROR_BIN"] = os.path.abspath(a.bin)
    subprocess.run([a.bin, "--shapes", ",".join(shapes), "--n", a.n, "--methods", "mc", "--dump", a.dir],
                   check=True, stdout=subprocess.DEVNULL)
    print("| shape | n | peer | triangles | corner (h) | convex corner (h) | crease (h) | field (h) |")
    print("|---|---|---|---|---|---|---|---|")
    skipped = set()
    for shape in shapes:
        for n in ns:
            stem = os.path.join(a.dir, f"{shape}-{n}")
            meta = json.load(open(stem + ".json"))
            for peer in a.peers.split(","):
                if peer in skipped:
                    continue
                py = sys.executable if peer == "openvdb" else a.py
                out = f"{stem}-{peer}.npz"
                r = subprocess.run([py, __file__, "--worker", peer, stem + ".npy", out], capture_output=True, text=True)
                if r.returncode != 0:
                    last = (r.stderr.strip().splitlines() or ["?"])[-1]
                    print(f"{peer}: skipped ({last})", file=sys.stderr)
                    skipped.add(peer)
                    continue
                m = np.load(out)
                h_own = meta["h"]
                if peer == "isomesh":
                    h_own = float(np.load(stem + "-isomesh-h.npy")[0])
                # Index units -> world: x = -1 + i h.
                verts = -1.0 + m["verts"] * meta["h"]
                pts = stem + f"-{peer}.f32"
                verts.astype("<f4").tofile(pts)
                subprocess.run([a.bin, "--shapes", shape, "--n", str(n), "--eval-points", pts], check=True)
                values = np.fromfile(pts + ".values", dtype="<f4")
                e = measure(dict(meta, h=h_own), verts, m["edges"], values)
                print(f"| {shape} | {n} | {peer} | {int(m['triangles'])} | {fmt(e.get('corner'))} | "
                      f"{fmt(e.get('convex'))} | {fmt(e.get('crease'))} | {fmt(e.get('field'))} |", flush=True)


if __name__ == "__main__":
    main()
