#!/usr/bin/env python3
"""File to file, fresh process, wall time (issue 11): gzip NRRD in, binary PLY out.

For each CT, in one run and interleaved (every repetition runs every command once, the order
rotated from one repetition to the next), N fresh-process repetitions of:

  isoforge   `isoforge extract -i CT.nrrd --iso V --method mc -o out.ply --threads T` (T = 1 and 2):
             classic MC, VTK's triangles (the default method, mc33, is a variant:
             `--variant "mc33=--method mc33"`)
  isoforge-NAME  the same with the extra arguments of `--variant NAME=ARGS` (its own --method
             replaces mc)
  NAME       any command given as `--command NAME[@T]=TEMPLATE` (a prototype, another build):
             one row per thread count, or at T only
  vtk        e2e_vtk.py: vtkNrrdReader -> vtkFlyingEdges3D -> vtkPLYWriter (binary), SMP threads T
  zlib-c     zlib_inflate.c (built here with gcc against the system zlib): header, then inflate
             the gzip body to /dev/null: the floor a gzip file sets on one core
  zlib-py    the same with Python's zlib module (same system zlib, 1 MiB input pieces)
  gzip -dc   / pigz -dc (when installed): the body fed on stdin, output to /dev/null, reference

Wall time is measured around each child (fork to reap); peak RSS is that child's own ru_maxrss
(GNU time's %M). Triangle counts of every classic-MC isoforge and VTK output must be equal (asserted, with the
PLY file size checked against its header), the zlib programs must produce exactly the bytes the
NRRD header declares. Page caches cannot be dropped here: every command runs once untimed
before the timed repetitions, so all timed runs read their input from the page cache.

    PY=${PEERS_VENV:-/tmp/peers-venv}/bin/python
    cargo build --release -p isoforge-cli
    $PY bench/peers/end_to_end.py --isoforge target/release/isoforge \
        --out bench/peers/results-DATE-e2e.md --json /tmp/e2e.json
"""
import argparse
import datetime
import json
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_DATA = os.path.normpath(os.path.join(HERE, "../../../shared/data/volumes"))
DEFAULT_VOLUMES = "stanford_bunny_ct_512x512x361,vhp_shoulder_ct_512x512x450"
NRRD_TYPES = {  # NRRD type names -> bytes per sample
    "uchar": 1, "unsigned char": 1, "uint8": 1, "uint8_t": 1,
    "signed char": 1, "int8": 1, "int8_t": 1,
    "short": 2, "int16": 2, "int16_t": 2, "signed short": 2, "short int": 2,
    "ushort": 2, "unsigned short": 2, "uint16": 2, "uint16_t": 2, "unsigned short int": 2,
    "int": 4, "int32": 4, "int32_t": 4, "signed int": 4,
    "uint": 4, "unsigned int": 4, "uint32": 4, "uint32_t": 4,
    "float": 4, "double": 8,
}
PIECE = 1 << 20
TIME = "/usr/bin/time"  # GNU time (Debian package `time`)


# ---------------------------------------------------------------------------------------------
# Inputs and outputs

def nrrd_header(path):
    """(header length in bytes, {field: value}) of an attached-header NRRD file."""
    with open(path, "rb") as f:
        head = f.read(1 << 20)
    end = head.find(b"\n\n")
    if not head.startswith(b"NRRD000") or end < 0:
        raise SystemExit(f"{path}: not an NRRD file with an attached header")
    fields = {}
    for line in head[:end].decode("utf-8", "replace").splitlines()[1:]:
        if line.startswith("#") or ":=" in line or ": " not in line:
            continue
        k, v = line.split(": ", 1)
        fields[k.strip().lower()] = v.strip()
    return end + 2, fields


def declared_bytes(fields, path):
    """Bytes of samples the header declares (sizes x type size)."""
    t = fields.get("type", "").lower()
    if t not in NRRD_TYPES:
        raise SystemExit(f"{path}: type {t!r} is not a known NRRD sample type")
    n = NRRD_TYPES[t]
    for s in fields.get("sizes", "").split():
        n *= int(s)
    return n


