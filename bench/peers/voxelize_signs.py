"""Issue 46, signs: isoforge voxelize beside libigl's fast winding number, MeshLib's
meshToDistanceVolume (hole-winding rule) and single-ray parity, on damaged analytic solids.

Each solid (torus, genus 2 as two crossing tori, nested shells = hollow ball, thin plate) is
meshed parametrically (numpy), damaged with a seeded RNG (faces removed, flipped, duplicated with
separate vertices and reversed half the time; or crossing extra spheres), written as PLY and
voxelized by isoforge on its 64-cell lattice (`--values occupancy`). The peers are sampled on the
SAME lattice points, read from the NRRD header. Score = % of lattice points more than one cell from
the analytic surface whose inside/outside decision is right.

    /tmp/p46-venv/bin/python bench/peers/voxelize_signs.py [--isoforge PATH] [--out FILE.md]
"""
import argparse
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from nrrd_io import read_nrrd  # noqa: E402
from ply_io import write_ply  # noqa: E402


def default_isoforge():
    """$ISOFORGE, else the copied release binary, else the workspace's own release build."""
    repo = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    for cand in (os.environ.get("ISOFORGE"), "/work/bin46/isoforge", os.path.join(repo, "target/release/isoforge")):
        if cand and os.path.exists(cand):
            return cand
    return "isoforge"


# ---------------------------------------------------------------- analytic solids and their meshes

def weld(verts, faces, decimals=9):
    """Merges coincident vertices (parametric seams, poles) and drops triangles that collapse."""
    key, inv = np.unique(np.round(verts, decimals), axis=0, return_inverse=True)
    faces = inv.reshape(-1)[faces]
    keep = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])
    return key, faces[keep]


def signed_volume(verts, faces):
    a, b, c = verts[faces[:, 0]], verts[faces[:, 1]], verts[faces[:, 2]]
    return np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0


def outward(verts, faces):
    """Orients a closed mesh so its signed volume is positive."""
    return faces if signed_volume(verts, faces) > 0 else faces[:, ::-1].copy()


def grid_mesh(fn, nu, nv):
    """Triangles of the map fn(u, v) over [0,1]² sampled (nu+1)×(nv+1), welded."""
    u, v = np.meshgrid(np.linspace(0, 1, nu + 1), np.linspace(0, 1, nv + 1), indexing="ij")
    verts = fn(u.ravel(), v.ravel())
    idx = np.arange((nu + 1) * (nv + 1)).reshape(nu + 1, nv + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return weld(verts, faces)


def torus_mesh(big, small, center=(0, 0, 0), nu=160, nv=64):
    def f(u, v):
        a, b = 2 * np.pi * u, 2 * np.pi * v
        rr = big + small * np.cos(b)
        return np.stack([rr * np.cos(a), rr * np.sin(a), small * np.sin(b)], 1) + np.asarray(center)
    v, f_ = grid_mesh(f, nu, nv)
    return v, outward(v, f_)


def sphere_mesh(r, center=(0, 0, 0), nu=128, nv=64):
    def f(u, v):
        a, b = 2 * np.pi * u, np.pi * v
        return r * np.stack([np.sin(b) * np.cos(a), np.sin(b) * np.sin(a), np.cos(b)], 1) + np.asarray(center)
    v, f_ = grid_mesh(f, nu, nv)
    return v, outward(v, f_)


def box_mesh(half, step):
    """A closed box [-half, half] with faces subdivided to about `step`."""
    parts = []
    for axis in range(3):
        for s in (-1.0, 1.0):
            a1, a2 = [x for x in range(3) if x != axis]
            n1, n2 = max(1, int(round(2 * half[a1] / step))), max(1, int(round(2 * half[a2] / step)))

            def f(u, v, axis=axis, s=s, a1=a1, a2=a2):
                p = np.zeros((len(u), 3))
                p[:, axis] = s * half[axis]
                p[:, a1] = (2 * u - 1) * half[a1]
                p[:, a2] = (2 * v - 1) * half[a2]
                return p
            parts.append(grid_mesh(f, n1, n2))
    v, f_ = merge(parts)
    v, f_ = weld(v, f_)
    # orient each face outward: its normal must point away from the centre
    a, b, c = v[f_[:, 0]], v[f_[:, 1]], v[f_[:, 2]]
    n = np.cross(b - a, c - a)
    flip = np.einsum("ij,ij->i", n, (a + b + c) / 3) < 0
    f_[flip] = f_[flip][:, ::-1]
    return v, f_


def merge(parts):
    verts, faces, base = [], [], 0
    for v, f in parts:
        verts.append(v)
        faces.append(f + base)
        base += len(v)
    return np.concatenate(verts), np.concatenate(faces)


def sdf_torus(p, big, small, center=(0, 0, 0)):
    q = p - np.asarray(center)
    a = np.hypot(q[:, 0], q[:, 1]) - big
    return np.hypot(a, q[:, 2]) - small


def sdf_box(p, half):
    q = np.abs(p) - np.asarray(half)
    return np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0)


