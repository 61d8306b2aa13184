#!/bin/sh
# Regenerates the contact sheet of docs/garments.md ("Every shipped pattern on the mannequin"):
# runs `weft --threads 1 garment` on every pattern under data/patterns (two at a time; tens of
# minutes on the busy 2-core development machine), draws each garment (garment.obj, or
# garment_unsewn.obj for one that did not sew) on the mannequin in its bind pose with
# `weft render` (a one-step run of the garment as an OBJ cloth, without gravity, drawn at
# frame 0) into docs/img/garments/sheet-NAME.png, and prints the page's table.
# Run from the repository root after building. A pattern whose OUT/NAME/summary.json exists is
# not sewn again (delete it to rerun).
set -e
WEFT=${WEFT:-build/weft}
OUT=${OUT:-out/garment-sheet}
IMG=docs/img/garments
mkdir -p "$OUT"
WEFT=$(realpath "$WEFT")

sew() {
  for f in "$@"; do
    n=$(basename "$f" .json)
    n=${n%_specification}
    [ -f "$OUT/$n/summary.json" ] && continue
    rm -rf "$OUT/$n"
    "$WEFT" --threads 1 garment "$f" --out "$OUT/$n" >"$OUT/$n.log" 2>&1 || true
  done
}
files=$(find data/patterns -name '*.json' | sort)
odd=$(echo "$files" | awk 'NR % 2 == 1')
even=$(echo "$files" | awk 'NR % 2 == 0')
sew $odd &
sew $even
wait

for f in $files; do
  n=$(basename "$f" .json)
  n=${n%_specification}
  obj="$OUT/$n/garment.obj"
  [ -f "$obj" ] || obj="$OUT/$n/garment_unsewn.obj"
  [ -f "$obj" ] || { echo "$n: no garment written (see $OUT/$n.log)" >&2; continue; }
  cat >"$OUT/$n.scene.json" <<EOF
{"weft_scene": 1, "duration": 0.005, "frame_interval": 0.005,
 "integrator": {"method": "backward-euler", "dt": 0.005}, "gravity": [0, 0, 0],
 "cloth": {"mesh": {"obj": "$(realpath "$obj")"}, "material": "cotton", "self_collision": false},
 "colliders": [{"type": "body", "bind_pose_hold": 1.0}]}
EOF
  rm -rf "$OUT/$n.run" "$OUT/$n.img"
  # (exit status 5: the garment as written has intersecting pairs, shown as they are)
  "$WEFT" --threads 1 run "$OUT/$n.scene.json" --out "$OUT/$n.run" -q >"$OUT/$n.run.log" 2>&1 || [ $? -eq 5 ]
  "$WEFT" render "$OUT/$n.run" --out "$OUT/$n.img" --frames 0 --no-caption --size 400x560 --samples 2 >/dev/null
  cp "$OUT/$n.img/frame_00000.png" "$IMG/sheet-$n.png"
done

/usr/bin/python3 - "$OUT" $files <<'PY'
import json, os, sys
out, files = sys.argv[1], sys.argv[2:]
print("| pattern | panels | triangles | sewn | CPU (s) | simulated (s) | largest gap placed (mm) | after sewing (mm) | stitches open | intersections (self, body) |")
print("|---|---|---|---|---|---|---|---|---|---|")
for f in files:
    n = os.path.basename(f)[:-5].removesuffix("_specification")
    s = json.load(open(os.path.join(out, n, "summary.json")))
    w = s["sewing"]
    print(f"| {n} | {len(s['panels'])} | {s['triangles']:,} | {'yes' if w['sewn'] else '**no** (exit 6)'} | "
          f"{w.get('cpu_time_s', float('nan')):.1f} | {w['simulated_time_s']:.2f} | "
          f"{w['largest_seam_gap_placed_m'] * 1e3:.0f} | {w['largest_seam_gap_m'] * 1e3:.2f} | "
          f"{len(w['open_stitches'])} of {len(s['stitches'])} | {w['intersections']['self']}, {w['intersections']['body']} |")
PY