def ply_counts(path):
    """(vertices, faces) of a binary PLY whose faces are `list uchar int` triangles; the file size
    must be exactly header + 12·V + 13·F (x y z floats only), so a cut file fails here."""
    with open(path, "rb") as f:
        head = f.read(4096)
    end = head.find(b"end_header\n")
    if end < 0:
        raise AssertionError(f"{path}: no end_header in the first 4 KiB")
    text = head[:end].decode("ascii", "replace")
    if "format binary_little_endian 1.0" not in text:
        raise AssertionError(f"{path}: not binary little-endian PLY")
    v = int(re.search(r"element vertex (\d+)", text).group(1))
    fcount = int(re.search(r"element face (\d+)", text).group(1))
    props = re.findall(r"property (\w+) (\w+)\n", text[: text.find("element face")])
    if [p[1] for p in props] != ["x", "y", "z"] or any(p[0] != "float" for p in props):
        raise AssertionError(f"{path}: vertex properties {props}, expected float x y z")
    want = end + len("end_header\n") + 12 * v + 13 * fcount
    size = os.path.getsize(path)
    if size != want:
        raise AssertionError(f"{path}: {size} bytes, the header implies {want}")
    return v, fcount


def iso_of(sidecar, name, overrides):
    if name in overrides:
        return overrides[name]
    sugg = sidecar.get("iso_suggestions") or []
    return float(sugg[0]["value"]) if sugg else float(sidecar["otsu_threshold"])


def zlib_py(path):
    """Python-zlib reference (run as `end_to_end.py --zlib-py FILE` in a fresh process)."""
    import zlib
    skip, fields = nrrd_header(path)
    if fields.get("encoding", "").lower() not in ("gzip", "gz"):
        raise SystemExit(f"{path}: encoding {fields.get('encoding')!r} is not gzip")
    z = zlib.decompressobj(16 + zlib.MAX_WBITS)
    n = 0
    with open(path, "rb") as f:
        f.seek(skip)
        while True:
            piece = f.read(PIECE)
            if not piece:
                break
            n += len(z.decompress(piece))
        n += len(z.flush())
    if not z.eof:
        raise SystemExit(f"{path}: gzip data: the stream is cut (no end of stream)")
    print(json.dumps({"bytes": n}))


# ---------------------------------------------------------------------------------------------
# Running

def run_once(argv, stdin_path=None, stdin_offset=0, cwd=None):
    """Runs argv as a fresh process; returns wall seconds, (peak RSS KiB, user s, sys s), exit
    code, stdout, stderr.

    The child is started through `/usr/bin/time`: Linux keeps a process's peak RSS across exec,
    so a child forked straight from this (larger) Python process would report at least our size;
    forked from `time` (a few MB) it reports its own. Wall time is taken here, fork to reap.
    """
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err, \
            tempfile.NamedTemporaryFile("r", suffix=".time") as tf:
        stdin = subprocess.DEVNULL
        fin = None
        if stdin_path is not None:
            fin = open(stdin_path, "rb")
            fin.seek(stdin_offset)
            stdin = fin
        try:
            t = time.perf_counter()
            p = subprocess.Popen([TIME, "-q", "-f", "%M %U %S", "-o", tf.name] + argv,
                                 stdin=stdin, stdout=out, stderr=err, cwd=cwd)
            p.wait()
            wall = time.perf_counter() - t
        finally:
            if fin:
                fin.close()
        out.seek(0)
        err.seek(0)
        fields = tf.read().split()
        usage = (int(fields[-3]), float(fields[-2]), float(fields[-1])) if len(fields) >= 3 else (0, 0.0, 0.0)
        return wall, usage, p.returncode, out.read().decode("utf-8", "replace"), err.read().decode("utf-8", "replace")


def build_zlib_c(workdir):
    exe = os.path.join(workdir, "zlib_inflate")
    src = os.path.join(HERE, "zlib_inflate.c")
    r = subprocess.run(["gcc", "-O2", "-o", exe, src, "-lz"], capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"gcc {src} failed (install zlib1g-dev?):\n{r.stderr}")
    return exe


