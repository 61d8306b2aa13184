#!/usr/bin/env python3
"""Counts, per time step and damping ratio, in how many seeds a method was unstable, from a
CSV of `weft experiment stability` runs with a leading `seed` column (see
docs/stability-experiment.md). Prints a Markdown table.

usage: tools/stability_seed_table.py SEEDS.csv [METHOD_LABEL]
"""
import csv
import sys
from collections import defaultdict


def main():
    rows = list(csv.DictReader(open(sys.argv[1])))
    method = sys.argv[2] if len(sys.argv) > 2 else rows[0]["method"]
    rows = [r for r in rows if r["method"] == method]
    dts = sorted({float(r["dt"]) for r in rows})
    ratios = sorted({float(r["damping_ratio"]) for r in rows})
    unstable, total, kappa = defaultdict(int), defaultdict(int), {}
    for r in rows:
        key = (float(r["dt"]), float(r["damping_ratio"]))
        total[key] += 1
        unstable[key] += r["stable"] == "0"
        kappa[float(r["dt"])] = float(r["kappa_max"])
    print(f"{method}: unstable in how many seeds\n")
    print("| dt | kappa max | " + " | ".join(f"{100 * z:g}%" for z in ratios) + " |")
    print("| --- | --- |" + " --- |" * len(ratios))
    for dt in dts:
        cells = " | ".join(f"{unstable[(dt, z)]} of {total[(dt, z)]}" for z in ratios)
        print(f"| {1e3 * dt:g} ms | {kappa[dt]:.3g} | {cells} |")


if __name__ == "__main__":
    main()
