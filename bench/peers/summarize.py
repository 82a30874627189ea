#!/usr/bin/env python3
"""Markdown summary of a run_peers.py results.json for docs/BENCHMARKS.md: isoforge against
vtkFlyingEdges3D at 1 and 2 threads (ratios from the same run; isoforge in one warm process as the
other peers, and in a fresh process per run), scikit-image, the bandwidth floor,
triangle counts, mesh verdicts and peak RSS.

    python3 bench/peers/summarize.py /tmp/peers-results/results.json
"""
import json
import sys


def main():
    d = json.load(open(sys.argv[1]))
    rows = {}
    for r in d["records"].values():
        rows[(r["volume"], r["peer"], r["threads"])] = r
    vols = sorted({v for v, _, _ in rows}, key=lambda v: (v.startswith("real_"), int(v.rsplit("_", 1)[1]) if not v.startswith("real_") else 0, v))
    ms = lambda r: r["median_s"] * 1e3 if r and r.get("median_s") else float("nan")
    mn = lambda r: r["min_s"] * 1e3 if r and r.get("min_s") else float("nan")
    rss = lambda r: (r.get("peak_rss_mb") or float("nan")) if r else float("nan")
    print("| volume | VTK FE 1T ms | isoforge 1T ms (min) | speed-up 1T | VTK FE 2T ms | isoforge 2T ms (min) | speed-up 2T "
          "| cold process 1T / 2T ms (speed-up) | skimage ms | floor 1T / 2T ms | isoforge ÷ floor 2T | triangles VTK = isoforge | isoforge mesh | peak RSS MB VTK / isoforge / skimage |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|---|")
    for v in vols:
        g = lambda p, t: rows.get((v, p, t))
        fe1, fe2, i1, i2 = g("vtk-flyingedges3d", 1), g("vtk-flyingedges3d", 2), g("isoforge", 1), g("isoforge", 2)
        sk, f1, f2 = g("skimage-lewiner", 1), g("rust-sum-f64", 1), g("rust-sum-f64", 2)
        c1, c2 = g("isoforge-cold", 1), g("isoforge-cold", 2)
        if not (fe1 and i1):
            continue
        tris = {r.get("triangles") for r in (fe1, fe2, i1, i2) if r and r.get("triangles") is not None}
        same = "yes" if len(tris) == 1 else f"no ({sorted(tris)})"
        c = i1.get("check") or {}
        verdict = "closed" if c.get("watertight") is True else (
            "open@faces" if c.get("boundary_edges_interior") == 0 and c.get("nonmanifold_edges") == 0 else str(c.get("watertight")))
        ok = lambda r: r and r.get("median_s")
        floor = f"{ms(f1):.2f} / {ms(f2):.2f}" if ok(f1) and ok(f2) else "-"
        fr = f"{ms(i2) / ms(f2):.0f}×" if ok(f2) and ok(i2) else "-"
        cold = (f"{ms(c1):.1f} / {ms(c2):.1f} ({ms(fe1) / ms(c1):.2f}× / {ms(fe2) / ms(c2):.2f}×)"
                if ok(c1) and ok(c2) and ok(fe2) else "-")
        name = v if v.startswith("real_") else v.replace("_", " ") + "³"
        print(f"| {name} | {ms(fe1):.1f} | {ms(i1):.1f} ({mn(i1):.1f}) | **{ms(fe1) / ms(i1):.2f}×** | {ms(fe2):.1f} | "
              f"{ms(i2):.1f} ({mn(i2):.1f}) | **{ms(fe2) / ms(i2):.2f}×** | {cold} | {ms(sk):.0f} | {floor} | {fr} | "
              f"{fe1.get('triangles', 0):,} {same} | {verdict} | {rss(fe1):.0f} / {rss(i1):.0f} / {rss(sk):.0f} |")


if __name__ == "__main__":
    main()
