#!/usr/bin/env python3
"""Checks the ctest labels of weft's tests (docs/testing.md, "Fast and slow tests"): every
test of the build folder has exactly one of the labels `fast` and `slow`, and every name in
tests/slow_tests.txt is a test there (a renamed or removed test must leave the list too).

Usage: tools/check_test_labels.py BUILD_DIR   (ctest runs it as the test `test_labels`)
Exit status 0 when the labels are in order, 1 otherwise (each problem on a line of its own).
"""
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    build = sys.argv[1]
    out = subprocess.run(["ctest", "--show-only=json-v1"], cwd=build, stdout=subprocess.PIPE, text=True, check=True)
    tests = json.loads(out.stdout)["tests"]
    problems = []
    names = set()
    for t in tests:
        names.add(t["name"])
        labels = []
        for p in t.get("properties", []):
            if p["name"] == "LABELS":
                labels = p["value"]
        speed = [label for label in labels if label in ("fast", "slow")]
        if len(speed) != 1:
            problems.append(f"{t['name']}: labels {labels}, expected exactly one of fast and slow")
    with open(os.path.join(ROOT, "tests", "slow_tests.txt"), encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            name = line.strip()
            if name and not name.startswith("#") and name not in names:
                problems.append(f"tests/slow_tests.txt:{n}: {name} is not a test of {build}")
    for p in problems:
        print(p)
    print(f"{len(tests)} tests, {len(problems)} problems")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
