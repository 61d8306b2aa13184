#!/bin/sh
# Runs every experiment behind docs/results.md and regenerates the page and its figures.
# Run from the repository root after building (cmake --build build). About 11 minutes of CPU
# time: the convergence studies and the RK45 references of the paper's swing test (8 s of a
# 1250-triangle cloth, 11,000 and 59,000 steps, about 1.5 minutes each pair) take most of it;
# the two energy experiments on the paper's swing test run side by side on two cores.
set -e
WEFT=${WEFT:-build/weft}
OUT=${OUT:-out/results}
$WEFT experiment energy -q --scene scenes/paper-swing.json --out "$OUT/energy-paper" --repeats 3 &
PAPER=$!
$WEFT experiment energy -q --scene scenes/paper-swing.json --out "$OUT/energy-paper-newton" --repeats 3 --newton 4
wait $PAPER
$WEFT experiment energy -q --out "$OUT/energy" --repeats 11 --no-injection
$WEFT experiment energy -q --scene scenes/swing-21x21.json --out "$OUT/energy-21x21" --repeats 0 --no-injection
rm -rf "$OUT/flat"
# 0 iterations: the linearised step, without backward Euler's automatic Newton iterations.
mkdir -p "$OUT"
sed 's/"dt": 0.02,/"dt": 0.02, "automatic_newton": false,/' scenes/paper-swing-flat.json > "$OUT/paper-swing-flat-linearised.json"
for m in backward-euler implicit-midpoint-plain; do
  for n in 0 4; do
    scene=scenes/paper-swing-flat.json
    [ $n = 0 ] && scene="$OUT/paper-swing-flat-linearised.json"
    $WEFT run -q "$scene" --out "$OUT/flat/$m-newton$n" --method $m --newton $n --no-frames || true
  done
done
$WEFT run -q scenes/paper-swing.json --out "$OUT/paper-guarded" --method implicit-midpoint --no-frames || true
$WEFT experiment convergence -q --out "$OUT/convergence"
$WEFT experiment convergence -q --scene scenes/drum.json --out "$OUT/convergence-drum"
python3 tools/results_md.py --energy "$OUT/energy" --energy-stiff "$OUT/energy-21x21" \
  --energy-paper "$OUT/energy-paper" --energy-paper-newton "$OUT/energy-paper-newton" --flat "$OUT/flat" \
  --paper-guarded "$OUT/paper-guarded" \
  --convergence "$OUT/convergence" --convergence-exact "$OUT/convergence-drum" \
  --commands tools/results.sh --out docs/results.md --img docs/img/results
