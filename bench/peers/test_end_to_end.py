"""Tests of the end-to-end harness (issue 11): its checks fail on bad outputs, the zlib-only
references decompress exactly the declared bytes and reject cut files, and a small run of the
whole harness (isoforge + VTK + zlib) agrees on triangle counts.

    PY=${PEERS_VENV:-/tmp/peers-venv}/bin/python
    ISOFORGE=target/release/isoforge $PY -m unittest bench/peers/test_end_to_end.py -v

The last test needs VTK (setup.sh) and an isoforge binary (ISOFORGE, default
target/release/isoforge); it is skipped without them.
"""
import gzip
import json
import math
import os
import struct
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import end_to_end as e2e  # noqa: E402
import perf_phases  # noqa: E402

ROOT = os.path.normpath(os.path.join(HERE, "../.."))


def sphere_nrrd(path, n=24, dtype="uint8", cut=0):
    """A gzip NRRD of a distance-to-centre ramp (inside = small values); `cut` bytes dropped."""
    samples = bytearray()
    c = (n - 1) / 2
    for k in range(n):
        for j in range(n):
            for i in range(n):
                samples.append(min(255, int(20 * math.dist((i, j, k), (c, c, c)))))
    body = gzip.compress(bytes(samples))
    header = (f"NRRD0004\ntype: {dtype}\ndimension: 3\nsizes: {n} {n} {n}\n"
              "spacings: 1 1 1\nencoding: gzip\n\n").encode()
    with open(path, "wb") as f:
        f.write(header + (body[:-cut] if cut else body))
    return len(samples)


def ply(path, verts, faces, extra=b""):
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(verts)}\nproperty float x\n"
            f"property float y\nproperty float z\nelement face {len(faces)}\n"
            "property list uchar int vertex_indices\nend_header\n").encode()
    body = b"".join(struct.pack("<3f", *v) for v in verts) + b"".join(struct.pack("<B3i", 3, *f) for f in faces)
    with open(path, "wb") as f:
        f.write(head + body + extra)


