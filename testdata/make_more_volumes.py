#!/usr/bin/env python3
"""Golden MRC and VTK-legacy volumes written by independent libraries (mrcfile, VTK), each with an
`.expect.json` of what those libraries report: dims, and world position + value at probe points.

    /tmp/peers-venv/bin/pip install mrcfile          # vtk is in the peer venv already
    /tmp/peers-venv/bin/python testdata/make_more_volumes.py

World positions follow each library's own convention: mrcfile voxel_size and header origin
(MRC2014) or nxstart · voxel size (CCP4); VTK image data origin + index · spacing.
"""
import json
import os

import mrcfile
import numpy as np
import vtk
from vtk.util import numpy_support

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "volumes")
PROBES = [(0, 0, 0), (1, 2, 3), (4, 3, 2), (5, 4, 6)]


def field(shape, dtype):
    z, y, x = np.indices(shape)
    v = (x * 7 + y * 13 + z * 29) % 23 - 5
    return v.astype(dtype)


def write_expect(name, arr, world):
    probes = []
    for (i, j, k) in PROBES:
        probes.append({"ijk": [i, j, k], "world": [float(w) for w in world(i, j, k)], "value": float(arr[k, j, i])})
    with open(os.path.join(OUT, name + ".expect.json"), "w") as f:
        json.dump({"dims": [arr.shape[2], arr.shape[1], arr.shape[0]], "dtype": str(arr.dtype), "probes": probes}, f, indent=1)


def mrc(name, dtype, voxel, origin=None, nstart=None, big=False):
    arr = field((7, 5, 6), dtype)  # z, y, x
    path = os.path.join(OUT, name)
    with mrcfile.new(path, overwrite=True) as m:
        m.set_data(arr)
        m.voxel_size = voxel
        if origin is not None:
            m.header.origin = origin
        if nstart is not None:
            m.header.nxstart, m.header.nystart, m.header.nzstart = nstart
    if big:  # rewrite big-endian with mrcfile's own byte swapping
        with mrcfile.open(path, mode="r+") as m:
            data = m.data.copy()
        with mrcfile.new(path, overwrite=True) as m:
            m.set_data(data.astype(data.dtype.newbyteorder(">")))
            m.voxel_size = voxel
            if origin is not None:
                m.header.origin = origin
    with mrcfile.open(path) as m:  # what mrcfile reports back
        vs = m.voxel_size
        o = m.header.origin
        ns = (int(m.header.nxstart), int(m.header.nystart), int(m.header.nzstart))
        back = np.asarray(m.data)
        use_origin = any(float(o[a]) != 0.0 for a in "xyz")
        base = [float(o[a]) for a in "xyz"] if use_origin else [ns[0] * float(vs.x), ns[1] * float(vs.y), ns[2] * float(vs.z)]
        write_expect(name, back, lambda i, j, k: (base[0] + i * float(vs.x), base[1] + j * float(vs.y), base[2] + k * float(vs.z)))


def vtk_legacy(name, np_dtype, binary, spacing, origin):
    arr = field((7, 5, 6), np_dtype)
    img = vtk.vtkImageData()
    img.SetDimensions(6, 5, 7)
    img.SetSpacing(*spacing)
    img.SetOrigin(*origin)
    a = numpy_support.numpy_to_vtk(arr.ravel(order="C"), deep=True)
    a.SetName("values")
    img.GetPointData().SetScalars(a)
    w = vtk.vtkStructuredPointsWriter()
    w.SetFileName(os.path.join(OUT, name))
    w.SetInputData(img)
    if binary:
        w.SetFileTypeToBinary()
    else:
        w.SetFileTypeToASCII()
    w.Write()
    r = vtk.vtkStructuredPointsReader()
    r.SetFileName(os.path.join(OUT, name))
    r.Update()
    out = r.GetOutput()
    back = numpy_support.vtk_to_numpy(out.GetPointData().GetScalars()).reshape(7, 5, 6)
    write_expect(name, back, lambda i, j, k: out.GetPoint(out.ComputePointId([i, j, k])))


