#!/usr/bin/env python3
"""Writes the must-fail corpus testdata/bad/: every file here must make its reader return an
error (crates/isoforge-io/tests/bad_input.rs). Each name says what is wrong. Standard library only."""
import gzip
import os
import struct

HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "bad")


def w(name, data):
    with open(os.path.join(HERE, name), "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


def nrrd(fields, body=b""):
    return ("NRRD0004\n" + "".join(f"{k}: {v}\n" for k, v in fields) + "\n").encode() + body


BASE = [("type", "uint8"), ("dimension", "3"), ("sizes", "4 4 4"), ("encoding", "raw")]


def nifti(dims=(4, 4, 4), datatype=2, bitpix=8, sizeof=348, magic=b"n+1\0", vox=352.0, data=None):
    h = bytearray(348)
    struct.pack_into("<i", h, 0, sizeof)
    dim = [3, *dims, 1, 1, 1, 1][:8]
    if len(dims) > 3:
        dim = [len(dims), *dims] + [1] * (7 - len(dims))
    struct.pack_into("<8h", h, 40, *dim)
    struct.pack_into("<hh", h, 70, datatype, bitpix)
    struct.pack_into("<8f", h, 76, 1, 1, 1, 1, 1, 1, 1, 1)
    struct.pack_into("<f", h, 108, vox)
    h[344:348] = magic
    n = 1
    for d in dims:
        n *= max(d, 0)
    body = data if data is not None else bytes(n * max(bitpix // 8, 1))
    return bytes(h) + b"\0\0\0\0" + body


def main():
    os.makedirs(HERE, exist_ok=True)
    # NRRD
    w("nrrd_bad_magic.nrrd", b"NRRX0004\n" + nrrd(BASE, bytes(64))[9:])
    w("nrrd_negative_size.nrrd", nrrd([("type", "uint8"), ("dimension", "3"), ("sizes", "512 512 -3"), ("encoding", "raw")], bytes(64)))
    w("nrrd_unknown_type.nrrd", nrrd([("type", "complex128"), ("dimension", "3"), ("sizes", "4 4 4"), ("encoding", "raw")], bytes(64)))
    w("nrrd_truncated_raw.nrrd", nrrd(BASE, bytes(10)))
    w("nrrd_truncated_gzip.nrrd", nrrd(BASE[:3] + [("encoding", "gzip")], gzip.compress(bytes(64))[:20]))
    w("nrrd_corrupt_gzip.nrrd", nrrd(BASE[:3] + [("encoding", "gzip")], b"\x1f\x8b\x08\x00garbagegarbagegarbage"))
    w("nrrd_huge_sizes.nrrd", nrrd([("type", "float"), ("dimension", "3"), ("sizes", "100000 100000 100000"), ("encoding", "raw"), ("endian", "little")]))
    w("nrrd_overflow_sizes.nrrd", nrrd([("type", "double"), ("dimension", "3"), ("sizes", "4294967295 4294967295 4294967295"), ("encoding", "raw"), ("endian", "little")]))
    w("nrrd_nan.nrrd", nrrd([("type", "float"), ("dimension", "3"), ("sizes", "2 2 2"), ("encoding", "raw"), ("endian", "little")],
                            struct.pack("<8f", 0, 1, 2, float("nan"), 4, 5, 6, 7)))
    w("nrrd_inf.nrrd", nrrd([("type", "double"), ("dimension", "3"), ("sizes", "2 2 2"), ("encoding", "raw"), ("endian", "little")],
                            struct.pack("<8d", 0, 1, 2, 3, 4, 5, 6, float("inf"))))
    w("nrrd_missing_endian.nrrd", nrrd([("type", "short"), ("dimension", "3"), ("sizes", "2 2 2"), ("encoding", "raw")], bytes(16)))
    w("nrrd_dimension_4.nrrd", nrrd([("type", "uint8"), ("dimension", "4"), ("sizes", "2 2 2 2"), ("encoding", "raw")], bytes(16)))
    w("nrrd_bzip2.nrrd", nrrd(BASE[:3] + [("encoding", "bzip2")], bytes(64)))
    w("nrrd_missing_data_file.nhdr", nrrd(BASE + [("data file", "does_not_exist.raw")]))
    w("nrrd_bad_space_directions.nrrd", nrrd(BASE + [("space directions", "(1,0,0) (0,1) (0,0,1)")], bytes(64)))
    w("nrrd_zero_direction.nrrd", nrrd(BASE + [("space directions", "(1,0,0) (0,0,0) (0,0,1)")], bytes(64)))
    w("nrrd_sheared.nrrd", nrrd(BASE + [("space directions", "(1,0,0) (1,1,0) (0,0,1)")], bytes(64)))
    w("nrrd_no_sizes.nrrd", nrrd([("type", "uint8"), ("dimension", "3"), ("encoding", "raw")], bytes(64)))
    w("nrrd_sizes_mismatch.nrrd", nrrd([("type", "uint8"), ("dimension", "3"), ("sizes", "4 4"), ("encoding", "raw")], bytes(64)))
    w("nrrd_bad_ascii.nrrd", nrrd(BASE[:3] + [("encoding", "ascii")], b"1 2 3 x 5"))
    w("nrrd_short_ascii.nrrd", nrrd(BASE[:3] + [("encoding", "ascii")], b"1 2 3"))
    w("nrrd_not_text.nrrd", b"NRRD0004\n\xff\xfe\xfd: \x80\n\n")
    w("nrrd_empty.nrrd", b"")
    # NIfTI-1
    w("nifti_short.nii", bytes(100))
    w("nifti_bad_sizeof.nii", nifti(sizeof=540))
    w("nifti_bad_magic.nii", nifti(magic=b"xyz\0"))
    w("nifti_complex_datatype.nii", nifti(datatype=32, bitpix=64))
    w("nifti_bitpix_mismatch.nii", nifti(datatype=4, bitpix=8))
    w("nifti_negative_dim.nii", nifti(dims=(4, -4, 4)))
    w("nifti_time_series.nii", nifti(dims=(4, 4, 4, 5)))
    w("nifti_truncated_data.nii", nifti(data=bytes(10)))
    w("nifti_huge.nii", nifti(dims=(32767, 32767, 32767), datatype=64, bitpix=64, data=b""))
    w("nifti_vox_offset_past_end.nii", nifti(vox=1e9))
    z = gzip.compress(nifti())
    w("nifti_truncated.nii.gz", z[: len(z) - 9])  # cut inside the CRC trailer
    w("nifti_truncated_header.nii.gz", z[:20])
    w("nifti_nan.nii", nifti(dims=(2, 2, 2), datatype=16, bitpix=32, data=struct.pack("<8f", 0, 1, float("nan"), 3, 4, 5, 6, 7)))
    # MetaImage
    mha = "ObjectType = Image\nNDims = 3\nDimSize = 4 4 4\nElementType = MET_UCHAR\n"
    w("mha_no_data_file.mha", mha)
    w("mha_unknown_type.mha", mha.replace("MET_UCHAR", "MET_ULONG_LONG") + "ElementDataFile = LOCAL\n" + "\0" * 512)
    w("mha_truncated.mha", mha + "ElementDataFile = LOCAL\n" + "\0" * 10)
    w("mha_channels.mha", mha + "ElementNumberOfChannels = 3\nElementDataFile = LOCAL\n" + "\0" * 192)
    w("mha_bad_dimsize.mha", mha.replace("4 4 4", "4 four 4") + "ElementDataFile = LOCAL\n" + "\0" * 64)
    w("mha_corrupt_zlib.mha", mha + "CompressedData = True\nElementDataFile = LOCAL\n" + "xxxxxxxx")
    w("mha_missing_external.mhd", mha + "ElementDataFile = nowhere.raw\n")
    w("mha_bad_spacing.mha", mha + "ElementSpacing = 1 0 1\nElementDataFile = LOCAL\n" + "\0" * 64)
    w("mha_no_equals.mha", "ObjectType Image\n")
    # MRC / CCP4
    def mrc_header(nx=4, ny=4, nz=4, mode=2, stamp=b"DD\0\0", nsymbt=0, mapcrs=(1, 2, 3)):
        h = bytearray(1024)
        struct.pack_into("<4i", h, 0, nx, ny, nz, mode)
        struct.pack_into("<3i", h, 28, nx, ny, nz)
        struct.pack_into("<3f", h, 40, float(nx), float(ny), float(nz))
        struct.pack_into("<3i", h, 64, *mapcrs)
        struct.pack_into("<i", h, 92, nsymbt)
        h[208:212] = b"MAP "
        h[212:216] = stamp
        return bytes(h)
    w("mrc_short_header.mrc", mrc_header()[:500])
    w("mrc_negative_nx.mrc", mrc_header(nx=-4) + bytes(256))
    w("mrc_complex_mode.mrc", mrc_header(mode=4) + bytes(512))
    w("mrc_unknown_mode.mrc", mrc_header(mode=9) + bytes(256))
    w("mrc_truncated_data.mrc", mrc_header() + bytes(100))
    w("mrc_permuted_axes.mrc", mrc_header(mapcrs=(3, 1, 2)) + bytes(256))
    w("mrc_huge.mrc", mrc_header(nx=100000, ny=100000, nz=100000))
    w("mrc_nan.mrc", mrc_header(nx=2, ny=2, nz=2) + struct.pack("<8f", 0, 0, 0, float("nan"), 0, 0, 0, 0))
    w("mrc_negative_nsymbt.mrc", mrc_header(nsymbt=-5) + bytes(256))
    # VTK legacy
    vtk_head = "# vtk DataFile Version 3.0\ntest\n{enc}\nDATASET {ds}\nDIMENSIONS {dims}\nSPACING 1 1 1\nORIGIN 0 0 0\nPOINT_DATA {n}\nSCALARS v {ty}\nLOOKUP_TABLE default\n"
    def vtkf(enc="ASCII", ds="STRUCTURED_POINTS", dims="2 2 2", n=8, ty="float"):
        return vtk_head.format(enc=enc, ds=ds, dims=dims, n=n, ty=ty)
    w("vtk_bad_magic.vtk", "# not vtk\n")
    w("vtk_polydata.vtk", vtkf(ds="POLYDATA") + "0 " * 8)
    w("vtk_bad_dims.vtk", vtkf(dims="2 -2 2") + "0 " * 8)
    w("vtk_point_count_mismatch.vtk", vtkf(n=9) + "0 " * 8)
    w("vtk_short_ascii.vtk", vtkf() + "0 1 2")
    w("vtk_bad_number.vtk", vtkf() + "0 1 x 3 4 5 6 7")
    w("vtk_truncated_binary.vtk", vtkf(enc="BINARY").encode() + bytes(10))
    w("vtk_unknown_type.vtk", vtkf(ty="bit") + "0 " * 8)
    w("vtk_no_lookup_table.vtk", "# vtk DataFile Version 3.0\nt\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 2 2\n")
    w("vtk_nan.vtk", vtkf() + "0 0 0 nan 0 0 0 0")
    # VTK XML image data
    vti = ('<VTKFile type="ImageData" version="0.1" byte_order="LittleEndian" header_type="UInt32"{comp}>\n'
           '<ImageData WholeExtent="{ext}" Origin="0 0 0" Spacing="1 1 1">\n<Piece Extent="{ext}">\n'
           '<PointData Scalars="v">\n<DataArray type="{ty}" Name="v" format="{fmt}"{extra}>\n{body}\n</DataArray>\n'
           '</PointData>\n</Piece>\n</ImageData>\n</VTKFile>\n')
    def vtif(ext="0 1 0 1 0 1", ty="Float32", fmt="ascii", body="0 1 2 3 4 5 6 7", comp="", extra=""):
        return vti.format(ext=ext, ty=ty, fmt=fmt, body=body, comp=comp, extra=extra)
    w("vti_polydata.vti", vtif().replace('type="ImageData"', 'type="PolyData"'))
    w("vti_bad_extent.vti", vtif(ext="0 1 0 -5 0 1"))
    w("vti_short_ascii.vti", vtif(body="0 1 2"))
    w("vti_bad_base64.vti", vtif(fmt="binary", body="@@@@"))
    w("vti_truncated_binary.vti", vtif(fmt="binary", body="IAAAAAAAAAA="))
    w("vti_bad_zlib.vti", vtif(fmt="binary", comp=' compressor="vtkZLibDataCompressor"', body="AQAAAAAAAAAgAAAACAAAAA==Z2FyYmFnZSE="))
    w("vti_lz4.vti", vtif(fmt="binary", comp=' compressor="vtkLZ4DataCompressor"', body="AAAA"))
    w("vti_vectors.vti", vtif(extra=' NumberOfComponents="3"'))
    w("vti_unknown_type.vti", vtif(ty="Bit"))
    w("vti_appended_offset_past_end.vti", vtif(fmt="appended", body="", extra=' offset="999"') .replace("</ImageData>", "</ImageData>\n<AppendedData encoding=\"raw\">\n_\x00\n</AppendedData>"))
    w("vti_nan.vti", vtif(body="0 1 2 nan 4 5 6 7"))
    # Images
    w("png_truncated.png", b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\x00\x00\x01\x00")
    w("png_not_png.png", b"GIF89a not a png at all")
    w("tiff_bad_magic.tif", b"II\x2b\x00garbage")
    w("tiff_truncated.tif", b"II\x2a\x00\x08\x00\x00\x00\x05\x00")
    # Meshes
    w("ply_bad_magic.ply", "plx\nformat ascii 1.0\nend_header\n")
    w("ply_no_end_header.ply", "ply\nformat ascii 1.0\nelement vertex 3\n")
    w("ply_index_out_of_range.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")
    w("ply_truncated_binary.ply", b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      b"element face 1\nproperty list uchar int vertex_indices\nend_header\n" + bytes(20))
    w("ply_huge_count.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n")
    w("ply_missing_z.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n")
    w("ply_nan_vertex.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 nan 0\n")
    w("ply_two_vertex_face.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n")
    w("obj_index_zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n")
    w("obj_index_past_end.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n")
    w("obj_bad_number.obj", "v 0 zero 0\n")
    w("obj_two_vertex_face.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n")
    w("stl_short.stl", bytes(40))
    w("stl_count_mismatch.stl", bytes(80) + struct.pack("<I", 5) + bytes(100))
    w("stl_ascii_truncated.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n")
    w("off_bad_magic.off", "OFX\n3 1 0\n")
    w("off_counts_too_large.off", "OFF\n999999999 999999999 0\n0 0 0\n")
    w("off_bad_index.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n")
    w("off_truncated.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n")
    # Issue 10: nonsense geometry (refused naming the field) and absurd counts (bounded before looping)
    w("nrrd_spacing_huge.nrrd", nrrd(BASE + [("spacings", "1e308 1 1")], bytes(64)))
    w("nrrd_spacing_negative.nrrd", nrrd(BASE + [("spacings", "1 -0.5 1")], bytes(64)))
    w("nrrd_spacing_zero.nrrd", nrrd(BASE + [("spacings", "1 1 0")], bytes(64)))
    w("nrrd_direction_huge.nrrd", nrrd(BASE + [("space directions", "(1e300,0,0) (0,1,0) (0,0,1)")], bytes(64)))
    neg = bytearray(nifti())
    struct.pack_into("<h", neg, 252, 1)  # qform_code: the qform (and pixdim) give the geometry
    struct.pack_into("<f", neg, 80, -1.5)  # pixdim[1]
    w("nifti_negative_pixdim.nii", bytes(neg))
    zero = bytearray(nifti())
    struct.pack_into("<f", zero, 84, 0.0)  # pixdim[2], no qform nor sform
    w("nifti_zero_pixdim.nii", bytes(zero))
    w("mha_spacing_huge.mha", mha + "ElementSpacing = 1e308 1 1\nElementDataFile = LOCAL\n" + "\0" * 64)
    cell = bytearray(mrc_header(nx=2, ny=2, nz=2))
    struct.pack_into("<f", cell, 40, -2.0)  # CELLA.X
    w("mrc_negative_cell.mrc", bytes(cell) + bytes(32))
    w("vtk_spacing_huge.vtk", vtkf().replace("SPACING 1 1 1", "SPACING 1e308 1 1") + "0 " * 8)
    w("vti_negative_spacing.vti", vtif().replace('Spacing="1 1 1"', 'Spacing="-1 1 1"'))
    w("vti_nan_spacing.vti", vtif().replace('Spacing="1 1 1"', 'Spacing="nan 1 1"'))
    w("ply_junk_huge_count.ply", "ply\nformat ascii 1.0\nelement junk 18446744073709551615\nproperty uchar a\n"
      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n")


if __name__ == "__main__":
    main()
    print(len(os.listdir(HERE)), "files")
