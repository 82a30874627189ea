#!/usr/bin/env bash
# build_times.sh [REV] [STEPS]: what a newcomer waits for (issue 43), from a fresh clone of REV (default
# HEAD) in a temporary folder, each step's wall time in seconds (docs/BENCHMARKS.md §7):
#   demo    `cargo run --release -- demo`      (the README's first command, fresh target)
#   test    `cargo test`                       (the README's second command, same target, dev profile)
#   edit    change one extractor's code, then `cargo test -p isoforge --lib`   (the edit-test cycle)
#   ci      `.ci/run` in another fresh clone    (needs npm and Chromium, as CI)
# STEPS defaults to "demo test edit". The crates come from ~/.cargo/registry (downloads are not
# counted). Run on an idle machine: `uptime` is printed before each step.
set -euo pipefail
REV=${1:-HEAD}
STEPS=${2:-demo test edit}
SRC=$(cd "$(dirname "$0")/../.." && pwd)
WORK=$(mktemp -d /tmp/isoforge-build-times.XXXX)
trap 'rm -rf "$WORK"' EXIT
git clone -q "$SRC" "$WORK/clone"
cd "$WORK/clone"
git checkout -q "$REV"
echo "rev $(git rev-parse --short HEAD), $(nproc) cores, $(cargo --version)"
step() {
    local name=$1
    shift
    echo "== $name: $* ($(uptime | sed 's/.*load/load/'))"
    local t0
    t0=$(date +%s)
    "$@" >"$WORK/$name.log" 2>&1 || {
        echo "$name FAILED (log below)"
        tail -30 "$WORK/$name.log"
        exit 1
    }
    echo "$name $(($(date +%s) - t0)) s"
}
for s in $STEPS; do
    case $s in
        demo) step demo cargo run --release -- demo -o "$WORK/demo.ply" ;;
        test) step test cargo test ;;
        edit)
            # A change the compiler must act on: a statement added to MC33's `process_decided`,
            # the body of the extractor the walker instantiates most.
            f=crates/isoforge/src/extract/mc33.rs
            sed -i '0,/fn process_decided<C: Cell>(&self, cell: &mut C, decision: Decision) {/s//&\n        std::hint::black_box('"$RANDOM"');/' $f
            git diff --quiet $f && { echo "edit: the edit did not apply" >&2; exit 1; }
            step edit cargo test -p isoforge --lib
            git checkout -q $f
            ;;
        ci)
            git clone -q "$SRC" "$WORK/ci" && (cd "$WORK/ci" && git checkout -q "$REV")
            step ci "$WORK/ci/.ci/run"
            ;;
        *) echo "unknown step $s" >&2 && exit 2 ;;
    esac
done
