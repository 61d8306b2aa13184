#!/bin/sh
# Runs every harness (built by `make fuzz` into build-san/fuzz/, or the folder FUZZ_BUILD) for
# SECONDS each, one after another on one core, on a corpus seeded from the shipped files.
# Prints each harness's executions and their total; exits 1 if any harness found a crash, a
# leak, a timeout or an undefined behaviour (the reproducer is left in FUZZ_BUILD/artifacts/).
# Inputs are capped at 4096 bytes (larger seeds are truncated): the shipped body files are up
# to 870 kB, and mutating whole copies of them runs a hundred times fewer inputs a second.
# Usage: fuzz/run.sh SECONDS [HARNESS...]
set -u
root=$(cd "$(dirname "$0")/.." && pwd)
seconds=${1:?usage: fuzz/run.sh SECONDS [HARNESS...]}
shift
build=${FUZZ_BUILD:-"$root/build-san/fuzz"}
harnesses=${*:-"scene material obj bvh rig weights tpose"}

seeds() {
  case "$1" in
    scene) ls "$root"/scenes/*.json ;;
    material) ls "$root"/data/materials/*.json ;;
    obj) ls "$root"/scenes/*.obj "$root"/data/body/*.obj ;;
    bvh) ls "$root"/data/motion/*.bvh "$root"/fuzz/seeds/bvh/* ;;
    rig) ls "$root"/data/body/rig.*.json ;;
    weights) ls "$root"/data/body/weights.*.json "$root"/fuzz/seeds/weights/* ;;
    tpose) ls "$root"/data/body/t-pose.*.json ;;
  esac
}

status=0
total=0
mkdir -p "$build/artifacts"
for h in $harnesses; do
  exe="$build/fuzz_$h"
  if [ ! -x "$exe" ]; then
    echo "fuzz/run.sh: $exe is missing (run make fuzz)" >&2
    exit 2
  fi
  corpus="$build/corpus/$h"
  if [ ! -d "$corpus" ]; then
    mkdir -p "$corpus"
    cp $(seeds "$h") "$corpus/"
  fi
  log="$build/fuzz_$h.log"
  "$exe" -max_total_time="$seconds" -max_len=4096 -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$build/artifacts/$h-" "$corpus" > "$log" 2>&1
  rc=$?
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
  runs=${runs:-0}
  total=$((total + runs))
  if [ "$rc" -ne 0 ]; then
    status=1
    echo "fuzz_$h: FAILED after $runs executions (exit $rc); see $log"
    grep -m 5 -E "ERROR|SUMMARY|runtime error|Test unit written" "$log"
  else
    echo "fuzz_$h: $runs executions, no finding"
  fi
done
echo "total: $total executions"
exit $status
