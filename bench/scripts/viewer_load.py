#!/usr/bin/env python3
"""Load test of `isoforge view` (issue 50), Python stdlib only.

1. exports (or meshes, checks: --endpoint): N clients at once each ask
   GET /api/export?format=obj&method=surface-nets&iso=<base + i*step> (mesh: /api/mesh?…&level=full,
   check: /api/check?…) and read the body; reports wall time, bytes, status codes, the server's peak RSS
   (VmHWM) and its RSS once idle again (VmRSS, 2 s after the last answer).
2. half-open: H connections send only "GET /api/info HTTP/1.1\\r\\n"; then R normal /api/info requests
   are timed one after the other; reports their median and max latency.

Usage: viewer_load.py BINARY [VOLUME] [--clients 40] [--iso 40] [--step 0.37] [--half-open 300]
       [--endpoint export|mesh|check] [--max-memory BYTES]
(VOLUME absent: the demo fields, client i asking n=100+i; a VOLUME path that does not exist is skipped with a
message.)
"""
import argparse
import os
import socket
import statistics
import subprocess
import sys
import threading
import time


def status_of(pid, key):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024
    return 0


def request(addr, path, timeout=600):
    host, port = addr.split(":")
    s = socket.create_connection((host, int(port)), timeout=timeout)
    s.sendall(f"GET {path} HTTP/1.1\r\nHost: {addr}\r\n\r\n".encode())
    head, total = b"", 0
    while True:
        chunk = s.recv(1 << 20)
        if not chunk:
            break
        if len(head) < 64:
            head += chunk[:64]
        total += len(chunk)
    s.close()
    parts = head.split(b" ")
    return (int(parts[1]) if len(parts) > 1 and parts[1].isdigit() else 0), total


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("binary")
    ap.add_argument("volume", nargs="?")
    ap.add_argument("--clients", type=int, default=40)
    ap.add_argument("--iso", type=float, default=40.0)
    ap.add_argument("--step", type=float, default=0.37)
    ap.add_argument("--half-open", type=int, default=300)
    ap.add_argument("--probes", type=int, default=30)
    ap.add_argument("--endpoint", choices=["export", "mesh", "check"], default="export")
    ap.add_argument("--max-memory", help="passed to `view --max-memory`")
    a = ap.parse_args()
    args = [a.binary, "view"]
    if a.max_memory:
        args += ["--max-memory", a.max_memory]
    if a.volume:
        if not os.path.exists(a.volume):
            print(f"skipped: {a.volume} is absent")
            return 0
        args.append(a.volume)
    server = subprocess.Popen(args, stdout=subprocess.PIPE)
    try:
        addr = server.stdout.readline().decode().strip().removeprefix("http://").rstrip("/")
        pid = server.pid
        print(f"server {addr} pid {pid}, RSS at start {status_of(pid, 'VmRSS') / 2**20:.0f} MiB")

        results = [None] * a.clients

        def one(i):
            iso = a.iso + i * a.step
            # The demo: one distinct resolution per client instead of one iso each.
            q = f"iso={iso:.4f}" if a.volume else f"n={100 + i}"
            t = time.monotonic()
            path = {
                "export": f"/api/export?format=obj&method=surface-nets&{q}",
                "mesh": f"/api/mesh?method=surface-nets&level=full&{q}",
                "check": f"/api/check?method=surface-nets&{q}",
            }[a.endpoint]
            code, n = request(addr, path)
            results[i] = (code, n, time.monotonic() - t)

        t0 = time.monotonic()
        threads = [threading.Thread(target=one, args=(i,)) for i in range(a.clients)]
        for t in threads:
            t.start()
        # A cheap request while the exports run.
        time.sleep(0.5)
        t = time.monotonic()
        code, _ = request(addr, "/api/info", timeout=60)
        info_under_load = time.monotonic() - t
        for t in threads:
            t.join()
        wall = time.monotonic() - t0
        codes = {}
        for c, _, _ in results:
            codes[c] = codes.get(c, 0) + 1
        total = sum(n for _, n, _ in results)
        peak = status_of(pid, "VmHWM")
        time.sleep(2)
        idle = status_of(pid, "VmRSS")
        lat = sorted(d for c, _, d in results if c == 200)
        med = f"{statistics.median(lat):.1f}" if lat else "-"
        print(f"{a.endpoint}: {a.clients} clients, answer time median {med} s, max {max(lat, default=0):.1f} s, "
              f"whole run {wall:.1f} s, {total / 2**20:.0f} MiB sent, codes {codes}, "
              f"peak RSS {peak / 2**20:.0f} MiB, idle RSS {idle / 2**20:.0f} MiB, "
              f"/api/info under load {info_under_load * 1000:.0f} ms (code {code})")

        half = []
        host, port = addr.split(":")
        for _ in range(a.half_open):
            s = socket.create_connection((host, int(port)))
            s.sendall(b"GET /api/info HTTP/1.1\r\n")
            half.append(s)
        lat, codes = [], {}
        for _ in range(a.probes):
            t = time.monotonic()
            c, _ = request(addr, "/api/info", timeout=30)
            lat.append(time.monotonic() - t)
            codes[c] = codes.get(c, 0) + 1
        for s in half:
            s.close()
        print(f"half-open: {a.half_open} held, {a.probes} probes of /api/info: median "
              f"{statistics.median(lat) * 1000:.1f} ms, max {max(lat) * 1000:.1f} ms, codes {codes}")
    finally:
        server.kill()
        server.wait()
    return 0


if __name__ == "__main__":
    sys.exit(main())
