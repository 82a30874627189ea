#!/usr/bin/python3
"""Writes the OpenVDB test files of testdata/vdb/ and, beside each, the JSON oracle of what
OpenVDB itself reports about it.

Run with Debian's python (the pyenv python3 on PATH has no pyopenvdb):

    apt-get install -y python3-openvdb                 # the files written by pyopenvdb
    apt-get install -y libopenvdb-dev libboost-dev g++  # optional: the variants of rewrite.cc
    /usr/bin/python3 testdata/vdb/make_vdb.py

pyopenvdb (OpenVDB 10.0.1) writes float grids with its default compression (blosc + active
mask) and offers no other: the variants (zip, none, no active-mask compression, a stream
without grid offsets, double grids, half floats, translation/unitary/frustum maps) come from
`rewrite.cc`, a small C++ program compiled against the same libopenvdb that rewrites a
pyopenvdb file. Without a compiler or libopenvdb-dev those variants are left as they are.

Every oracle is what pyopenvdb reads back from the file written (so half-float rounding is in
it), except for double grids, which pyopenvdb cannot open: their oracle is the one of the float
file they were converted from (`rewrite.cc --double` converts values exactly; see
`ORACLE_FROM` below).
"""

import json
import os
import random
import shutil
import struct
import subprocess
import sys
import tempfile

import pyopenvdb as vdb

HERE = os.path.dirname(os.path.abspath(__file__))

# Points whose index -> world image each oracle records.
PROBE_POINTS = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (3, -5, 7), (-100, 250, 33)]

# blosc | active mask is OpenVDB's default; rewrite.cc takes the io::COMPRESS_* flags as a number.
NONE, ZIP, MASK, BLOSC = 0, 1, 2, 4


# Tiles listed in full; all of them are summed up by `tile_digest`.
TILES_LISTED = 64


