#!/usr/bin/env bash
# Real volumes from $ISOFORGE_DATA/volumes (default ../shared/data next to the checkout); see docs/BENCHMARKS.md §6.12–6.15.
# ident.sh NEW OLD: cmp outputs of two binaries across methods, volumes, thread counts
NEW=$1; OLD=$2; D=${ISOFORGE_DATA:-$(cd "$(dirname "$0")/../../.." && pwd)/shared/data}/volumes; P=${PEERS_DATA:-/tmp/peers-data}; T=/tmp/ident; mkdir -p $T
n=0; bad=0
run() { # name args...
  local name=$1; shift
  $NEW "$@" -o $T/new.ply >/dev/null 2>$T/err.new; a=$?
  $OLD "$@" -o $T/old.ply >/dev/null 2>$T/err.old; b=$?
  n=$((n+1))
  if [ $a != 0 ] || [ $b != 0 ] || ! cmp -s $T/new.ply $T/old.ply; then echo "DIFF $name rc=$a/$b"; bad=$((bad+1)); fi
}
for m in ${METHODS:-mc mc33 mt5 mt6 mt-bcc surface-nets}; do for t in 1 2; do
  run bunny-$m-$t extract -i $D/stanford_bunny_ct_512x512x361.nrrd --iso 988.37 --method $m --threads $t
  run shoulder-$m-$t extract -i $D/vhp_shoulder_ct_512x512x450.nrrd --iso 46.3184 --method $m --threads $t
  run bunny-stream-$m-$t extract -i $D/stanford_bunny_ct_512x512x361.nrrd --iso 988.37 --method $m --threads $t --max-memory 64M
  run chest-normals-$m-$t extract -i $D/lidc2_chest_ct_u8.nrrd --iso 59.3 --method $m --threads $t --normals gradient
  run chest-roi-$m-$t extract -i $D/lidc2_chest_ct_u8.nrrd --iso 59.3 --method $m --threads $t --roi 20:200,:,10:90 --close
  for v in cthead_8bit_256x256x99:52.3 volvis_engine_256x256x128:71.2 lidc2_chest_ct_u8:59.3 vtk_headsq_quarter:500 emd3197_subtomo_20:3.184; do
    run ${v%%:*}-$m-$t extract -i $D/${v%%:*}.nrrd --iso ${v##*:} --method $m --threads $t
  done
done; done
for m in ${METHODS:-mc mc33 mt5 mt6 mt-bcc surface-nets}; do
  run field-$m extract -i 'field:gyroid?n=96' --iso 0 --method $m
  for v in gyroid noise sphere; do
    if [ -f $P/${v}_256.raw ]; then iso=$(python3 -c "import json;print(json.load(open('$P/${v}_256.json'))['iso'])"); run $v-$m extract -i $P/${v}_256.raw --dims 256,256,256 --dtype f32 --iso $iso --method $m; fi
  done
done
echo "$n cases, $bad differ"; [ $bad = 0 ] && echo ALL-IDENTICAL
