#!/usr/bin/env python3
"""Every extraction method of isoforge on the same volumes: time, triangles, mesh checks and
triangle quality (mean and minimum of each triangle's smallest angle). Writes a Markdown table.

    cargo build --release -p isoforge-cli
    python3 bench/methods.py --isoforge target/release/isoforge [--repeat 3] \\
        [VOLUME.raw:X,Y,Z:ISO | VOLUME.nrrd:ISO ...]   # default: built-in sphere and gyroid fields at 128³

Times are the median of `--repeat` in-process runs (`extract --repeat`), extraction only.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

METHODS = ["mc", "mc33", "mt5", "mt6", "mt-bcc", "surface-nets", "dc"]


def run(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)}\n{p.stderr}")
    return p.stdout


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--isoforge", default="target/release/isoforge")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("inputs", nargs="*", help="raw f32 volumes as PATH:X,Y,Z:ISO, files with a header as PATH:ISO, or field specs")
    a = ap.parse_args()
    inputs = a.inputs or ["field:sphere?n=128", "field:gyroid?n=128"]
    print("| input | method | triangles | vertices | extraction ms | ÷ mc | watertight | components / χ | min angle mean / min (°) |")
    print("|---|---|---:|---:|---:|---:|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for spec in inputs:
            if spec.startswith("field:"):
                src, name = ["--input", spec], spec
            elif spec.count(":") == 1:
                path, iso = spec.split(":")
                src, name = ["--input", path, "--iso", iso], os.path.basename(path)
            else:
                path, dims, iso = spec.split(":")
                src = ["--input", path, "--dims", dims, "--dtype", "f32", "--iso", iso]
                name = os.path.basename(path)
            base = None
            for m in METHODS:
                out, tj = os.path.join(tmp, "m.ply"), os.path.join(tmp, "t.json")
                run([a.isoforge, "--threads", str(a.threads), "extract", *src, "--method", m, "-o", out,
                     "--time-json", tj, "--repeat", str(a.repeat)])
                t = json.load(open(tj))
                ms = sorted(t["runs"])[len(t["runs"]) // 2] * 1e3
                base = base or ms
                r = json.loads(run([a.isoforge, "check", out, "--json"]))
                print(f"| {name} | {m} | {t['triangles']:,} | {t['vertices']:,} | {ms:.1f} | {ms / base:.2f} | "
                      f"{'yes' if r['watertight'] else 'no'} | {len(r['components'])} / {r['euler']} | "
                      f"{r['min_angle_mean_deg']:.1f} / {r['min_angle_deg']:.2f} |", flush=True)


if __name__ == "__main__":
    main()
