"""Binary little-endian PLY of triangles: the reader and writer the issue-46 peer scripts share."""
import numpy as np

PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
             "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
             "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}


def write_ply(path, verts, faces):
    """Writes float32 vertices and int32 triangles as binary little-endian PLY."""
    verts = np.ascontiguousarray(verts, dtype="<f4")
    faces = np.asarray(faces, dtype="<i4").reshape(-1, 3)
    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(verts)}\n"
              "property float x\nproperty float y\nproperty float z\n"
              f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
    rows = np.empty(len(faces), dtype=[("n", "u1"), ("v", "<i4", (3,))])
    rows["n"] = 3
    rows["v"] = faces
    with open(path, "wb") as f:
        f.write(header.encode())
        f.write(verts.tobytes())
        f.write(rows.tobytes())


def read_ply(path):
    """Reads a binary little-endian PLY whose faces are all triangles (uchar count, int or uint
    indices, any extra per-face properties): returns (float64 vertices, int64 triangles)."""
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    elements = []
    for line in data[:end].decode("latin-1").splitlines():
        w = line.split()
        if not w:
            continue
        if w[0] == "format" and w[1] != "binary_little_endian":
            raise ValueError(f"{path}: format {w[1]} not supported (binary_little_endian only)")
        if w[0] == "element":
            elements.append((w[1], int(w[2]), []))
        elif w[0] == "property":
            elements[-1][2].append(w[1:])
    pos = end
    verts = faces = None
    for name, count, props in elements:
        if name == "vertex":
            dt = np.dtype([(p[1], "<" + PLY_TYPES[p[0]]) for p in props])
            arr = np.frombuffer(data, dtype=dt, count=count, offset=pos)
            verts = np.stack([arr["x"], arr["y"], arr["z"]], axis=1).astype(np.float64)
            pos += dt.itemsize * count
        elif name == "face":
            fields = []
            for p in props:
                if p[0] == "list":
                    if p[1] not in ("uchar", "uint8"):
                        raise ValueError(f"{path}: face list count type {p[1]} not supported")
                    fields += [("n", "u1"), ("v", "<" + PLY_TYPES[p[2]], (3,))]
                else:
                    fields.append((p[1], "<" + PLY_TYPES[p[0]]))
            dt = np.dtype(fields)
            arr = np.frombuffer(data, dtype=dt, count=count, offset=pos)
            if count and not (arr["n"] == 3).all():
                raise ValueError(f"{path}: non-triangle faces")
            faces = arr["v"].astype(np.int64)
            pos += dt.itemsize * count
        else:
            raise ValueError(f"{path}: element {name} not supported")
    return verts, faces
