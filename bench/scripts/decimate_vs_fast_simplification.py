"""isoforge simplify --max-error beside fast-simplification at isoforge's triangle count, in one
process run after run (issue 49's time goal: at most twice the fastest peer).

    /tmp/post-venv/bin/python bench/scripts/decimate_vs_fast_simplification.py MESH.ply TRIANGLES ISOFORGE BOUND

Prints, for two rounds, isoforge's own decimation seconds (file I/O excluded), fast-simplification's
(its call alone) and their ratio; then the self-intersecting pairs of triangles (`isoforge check
--self-intersections`) of the input and of both outputs (before → after). Needs trimesh and
fast-simplification (bench/peers/simplify_peers.py).
"""
import sys, time, json, numpy as np, trimesh, fast_simplification, subprocess, re
path, target, exe, bound = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
m = trimesh.load(path, process=False)
v, f = np.asarray(m.vertices, dtype=np.float32), np.asarray(m.faces, dtype=np.int64)
for r in range(2):
    out = subprocess.run([exe, "simplify", path, "--max-error", bound, "-o", "/tmp/fs_iso.ply"], capture_output=True, text=True).stderr
    secs = float(re.search(r"in ([0-9.]+) s", out).group(1))
    t = time.perf_counter(); fv, ff = fast_simplification.simplify(v, f, target_count=target); fs = time.perf_counter() - t
    print(f"round {r}: isoforge {secs:.2f} s, fast-simplification {fs:.2f} s, ratio {secs/fs:.2f}", flush=True)
trimesh.Trimesh(fv, ff, process=False).export("/tmp/fs_fs.ply")
def pairs(mesh):
    out = subprocess.run([exe, "check", mesh, "--self-intersections", "--json"], capture_output=True, text=True).stdout
    return json.loads(out)["self_intersections"]
print(f"self-intersections: input {pairs(path)}, isoforge {pairs('/tmp/fs_iso.ply')}, "
      f"fast-simplification {pairs('/tmp/fs_fs.ply')}", flush=True)
