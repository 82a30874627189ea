#!/usr/bin/env bash
# Real volumes from $ISOFORGE_DATA/volumes (default ../shared/data next to the checkout); see docs/BENCHMARKS.md §6.15.
# abm.sh METHOD THREADS ROUNDS VOL ISO BIN...: per binary, median and min of runs[1:] of --repeat 21, interleaved rounds;
# prints per binary the median of round medians and the min of mins.
M=$1; T=$2; R=$3; VOL=$4; ISO=$5; shift 5; D=${ISOFORGE_DATA:-$(cd "$(dirname "$0")/../../.." && pwd)/shared/data}/volumes
out=/tmp/abm.$$.tsv; : > $out
for r in $(seq 1 $R); do for b in "$@"; do
  $b extract -i $D/$VOL.nrrd --iso $ISO --method $M --threads $T --repeat 21 --time-json /tmp/abm.json -o /tmp/abm.ply >/dev/null 2>&1 || echo FAIL $b
  python3 -c "import json,statistics;d=json.load(open('/tmp/abm.json'));x=d['runs'][1:];print('$b',statistics.median(x),min(x))" >> $out
done; done
python3 - $out <<'PY'
import sys,collections,statistics
d=collections.defaultdict(list)
for l in open(sys.argv[1]):
    b,m,n=l.split(); d[b].append((float(m),float(n)))
for b,x in d.items():
    print(f"{b.split('/')[-1]:20s} median {1e3*statistics.median(p[0] for p in x):8.2f} ms  min {1e3*min(p[1] for p in x):8.2f} ms  rounds {[round(1e3*p[0],1) for p in x]}")
PY