def shapes():
    """(name, mesh, sdf) of the four solids; the meshes are closed and outward (the hollow ball's
    inner sphere inward), with edges about 0.03–0.04 long (the lattice's cell is about 0.03)."""
    plate_half = (0.9, 0.9, 0.06)
    inner_v, inner_f = sphere_mesh(0.45, nu=64, nv=32)
    return [
        ("torus", torus_mesh(0.7, 0.3), lambda p: sdf_torus(p, 0.7, 0.3)),
        ("genus 2 (two crossing tori)",
         merge([torus_mesh(0.45, 0.18, (-0.42, 0, 0), 96, 40), torus_mesh(0.45, 0.18, (0.42, 0, 0), 96, 40)]),
         lambda p: np.minimum(sdf_torus(p, 0.45, 0.18, (-0.42, 0, 0)), sdf_torus(p, 0.45, 0.18, (0.42, 0, 0)))),
        ("nested shells (hollow ball)",
         merge([sphere_mesh(0.9), (inner_v, inner_f[:, ::-1].copy())]),
         lambda p: np.maximum(np.linalg.norm(p, axis=1) - 0.9, 0.45 - np.linalg.norm(p, axis=1))),
        ("thin plate (0.12 thick)", box_mesh(plate_half, 0.03), lambda p: sdf_box(p, plate_half)),
    ]


def damage(verts, faces, holes, flips, dups, rng):
    """Removes `holes` of the faces, flips `flips` of them, appends `dups` of them again with
    separate vertices (reversed half the time)."""
    n = len(faces)
    keep = rng.random(n) >= holes
    flip = rng.random(n) < flips
    dup = rng.random(n) < dups
    rev = rng.random(n) < 0.5
    f = faces.copy()
    f[flip] = f[flip][:, ::-1]
    out_f = [f[keep]]
    d = f[keep & dup]
    r = rev[keep & dup]
    extra_v = verts[d].reshape(-1, 3)
    extra_f = np.arange(len(extra_v)).reshape(-1, 3) + len(verts)
    extra_f[r] = extra_f[r][:, ::-1]
    out_f.append(extra_f)
    return np.concatenate([verts, extra_v]), np.concatenate(out_f)


CASES = [
    ("clean", dict(holes=0.0, flips=0.0, dups=0.0)),
    ("5 % holes + 5 % flips", dict(holes=0.05, flips=0.05, dups=0.0)),
    ("20 % holes", dict(holes=0.2, flips=0.0, dups=0.0)),
    ("20 % flips", dict(holes=0.0, flips=0.2, dups=0.0)),
    ("20 % holes + 20 % flips + 10 % dups", dict(holes=0.2, flips=0.2, dups=0.1)),
    ("3 crossing spheres + 5 % holes + 5 % flips", dict(holes=0.05, flips=0.05, dups=0.0, spheres=3)),
]


def make_case(shape, case, seed):
    name, (verts, faces), sdf = shape
    rng = np.random.default_rng(seed)
    if case.get("spheres"):
        # self-intersecting extra pieces: closed outward spheres of radius 0.2 centred on surface
        # vertices of the solid, crossing its surface; the truth becomes the union.
        centers = verts[rng.choice(len(verts), case["spheres"], replace=False)]
        parts = [(verts, faces)] + [sphere_mesh(0.2, c, 48, 24) for c in centers]
        verts, faces = merge(parts)
        base = sdf

        def sdf(p, base=base, centers=centers):
            d = base(p)
            for c in centers:
                d = np.minimum(d, np.linalg.norm(p - c, axis=1) - 0.2)
            return d
    v, f = damage(verts, faces, case["holes"], case["flips"], case["dups"], rng)
    return v, f, sdf


# ---------------------------------------------------------------- the deciders

def isoforge_inside(exe, ply, workdir):
    """Runs isoforge voxelize (occupancy, 64 cells); returns (inside[z,y,x], origin, h, seconds)."""
    out = os.path.join(workdir, "occ.nrrd")
    t = time.perf_counter()
    subprocess.run([exe, "voxelize", ply, "-o", out, "--values", "occupancy", "--resolution", "64"],
                   check=True, stdout=subprocess.DEVNULL)
    secs = time.perf_counter() - t
    arr, spacing, origin = read_nrrd(out)
    assert max(spacing) - min(spacing) < 1e-12 * max(spacing), spacing
    return arr != 0, np.asarray(origin), spacing[0], secs


