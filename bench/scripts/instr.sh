#!/usr/bin/env bash
# Instructions per extraction (callgrind, one thread): (--repeat 3 − --repeat 1) / 2, so reading
# and writing the files cancel out. See docs/BENCHMARKS.md §6.18.
# instr.sh BIN VOLUME [METHOD] [PEERS_DATA]: VOLUME is engine, chest, cthead, or a synthetic volume
# of PEERS_DATA (the --out of bench/peers/volumes.py, default /tmp/peers-data), e.g. noise_256
B=$1; V=$2; M=${3:-mt-bcc}; P=${4:-/tmp/peers-data}
D=${ISOFORGE_DATA:-$(cd "$(dirname "$0")/../../.." && pwd)/shared/data}/volumes
case $V in
 engine) A="-i $D/volvis_engine_256x256x128.nrrd --iso 71.2";;
 chest) A="-i $D/lidc2_chest_ct_u8.nrrd --iso 59.3";;
 cthead) A="-i $D/cthead_8bit_256x256x99.nrrd --iso 52.3";;
 *) A=$(python3 -c "
import json,sys; m=json.load(open(f'{sys.argv[1]}/{sys.argv[2]}.json'))
print(f\"--input {sys.argv[1]}/{m['file']} --dims {','.join(map(str,m['dims']))} --dtype f32 --iso {float(m['iso'])!r}\")" "$P" "$V");;
esac
ir() {
 valgrind --tool=callgrind --callgrind-out-file=/dev/null "$B" extract $A --method "$M" --threads 1 --repeat "$1" \
  -o /tmp/instr.$$.ply 2>&1 >/dev/null | grep -oP "Collected : \K[0-9]+"
}
a=$(ir 1); b=$(ir 3); rm -f /tmp/instr.$$.ply
echo "$V $M $(basename "$B") $(( (b - a) / 2 ))"
