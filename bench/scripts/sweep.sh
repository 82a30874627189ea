#!/usr/bin/env bash
# Real volumes from $ISOFORGE_DATA/volumes (default ../shared/data next to the checkout); see docs/BENCHMARKS.md §6.12–6.17.
# sweep.sh BIN ROUNDS [PEERS_DATA]: every method ÷ mc at 2 threads on 6 real CTs, interleaved rounds, and on the
# peer harness's synthetic volumes when PEERS_DATA (the --out of bench/peers/volumes.py) is given; appends to
# /tmp/sweep.tsv (round, volume, method, median seconds, triangles); prints the time ratios, then the same per
# output triangle. METHODS (default "mc33 mt5 mt6 mt-bcc") picks the methods timed beside mc.
BIN=$1; ROUNDS=${2:-3}; PEERS=${3:-}; D=${ISOFORGE_DATA:-$(cd "$(dirname "$0")/../../.." && pwd)/shared/data}/volumes
declare -A ISO=([stanford_bunny_ct_512x512x361]=988.37 [vhp_shoulder_ct_512x512x450]=46.3184 [cthead_8bit_256x256x99]=52.3 [volvis_engine_256x256x128]=71.2 [lidc2_chest_ct_u8]=59.3 [vtk_headsq_quarter]=500)
declare -A ARGS
for v in "${!ISO[@]}"; do ARGS[$v]="-i $D/$v.nrrd --iso ${ISO[$v]}"; done
if [ -n "$PEERS" ]; then
 for j in "$PEERS"/*.json; do
  case $(basename "$j") in real_*) continue ;; esac   # the CTs above, as raw
  ARGS[$(basename "$j" .json)]=$(python3 -c "
import json,sys; m=json.load(open(sys.argv[1])); assert m['dtype']=='float32' and m['order']=='x-fastest'
print(f\"--input {sys.argv[2]}/{m['file']} --dims {','.join(map(str,m['dims']))} --dtype f32 --iso {float(m['iso'])!r}\")" "$j" "$PEERS")
 done
fi
for r in $(seq 1 $ROUNDS); do
 for v in "${!ARGS[@]}"; do
  for m in mc ${METHODS:-mc33 mt5 mt6 mt-bcc}; do
   $BIN extract ${ARGS[$v]} --method $m --threads 2 --repeat 7 --time-json /tmp/sw.json -o /tmp/sw.ply >/dev/null 2>&1 || echo FAIL $v $m
   med=$(python3 -c "import json,statistics;d=json.load(open('/tmp/sw.json'));print(statistics.median(d['runs'][1:]), d['triangles'])")
   printf "%s\t%s\t%s\t%s\t%s\n" $r $v $m $med >> /tmp/sweep.tsv
  done
 done
done
python3 - <<'PY'
import collections,statistics
d=collections.defaultdict(dict)
tris={}
for l in open('/tmp/sweep.tsv'):
    r,v,m,t,n=l.split(); d[(v,m)][r]=float(t); tris[(v,m)]=int(n)
vs=sorted({v for v,_ in d})
ms=[m for m in ["mc33","mt5","mt6","mt-bcc"] if all((v,m) in d for v in vs)]
print("volume\t"+"\t".join(ms)+"\t(ratio of medians; median of per-round ratios in brackets)")
for v in vs:
    mc=d[(v,'mc')]; mcm=statistics.median(mc.values())
    cells=[]
    for m in ms:
        x=d[(v,m)]; per=[x[r]/mc[r] for r in x if r in mc]
        cells.append(f"{statistics.median(x.values())/mcm:.2f} [{statistics.median(per):.2f}]")
    print(v[:22]+"\t"+"\t".join(cells)+f"\t(mc {mcm*1e3:.2f} ms, n={len(mc)})")
print("\nper output triangle: (time ÷ triangles) ÷ mc's; triangles ÷ mc's in brackets")
for v in vs:
    mcm=statistics.median(d[(v,'mc')].values())/tris[(v,'mc')]
    cells=[f"{statistics.median(d[(v,m)].values())/tris[(v,m)]/mcm:.2f} [{tris[(v,m)]/tris[(v,'mc')]:.2f}]" for m in ms]
    print(v[:22]+"\t"+"\t".join(cells))
PY
