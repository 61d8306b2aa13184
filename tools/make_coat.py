#!/usr/bin/env python3
"""Derives weft's coat pattern (data/patterns/coat/coat.json) from GarmentCode's shirt
(data/patterns/garmentcode/shirt_mean_specification.json): the four torso panels lengthened
below the hem and flared at the side seams, the sleeves lengthened at the cuff. Every stitch
keeps both its sides changed alike, so their lengths still match.

    python3 tools/make_coat.py [--torso CM] [--flare CM] [--sleeve CM]
"""
import argparse
import json
import pathlib

ROOT = pathlib.Path(__file__).resolve().parent.parent
SOURCE = ROOT / "data/patterns/garmentcode/shirt_mean_specification.json"
TARGET = ROOT / "data/patterns/coat/coat.json"


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--torso", type=float, default=58.0, help="cm added below the hem (default 58)")
    parser.add_argument("--flare", type=float, default=0.0, help="cm the hem widens at each side seam (default 0: panels rolled onto one cylinder would overlap at a flared hem)")
    parser.add_argument("--sleeve", type=float, default=12.0, help="cm added at the cuff (default 12: the cuff at the wrist)")
    args = parser.parse_args()
    spec = json.loads(SOURCE.read_text())
    panels = spec["pattern"]["panels"]
    for name, panel in panels.items():
        vertices = panel["vertices"]
        if "torso" in name:
            # The hem's corners lie at y = 0: move them down, and the one on the side seam out.
            side = max(abs(v[0]) for v in vertices)
            for v in vertices:
                if abs(v[1]) < 1e-9:
                    v[1] = -args.torso
                    if abs(abs(v[0]) - side) < 1e-6:
                        v[0] += args.flare if v[0] > 0 else -args.flare
        elif "sleeve" in name:
            # The cuff's corners lie at x = 0; the armhole is at |x| of about 31 cm.
            outward = -1.0 if any(v[0] > 1 for v in vertices) else 1.0
            for v in vertices:
                if abs(v[0]) < 1e-9:
                    v[0] = outward * args.sleeve
    spec["properties"]["derived_by"] = ("weft tools/make_coat.py from GarmentCode's shirt_mean_specification.json: "
                                        f"torso +{args.torso} cm, flare {args.flare} cm, sleeves +{args.sleeve} cm")
    TARGET.parent.mkdir(parents=True, exist_ok=True)
    TARGET.write_text(json.dumps(spec, indent=1) + "\n")
    print(f"wrote {TARGET}")


if __name__ == "__main__":
    main()
