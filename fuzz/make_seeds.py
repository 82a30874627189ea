#!/usr/bin/env python3
"""Writes the fuzz seed corpus fuzz/seeds/<target>/ from testdata/ (standard library only;
Pillow, when importable, adds a JPEG-compressed DICOM seed).

Every seed is the selector byte of the target (see fuzz_targets/*.rs) followed by a small valid
file; detached data (an .nhdr's data file, a .hdr's .img, further DICOM slices) follows the split
marker of fuzz_targets/common.rs. Must-fail files of testdata/bad/ are seeds too: they start the
fuzzer inside the error paths. Run from the repository root: python3 fuzz/make_seeds.py
"""

import binascii
import pathlib
import shutil
import struct
import zlib

ROOT = pathlib.Path(__file__).resolve().parent.parent
TESTDATA = ROOT / "testdata"
OUT = ROOT / "fuzz" / "seeds"
SPLIT = b"\n--ISOFORGE-FUZZ-SPLIT--\n"
MAX_SEED = 64 << 10


def seed(target, name, selector, body):
    if len(body) > MAX_SEED:
        return
    d = OUT / target
    d.mkdir(parents=True, exist_ok=True)
    (d / name).write_bytes(bytes([selector]) + body)


def files(folder, *suffixes):
    for p in sorted((TESTDATA / folder).iterdir()):
        if any(p.name.endswith(s) for s in suffixes):
            yield p


# ------------------------------------------------------------------------------------------
# Volumes

def volumes():
    for p in files("volumes", ".nrrd"):
        seed("read_nrrd", p.name, 0, p.read_bytes())
    for p in files("bad", ".nrrd"):
        seed("read_nrrd", "bad_" + p.name, 0, p.read_bytes())
    nhdr = (TESTDATA / "volumes" / "u16_detached.nhdr").read_text()
    lines = [("data file: d.raw" if l.startswith("data file") else l) for l in nhdr.splitlines()]
    raw = (TESTDATA / "volumes" / "u16_detached.raw").read_bytes()
    seed("read_nrrd", "u16_detached.nhdr", 1, ("\n".join(lines) + "\n").encode() + SPLIT + raw)

    for p in files("volumes", ".nii"):
        seed("read_nifti", p.name, 0, p.read_bytes())
    for p in files("volumes", ".nii.gz"):
        seed("read_nifti", p.name, 1, p.read_bytes())
    for p in files("bad", ".nii", ".nii.gz"):
        seed("read_nifti", "bad_" + p.name, 1 if p.name.endswith(".gz") else 0, p.read_bytes())
    # A .hdr/.img pair made of u8_plain.nii: magic "ni1", samples at offset 0 of the .img.
    nii = (TESTDATA / "volumes" / "u8_plain.nii").read_bytes()
    vox = int(struct.unpack("<f", nii[108:112])[0])
    hdr = bytearray(nii[:348])
    hdr[108:112] = struct.pack("<f", 0.0)
    hdr[344:348] = b"ni1\0"
    seed("read_nifti", "u8_pair.hdr", 2, bytes(hdr) + SPLIT + nii[vox:])

    for p in files("volumes", ".mha"):
        seed("read_metaimage", p.name, 0, p.read_bytes())
    for p in files("bad", ".mha"):
        seed("read_metaimage", "bad_" + p.name, 0, p.read_bytes())
    mhd = (TESTDATA / "volumes" / "f64_external.mhd").read_text()
    lines = [("ElementDataFile = d.raw" if l.startswith("ElementDataFile") else l) for l in mhd.splitlines()]
    raw = (TESTDATA / "volumes" / "f64_external.raw").read_bytes()
    seed("read_metaimage", "f64_external.mhd", 1, ("\n".join(lines) + "\n").encode() + SPLIT + raw)

    for p in files("volumes", ".mrc", ".map"):
        seed("read_mrc", p.name, 0, p.read_bytes())
    for p in files("bad", ".mrc"):
        seed("read_mrc", "bad_" + p.name, 0, p.read_bytes())
    for p in files("volumes", ".vtk"):
        seed("read_vtk", p.name, 0, p.read_bytes())
    for p in files("bad", ".vtk"):
        seed("read_vtk", "bad_" + p.name, 0, p.read_bytes())
    for p in files("volumes", ".vti"):
        seed("read_vti", p.name, 0, p.read_bytes())
    for p in files("bad", ".vti"):
        seed("read_vti", "bad_" + p.name, 0, p.read_bytes())

    # Raw: 8 layout bytes (dims − 1 per axis, type, byte order, header bytes, spacing exponent,
    # origin), then the samples.
    seed("read_raw", "u8_3x4x2", 0, bytes([2, 3, 1, 0, 0, 0, 160, 0]) + bytes(range(24)))
    seed("read_raw", "f32_2x2x2_be_header4", 0, bytes([1, 1, 1, 6, 1, 4, 161, 0]) + bytes(4) +
         b"".join(struct.pack(">f", v) for v in [0, 1, 2, 3, 4, 5, 6, 7]))
    seed("read_raw", "i16_2x3x1", 0, bytes([1, 2, 0, 3, 0, 0, 150, 1]) +
         b"".join(struct.pack("<h", v) for v in [-3, -2, -1, 0, 1, 2]))