def lattice_points(shape_zyx, origin, h):
    nz, ny, nx = shape_zyx
    z, y, x = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    return np.stack([x.ravel(), y.ravel(), z.ravel()], 1) * h + origin


def igl_inside(verts, faces, pts):
    import igl
    w = igl.fast_winding_number(np.ascontiguousarray(verts, np.float64),
                                np.ascontiguousarray(faces, np.int64), np.ascontiguousarray(pts))
    return w >= 0.5


def meshlib_inside(verts, faces, shape_zyx, origin, h):
    """MeshLib meshToDistanceVolume, HoleWindingRule; its samples are at voxel centres
    (origin + (i + ½)·size), so its origin is the lattice's less half a cell."""
    import meshlib.mrmeshnumpy as mn
    import meshlib.mrmeshpy as mm
    mesh = mn.meshFromFacesVerts(np.ascontiguousarray(faces, np.int32), np.ascontiguousarray(verts, np.float32))
    p = mm.MeshToDistanceVolumeParams()
    o = origin - 0.5 * h
    p.vol.origin = mm.Vector3f(*o)
    p.vol.voxelSize = mm.Vector3f(h, h, h)
    nz, ny, nx = shape_zyx
    p.vol.dimensions = mm.Vector3i(nx, ny, nz)
    p.dist.signMode = mm.SignDetectionMode.HoleWindingRule
    vol = mm.meshToDistanceVolume(mm.MeshPart(mesh), p)
    a = mn.getNumpy3Darray(vol)  # [x, y, z]
    return np.transpose(a, (2, 1, 0)) < 0


def parity_inside(verts, faces, shape_zyx, origin, h):
    """Single-ray parity: a ray along +x from each lattice point (moved by a tiny fixed offset in
    y and z so no ray runs exactly through an edge), inside when it crosses an odd number of
    triangles."""
    nz, ny, nx = shape_zyx
    eps = np.array([0.0, 1.2345e-4, 2.71828e-4]) * h
    tri = verts[faces]
    ty = (tri[:, :, 1] - origin[1] - eps[1]) / h
    tz = (tri[:, :, 2] - origin[2] - eps[2]) / h
    j0 = np.clip(np.ceil(ty.min(1)), 0, ny).astype(np.int64)
    j1 = np.clip(np.floor(ty.max(1)), -1, ny - 1).astype(np.int64)
    k0 = np.clip(np.ceil(tz.min(1)), 0, nz).astype(np.int64)
    k1 = np.clip(np.floor(tz.max(1)), -1, nz - 1).astype(np.int64)
    cj, ck = np.maximum(j1 - j0 + 1, 0), np.maximum(k1 - k0 + 1, 0)
    cnt = cj * ck
    t = np.repeat(np.arange(len(faces)), cnt)
    off = np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    j = j0[t] + off // np.maximum(ck[t], 1)
    k = k0[t] + off % np.maximum(ck[t], 1)
    # 2D barycentric test of the line (j, k) in the triangle's (y, z) projection
    y, z = j.astype(np.float64), k.astype(np.float64)
    ay, az, by, bz, cy, cz = ty[t, 0], tz[t, 0], ty[t, 1], tz[t, 1], ty[t, 2], tz[t, 2]
    det = (by - ay) * (cz - az) - (cy - ay) * (bz - az)
    ok = det != 0
    with np.errstate(divide="ignore", invalid="ignore"):
        l1 = ((y - ay) * (cz - az) - (cy - ay) * (z - az)) / det
        l2 = ((by - ay) * (z - az) - (y - ay) * (bz - az)) / det
    l0 = 1 - l1 - l2
    hit = ok & (l0 >= 0) & (l1 >= 0) & (l2 >= 0) & (l0 <= 1) & (l1 <= 1) & (l2 <= 1)
    tx = (tri[:, :, 0] - origin[0]) / h
    x = l0 * tx[t, 0] + l1 * tx[t, 1] + l2 * tx[t, 2]
    line = (k * ny + j)[hit]
    x = np.clip(x[hit], -50, nx + 50)
    width = nx + 200.0
    keys = np.sort(line * width + x + 100)
    pk, pj, pi = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    pline = (pk * ny + pj).ravel()
    start = pline * width + pi.ravel() + 100
    end = (pline + 1) * width
    crossings = np.searchsorted(keys, end, "left") - np.searchsorted(keys, start, "right")
    return (crossings % 2 == 1).reshape(nz, ny, nx)


