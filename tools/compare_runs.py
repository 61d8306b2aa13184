#!/usr/bin/env python3
"""Distance between the cloth trajectories of two `weft run` outputs: the RMS and the
largest vertex distance (m) over all output frames both runs have in common.

    tools/compare_runs.py REFERENCE_DIR RUN_DIR [RUN_DIR ...]

Used to check how far a cheaper setting (a looser solver tolerance, a longer step) moves
the motion, against a reference run of the same scene.
"""
import glob
import math
import os
import sys


def load(run):
    frames = sorted(glob.glob(os.path.join(run, "frames", "frame_*.obj")))
    if not frames:
        sys.exit(f"{run}: no frames/frame_*.obj (run weft without --no-frames)")
    out = []
    for path in frames:
        with open(path) as f:
            out.append([tuple(float(t) for t in line.split()[1:4]) for line in f if line.startswith("v ")])
    return out


def main(reference, runs):
    ref = load(reference)
    for run in runs:
        frames = load(run)
        n = min(len(frames), len(ref))
        total, count, largest = 0.0, 0, 0.0
        for a, b in zip(frames[:n], ref[:n]):
            if len(a) != len(b):
                sys.exit(f"{run}: {len(a)} vertices per frame, {reference} has {len(b)}")
            for p, q in zip(a, b):
                d2 = sum((x - y) ** 2 for x, y in zip(p, q))
                total += d2
                count += 1
                largest = max(largest, d2)
        print(f"{run}: {n} frames, RMS distance {math.sqrt(total / count):.3e} m, "
              f"largest {math.sqrt(largest):.3e} m")


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2:])