def tile_digest(tiles):
    """FNV-1a (64-bit) over the sorted lines "x y z size bits active" (bits: the IEEE-754 bits of
    the value as a double), so that thousands of tiles compare without being listed."""
    lines = sorted("%d %d %d %d %d %d\n" % (t["origin"][0], t["origin"][1], t["origin"][2], t["size"],
                                             struct.unpack("<Q", struct.pack("<d", t["value"]))[0], int(t["active"]))
                   for t in tiles)
    h = 0xCBF29CE484222325
    for byte in "".join(lines).encode():
        h = ((h ^ byte) * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return "%016x" % h


def grid_oracle(grid, type_name):
    """What OpenVDB reports about one float grid: geometry, counts, tiles, per-leaf sums,
    and 200 deterministic (ijk, value, active) samples."""
    acc = grid.getConstAccessor()
    bg = grid.background
    tiles = []
    leaves = {}
    for it in grid.iterAllValues():
        if it.depth == 3:
            ijk = it.min
            origin = tuple(c & ~7 for c in ijk)
            leaf = leaves.setdefault(origin, [0, 0.0, 0.0])
            leaf[2] += it.value
            if it.active:
                leaf[0] += 1
                leaf[1] += it.value
        elif it.active or it.value != bg:
            size = it.max[0] - it.min[0] + 1
            tiles.append({"origin": list(it.min), "size": size, "value": it.value, "active": it.active})
    n_leaf_voxels = sum(1 for it in grid.iterAllValues() if it.depth == 3)
    assert n_leaf_voxels == 512 * len(leaves), "leaf iteration did not visit every voxel"

    active = []
    for it in grid.iterOnValues():
        if it.count == 1:
            active.append(tuple(it.min))
        else:
            active.append(tuple(it.min))
            active.append(tuple(it.max))
    rng = random.Random(20261128)
    samples = []
    picks = rng.sample(active, min(100, len(active))) if active else []
    bbox = grid.evalActiveVoxelBoundingBox()
    lo = [min(bbox[0][a], 0) - 16 for a in range(3)]
    hi = [max(bbox[1][a], 0) + 16 for a in range(3)]
    # Leaf origins first: every leaf gets its first voxel probed, then random points around.
    for origin in sorted(leaves)[:40]:
        picks.append((origin[0] + 3, origin[1] + 5, origin[2] + 6))
    while len(picks) < 200:
        picks.append(tuple(rng.randint(lo[a], hi[a]) for a in range(3)))
    for ijk in picks[:200]:
        samples.append([list(ijk), acc.getValue(ijk), acc.isValueOn(ijk)])

    t = grid.transform
    vmin, vmax = grid.evalMinMax() if grid.activeVoxelCount() > 0 else (None, None)
    return {
        "name": grid.name,
        "type": type_name,
        "class": grid.gridClass if grid.gridClass != "unknown" else None,
        "half": bool(grid.saveFloatAsHalf),
        "background": bg,
        "map_type": t.typeName,
        "voxel_size": list(t.voxelSize()),
        "index_to_world": [[list(p), list(t.indexToWorld(p))] for p in PROBE_POINTS],
        "active_voxel_count": grid.activeVoxelCount(),
        "active_bbox": [list(bbox[0]), list(bbox[1])] if grid.activeVoxelCount() > 0 else None,
        "active_min": vmin,
        "active_max": vmax,
        "leaf_count": grid.leafCount(),
        "leaves": [[list(o), v[0], v[1], v[2]] for o, v in sorted(leaves.items())],
        "tile_count": len(tiles),
        "tile_digest": tile_digest(tiles),
        "tiles": sorted(tiles, key=lambda x: (x["origin"], x["size"]))[:TILES_LISTED],
        "samples": samples,
    }


def file_oracle(path, made_by):
    """The oracle of a whole file, read back with pyopenvdb."""
    grids, _ = vdb.readAll(path)
    out = {"file": os.path.basename(path), "made_by": made_by, "grids": [], "skipped": []}
    for g in grids:
        if g.valueTypeName == "float":
            out["grids"].append(grid_oracle(g, "float"))
        else:
            out["skipped"].append([g.name, "Tree_%s_5_4_3" % g.valueTypeName])
    return out


def write_oracle(path, oracle):
    with open(path[:-4] + ".json", "w") as f:
        json.dump(oracle, f, indent=None, separators=(",", ":"), sort_keys=True)
        f.write("\n")


def save(name, grids):
    path = os.path.join(HERE, name)
    vdb.write(path, grids=grids)
    write_oracle(path, file_oracle(path, "pyopenvdb %s" % ".".join(map(str, vdb.LIBRARY_VERSION))))
    return path


def sphere():
    """A narrow-band level set: UniformScaleTranslateMap, -background inside, leaves whose
    inactive voxels are +background, -background or both (mask compression modes 0, 1, 3)."""
    g = vdb.createLevelSetSphere(2.0, (1.5, -2.0, 0.75), 0.37, 3.0)
    g.name = "sphere"
    g.transform.translate((0.25, -0.5, 1.0))
    return g


def fog():
    """A fog volume with tiles at every level: a 4096^3 root tile, a 128^3 tile of a 32^3
    node, 8^3 tiles of 16^3 nodes (active and inactive), and scattered voxels. ScaleMap."""
    g = vdb.FloatGrid(background=0.0)
    g.name = "density"
    g.gridClass = vdb.GridClass.FOG_VOLUME
    g.transform = vdb.createLinearTransform(1.0)
    g.transform.scale((0.5, 1.0, 2.0))
    g.fill((-4096, -4096, -4096), (-1, -1, -1), 0.25, True)  # a root tile
    g.fill((0, 0, 0), (127, 127, 127), 0.5, True)  # a tile of a 32^3 node
    g.fill((128, 0, 0), (135, 7, 7), 0.75, True)  # tiles of a 16^3 node
    g.fill((136, 8, 0), (143, 15, 7), 0.125, False)  # inactive, not the background
    rng = random.Random(7)
    acc = g.getAccessor()
    for _ in range(150):
        ijk = (rng.randint(200, 240), rng.randint(-10, 20), rng.randint(0, 30))
        acc.setValueOn(ijk, round(rng.uniform(0.0, 1.0), 6))
    return g


def modes():
    """A grid of class "unknown" (so zip applies) whose leaves and 16^3 nodes exercise every
    per-node compression mode: inactive voxels all background (0), all -background (1), all one
    other value (2), a mix of +/-background (3), background and one other value (4), two other
    values (5), more than two values (6). ScaleTranslateMap."""
    bg = 2.0
    g = vdb.FloatGrid(background=bg)
    g.name = "modes"
    g.transform = vdb.createLinearTransform(0.5)
    g.transform.scale((1.0, 2.0, 4.0))
    g.transform.translate((10.0, -20.0, 30.0))
    acc = g.getAccessor()
    rng = random.Random(3)
    inactive_sets = [[bg], [-bg], [7.5], [bg, -bg], [bg, 7.5], [7.5, -3.25], [1.0, 2.5, -4.0]]
    for m, choices in enumerate(inactive_sets):
        ox = m * 8
        for x in range(8):
            for y in range(8):
                for z in range(8):
                    ijk = (ox + x, y, z)
                    if (x + 2 * y + 3 * z) % 5 == 0:
                        acc.setValueOn(ijk, round(rng.uniform(-5, 5), 4))
                    else:
                        acc.setValueOff(ijk, choices[(x * 7 + y * 3 + z) % len(choices)])
    # 16^3 nodes (one per mode) whose inactive tiles are: all background (0), all -background
    # (1), all 7.5 (2), background and -background (3), background and 7.5 (4), 7.5 and -3.25
    # (5), three values (6). Each also holds one active 8^3 tile.
    node_sets = [(None, []), (-bg, []), (7.5, []), (None, [-bg]), (None, [7.5]), (7.5, [-3.25]), (None, [7.5, -3.25])]
    for m, (fill_value, subs) in enumerate(node_sets):
        x0 = 1024 + m * 128
        if fill_value is not None:
            g.fill((x0, 0, 0), (x0 + 127, 127, 127), fill_value, False)
        g.fill((x0, 0, 0), (x0 + 7, 7, 7), 0.5, True)
        for t, value in enumerate(subs):
            lo = (x0 + 8 * (t + 1), 8, 0)
            g.fill(lo, (lo[0] + 7, lo[1] + 7, 7), value, False)
    return g


def multi():
    """Four float grids and two of other types: "a" (AffineMap with a rotation), "velocity"
    (vec3s, skipped), "b", "mask" (bool, skipped), "a_instance" (shares the tree of "a": written
    as an instance), "empty" (no nodes at all)."""
    a = vdb.FloatGrid(background=-1.0)
    a.name = "a"
    a.transform = vdb.createLinearTransform([[0.0, 0.5, 0.0, 0.0], [-0.5, 0.0, 0.0, 0.0], [0.0, 0.0, 0.25, 0.0], [1.0, 2.0, 3.0, 1.0]])
    rng = random.Random(11)
    acc = a.getAccessor()
    for _ in range(300):
        acc.setValueOn((rng.randint(-4, 40), rng.randint(0, 40), rng.randint(0, 40)), round(rng.uniform(-3, 3), 5))
    v = vdb.Vec3SGrid()
    v.name = "velocity"
    v.fill((0, 0, 0), (9, 9, 9), (1.0, 2.0, 3.0), True)
    b = vdb.FloatGrid(background=0.5)
    b.name = "b"
    b.fill((0, 0, 0), (15, 15, 15), 3.0, True)
    b.getAccessor().setValueOn((100, 100, 100), -2.0)
    mask = vdb.BoolGrid()
    mask.name = "mask"
    mask.fill((0, 0, 0), (3, 3, 3), True, True)
    inst = a.copy()  # shallow: shares the tree, written as an instance of "a"
    inst.name = "a_instance"
    inst.transform = vdb.createLinearTransform(2.0)
    empty = vdb.FloatGrid(background=4.0)
    empty.name = "empty"
    return [a, v, b, mask, inst, empty]


def half():
    """Values saved as 16-bit halves (`is_saved_as_half_float`): values that halves round."""
    g = vdb.FloatGrid(background=0.1)
    g.name = "halves"
    g.saveFloatAsHalf = True
    acc = g.getAccessor()
    rng = random.Random(5)
    for _ in range(400):
        acc.setValueOn((rng.randint(0, 30), rng.randint(0, 30), rng.randint(0, 30)), rng.uniform(-1000.0, 1000.0))
    g.fill((64, 64, 64), (71, 71, 71), 1.0 / 3.0, True)
    return g


def tiny():
    """The smallest useful file (one leaf; about 10 kB, most of it the two uncompressed masks of
    the 32^3 node): a fuzzing seed as much as a test."""
    g = vdb.FloatGrid(background=0.5)
    g.name = "tiny"
    acc = g.getAccessor()
    acc.setValueOn((1, 2, 3), 5.0)
    acc.setValueOn((6, 0, 7), -1.25)
    acc.setValueOff((0, 0, 1), 0.75)
    g.fill((8, 0, 0), (15, 7, 7), 2.0, True)
    return g


# rewrite.cc variants: (output, source, arguments). The oracle of a double file is the oracle of
# the float file named in ORACLE_FROM.
VARIANTS = [
    ("modes_zip.vdb", "modes.vdb", ["--compression", str(ZIP | MASK)]),
    ("modes_zip_nomask.vdb", "modes.vdb", ["--compression", str(ZIP)]),
    # Uncompressed full floats would store 32^3 values of 4 bytes per root child (over 200 KB).
    ("modes_none.vdb", "modes.vdb", ["--half", "--compression", str(NONE)]),
    ("modes_mask.vdb", "modes.vdb", ["--compression", str(MASK)]),
    ("modes_half.vdb", "modes.vdb", ["--half"]),
    ("tiny_half.vdb", "tiny.vdb", ["--half"]),
    ("stream.vdb", "multi.vdb", ["--stream", "--only-float"]),
    ("double.vdb", "modes.vdb", ["--double"]),
    ("double_zip.vdb", "modes.vdb", ["--double", "--compression", str(ZIP | MASK)]),
    ("double_half.vdb", "modes.vdb", ["--double", "--half"]),
    ("translation.vdb", "half.vdb", ["--map", "translation"]),
    ("unitary.vdb", "half.vdb", ["--map", "unitary"]),
    ("frustum.vdb", "half.vdb", ["--map", "frustum"]),
    ("tiny_zip.vdb", "tiny.vdb", ["--compression", str(ZIP | MASK)]),
    ("tiny_stream.vdb", "tiny.vdb", ["--stream"]),
    ("tiny_double.vdb", "tiny.vdb", ["--double", "--half"]),
]
ORACLE_FROM = {
    "double.vdb": "modes.vdb",
    "double_zip.vdb": "modes.vdb",
    "double_half.vdb": "modes_half.vdb",
    "tiny_double.vdb": "tiny_half.vdb",
}

REWRITE_CC = r"""
// Rewrites a .vdb file with other settings: the variants pyopenvdb cannot write.
#include <openvdb/openvdb.h>
#include <openvdb/io/Stream.h>
#include <fstream>
#include <map>
#include <string>
using namespace openvdb;
int main(int argc, char** argv) {
    openvdb::initialize();
    if (argc < 3) return 2;
    uint32_t flags = io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK;
    bool stream = false, toDouble = false, half = false, onlyFloat = false;
    std::string map;
    for (int i = 3; i < argc; ++i) {
        std::string a = argv[i];
        if (a == "--compression") flags = std::stoul(argv[++i]);
        else if (a == "--stream") stream = true;
        else if (a == "--double") toDouble = true;
        else if (a == "--half") half = true;
        else if (a == "--only-float") onlyFloat = true;
        else if (a == "--map") map = argv[++i];
        else return 2;
    }
    io::File in(argv[1]);
    in.open();
    GridPtrVec all = *in.getGrids();
    MetaMap::Ptr meta = in.getMetadata();
    in.close();
    GridPtrVec grids;
    std::map<const TreeBase*, DoubleTree::Ptr> converted; // keeps instances shared
    for (GridBase::Ptr g : all) {
        FloatGrid::Ptr fg = gridPtrCast<FloatGrid>(g);
        if (onlyFloat && !fg) continue;
        if (toDouble && fg) {
            DoubleTree::Ptr& t = converted[&fg->baseTree()];
            if (!t) t.reset(new DoubleTree(fg->tree()));
            DoubleGrid::Ptr dg = DoubleGrid::create(t);
            static_cast<MetaMap&>(*dg) = static_cast<const MetaMap&>(*fg);
            dg->setTransform(fg->transform().copy());
            g = dg;
        }
        if (half) g->setSaveFloatAsHalf(true);
        if (map == "frustum") {
            g->setTransform(math::Transform::createFrustumTransform(BBoxd(Vec3d(0), Vec3d(10)), 0.5, 2.0, 0.1));
        } else if (!map.empty()) {
            math::MapBase::Ptr m;
            if (map == "translation") m.reset(new math::TranslationMap(Vec3d(1.5, -2.0, 0.25)));
            else if (map == "unitary") m.reset(new math::UnitaryMap(Vec3d(0, 0, 1), 0.5));
            else return 2;
            g->setTransform(math::Transform::Ptr(new math::Transform(m)));
        }
        grids.push_back(g);
    }
    if (stream) {
        std::ofstream os(argv[2], std::ios_base::binary);
        io::Stream s(os);
        s.setCompression(flags);
        s.write(grids, *meta);
    } else {
        io::File out(argv[2]);
        out.setCompression(flags);
        out.write(grids, *meta);
        out.close();
    }
    return 0;
}
"""


def build_rewrite(tmp):
    """Compiles rewrite.cc into `tmp`; None when there is no compiler or libopenvdb-dev."""
    if not shutil.which("g++") or not os.path.exists("/usr/include/openvdb/openvdb.h"):
        return None
    src = os.path.join(tmp, "rewrite.cc")
    exe = os.path.join(tmp, "rewrite")
    with open(src, "w") as f:
        f.write(REWRITE_CC)
    cmd = ["g++", "-O1", "-std=c++17", src, "-o", exe, "-lopenvdb", "-ltbb", "-lImath-3_1"]
    if subprocess.run(cmd).returncode != 0:
        return None
    return exe


def main():
    save("sphere.vdb", [sphere()])
    save("fog.vdb", [fog()])
    save("modes.vdb", [modes()])
    save("multi.vdb", multi())
    save("half.vdb", [half()])
    save("tiny.vdb", [tiny()])
    with tempfile.TemporaryDirectory() as tmp:
        exe = build_rewrite(tmp)
        if exe is None:
            print("no g++ or libopenvdb-dev: the rewrite.cc variants are left as they are", file=sys.stderr)
            return
        for out, source, args in VARIANTS:
            path = os.path.join(HERE, out)
            subprocess.run([exe, os.path.join(HERE, source), path] + args, check=True)
            made_by = "rewrite.cc %s %s (libopenvdb %s)" % (source, " ".join(args), ".".join(map(str, vdb.LIBRARY_VERSION)))
            if out == "frustum.vdb":
                # pyopenvdb reads it, but the reader refuses the map: the oracle says so.
                oracle = {"file": out, "made_by": made_by, "error": "NonlinearFrustumMap"}
            elif out in ORACLE_FROM:
                with open(os.path.join(HERE, ORACLE_FROM[out][:-4] + ".json")) as f:
                    oracle = json.load(f)
                oracle["file"] = out
                oracle["made_by"] = made_by + "; oracle of %s (pyopenvdb cannot open double grids)" % ORACLE_FROM[out]
                for g in oracle["grids"]:
                    g["type"] = "double"
            else:
                oracle = file_oracle(path, made_by)
            write_oracle(path, oracle)
    for name in sorted(os.listdir(HERE)):
        if name.endswith(".vdb"):
            print("%-24s %7d bytes" % (name, os.path.getsize(os.path.join(HERE, name))))


if __name__ == "__main__":
    main()
