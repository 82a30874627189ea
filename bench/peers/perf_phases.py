#!/usr/bin/env python3
"""Where a process's CPU went, by pipeline phase, from a `perf record` with call chains.

perf's hardware counters are not available on this VM, but its software clock is:

    perf record -e cpu-clock -F 4000 --call-graph dwarf,16384 -o /tmp/p.data -- \\
        target/release/isoforge extract -i CT.nrrd --iso V -o out.ply --threads 1
    perf script -i /tmp/p.data -F ip,sym,dso | python3 bench/peers/perf_phases.py

Each sample is put in the first phase whose pattern matches any frame of its call chain (so a
page fault taken while inflating counts as inflate, and a PLY write made from inside the
streaming walker counts as writing). Prints a markdown table: share of samples, the part spent
in the kernel, and the part in the kernel's page zeroing (`clear_page*`: first touch of fresh
memory, which is slow on this VM).
"""
import collections
import re
import sys

PHASES = [  # order matters: the first match wins
    ("PLY write", r"write_ply|write_atomic|write_mesh|PlyStream|MeshSink.*push"),
    ("fsync / rename", r"sync_all|fsync|rename"),
    ("inflate", r"miniz_oxide|flate2|zlib_rs|libdeflate|inflate|crc32"),
    ("value range / finite check", r"value_range|first_non_finite"),
    ("extract (walker)", r"flying_edges|pipeline::extract|isoforge::walk|count_slab|classify_row|Fill<"),
    ("read (other)", r"read_grid|read_slab|VolumeReader|open_volume"),
]
PHASES = [(name, re.compile(rx)) for name, rx in PHASES]
OTHER = "other (start-up, exit, unmapping, idle threads)"


def classify(frames):
    for name, rx in PHASES:
        if any(rx.search(f) for f in frames):
            return name
    return OTHER


def samples(lines):
    """Call chains (innermost frame first) of `perf script -F ip,sym,dso` output."""
    frames = []
    for line in lines:
        line = line.rstrip("\n")
        if line.startswith(("\t", " ")) and line.strip():
            frames.append(line.strip())
        elif frames:
            yield frames
            frames = []
    if frames:
        yield frames


def main():
    counts, kernel, zeroing = collections.Counter(), collections.Counter(), collections.Counter()
    total = 0
    for frames in samples(sys.stdin):
        total += 1
        phase = classify(frames)
        counts[phase] += 1
        if "[kernel" in frames[0]:
            kernel[phase] += 1
        if any("clear_page" in f for f in frames[:6]):
            zeroing[phase] += 1
    if not total:
        raise SystemExit("no samples on stdin (perf script -F ip,sym,dso of a recording with call chains)")
    print(f"samples: {total}\n")
    print("| phase | share of CPU samples | in the kernel | in page zeroing (first touch) |")
    print("|---|---:|---:|---:|")
    for phase, n in counts.most_common():
        print(f"| {phase} | {100 * n / total:.1f} % | {100 * kernel[phase] / total:.1f} % | "
              f"{100 * zeroing[phase] / total:.1f} % |")


if __name__ == "__main__":
    main()
