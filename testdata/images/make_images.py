#!/usr/bin/env python3
"""Real 2D slices for the marching-squares tests, written by Pillow and tifffile (independent
writers), plus scikit-image's find_contours figures for them (the reference oracle).

    /tmp/peers-venv/bin/python testdata/images/make_images.py ../shared/data/volumes

Writes next to this script:
  cthead_z50.png      8-bit, cthead_8bit_256x256x99.nrrd slice z = 50
  engine_z64.png      8-bit, volvis_engine_256x256x128.nrrd slice z = 64
  bunny_z180_u16.png  16-bit, stanford_bunny_ct_512x512x361.nrrd slice z = 180, value + 32768
  bunny_z180_u16.tif  the same pixels as a 16-bit TIFF
  stack3.tif          3 pages of engine (z = 63, 64, 65), 8-bit: a multi-page stack
  skimage.json        find_contours counts and total lengths per image, level and connectivity
"""
import json
import os
import sys

import numpy as np
import tifffile
from PIL import Image
from skimage import measure

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "bench", "peers"))
from nrrd_io import read_nrrd  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    src = sys.argv[1]
    cthead, _, _ = read_nrrd(os.path.join(src, "cthead_8bit_256x256x99.nrrd"))
    engine, _, _ = read_nrrd(os.path.join(src, "volvis_engine_256x256x128.nrrd"))
    bunny, _, _ = read_nrrd(os.path.join(src, "stanford_bunny_ct_512x512x361.nrrd"))
    images = {
        "cthead_z50.png": (cthead[50].astype(np.uint8), [40.5, 90.5]),
        "engine_z64.png": (engine[64].astype(np.uint8), [60.5, 150.5]),
        "bunny_z180_u16.png": ((bunny[180].astype(np.int32) + 32768).astype(np.uint16), [32768.0 - 500.5, 32768.0 + 0.5]),
    }
    for name, (img, _) in images.items():
        Image.fromarray(img).save(os.path.join(HERE, name))
    tifffile.imwrite(os.path.join(HERE, "bunny_z180_u16.tif"), images["bunny_z180_u16.png"][0], compression="zlib")
    tifffile.imwrite(os.path.join(HERE, "stack3.tif"), engine[63:66].astype(np.uint8), compression="zlib", photometric="minisblack")
    rows = []
    for name, (img, levels) in images.items():
        back = np.asarray(Image.open(os.path.join(HERE, name))).astype(np.float64)
        assert (back == img).all(), name
        for level in levels:
            for conn in ("low", "high"):
                cs = measure.find_contours(back, level, fully_connected=conn)
                closed = sum(1 for c in cs if len(c) > 2 and (c[0] == c[-1]).all())
                length = sum(float(np.sum(np.sqrt(np.sum(np.diff(c, axis=0) ** 2, axis=1)))) for c in cs)
                rows.append({"file": name, "level": level, "fully_connected": conn, "contours": len(cs),
                             "closed": closed, "length": length})
                print(rows[-1])
    with open(os.path.join(HERE, "skimage.json"), "w") as f:
        json.dump({"generator": "skimage.measure.find_contours " + __import__("skimage").__version__,
                   "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