# ---------------------------------------------------------------- the run

PEERS = ["isoforge voxelize", "libigl fast_winding_number (≥ ½)", "MeshLib meshToDistanceVolume (HoleWindingRule)",
         "single-ray parity (+x)"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--isoforge", default=default_isoforge(),
                    help="the isoforge binary ($ISOFORGE, else /work/bin46/isoforge, else target/release/isoforge)")
    ap.add_argument("--out", default=None, help="markdown file for the table")
    ap.add_argument("--seed", type=int, default=46)
    args = ap.parse_args()
    rows = []
    load = open("/proc/loadavg").read().split()[:3]
    with tempfile.TemporaryDirectory(prefix="p46-signs-") as work:
        for si, shape in enumerate(shapes()):
            for ci, (cname, case) in enumerate(CASES):
                v, f, sdf = make_case(shape, case, args.seed + 100 * si + ci)
                ply = os.path.join(work, "m.ply")
                write_ply(ply, v, f)
                inside_iso, origin, h, t_iso = isoforge_inside(args.isoforge, ply, work)
                pts = lattice_points(inside_iso.shape, origin, h)
                truth_d = sdf(pts).reshape(inside_iso.shape)
                far = np.abs(truth_d) > h
                truth = truth_d < 0
                res = {"isoforge voxelize": (inside_iso, t_iso)}
                t = time.perf_counter()
                res[PEERS[1]] = (igl_inside(v, f, pts).reshape(inside_iso.shape), time.perf_counter() - t)
                try:
                    t = time.perf_counter()
                    res[PEERS[2]] = (meshlib_inside(v, f, inside_iso.shape, origin, h), time.perf_counter() - t)
                except Exception as e:  # a peer that fails is recorded, not fatal
                    res[PEERS[2]] = (f"n/a: {type(e).__name__}: {e}"[:80], 0.0)
                t = time.perf_counter()
                res[PEERS[3]] = (parity_inside(v, f, inside_iso.shape, origin, h), time.perf_counter() - t)
                scores = {}
                for peer, (inside, secs) in res.items():
                    if isinstance(inside, str):
                        scores[peer] = (inside, secs)
                        continue
                    wrong = int(((inside != truth) & far).sum())
                    scores[peer] = (100.0 * (1 - wrong / far.sum()), wrong, secs)
                rows.append((shape[0], cname, len(f), int(far.sum()), scores))
                print(shape[0], "|", cname, "|", len(f), "faces |",
                      "; ".join(f"{k.split()[0]} {s[0]:.3f}% ({s[1]} wrong, {s[2]:.2f}s)" if not isinstance(s[0], str)
                                else f"{k.split()[0]} {s[0]}" for k, s in scores.items()), flush=True)
    lines = [
        f"# Issue 46: inside/outside on damaged analytic solids ({time.strftime('%Y-%m-%d', time.gmtime())})",
        "",
        f"`{' '.join(['python'] + sys.argv)}` — load average at start {' '.join(load)} (2 cores).",
        "Lattice: isoforge's own for `--resolution 64` (64 cells along the longest side, 4-cell margin),",
        "read from the NRRD header; every peer sampled at the same points. % = lattice points more than",
        "one cell from the analytic surface on the right side (wrong points in brackets). Times are",
        "per case, whole-lattice (isoforge: the CLI process, reading the PLY and writing the NRRD).",
        "",
        "| shape | damage | faces | points scored | " + " | ".join(PEERS) + " |",
        "|---|---|---:|---:|" + "---:|" * len(PEERS),
    ]
    for shape, cname, nf, nfar, scores in rows:
        cells = []
        for peer in PEERS:
            s = scores[peer]
            cells.append(s[0] if isinstance(s[0], str) else f"{s[0]:.3f} % ({s[1]})")
        lines.append(f"| {shape} | {cname} | {nf} | {nfar} | " + " | ".join(cells) + " |")
    lines += ["", "Median seconds per case (whole lattice): " + ", ".join(
        f"{peer.split(' (')[0]} {np.median([r[4][peer][-1] for r in rows]):.2f}" for peer in PEERS)]
    lines += ["", "Worst case per decider: " + ", ".join(
        f"{peer.split(' (')[0]} {min(r[4][peer][0] for r in rows if not isinstance(r[4][peer][0], str)):.3f} %"
        for peer in PEERS)]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        open(args.out, "w").write(text)


if __name__ == "__main__":
    main()
