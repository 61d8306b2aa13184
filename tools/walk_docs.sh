#!/bin/sh
# Regenerates the full-walk comparison of docs/walk.md: runs `weft experiment walk` on
# scenes/walk.json (all seven configurations, one thread; about 30 minutes on the 2-core
# development machine), then puts its table between the page's walk-table markers and its
# pictures in docs/img/walk/: Implicit Midpoint at 5 ms beside backward Euler at 2 ms at 1.6 s
# and 3.2 s and as a video of the whole walk (`weft render --beside --follow`), and the
# liveliness plot.
# Run from the repository root after building. An OUT that already holds results.md is not
# run again (delete it to rerun).
set -e
WEFT=${WEFT:-build/weft}
OUT=${OUT:-out/walk-experiment}
IMG=docs/img/walk
if [ ! -f "$OUT/results.md" ]; then
  $WEFT --threads 1 experiment walk -q --scene scenes/walk.json --out "$OUT"
fi
$WEFT render "$OUT/im-5ms" --beside "$OUT/be-2ms" --labels "implicit midpoint 5 ms,backward euler 2 ms" \
  --frames 40,80 --size 640x720 --follow --out "$OUT/side-by-side"
cp "$OUT/side-by-side/frame_00040.png" "$IMG/coat-im5-vs-be2-1.6s.png"
cp "$OUT/side-by-side/frame_00080.png" "$IMG/coat-im5-vs-be2-3.2s.png"
cp "$OUT/liveliness.png" "$IMG/coat-liveliness.png"
$WEFT render "$OUT/im-5ms" --beside "$OUT/be-2ms" --labels "implicit midpoint 5 ms,backward euler 2 ms" \
  --video --size 480x540 --samples 2 --follow --out "$OUT/side-by-side-video"
cp "$OUT/side-by-side-video/render.mp4" "$IMG/coat-im5-vs-be2.mp4"
python3 - "$OUT/results.md" docs/walk.md <<'PY'
import sys
results, page = sys.argv[1], sys.argv[2]
lines = open(results).read().splitlines()
table = []
for line in lines:
    if line.startswith("|"):
        table.append(line)
    elif table:
        break
notes = [l for l in lines if ": unstable at " in l or ": failed" in l]
block = "\n".join(table) + "\n" + ("\n" + "\n\n".join(notes) + "\n" if notes else "")
text = open(page).read()
begin, end = "<!-- walk-table begin -->\n", "<!-- walk-table end -->"
a, b = text.index(begin) + len(begin), text.index(end)
open(page + ".tmp", "w").write(text[:a] + block + text[b:])
import os
os.replace(page + ".tmp", page)
PY
echo "docs/walk.md's table and $IMG/coat-*.png regenerated from $OUT"
