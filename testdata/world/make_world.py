#!/usr/bin/env python3
"""World-coordinate oracle: for NIfTI and NRRD volumes, the bounding box of every iso crossing on
a lattice edge (linear interpolation, the points marching cubes puts vertices on), placed in world
space by nibabel's affine (NIfTI) or pynrrd's space directions / space origin (NRRD). isoforge's
mesh bounds must match within half a voxel (tests/cli.rs, `world_bounds_match_nibabel_and_pynrrd`).

    /tmp/gen-venv/bin/python testdata/world/make_world.py ../shared/data/volumes

Writes expect.json next to this script. Inside is below iso (isoforge's default).
"""
import json
import os
import sys

import nibabel as nib
import nrrd
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
TESTDATA = os.path.dirname(HERE)


def crossings_bbox(vol, affine, iso):
    """vol indexed [i, j, k]; affine maps (i, j, k, 1) to world."""
    vol = vol.astype(np.float64)
    inside = vol < iso
    pts = []
    for axis in range(3):
        a = [slice(None)] * 3
        b = [slice(None)] * 3
        a[axis] = slice(0, -1)
        b[axis] = slice(1, None)
        v0, v1 = vol[tuple(a)], vol[tuple(b)]
        cross = inside[tuple(a)] != inside[tuple(b)]
        idx = np.argwhere(cross).astype(np.float64)
        if len(idx) == 0:
            continue
        t = (iso - v0[cross]) / (v1[cross] - v0[cross])
        idx[:, axis] += t
        pts.append(idx)
    p = np.concatenate(pts)
    w = p @ affine[:3, :3].T + affine[:3, 3]
    return w.min(axis=0).tolist(), w.max(axis=0).tolist()


def voxel(affine):
    return float(np.max(np.linalg.norm(affine[:3, :3], axis=0)))


def main():
    shared = sys.argv[1] if len(sys.argv) > 1 else None
    rows = []
    vols = os.path.join(TESTDATA, "volumes")
    items = []
    for name in sorted(os.listdir(vols)):
        path = os.path.join(vols, name)
        if name.endswith((".nii", ".nii.gz")):
            items.append(("testdata/volumes/" + name, path, "nifti"))
        elif name.endswith((".nrrd", ".nhdr")):
            items.append(("testdata/volumes/" + name, path, "nrrd"))
    if shared:
        for name in sorted(os.listdir(shared)):
            if name.endswith(".nrrd"):
                items.append(("shared/data/volumes/" + name, os.path.join(shared, name), "nrrd"))
    for rel, path, kind in items:
        if kind == "nifti":
            img = nib.load(path)
            vol = np.asarray(img.get_fdata())
            affine = img.affine
        else:
            vol, h = nrrd.read(path)  # pynrrd: index order (i, j, k) = Fortran order of the file
            dirs = h.get("space directions")
            if dirs is None:
                sp = h.get("spacings", [1.0, 1.0, 1.0])
                dirs = np.diag(sp)
            dirs = np.asarray(dirs, dtype=np.float64)
            origin = np.asarray(h.get("space origin", [0.0, 0.0, 0.0]), dtype=np.float64)
            affine = np.eye(4)
            affine[:3, :3] = dirs.T  # columns = index axes
            affine[:3, 3] = origin
        if vol.ndim != 3:
            continue
        lo_v, hi_v = float(np.min(vol)), float(np.max(vol))
        iso = float(np.quantile(vol, 0.6))
        if not (lo_v < iso < hi_v):
            iso = (lo_v + hi_v) / 2
        iso = round(iso, 3) + 0.0001  # off the sample values (no ties)
        lo, hi = crossings_bbox(vol, affine, iso)
        rows.append({"file": rel, "reader": "nibabel" if kind == "nifti" else "pynrrd", "iso": iso,
                     "min": lo, "max": hi, "voxel": voxel(affine)})
        print(rows[-1])
    with open(os.path.join(HERE, "expect.json"), "w") as f:
        json.dump({"rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
