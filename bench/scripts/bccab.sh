#!/usr/bin/env bash
# Real volumes from $ISOFORGE_DATA/volumes (default ../shared/data next to the checkout); see docs/BENCHMARKS.md §6.12–6.15.
# bccab.sh OLD NEW ROUNDS: on the six CTs at 2 threads, interleaved: OLD mt-bcc, NEW mt-bcc, NEW mc (medians of runs[1:] of --repeat 11);
# prints per CT the medians over rounds and NEW's mt-bcc ÷ mc (ratio of medians, and median of per-round ratios).
OLD=$1; NEW=$2; R=${3:-3}; D=${ISOFORGE_DATA:-$(cd "$(dirname "$0")/../../.." && pwd)/shared/data}/volumes
declare -A ISO=([stanford_bunny_ct_512x512x361]=988.37 [vhp_shoulder_ct_512x512x450]=46.3184 [cthead_8bit_256x256x99]=52.3 [volvis_engine_256x256x128]=71.2 [lidc2_chest_ct_u8]=59.3 [vtk_headsq_quarter]=500)
out=/tmp/bccab.$$.tsv; : > $out
one(){ $1 extract -i $D/$2.nrrd --iso ${ISO[$2]} --method $3 --threads 2 --repeat 11 --time-json /tmp/bccab.json -o /tmp/bccab.ply >/dev/null 2>&1 || echo FAIL $1 $2 $3 >&2
  python3 -c "import json,statistics;d=json.load(open('/tmp/bccab.json'));print(statistics.median(d['runs'][1:]))"; }
for r in $(seq 1 $R); do for v in "${!ISO[@]}"; do
  a=$(one $OLD $v mt-bcc); b=$(one $NEW $v mt-bcc); c=$(one $NEW $v mc); printf "%s\t%s\t%s\t%s\n" $v $a $b $c >> $out
done; done
python3 - $out <<'PY'
import sys,collections,statistics as st
d=collections.defaultdict(list)
for l in open(sys.argv[1]):
    v,a,b,c=l.split(); d[v].append((float(a),float(b),float(c)))
print(f"{'volume':24s} {'old bcc':>9s} {'new bcc':>9s} {'new/old':>8s} {'mc':>8s} {'bcc÷mc':>7s} per-round")
for v,x in sorted(d.items()):
    a,b,c=(st.median(p[i] for p in x) for i in range(3))
    print(f"{v[:24]:24s} {a*1e3:9.2f} {b*1e3:9.2f} {b/a:8.3f} {c*1e3:8.2f} {b/c:7.2f} [{st.median(p[1]/p[2] for p in x):.2f}] {[round(p[1]/p[2],2) for p in x]}")
PY
