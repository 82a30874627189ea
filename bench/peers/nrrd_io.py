"""A minimal NRRD reader for the benchmark scripts (attached header; raw or gzip; axis-aligned)."""
import gzip

import numpy as np

TYPES = {"uint8": "u1", "uchar": "u1", "unsigned char": "u1", "int8": "i1", "signed char": "i1",
         "uint16": "u2", "ushort": "u2", "unsigned short": "u2", "int16": "i2", "short": "i2",
         "int32": "i4", "int": "i4", "uint32": "u4", "float": "f4", "double": "f8"}


def read_nrrd(path):
    """A minimal NRRD reader (attached header, raw/gzip): returns (array[k, j, i], spacing, origin)."""
    data = open(path, "rb").read()
    end = data.index(b"\n\n")
    fields = {}
    for line in data[:end].decode().splitlines()[1:]:
        if line.startswith("#") or ": " not in line:
            continue
        k, v = line.split(": ", 1)
        fields[k.strip()] = v.strip()
    sizes = [int(x) for x in fields["sizes"].split()]
    dt = np.dtype(TYPES[fields["type"]]).newbyteorder("<" if fields.get("endian", "little") == "little" else ">")
    body = data[end + 2:]
    if fields["encoding"] in ("gzip", "gz"):
        body = gzip.decompress(body)
    arr = np.frombuffer(body, dtype=dt, count=int(np.prod(sizes))).reshape(sizes[::-1])
    spacing, origin = [1.0, 1.0, 1.0], [0.0, 0.0, 0.0]
    if "space directions" in fields:
        vecs = [[float(x) for x in t.strip("()").split(",")] for t in fields["space directions"].split()]
        spacing = [float(np.linalg.norm(v)) for v in vecs]
        assert all(abs(v[i]) == np.linalg.norm(v) for i, v in enumerate(vecs)), "axis-aligned only"
    elif "spacings" in fields:
        spacing = [float(x) for x in fields["spacings"].split()]
    if "space origin" in fields:
        origin = [float(x) for x in fields["space origin"].strip("()").split(",")]
    return arr, spacing, origin