# ------------------------------------------------------------------------------------------
# Images

def png(width, height, color, depth, rows, interlace=0):
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", binascii.crc32(kind + data))
    raw = b"".join(b"\0" + r for r in rows)
    ihdr = struct.pack(">IIBBBBB", width, height, depth, color, 0, 0, interlace)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")


def images():
    for p in files("images", ".png"):
        seed("read_png", p.name, 0, p.read_bytes())
    for p in files("bad", ".png"):
        seed("read_png", "bad_" + p.name, 0, p.read_bytes())
    seed("read_png", "gray8_5x4", 0, png(5, 4, 0, 8, [bytes(range(r * 5, r * 5 + 5)) for r in range(4)]))
    seed("read_png", "gray16_3x3", 0, png(3, 3, 0, 16, [struct.pack(">3H", r, 300 * r, 65535) for r in range(3)]))
    seed("read_png", "grayalpha8_3x2", 0, png(3, 2, 4, 8, [bytes([9, 255] * 3) for _ in range(2)]))
    seed("read_png", "gray4_4x2", 0, png(4, 2, 0, 4, [bytes([0x12, 0x34]) for _ in range(2)]))
    for p in files("volumes", ".tif"):
        seed("read_tiff", p.name, 0, p.read_bytes())
    for p in files("images", ".tif"):
        seed("read_tiff", p.name, 0, p.read_bytes())
    for p in files("bad", ".tif"):
        seed("read_tiff", "bad_" + p.name, 0, p.read_bytes())


# ------------------------------------------------------------------------------------------
# Meshes

def meshes():
    for ext in ["ply", "obj", "stl", "off"]:
        for p in files("meshes", "." + ext):
            seed("read_" + ext, p.name, 0, p.read_bytes())
        for p in files("bad", "." + ext):
            seed("read_" + ext, "bad_" + p.name, 0, p.read_bytes())
    tetra = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    head = ("ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
            "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n").encode()
    body = b"".join(struct.pack("<3f", *v) for v in tetra) + b"".join(struct.pack("<B3i", 3, *f) for f in faces)
    seed("read_ply", "tetra_le.ply", 0, head + body)
    stl = bytes(80) + struct.pack("<I", len(faces))
    for f in faces:
        stl += struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *tetra[i]) for i in f) + b"\0\0"
    seed("read_stl", "tetra_binary.stl", 0, stl)


# ------------------------------------------------------------------------------------------
# DICOM

LONG_VRS = {"OB", "OD", "OF", "OL", "OV", "OW", "SQ", "SV", "UC", "UN", "UR", "UT", "UV"}


def pad(vr, value):
    if len(value) % 2:
        value += b"\0" if vr in ("UI", "OB", "UN") else b" "
    return value


def explicit(group, element, vr, value, length=None):
    value = pad(vr, value)
    n = len(value) if length is None else length
    if vr in LONG_VRS:
        return struct.pack("<HH2sHI", group, element, vr.encode(), 0, n) + value
    return struct.pack("<HH2sH", group, element, vr.encode(), n) + value


def implicit(group, element, vr, value):
    value = pad(vr, value)
    return struct.pack("<HHI", group, element, len(value)) + value


