#!/usr/bin/env python3
"""Writes the small golden volumes in testdata/volumes/ with independent writers (pynrrd, nibabel,
SimpleITK) and a sidecar `<file>.expect.json` holding what those libraries say about them: dims,
world position of a few lattice points, and values at those points.

Run once by hand when adding a case (python3 -m pip install numpy pynrrd nibabel SimpleITK);
the outputs are committed and read by crates/isoforge-io/tests/golden.rs.
"""
import json
import os

import numpy as np

HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "volumes")
PROBES = [(0, 0, 0), (1, 2, 3), (4, 3, 2), (5, 4, 6)]  # (i, j, k), all inside 6x5x7


def field(dtype, scale=1.0, offset=0.0):
    """A 6x5x7 array indexed [i, j, k] (x fastest on disk in F order)."""
    i, j, k = np.meshgrid(np.arange(6), np.arange(5), np.arange(7), indexing="ij")
    v = (i * 7 + j * 3 + k * 5 + i * j) % 23
    return (v * scale + offset).astype(dtype)


def sidecar(name, dims, world, values, dtype):
    with open(os.path.join(HERE, name + ".expect.json"), "w") as f:
        json.dump({"dims": list(dims), "dtype": dtype, "probes": [
            {"ijk": list(p), "world": [float(x) for x in w], "value": float(v)}
            for p, w, v in zip(PROBES, world, values)]}, f, indent=1)


def nrrd_cases():
    import nrrd
    dirs = np.array([[0.5, 0.0, 0.0], [0.0, 0.75, 0.0], [0.0, 0.0, 2.0]])
    origin = np.array([10.0, -20.0, 5.5])
    for name, dtype, enc, endian, detached in [
        ("u8_raw.nrrd", np.uint8, "raw", "little", False),
        ("i16_gzip.nrrd", np.int16, "gzip", "little", False),
        ("f32_big.nrrd", np.float32, "raw", "big", False),
        ("u16_detached.nhdr", np.uint16, "raw", "little", True),
        ("f64_ascii.nrrd", np.float64, "ascii", "little", False),
    ]:
        data = field(dtype, 1.0 if np.dtype(dtype).kind in "ui" else 0.25, -3 if dtype == np.int16 else 0)
        header = {"space": "left-posterior-superior", "space directions": dirs, "space origin": origin,
                  "encoding": enc, "endian": endian}
        path = os.path.join(HERE, name)
        nrrd.write(path, data, header, detached_header=detached, index_order="F")
        back, h = nrrd.read(path, index_order="F")
        world = [h["space origin"] + np.asarray(p) @ h["space directions"] for p in PROBES]
        sidecar(name, data.shape, world, [back[p] for p in PROBES], np.dtype(dtype).name)


def nifti_cases():
    import nibabel as nib
    # sform with a flipped x axis (RAS from LPS-ordered data) and scaling.
    aff = np.array([[-0.8, 0, 0, 30.0], [0, 0.8, 0, -12.0], [0, 0, 1.5, 4.0], [0, 0, 0, 1]])
    img = nib.Nifti1Image(field(np.int16), aff)
    img.header.set_slope_inter(2.0, -100.0)
    img.set_qform(aff, code=1)
    img.set_sform(aff, code=2)
    nib.save(img, os.path.join(HERE, "i16_sform_scaled.nii"))
    # qform only: a rotation about z by 30 degrees, f32, gzipped.
    c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
    rot = np.array([[c * 1.2, -s * 1.2, 0, 1.0], [s * 1.2, c * 1.2, 0, 2.0], [0, 0, 0.9, 3.0], [0, 0, 0, 1]])
    img = nib.Nifti1Image(field(np.float32, 0.5), None)
    img.set_qform(rot, code=1)
    img.set_sform(None, code=0)
    nib.save(img, os.path.join(HERE, "f32_qform.nii.gz"))
    # u8 with a plain diagonal sform.
    img = nib.Nifti1Image(field(np.uint8), np.diag([2.0, 3.0, 4.0, 1.0]))
    nib.save(img, os.path.join(HERE, "u8_plain.nii"))
    for name in ["i16_sform_scaled.nii", "f32_qform.nii.gz", "u8_plain.nii"]:
        back = nib.load(os.path.join(HERE, name))
        data = back.get_fdata()
        world = [back.affine @ np.array([*p, 1.0]) for p in PROBES]
        sidecar(name, data.shape, [w[:3] for w in world], [data[p] for p in PROBES], str(back.get_data_dtype()))


def metaimage_cases():
    import SimpleITK as sitk
    for name, dtype, compress in [("u16_compressed.mha", np.uint16, True), ("f64_external.mhd", np.float64, False)]:
        data = field(dtype, 1.0 if np.dtype(dtype).kind == "u" else 0.125)
        img = sitk.GetImageFromArray(np.ascontiguousarray(data.transpose(2, 1, 0)))  # [k, j, i]
        img.SetSpacing((0.6, 0.7, 1.9))
        img.SetOrigin((-3.0, 4.0, 100.0))
        path = os.path.join(HERE, name)
        sitk.WriteImage(img, path, useCompression=compress)
        back = sitk.ReadImage(path)
        arr = sitk.GetArrayFromImage(back)
        world = [back.TransformIndexToPhysicalPoint(tuple(int(x) for x in p)) for p in PROBES]
        sidecar(name, data.shape, world, [arr[p[2], p[1], p[0]] for p in PROBES], np.dtype(dtype).name)


if __name__ == "__main__":
    os.makedirs(HERE, exist_ok=True)
    nrrd_cases()
    nifti_cases()
    metaimage_cases()
    print("wrote", sorted(os.listdir(HERE)))
