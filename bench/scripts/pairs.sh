#!/usr/bin/env bash
# pairs.sh BIN ROUNDS [PEERS_DATA]: `method_pairs` (bench/src/bin/method_pairs.rs: methods timed side
# by side in one process, rounds interleaved) on the six real CTs of $ISOFORGE_DATA/volumes (default
# ../shared/data next to the checkout) and, when PEERS_DATA (the --out of bench/peers/volumes.py) is
# given, its synthetic volumes. METHODS (default "mc,mc33,mt5,mt6,mt-bcc", the first the reference)
# and THREADS (default 2) as in method_pairs. BIN is target/release/method_pairs
# (cargo build --release -p isoforge-bench --bin method_pairs). See docs/BENCHMARKS.md §6.20.
BIN=$1; ROUNDS=${2:-21}; PEERS=${3:-}; D=${ISOFORGE_DATA:-$(cd "$(dirname "$0")/../../.." && pwd)/shared/data}/volumes
M=${METHODS:-mc,mc33,mt5,mt6,mt-bcc}; T=${THREADS:-2}
declare -A ISO=([stanford_bunny_ct_512x512x361]=988.37 [vhp_shoulder_ct_512x512x450]=46.3184 [cthead_8bit_256x256x99]=52.3 [volvis_engine_256x256x128]=71.2 [lidc2_chest_ct_u8]=59.3 [vtk_headsq_quarter]=500)
for v in $(printf "%s\n" "${!ISO[@]}" | sort); do
 [ -f "$D/$v.nrrd" ] || { echo "skipped $v: $D/$v.nrrd is absent"; continue; }
 "$BIN" "$D/$v.nrrd" --iso="${ISO[$v]}" --methods "$M" --threads "$T" --rounds "$ROUNDS" || echo "FAIL $v"
done
[ -n "$PEERS" ] || exit 0
for j in "$PEERS"/*.json; do
 case $(basename "$j") in real_*) continue ;; esac   # the CTs above, as raw
 read -r file dims iso < <(python3 -c "
import json,sys; m=json.load(open(sys.argv[1])); assert m['dtype']=='float32' and m['order']=='x-fastest'
print(m['file'], ','.join(map(str,m['dims'])), repr(float(m['iso'])))" "$j")
 "$BIN" "$PEERS/$file" --dims "$dims" --dtype f32 --iso="$iso" --methods "$M" --threads "$T" --rounds "$ROUNDS" || echo "FAIL $j"
done
