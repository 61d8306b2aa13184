#!/bin/sh
# Runs every experiment behind docs/results.md and regenerates the page and its figures.
# Run from the repository root after building (cmake --build build). Takes a few minutes.
set -e
WEFT=${WEFT:-build/weft}
OUT=${OUT:-out/results}
$WEFT experiment energy -q --out "$OUT/energy" --repeats 11
$WEFT experiment energy -q --scene scenes/swing-21x21.json --out "$OUT/energy-21x21" --repeats 0
$WEFT experiment convergence -q --out "$OUT/convergence"
$WEFT experiment convergence -q --scene scenes/drum.json --out "$OUT/convergence-drum"
python3 tools/results_md.py --energy "$OUT/energy" --energy-stiff "$OUT/energy-21x21" \
  --convergence "$OUT/convergence" --convergence-exact "$OUT/convergence-drum" \
  --commands tools/results.sh --out docs/results.md --img docs/img/results
