#!/usr/bin/env python3
"""Writes scenes/stacked-sheets.obj: five square sheets of cloth, one OBJ of five separate
pieces, stacked 2 cm apart, each turned a little further about the vertical axis.

Usage: tools/stacked_sheets_obj.py [OUT] [--sheets N] (default scenes/stacked-sheets.obj, five
sheets; `--sheets 2` gives the two sheets of docs/collisions.md, "Layers on a layer a still
collider holds")."""
import argparse
import math

SHEETS = 5
SIZE = 0.6          # m, side of each sheet
VERTICES = 21       # per side
BOTTOM = 0.45       # m, height of the lowest sheet
SPACING = 0.02      # m, between sheets
TURN_DEG = 9.0      # each sheet turned this much more than the one below


def main():
    parser = argparse.ArgumentParser(description="Writes an OBJ of square sheets stacked over each other.")
    parser.add_argument("out", nargs="?", default="scenes/stacked-sheets.obj")
    parser.add_argument("--sheets", type=int, default=SHEETS, help="how many sheets (default 5)")
    args = parser.parse_args()
    if args.sheets < 1:
        parser.error(f"--sheets must be at least 1, got {args.sheets}")
    words = {1: "one", 2: "two", 3: "three", 4: "four", 5: "five"}
    count = words.get(args.sheets, str(args.sheets))
    lines = [f"# weft: {count} stacked sheet{'s' if args.sheets > 1 else ''} (tools/stacked_sheets_obj.py)"]
    faces = []
    n = VERTICES
    for k in range(args.sheets):
        angle = math.radians(TURN_DEG * k)
        c, s = math.cos(angle), math.sin(angle)
        y = BOTTOM + SPACING * k
        base = k * n * n
        for j in range(n):
            for i in range(n):
                u = SIZE * i / (n - 1) - SIZE / 2
                w = SIZE * j / (n - 1) - SIZE / 2
                lines.append(f"v {c * u + s * w:.6f} {y:.6f} {-s * u + c * w:.6f}")
        for j in range(n - 1):
            for i in range(n - 1):
                a = base + j * n + i + 1  # OBJ counts from 1
                b, d, e = a + 1, a + n, a + n + 1
                # Alternating diagonals, wound so the normals point up (+y).
                if (i + j) % 2 == 0:
                    faces += [(a, e, b), (a, d, e)]
                else:
                    faces += [(a, d, b), (b, d, e)]
    lines += [f"f {a} {b} {c}" for a, b, c in faces]
    with open(args.out, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
