#!/usr/bin/env python3
"""Writes a large u16 raw volume slab by slab (never whole in memory) for the out-of-core run:
a CT-like phantom of nested shells and a gyroid lattice, values 0..4000.

    python3 bench/peers/make_big_volume.py OUT.raw --dims 1024,1024,2048
"""
import argparse

import numpy as np


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--dims", default="1024,1024,2048")
    a = ap.parse_args()
    nx, ny, nz = (int(x) for x in a.dims.split(","))
    y, x = np.mgrid[0:ny, 0:nx].astype(np.float32)
    x = (x - nx / 2) / (nx / 2)
    y = (y - ny / 2) / (ny / 2)
    with open(a.out, "wb") as f:
        for k in range(nz):
            z = (k - nz / 2) / (nz / 2)
            r = np.sqrt(x * x + y * y + z * z)
            w = 12.0
            gyroid = np.sin(w * x) * np.cos(w * y) + np.sin(w * y) * np.cos(w * z) + np.sin(w * z) * np.cos(w * x)
            v = np.where(r < 0.9, 1000 + 800 * gyroid, 0) + np.where(np.abs(r - 0.95) < 0.02, 3000, 0)
            f.write(np.clip(v, 0, 4000).astype("<u2").tobytes())


if __name__ == "__main__":
    main()