def dicom(ts, rows, cols, bits, position, pixels, encode=explicit, encapsulated=False, deflate=False):
    us = lambda v: struct.pack("<H", v)
    sop = b"1.2.840.10008.5.1.4.1.1.2"
    meta = explicit(2, 1, "OB", b"\0\1") + explicit(2, 2, "UI", sop) + explicit(2, 3, "UI", b"1.2.3.4.5." + str(position).encode())
    meta += explicit(2, 0x10, "UI", ts.encode()) + explicit(2, 0x12, "UI", b"1.2.3.4")
    meta = explicit(2, 0, "UL", struct.pack("<I", len(meta))) + meta
    ds = encode(8, 0x16, "UI", sop) + encode(8, 0x18, "UI", b"1.2.3.4.5." + str(position).encode())
    ds += encode(0x18, 0x50, "DS", b"2.5")
    ds += encode(0x20, 0x0E, "UI", b"1.2.3.4.5")
    ds += encode(0x20, 0x32, "DS", b"0\\0\\" + str(position * 2.5).encode())
    ds += encode(0x20, 0x37, "DS", b"1\\0\\0\\0\\1\\0")
    ds += encode(0x28, 2, "US", us(1)) + encode(0x28, 4, "CS", b"MONOCHROME2")
    ds += encode(0x28, 0x10, "US", us(rows)) + encode(0x28, 0x11, "US", us(cols))
    ds += encode(0x28, 0x30, "DS", b"0.8\\0.7")
    ds += encode(0x28, 0x100, "US", us(bits)) + encode(0x28, 0x101, "US", us(bits)) + encode(0x28, 0x102, "US", us(bits - 1))
    ds += encode(0x28, 0x103, "US", us(1 if bits == 16 else 0))
    ds += encode(0x28, 0x1052, "DS", b"-1024") + encode(0x28, 0x1053, "DS", b"1")
    if encapsulated:
        item = lambda data: struct.pack("<HHI", 0xFFFE, 0xE000, len(data)) + data
        ds += struct.pack("<HH2sHI", 0x7FE0, 0x10, b"OB", 0, 0xFFFFFFFF) + item(b"") + item(pad("OB", pixels))
        ds += struct.pack("<HHI", 0xFFFE, 0xE0DD, 0)
    else:
        ds += encode(0x7FE0, 0x10, "OW" if bits == 16 else "OB", pixels)
    if deflate:
        c = zlib.compressobj(9, zlib.DEFLATED, -15)
        ds = c.compress(ds) + c.flush()
    return bytes(128) + b"DICM" + meta + ds


def packbits(data):
    out = b""
    for i in range(0, len(data), 128):
        chunk = data[i:i + 128]
        out += bytes([len(chunk) - 1]) + chunk
    return out


def dicoms():
    rows, cols = 3, 4
    px16 = lambda k: b"".join(struct.pack("<h", 1000 + 10 * k + i) for i in range(rows * cols))
    px8 = bytes(range(rows * cols))
    evle, ivle, debe = "1.2.840.10008.1.2.1", "1.2.840.10008.1.2", "1.2.840.10008.1.2.1.99"
    seed("read_dicom", "explicit_le_16", 0, dicom(evle, rows, cols, 16, 0, px16(0)))
    seed("read_dicom", "explicit_le_series3", 0, SPLIT.join(dicom(evle, rows, cols, 16, k, px16(k)) for k in [2, 0, 1]))
    seed("read_dicom", "implicit_le_8", 0, dicom(ivle, rows, cols, 8, 0, px8, encode=implicit))
    seed("read_dicom", "deflated_16", 0, dicom(debe, rows, cols, 16, 0, px16(0), deflate=True))
    rle = packbits(px8)
    rle = struct.pack("<16I", 1, 64, *([0] * 14)) + rle
    seed("read_dicom", "rle_8", 0, dicom("1.2.840.10008.1.2.5", rows, cols, 8, 0, rle, encapsulated=True))
    # 16 bits: two segments, most significant bytes first.
    p16 = px16(0)
    msb, lsb = packbits(p16[1::2]), packbits(p16[0::2])
    rle16 = struct.pack("<16I", 2, 64, 64 + len(msb), *([0] * 13)) + msb + lsb
    seed("read_dicom", "rle_16", 0, dicom("1.2.840.10008.1.2.5", rows, cols, 16, 0, rle16, encapsulated=True))
    try:
        import io
        from PIL import Image
        img = Image.frombytes("L", (cols, rows), px8)
        buf = io.BytesIO()
        img.save(buf, format="JPEG", quality=90)
        seed("read_dicom", "jpeg_baseline_8", 0, dicom("1.2.840.10008.1.2.4.50", rows, cols, 8, 0, buf.getvalue(), encapsulated=True))
    except ImportError:
        print("Pillow not importable: no JPEG DICOM seed")


# ------------------------------------------------------------------------------------------
# OpenVDB

