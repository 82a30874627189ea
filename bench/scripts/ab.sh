#!/usr/bin/env bash
# Binaries side by side: one method at THREADS threads on three CTs and the four 256³ synthetic
# volumes of PEERS_DATA (the --out of bench/peers/volumes.py, default /tmp/peers-data), interleaved
# rounds, each the median of a --repeat 9 run (its first run left out); prints medians over rounds
# and each binary ÷ the first. See docs/BENCHMARKS.md §6.18.
# ab.sh METHOD THREADS ROUNDS BIN...
M=$1; T=$2; R=$3; shift 3; P=${PEERS_DATA:-/tmp/peers-data}
D=${ISOFORGE_DATA:-$(cd "$(dirname "$0")/../../.." && pwd)/shared/data}/volumes
declare -A A=([chest]="-i $D/lidc2_chest_ct_u8.nrrd --iso 59.3" [engine]="-i $D/volvis_engine_256x256x128.nrrd --iso 71.2"
 [cthead]="-i $D/cthead_8bit_256x256x99.nrrd --iso 52.3")
for v in sphere gyroid metaballs noise; do
 A[${v}_256]=$(python3 -c "
import json,sys; m=json.load(open(f'{sys.argv[1]}/{sys.argv[2]}.json'))
print(f\"--input {sys.argv[1]}/{m['file']} --dims {','.join(map(str,m['dims']))} --dtype f32 --iso {float(m['iso'])!r}\")" "$P" ${v}_256)
done
out=/tmp/ab.$$.tsv; : > $out
for r in $(seq 1 "$R"); do for v in "${!A[@]}"; do for b in "$@"; do
 "$b" extract ${A[$v]} --method "$M" --threads "$T" --repeat 9 --time-json /tmp/ab.$$.json -o /tmp/ab.$$.ply >/dev/null 2>&1 || echo "FAIL $b $v" >&2
 printf "%s\t%s\t%s\n" "$v" "$b" "$(python3 -c "import json,statistics,sys;print(statistics.median(json.load(open(sys.argv[1]))['runs'][1:]))" /tmp/ab.$$.json)" >> $out
done; done; done
rm -f /tmp/ab.$$.json /tmp/ab.$$.ply
python3 - $out "$@" <<'PY'
import sys,collections,statistics as st
f,*bins=sys.argv[1:]
d=collections.defaultdict(list)
for l in open(f):
    v,b,t=l.split('\t'); d[(v,b)].append(float(t))
for v in sorted({v for v,_ in d}):
    m=[st.median(d[(v,b)]) for b in bins]
    print(f"{v:14s}", " ".join(f"{x*1e3:8.2f} ms" for x in m), " ÷ first:", " ".join(f"{x/m[0]:.3f}" for x in m[1:]))
PY