class Checks(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = self.tmp.name

    def tearDown(self):
        self.tmp.cleanup()

    def test_ply_counts_reads_header_and_rejects_cut_or_padded_files(self):
        p = os.path.join(self.dir, "t.ply")
        ply(p, [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [(0, 1, 2)])
        self.assertEqual(e2e.ply_counts(p), (3, 1))
        with open(p, "r+b") as f:
            f.truncate(os.path.getsize(p) - 1)
        with self.assertRaisesRegex(AssertionError, "the header implies"):
            e2e.ply_counts(p)
        ply(p, [(0, 0, 0)], [], extra=b"x")
        with self.assertRaisesRegex(AssertionError, "the header implies"):
            e2e.ply_counts(p)

    def test_declared_bytes_from_header(self):
        p = os.path.join(self.dir, "s.nrrd")
        n = sphere_nrrd(p, n=10)
        skip, fields = e2e.nrrd_header(p)
        self.assertEqual(e2e.declared_bytes(fields, p), n)
        with open(p, "rb") as f:
            self.assertEqual(len(gzip.decompress(f.read()[skip:])), n)

    def test_iso_rule_first_suggestion_else_otsu(self):
        self.assertEqual(e2e.iso_of({"iso_suggestions": [{"value": 988.37}], "otsu_threshold": 1.0}, "b", {}), 988.37)
        self.assertEqual(e2e.iso_of({"iso_suggestions": [], "otsu_threshold": 46.3184}, "s", {}), 46.3184)
        self.assertEqual(e2e.iso_of({"otsu_threshold": 1.0}, "s", {"s": 7.5}), 7.5)

    def test_zlib_c_and_py_inflate_exactly_the_declared_bytes(self):
        p = os.path.join(self.dir, "s.nrrd")
        n = sphere_nrrd(p, n=40)
        exe = e2e.build_zlib_c(self.dir)
        out = subprocess.run([exe, p], capture_output=True, text=True, check=True).stdout
        self.assertEqual(json.loads(out)["bytes"], n)
        out = subprocess.run([sys.executable, e2e.__file__, "--zlib-py", p], capture_output=True, text=True,
                             check=True).stdout
        self.assertEqual(json.loads(out)["bytes"], n)

    def test_zlib_c_and_py_reject_a_cut_stream_naming_the_file(self):
        p = os.path.join(self.dir, "cut.nrrd")
        sphere_nrrd(p, n=40, cut=20)
        exe = e2e.build_zlib_c(self.dir)
        r = subprocess.run([exe, p], capture_output=True, text=True)
        self.assertEqual(r.returncode, 2)
        self.assertIn(p, r.stderr)
        r = subprocess.run([sys.executable, e2e.__file__, "--zlib-py", p], capture_output=True, text=True)
        self.assertEqual(r.returncode, 2)
        self.assertIn(p, r.stderr)

    def test_zlib_c_rejects_a_raw_nrrd(self):
        p = os.path.join(self.dir, "raw.nrrd")
        with open(p, "wb") as f:
            f.write(b"NRRD0004\ntype: uint8\ndimension: 1\nsizes: 4\nencoding: raw\n\n\x00\x01\x02\x03")
        r = subprocess.run([e2e.build_zlib_c(self.dir), p], capture_output=True, text=True)
        self.assertEqual(r.returncode, 2)
        self.assertIn("encoding is not gzip", r.stderr)


class BadArguments(unittest.TestCase):
    def run_e2e(self, *args):
        return subprocess.run([sys.executable, e2e.__file__, *args], capture_output=True, text=True)

    def test_bad_arguments_give_one_line_and_exit_2(self):
        exe = sys.executable  # any executable: the run stops before using it
        cases = [
            (["--isoforge", "/nonexistent/isoforge"], "--isoforge /nonexistent/isoforge: not an executable (cargo build --release -p isoforge-cli)"),
            (["--isoforge", exe, "--iso", "bunny"], "--iso 'bunny': expected NAME=VALUE"),
            (["--isoforge", exe, "--iso", "bunny=abc"], "--iso 'bunny=abc': expected NAME=VALUE"),
            (["--isoforge", exe, "--variant", "stream"], "--variant 'stream': expected NAME=VALUE"),
            (["--isoforge", exe, "--threads", "1,x"], "--threads '1,x': expected comma-separated whole numbers"),
            (["--isoforge", exe, "--repeats", "0"], "--repeats must be at least 1"),
        ]
        for args, message in cases:
            r = self.run_e2e(*args)
            self.assertEqual(r.returncode, 2, (args, r.stderr))
            self.assertEqual(r.stderr.strip(), message)

    def test_missing_volume_is_named(self):
        with tempfile.TemporaryDirectory() as d:
            r = self.run_e2e("--isoforge", sys.executable, "--data", d, "--volumes", "nothere", "--no-vtk")
            self.assertEqual(r.returncode, 2)
            self.assertIn("--volumes nothere: " + os.path.join(d, "nothere.nrrd") + " is missing", r.stderr)


class PerfPhases(unittest.TestCase):
    SCRIPT = """isoforge 1 [000] 1.0: cpu-clock:
\tffffffff81000000 clear_page_erms ([kernel.kallsyms])
\t5555 miniz_oxide::inflate::core::decompress_fast (/x/isoforge)
\t5556 isoforge_io::read::stream::VolumeReader::fill (/x/isoforge)

isoforge 1 [000] 1.1: cpu-clock:
\t5557 isoforge::walk::flying_edges::count_slab (/x/isoforge)

isoforge 1 [000] 1.2: cpu-clock:
\t5558 <isoforge_io::write::ply::PlyStream as isoforge::walk::flying_edges::MeshSink>::push (/x/isoforge)
\t5559 isoforge::walk::flying_edges::flying_edges_streaming (/x/isoforge)

isoforge 1 [000] 1.3: cpu-clock:
\t5560 main (/x/isoforge)
"""

    def test_samples_go_to_the_first_matching_phase(self):
        chains = list(perf_phases.samples(self.SCRIPT.splitlines(True)))
        self.assertEqual(len(chains), 4)
        self.assertEqual([perf_phases.classify(c) for c in chains],
                         ["inflate", "extract (walker)", "PLY write", perf_phases.OTHER])
        self.assertIn("[kernel", chains[0][0])


def have_vtk():
    try:
        import vtkmodules.vtkFiltersCore  # noqa: F401
        return True
    except ImportError:
        return False


ISOFORGE = os.path.abspath(os.environ.get("ISOFORGE", os.path.join(ROOT, "target/release/isoforge")))


@unittest.skipUnless(have_vtk() and os.access(ISOFORGE, os.X_OK), "needs VTK (setup.sh) and an isoforge binary")
class SmallRun(unittest.TestCase):
    def test_issue_11_harness_runs_isoforge_vtk_and_zlib_with_equal_triangles(self):
        with tempfile.TemporaryDirectory() as d:
            p = os.path.join(d, "sphere_24.nrrd")
            sphere_nrrd(p, n=24)
            with open(os.path.join(d, "sphere_24.json"), "w") as f:
                json.dump({"iso_suggestions": [{"value": 150.5}]}, f)
            out = os.path.join(d, "r.json")
            r = subprocess.run([sys.executable, e2e.__file__, "--isoforge", ISOFORGE, "--data", d,
                                "--volumes", "sphere_24", "--repeats", "2", "--json", out,
                                "--variant", "stream=--max-memory 1KiB"], capture_output=True, text=True)
            self.assertEqual(r.returncode, 0, r.stderr)
            with open(out) as f:
                res = json.load(f)["results"][0]
            ids = {c["id"] for c in res["commands"]}
            self.assertTrue({"isoforge 1T", "isoforge 2T", "isoforge-stream 1T", "vtk 1T", "vtk 2T",
                             "zlib-c", "zlib-py", "gzip -dc"} <= ids, ids)
            tris = {k: v["triangles"] for k, v in res["produced"].items() if "triangles" in v}
            self.assertGreater(min(tris.values()), 100)
            self.assertEqual(len(set(tris.values())), 1, tris)
            self.assertEqual(res["produced"]["zlib-c"]["bytes"], 24 ** 3)
            self.assertTrue(all(len(runs) == 2 for runs in res["runs"].values()))
            self.assertIn("÷ VTK same thr", r.stdout)

    def test_issue_11_harness_stops_when_triangle_counts_differ(self):
        with tempfile.TemporaryDirectory() as d:
            p = os.path.join(d, "sphere_16.nrrd")
            sphere_nrrd(p, n=16)
            with open(os.path.join(d, "sphere_16.json"), "w") as f:
                json.dump({"iso_suggestions": [{"value": 100.5}]}, f)
            other = f"{ISOFORGE} extract -i {{input}} --iso 60.5 -o {{output}}"  # another iso: fewer triangles
            r = subprocess.run([sys.executable, e2e.__file__, "--isoforge", ISOFORGE, "--data", d, "--volumes",
                                "sphere_16", "--repeats", "1", "--no-vtk", "--command", f"other@1={other}"],
                               capture_output=True, text=True)
            self.assertEqual(r.returncode, 2)
            self.assertIn("triangle counts differ", r.stderr)


if __name__ == "__main__":
    unittest.main()