def commands(args, vol, iso, workdir, zlib_c):
    """The commands for one volume: dicts with id, group, threads, argv, output, stdin."""
    out = lambda name: os.path.join(workdir, name)  # noqa: E731
    skip, _ = nrrd_header(vol)
    cmds = []
    for t in args.threads:
        cmds.append(dict(id=f"isoforge {t}T", group="isoforge", threads=t, output=out(f"isoforge-{t}.ply"),
                         argv=[args.isoforge, "extract", "-i", vol, "--iso", repr(iso), "--method", "mc",
                               "-o", out(f"isoforge-{t}.ply"), "--threads", str(t)]))
        for name, extra in args.variant:
            o = out(f"isoforge-{name}-{t}.ply")
            extra = extra.split()
            method = extra[extra.index("--method") + 1] if "--method" in extra else "mc"
            base = [] if "--method" in extra else ["--method", "mc"]
            cmds.append(dict(id=f"isoforge-{name} {t}T", group="isoforge", threads=t, output=o, method=method,
                             argv=[args.isoforge, "extract", "-i", vol, "--iso", repr(iso), *base, "-o", o,
                                   "--threads", str(t)] + extra))
    for name, template in args.command:
        name, _, fixed = name.partition("@")
        for t in [int(fixed)] if fixed else args.threads:
            o = out(f"{name}-{t}.ply")
            argv = [a.format(input=vol, iso=repr(iso), output=o, threads=t) for a in template.split()]
            cmds.append(dict(id=f"{name} {t}T", group="isoforge", threads=t, output=o, argv=argv))
    if not args.no_vtk:
        for t in args.threads:
            o = out(f"vtk-{t}.ply")
            cmds.append(dict(id=f"vtk {t}T", group="vtk", threads=t, output=o,
                             argv=[args.python, os.path.join(HERE, "e2e_vtk.py"), vol, "--iso", repr(iso),
                                   "-o", o, "--threads", str(t)]))
    cmds.append(dict(id="zlib-c", group="zlib", threads=1, argv=[zlib_c, vol]))
    cmds.append(dict(id="zlib-py", group="zlib", threads=1,
                     argv=[args.python, os.path.abspath(__file__), "--zlib-py", vol]))
    for tool in ("gzip", "pigz"):
        exe = shutil.which(tool)
        if exe:
            cmds.append(dict(id=f"{tool} -dc", group="gzip", threads=1 if tool == "gzip" else os.cpu_count(),
                             argv=[exe, "-dc"], stdin=(vol, skip)))
    return cmds


def check(cmd, rc, stdout, stderr, want_bytes):
    """Validates one run; returns what it produced: triangles/vertices or bytes, plus stage times."""
    if rc != 0:
        raise SystemExit(f"{cmd['id']} failed (exit {rc}): {' '.join(cmd['argv'])}\n{stderr[-2000:]}")
    got = {}
    if cmd["group"] in ("isoforge", "vtk"):
        got["vertices"], got["triangles"] = ply_counts(cmd["output"])
        if cmd["group"] == "vtk":
            got["stages"] = json.loads(stdout.strip().splitlines()[-1])
        else:
            m = re.search(r"(extraction|reading \+ extraction \+ writing) ([0-9.]+) s\)", stderr)
            if m:
                got["stages"] = {"isoforge_reported_s": float(m.group(2)), "what": m.group(1)}
    elif cmd["group"] == "zlib":
        got["bytes"] = json.loads(stdout.strip().splitlines()[-1])["bytes"]
        if got["bytes"] != want_bytes:
            raise SystemExit(f"{cmd['id']}: {got['bytes']} bytes out, the NRRD header declares {want_bytes}")
    return got