def vti(name, np_dtype, mode, compress, encode, direction=None, header64=False):
    arr = field((7, 5, 6), np_dtype)
    img = vtk.vtkImageData()
    img.SetDimensions(6, 5, 7)
    img.SetSpacing(0.5, 1.25, 2.0)
    img.SetOrigin(-1.0, 4.0, 2.5)
    if direction is not None:
        img.SetDirectionMatrix(*direction)
    a = numpy_support.numpy_to_vtk(arr.ravel(order="C"), deep=True)
    a.SetName("density")
    img.GetPointData().SetScalars(a)
    other = numpy_support.numpy_to_vtk((arr.ravel() * 0).astype(np.float64), deep=True)
    other.SetName("other")
    img.GetPointData().AddArray(other)  # a second array: the Scalars one must be chosen
    w = vtk.vtkXMLImageDataWriter()
    w.SetFileName(os.path.join(OUT, name))
    w.SetInputData(img)
    {"ascii": w.SetDataModeToAscii, "binary": w.SetDataModeToBinary, "appended": w.SetDataModeToAppended}[mode]()
    if not compress:
        w.SetCompressorTypeToNone()
    w.SetEncodeAppendedData(encode)
    if header64:
        w.SetHeaderTypeToUInt64()
    w.Write()
    r = vtk.vtkXMLImageDataReader()
    r.SetFileName(os.path.join(OUT, name))
    r.Update()
    out = r.GetOutput()
    back = numpy_support.vtk_to_numpy(out.GetPointData().GetScalars()).reshape(7, 5, 6)
    write_expect(name, back, lambda i, j, k: out.GetPoint(out.ComputePointId([i, j, k])))


mrc("i16_mrc2014_origin.mrc", np.int16, (0.5, 0.75, 1.25), origin=(10.0, -4.0, 2.5))
mrc("f32_ccp4_nstart.map", np.float32, (1.5, 1.5, 2.0), nstart=(-3, 2, 4))
mrc("u16_bigendian.mrc", np.uint16, (1.0, 2.0, 3.0), big=True)
mrc("i8_mode0.mrc", np.int8, (1.0, 1.0, 1.0))
mrc("f16_mode12.mrc", np.float16, (0.8, 0.8, 0.8), origin=(1.0, 2.0, 3.0))


def tiff_stack(name, np_dtype):
    """A multi-page greyscale TIFF (tifffile): page k is slice z = k, index = world."""
    arr = field((7, 5, 6), np_dtype) * np_dtype(1.5) if np.issubdtype(np_dtype, np.floating) else field((7, 5, 6), np_dtype)
    path = os.path.join(OUT, name)
    tifffile.imwrite(path, arr, photometric="minisblack")
    back = tifffile.imread(path)
    write_expect(name, back, lambda i, j, k: (float(i), float(j), float(k)))
vtk_legacy("f32_binary.vtk", np.float32, True, (0.5, 1.0, 2.0), (1.0, -2.0, 3.5))
vtk_legacy("i16_ascii.vtk", np.int16, False, (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))
import tifffile  # noqa: E402

tiff_stack("f32_stack.tif", np.float32)
tiff_stack("i32_stack.tif", np.int32)
vti("f32_ascii.vti", np.float32, "ascii", False, False)
vti("i16_binary_zlib.vti", np.int16, "binary", True, False)
vti("u16_appended_raw.vti", np.uint16, "appended", False, False, header64=True)
vti("f64_appended_base64_zlib.vti", np.float64, "appended", True, True,
    direction=(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0))
vti("u8_binary.vti", np.uint8, "binary", False, False)
print("written to", OUT)

# An 8-bit RGB TIFF stack on the grid of u8_raw.nrrd (6 x 5 x 7): colour linear in the indices,
# so trilinear sampling is exact (read with --color-volume).
import tifffile  # noqa: E402

k, j, i = np.indices((7, 5, 6))
rgb = np.stack([10 * i + 3, 20 * j + 7, 30 * k + 1], axis=-1).astype(np.uint8)
tifffile.imwrite(os.path.join(os.path.dirname(OUT), "images", "rgb_6x5x7.tif"), rgb, photometric="rgb")
