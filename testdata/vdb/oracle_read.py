#!/usr/bin/python3
"""Reads a .vdb file with OpenVDB itself and prints, as JSON, what it sees of one grid: the
oracle of isoforge's writer (crates/isoforge-io/tests/vdb_write.rs).

    /usr/bin/python3 testdata/vdb/oracle_read.py FILE.vdb GRID I,J,K [I,J,K ...]

Prints {"name", "class", "type", "background", "active_voxels", "active_bbox" ([min, max],
inclusive, or null), "leaves", "world" (index → world of (0,0,0), (1,0,0), (0,1,0), (0,0,1)),
"values" ([value, active] at each I,J,K)}. Needs Debian's python3-openvdb (module pyopenvdb;
float grids only: it cannot open double grids). Exits 3 when the module is missing.
"""

import json
import sys

try:
    import pyopenvdb as vdb
except ImportError:
    try:
        import openvdb as vdb
    except ImportError:
        sys.exit(3)


def main():
    path, name = sys.argv[1], sys.argv[2]
    points = [tuple(int(c) for c in p.split(",")) for p in sys.argv[3:]]
    grid = vdb.read(path, name)
    acc = grid.getConstAccessor()
    bbox = grid.evalActiveVoxelBoundingBox() if grid.activeVoxelCount() > 0 else None
    xf = grid.transform
    out = {
        "name": grid.name,
        "class": grid.gridClass,
        "type": grid.valueTypeName,
        "background": grid.background,
        "active_voxels": grid.activeVoxelCount(),
        "active_bbox": [list(bbox[0]), list(bbox[1])] if bbox else None,
        "leaves": grid.leafCount(),
        "world": [list(xf.indexToWorld(p)) for p in [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]],
        "values": [list(acc.probeValue(p)) for p in points],
    }
    print(json.dumps(out))


main()