def measure_volume(args, name, workdir, zlib_c):
    vol = os.path.join(args.data, name + ".nrrd")
    for path in (vol, os.path.join(args.data, name + ".json")):
        if not os.path.isfile(path):
            raise SystemExit(f"--volumes {name}: {path} is missing (an NRRD file and its JSON sidecar)")
    with open(os.path.join(args.data, name + ".json")) as f:
        sidecar = json.load(f)
    iso = iso_of(sidecar, name, args.iso)
    _, fields = nrrd_header(vol)
    want = declared_bytes(fields, vol)
    cmds = commands(args, vol, iso, workdir, zlib_c)
    with open(vol, "rb") as f:  # into the page cache
        while f.read(16 << 20):
            pass
    records = {c["id"]: [] for c in cmds}
    produced = {}
    for rep in range(-1, args.repeats):  # rep -1: the untimed warm-up of every command
        shift = max(rep, 0) % len(cmds)
        for c in cmds[shift:] + cmds[:shift]:
            if c.get("output") and os.path.exists(c["output"]):
                os.remove(c["output"])  # untimed: every run writes a new file
            stdin = c.get("stdin") or (None, 0)
            wall, (rss_kb, user, sys_s), rc, so, se = run_once(c["argv"], stdin[0], stdin[1], cwd=workdir)
            got = check(c, rc, so, se, want)
            produced[c["id"]] = got
            if rep >= 0:
                records[c["id"]].append(dict(wall=wall, rss_kb=rss_kb, user=user, sys=sys_s,
                                             rep=rep, stages=got.get("stages")))
        print(f"  {name}: repetition {rep + 1 if rep >= 0 else 'warm-up'} done", file=sys.stderr)
    other = {c["id"] for c in cmds if c.get("method", "mc") != "mc"}
    tris = {cid: g["triangles"] for cid, g in produced.items() if "triangles" in g and cid not in other}
    if len(set(tris.values())) > 1:
        raise SystemExit(f"{name}: triangle counts differ: {tris}")
    for c in cmds:
        if c.get("output") and os.path.exists(c["output"]):
            os.remove(c["output"])
    return dict(volume=name, path=vol, iso=iso, input_bytes=os.path.getsize(vol), raw_bytes=want,
                commands=[{k: v for k, v in c.items() if k != "stdin"} for c in cmds],
                produced=produced, runs=records)


# ---------------------------------------------------------------------------------------------
# Report

def med(xs):
    return statistics.median(xs) if xs else float("nan")


def summarize(vr):
    """Rows of one volume's table."""
    runs = vr["runs"]
    rows = []
    zlib = runs.get("zlib-c") or []
    zmed = med([r["wall"] for r in zlib])
    for c in vr["commands"]:
        rs = runs[c["id"]]
        walls = [r["wall"] for r in rs]
        row = dict(id=c["id"], group=c["group"], threads=c["threads"], n=len(rs), median=med(walls),
                   min=min(walls), max=max(walls), rss_mb=med([r["rss_kb"] for r in rs]) / 1024,
                   rss_max_mb=max(r["rss_kb"] for r in rs) / 1024,
                   cpu=med([r["user"] + r["sys"] for r in rs]),
                   triangles=vr["produced"][c["id"]].get("triangles"))
        if c["group"] == "isoforge":
            vtk = runs.get(f"vtk {c['threads']}T")
            if vtk:
                row["vs_vtk"] = row["median"] / med([r["wall"] for r in vtk])
                by_rep = {r["rep"]: r["wall"] for r in vtk}
                row["vs_vtk_paired"] = med([r["wall"] / by_rep[r["rep"]] for r in rs if r["rep"] in by_rep])
                row["vtk_rss_mb"] = med([r["rss_kb"] for r in vtk]) / 1024
            if zlib:
                row["vs_zlib"] = row["median"] / zmed
                by_rep = {r["rep"]: r["wall"] for r in zlib}
                row["vs_zlib_paired"] = med([r["wall"] / by_rep[r["rep"]] for r in rs if r["rep"] in by_rep])
        if c["group"] == "vtk" and rs and rs[0].get("stages"):
            row["stages"] = {k: med([r["stages"][k] for r in rs]) for k in ("import_s", "read_s", "extract_s", "write_s")}
        if c["group"] == "zlib" and c["id"] != "zlib-c" and zlib:
            row["vs_zlib"] = row["median"] / zmed
        rows.append(row)
    return rows