def vdbs():
    """The .vdb files of testdata/vdb/ (made by its make_vdb.py) read from memory (selector 0),
    the smallest also through a file (1), and truncations of tiny.vdb (inside the header, the
    descriptor, the metadata, the 32^3 node's masks, the leaf values)."""
    for p in files("vdb", ".vdb"):
        seed("read_vdb", p.name, 0, p.read_bytes())
    for name in ["tiny.vdb", "tiny_stream.vdb"]:
        seed("read_vdb", "file_" + name, 1, (TESTDATA / "vdb" / name).read_bytes())
    tiny = (TESTDATA / "vdb" / "tiny.vdb").read_bytes()
    for cut in [40, 120, 400, 2000, 8000, len(tiny) - 300, len(tiny) - 1]:
        seed("read_vdb", "tiny_cut_%d.vdb" % cut, 0, tiny[:cut])


# ------------------------------------------------------------------------------------------
# SOG (PolyMender's signed octree grids)

def sog(dim, nodes, edge=2.0):
    """A .sog file: magic, origin 0, `edge`, zero padding to byte 128, `dim`, the node bytes."""
    head = b"SOG.Format 1.0\0" + struct.pack("<4f", 0.0, 0.0, 0.0, edge)
    return head.ljust(128, b"\0") + struct.pack("<i", dim) + nodes


def sogs():
    """Small made trees (one empty node; a depth-1 tree with a leaf; a depth-2 one) in both
    variants, and, when ../shared/data/sog is there, wisky.5.sog (39 KB) whole and cut inside
    its header and its tree."""
    leaf = lambda signs, v: bytes([2, signs]) + struct.pack("<3f", *v)
    depth1 = b"\0" + leaf(0x7F, (0.5, 0.5, 0.5)) + b"\1\1" * 7
    depth2 = b"\0" + b"\0" + leaf(0x7F, (0.25, 0.25, 0.25)) + b"\1\1" * 7 + b"\1\1" * 7
    for name, body in [("empty", sog(1, b"\1\1")), ("depth1", sog(2, depth1)), ("depth2", sog(4, depth2, 2.0))]:
        seed("read_sog", name + ".sog", 0, body)
        seed("read_sog", "file_" + name + ".sog", 1, body)
    shared = ROOT.parent / "shared" / "data" / "sog" / "wisky.5.sog"
    if shared.is_file():
        wisky = shared.read_bytes()
        seed("read_sog", "wisky.5.sog", 0, wisky)
        seed("read_sog", "file_wisky.5.sog", 1, wisky)
        for cut in [20, 130, 200, 5000, len(wisky) - 5]:
            seed("read_sog", "wisky_cut_%d.sog" % cut, 0, wisky[:cut])


# ------------------------------------------------------------------------------------------
# SKT (TopoMender's skeletons)

def skt_record(kind, weight, a, b):
    """One 21-byte record: type, f32 weight, two positions z | y << 20 | x << 40."""
    pos = lambda p: p[2] | p[1] << 20 | p[0] << 40
    return struct.pack("<BfQQ", kind, weight, pos(a), pos(b))


def skts():
    """Both passes (kept, cut, filled, an infinite weight), the outside's pass alone, no
    skeleton, two empty passes, and must-fail ones: cut inside a record, a pass not closed,
    a bad type, a NaN weight, a third pass."""
    s = 1 << 15
    solid = skt_record(0, 0.5, (s, 2 * s, 3 * s), (2 * s, 2 * s, 3 * s)) + skt_record(1, 0.25, (2 * s, 2 * s, 3 * s), (2 * s, 3 * s, 3 * s))
    solid += skt_record(0, float("inf"), (0, 0, 0), (0, 0, s))
    outside = skt_record(2, 4.0, (s, s, s), (s, s, 2 * s)) + skt_record(3, 1.5, (s, s, 2 * s), (s, 2 * s, 2 * s))
    both = solid + b"\xff" + outside + b"\xff"
    for name, body in [("both", both), ("outside", outside + b"\xff"), ("none", b""), ("empty_passes", b"\xff\xff"),
                       ("cut", both[:30]), ("open", solid), ("type", b"\x07" + both[1:]),
                       ("nan", both[:1] + struct.pack("<f", float("nan")) + both[5:]), ("third", b"\xff\xff\xff")]:
        seed("read_skt", name + ".skt", 0, body)


if __name__ == "__main__":
    shutil.rmtree(OUT, ignore_errors=True)
    volumes()
    images()
    meshes()
    dicoms()
    vdbs()
    sogs()
    skts()
    for d in sorted(OUT.iterdir()):
        print(f"{d.name}: {len(list(d.iterdir()))} seeds")
