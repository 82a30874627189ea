"""Issue 48's table: isoforge against scikit-image, PyMCubes and VTK's wheel from Python, on a 256³
and a 512³ float32 volume of sines and the real CTs in ../shared/data/volumes (absent ones
skipped). Every (library, volume) runs in its own process: it loads the volume, runs the call 3
times (median wall time) and reports its peak RSS (the volume included). Same iso for all, marching
cubes (scikit-image's lorensen; VTK's vtkFlyingEdges3D on the STDThread SMP backend); `threads`
for isoforge and VTK.

    python bench/peers/python_peers.py [threads] [volume names...]
"""

import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

DATA = Path(__file__).resolve().parents[3] / "shared" / "data" / "volumes"
CTS = {
    "cthead_8bit_256x256x99": None,
    "lidc2_chest_ct_u8": None,
    "stanford_bunny_ct_512x512x361": None,
    "vhp_shoulder_ct_512x512x450": None,
}
LIBS = ("skimage", "pymcubes", "vtk", "isoforge.marching_cubes", "isoforge.extract", "isoforge.extract-no-normals")


def load(name):
    import numpy as np

    import isoforge

    if name.startswith("sines"):
        n = int(name[5:])
        z, y, x = np.ogrid[:n, :n, :n]
        f = lambda a: a * 2 * np.pi / n  # noqa: E731
        return (np.sin(f(x) * 3) * np.cos(f(y) * 2) + np.sin(f(z) * 4) * 0.7).astype(np.float32), 0.1
    vol, _ = isoforge.read_volume(DATA / f"{name}.nrrd")
    iso = json.loads((DATA / f"{name}.json").read_text())["otsu_threshold"]
    return vol, float(iso)


def child(lib, name, threads):
    vol, iso = load(name)
    if lib == "skimage":
        from skimage import measure

        def run():
            return len(measure.marching_cubes(vol, iso, method="lorensen")[1])
    elif lib == "pymcubes":
        import mcubes

        def run():
            return len(mcubes.marching_cubes(vol, iso)[1])
    elif lib == "vtk":
        import vtk
        from vtk.util import numpy_support

        vtk.vtkSMPTools.SetBackend("STDThread")
        vtk.vtkSMPTools.Initialize(threads)

        def run():
            img = vtk.vtkImageData()
            img.SetDimensions(vol.shape[2], vol.shape[1], vol.shape[0])
            img.GetPointData().SetScalars(numpy_support.numpy_to_vtk(vol.ravel(), deep=False))
            fe = vtk.vtkFlyingEdges3D()
            fe.SetInputData(img)
            fe.SetValue(0, iso)
            fe.ComputeNormalsOn()
            fe.Update()
            return fe.GetOutput().GetNumberOfPolys()
    else:
        import isoforge

        if lib == "isoforge.marching_cubes":
            def run():
                return len(isoforge.marching_cubes(vol, iso, method="lorensen", threads=threads)[1])
        else:
            normals = lib == "isoforge.extract"

            def run():
                return len(isoforge.extract(vol, iso, method="mc", threads=threads, normals=normals).faces)
    times = []
    for _ in range(3):
        t = time.perf_counter()
        tris = run()
        times.append(time.perf_counter() - t)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps({"median_s": statistics.median(times), "tris": tris, "rss_mb": rss}))


def main(args):
    threads = int(args[0]) if args else 2
    names = args[1:] or ["sines256", "sines512", *[n for n in CTS if (DATA / f"{n}.nrrd").exists()]]
    print(f"load average {os.getloadavg()[0]:.1f}; threads {threads}")
    print("| volume | library | median s | triangles | peak RSS MB | vs skimage |")
    print("|---|---|---|---|---|---|")
    for name in names:
        base = None
        for lib in LIBS:
            r = subprocess.run([sys.executable, __file__, "--child", lib, name, str(threads)],
                               capture_output=True, text=True)
            if r.returncode != 0:
                print(f"| {name} | {lib} | failed: {r.stderr.strip().splitlines()[-1:]} | | | |", flush=True)
                continue
            d = json.loads(r.stdout.strip().splitlines()[-1])
            base = d["median_s"] if lib == "skimage" else base
            ratio = f"{base / d['median_s']:.1f}x" if base else ""
            print(f"| {name} | {lib} | {d['median_s']:.3f} | {d['tris']:,} | {d['rss_mb']:.0f} | {ratio} |", flush=True)


if __name__ == "__main__":
    if sys.argv[1:2] == ["--child"]:
        child(sys.argv[2], sys.argv[3], int(sys.argv[4]))
    else:
        main(sys.argv[1:])