def fmt_ratio(row, key):
    if key not in row:
        return "-"
    return f"{row[key]:.2f}× ({row[key + '_paired']:.2f}×)" if key + "_paired" in row else f"{row[key]:.2f}×"


def report(results, env):
    lines = [
        f"# End to end: gzip NRRD → binary PLY, fresh process per run ({env['date']})",
        "",
        f"Command: `{env['command']}`",
        "",
        f"- machine: {env['machine']}; load average before / after: {env['load_before']} / {env['load_after']}",
        f"- isoforge: {env['isoforge']}; VTK {env['vtk']}; system zlib {env['zlib']}; {env['gcc']}; Python {env['python']}",
        f"- {env['repeats']} timed repetitions per command, interleaved (each repetition runs every command once, "
        "the order rotated by one each time), after one untimed run of every command: all timed runs read the "
        "input from the page cache (dropping caches is not possible here).",
        "- wall: fork to reap of the child, seconds; peak RSS: that child's own (GNU time `%M`); cpu: user + sys.",
        "- ÷ VTK: isoforge median / VTK median at the same thread count, then in brackets the median of the "
        "per-repetition ratios (runs of one repetition ran back to back, so they saw the same load). "
        "÷ zlib: median / `zlib-c` median, same bracket rule. Targets (issue 11): ≤ 0.6× VTK, ≤ 1.3× zlib.",
        "",
    ]
    for vr in results:
        rows = summarize(vr)
        lines += [
            f"## {vr['volume']} (iso {vr['iso']!r}; {vr['input_bytes'] / 1e6:.1f} MB gzip → {vr['raw_bytes'] / 1e6:.1f} MB of samples)",
            "",
            "| command | thr | n | median s | min s | max s | peak RSS MB (max) | cpu s | triangles | ÷ VTK same thr (paired) | ÷ zlib-c (paired) | VTK peak RSS MB |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for r in rows:
            vtk_rss = f"{r['vtk_rss_mb']:.0f}" if "vtk_rss_mb" in r else "-"
            tris = r["triangles"] if r["triangles"] is not None else "-"
            lines.append(
                f"| {r['id']} | {r['threads']} | {r['n']} | {r['median']:.3f} | {r['min']:.3f} | {r['max']:.3f} | "
                f"{r['rss_mb']:.0f} ({r['rss_max_mb']:.0f}) | {r['cpu']:.3f} | {tris} | {fmt_ratio(r, 'vs_vtk')} | "
                f"{fmt_ratio(r, 'vs_zlib')} | {vtk_rss} |")
        stages = [r for r in rows if "stages" in r]
        if stages:
            lines += ["", "VTK stage medians (s): " + "; ".join(
                f"{r['id']}: import {r['stages']['import_s']:.3f}, read {r['stages']['read_s']:.3f}, "
                f"extract {r['stages']['extract_s']:.3f}, write {r['stages']['write_s']:.3f}" for r in stages)]
        lines.append("")
    return "\n".join(lines)


def environment(args):
    def out(argv):
        try:
            return subprocess.run(argv, capture_output=True, text=True, timeout=60).stdout.strip()
        except OSError:
            return "?"
    vtk = out([args.python, "-c", "import vtk; print(vtk.vtkVersion.GetVTKVersion())"]) or "?"
    iso_dir = os.path.dirname(os.path.abspath(args.isoforge))
    commit = out(["git", "-C", iso_dir, "rev-parse", "--short", "HEAD"])
    zlib = out(["sh", "-c", "dpkg-query -W -f '${Version}' zlib1g 2>/dev/null"]) or "?"
    return dict(
        date=datetime.datetime.now().strftime("%Y-%m-%d %H:%M"),
        command=" ".join(os.path.relpath(a) if a == os.path.abspath(__file__) else a for a in sys.argv),
        machine=f"{platform.machine()}, {os.cpu_count()} cores, {platform.platform()}",
        isoforge=f"{args.isoforge} (commit {commit or '?'})",
        vtk=vtk, zlib=zlib, gcc=out(["gcc", "--version"]).splitlines()[0] if shutil.which("gcc") else "?",
        python=platform.python_version(), repeats=args.repeats,
        load_before=" ".join(f"{x:.2f}" for x in os.getloadavg()), load_after="?",
    )


def parse_pair(flag, text, conv):
    """`NAME=VALUE` of a repeatable option, VALUE converted by `conv`."""
    name, eq, value = text.partition("=")
    try:
        if not (name and eq and value):
            raise ValueError
        return name, conv(value)
    except ValueError:
        raise SystemExit(f"{flag} {text!r}: expected NAME=VALUE") from None


def main():
    if len(sys.argv) == 3 and sys.argv[1] == "--zlib-py":
        return zlib_py(sys.argv[2])
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--isoforge", required=True, help="isoforge binary (a release build)")
    ap.add_argument("--data", default=DEFAULT_DATA, help="folder of NRRD files with JSON sidecars")
    ap.add_argument("--volumes", default=DEFAULT_VOLUMES, help="comma-separated stems")
    ap.add_argument("--iso", action="append", default=[], metavar="STEM=V", help="iso for a stem (default: "
                    "the sidecar's first suggestion, else its Otsu threshold)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--threads", default="1,2", help="thread counts for isoforge and VTK")
    ap.add_argument("--variant", action="append", default=[], metavar="NAME=ARGS",
                    help="extra isoforge rows with these arguments appended, e.g. 'stream=--max-memory 1MiB'")
    ap.add_argument("--command", action="append", default=[], metavar="NAME[@T]=TEMPLATE",
                    help="another gzip-NRRD -> binary-PLY command, compared like isoforge; TEMPLATE is split "
                    "on spaces and {input} {iso} {output} {threads} are substituted (e.g. a prototype); NAME@T: "
                    "one row, at T threads, instead of one per --threads; commands run in the work folder, so give "
                    "absolute paths")
    ap.add_argument("--no-vtk", action="store_true")
    ap.add_argument("--python", default=sys.executable, help="interpreter with VTK (default: this one)")
    ap.add_argument("--workdir", help="where outputs go (default: a temporary folder, removed)")
    ap.add_argument("--out", help="write the markdown report here too")
    ap.add_argument("--json", help="write all records here")
    args = ap.parse_args()
    args.isoforge = os.path.abspath(args.isoforge)
    if not os.access(TIME, os.X_OK):
        raise SystemExit(f"{TIME} is missing (apt-get install time)")
    if not os.access(args.isoforge, os.X_OK):
        raise SystemExit(f"--isoforge {args.isoforge}: not an executable (cargo build --release -p isoforge-cli)")
    try:
        args.threads = [int(t) for t in args.threads.split(",")]
    except ValueError:
        raise SystemExit(f"--threads {args.threads!r}: expected comma-separated whole numbers") from None
    args.iso = dict(parse_pair("--iso", s, float) for s in args.iso)
    args.variant = [parse_pair("--variant", s, str) for s in args.variant]
    args.command = [parse_pair("--command", s, str) for s in args.command]
    if args.repeats < 1:
        raise SystemExit("--repeats must be at least 1")
    env = environment(args)
    workdir = args.workdir or tempfile.mkdtemp(prefix="e2e-")
    os.makedirs(workdir, exist_ok=True)
    try:
        zlib_c = build_zlib_c(workdir)
        results = [measure_volume(args, name, workdir, zlib_c) for name in args.volumes.split(",") if name]
    finally:
        if not args.workdir:
            shutil.rmtree(workdir, ignore_errors=True)
    env["load_after"] = " ".join(f"{x:.2f}" for x in os.getloadavg())
    text = report(results, env)
    print(text)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(dict(environment=env, results=results), f, indent=1)


if __name__ == "__main__":
    try:
        main()
    except SystemExit as e:
        if isinstance(e.code, str):  # our one-line errors: bad input or a failed check, exit 2
            print(e.code, file=sys.stderr)
            sys.exit(2)
        raise
