#!/usr/bin/env python3
"""Sparse sampling and meshing against OpenVDB, size by size, in one run (issue 44).

For every size N (points per axis over [-1, 1]^3), in fresh processes, alternating:

  isoforge   bench's `sparse_sizes 'field:sphere?n=N' --method mc` (SparseGrid::from_field with the
             sphere's Lipschitz bound, then extract_sparse): sampling and extraction seconds,
             leaves, bytes, triangles, peak RSS
  openvdb    Debian's pyopenvdb (/usr/bin/python3): createLevelSetSphere(radius 0.7, voxel size
             2/(N-1), half width 3) then convertToPolygons(isovalue 0, adaptivity 0): seconds,
             active voxels, memUsage, polygons, peak RSS

and, for isoforge only, the gyroid clipped to a ball (`field:gyroid?n=N&periods=8&clip=0.9`, its
interval bounds): OpenVDB has no way to build it but from a dense array. Prints a markdown table
(medians of --repeats runs) and writes the records as JSON.

    python3 bench/peers/sparse_vs_openvdb.py --bin target/release/sparse_sizes \\
        --sizes 256,512,1024,2048,4096 --repeats 3 --json /tmp/sparse.json
"""
import argparse
import json
import statistics
import subprocess
import sys

OPENVDB = r"""
import json, resource, sys, time
import pyopenvdb as vdb
n = int(sys.argv[1]); threads = int(sys.argv[2])
voxel = 2.0 / (n - 1)
t = time.perf_counter()
grid = vdb.createLevelSetSphere(radius=0.7, center=(0.0, 0.0, 0.0), voxelSize=voxel, halfWidth=3.0)
build = time.perf_counter() - t
t = time.perf_counter()
points, triangles, quads = grid.convertToPolygons(isovalue=0.0, adaptivity=0.0)
mesh = time.perf_counter() - t
print(json.dumps({"sample_s": build, "extract_s": mesh, "active_voxels": grid.activeVoxelCount(),
                  "grid_bytes": grid.memUsage(), "vertices": len(points), "triangles": len(triangles),
                  "quads": len(quads),
                  "peak_rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024}))
"""


def run(cmd):
    out = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if out.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: exit {out.returncode}: {out.stderr.strip()}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", required=True, help="the sparse_sizes binary (a release build)")
    ap.add_argument("--sizes", default="256,512,1024,2048,4096")
    ap.add_argument("--gyroid-sizes", default="256,512,1024,2048",
                    help="sizes for the clipped gyroid (at 4096³ its 8 periods make ~3·10⁸ triangles: "
                         "more than this 24 GiB machine holds with its grid)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--openvdb-python", default="/usr/bin/python3")
    ap.add_argument("--no-openvdb", action="store_true")
    ap.add_argument("--json")
    a = ap.parse_args()
    records = []
    gyroid_sizes = {int(s) for s in a.gyroid_sizes.split(",") if s}
    for n in [int(s) for s in a.sizes.split(",")]:
        rows = {"isoforge sphere": [], "openvdb sphere": [], "isoforge gyroid in a ball": []}
        for _ in range(a.repeats):
            rows["isoforge sphere"].append(
                run([a.bin, f"field:sphere?n={n}", "--method", "mc", "--threads", str(a.threads)]))
            if not a.no_openvdb:
                rows["openvdb sphere"].append(run([a.openvdb_python, "-c", OPENVDB, str(n), str(a.threads)]))
            if n in gyroid_sizes:
                rows["isoforge gyroid in a ball"].append(run(
                    [a.bin, f"field:gyroid?n={n}&periods=8&clip=0.9", "--method", "mc", "--threads", str(a.threads)]))
        for name, runs in rows.items():
            if runs:
                records.append({"n": n, "what": name, "runs": runs})
                print(json.dumps(records[-1]), file=sys.stderr, flush=True)
    print("| n³ | what | sampling s | meshing s | total s | peak RSS MB | stored or active samples | grid MB | B / sample | polygons |")
    print("|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in records:
        med = lambda k: statistics.median(x[k] for x in r["runs"])
        samples = r["runs"][0].get("stored_samples", r["runs"][0].get("active_voxels"))
        grid = r["runs"][0]["grid_bytes"]
        polys = r["runs"][0]["triangles"] + r["runs"][0]["quads"]
        print(f"| {r['n']} | {r['what']} | {med('sample_s'):.3f} | {med('extract_s'):.3f} | "
              f"{med('sample_s') + med('extract_s'):.3f} | {med('peak_rss') / 2**20:.0f} | {samples:,} | "
              f"{grid / 2**20:.0f} | {grid / max(samples, 1):.1f} | {polys:,} |")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(records, f, indent=1)


if __name__ == "__main__":
    main()
