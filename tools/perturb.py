#!/usr/bin/env python3
"""Runs a scene and copies of it changed by a little, as a `weft sweep`, and tabulates how each
run ended.

A contact scene whose clean run is luck shows it here: moved by a millimetre, the same cloth
should still end `ok` with no intersecting pair (docs/collisions.md, "The body drape under
small changes, and the guarded step"). The variations:

- the cloth's placement moved by --shift metres along +x, -x, +y and +z (scenes whose cloth is
  an OBJ without a placement: the first collider's centre or point moved the other way instead);
- the first collider's friction lowered by 0.01.

The variations are a sweep file, OUT/perturb.json (one named axis, `variation`; for the body
drape examples/perturb.json is the same sweep), run by `weft sweep OUT/perturb.json --out OUT
--workers JOBS` (docs/sweeps.md: Dask, one thread a run; runs already in OUT are kept unless
--fresh). The table, from OUT/results.csv (status, the fail-safes' work and moves, intersecting
pairs, the guard's parts per step, steps halved, wall time), goes to standard output and
OUT/results.md.
The exit status is 1 when any run did not end `ok` with no intersecting pair, 2 when the sweep
was refused.

    tools/perturb.py scenes/body-drape.json --out out/perturb-body-drape --jobs 2
"""
import argparse
import csv
import json
import os
import shutil
import subprocess
import sys


def variations(scene, shift):
    """[(name, what, {key path: value})]: the runs of the sweep, the first the scene as it is."""
    out = [("as-shipped", "nothing changed", {})]
    placement = scene.get("cloth", {}).get("placement")
    colliders = scene.get("colliders", [])
    for axis, name in ((0, "x"), (1, "y"), (2, "z")):
        for sign in ((1, -1) if axis == 0 else (1,)):
            label = f"{'+' if sign > 0 else '-'}{name}"
            if placement is not None:
                t = list(placement.get("translation", [0, 0, 0]))
                t[axis] += sign * shift
                out.append((f"shift{label}", f"the cloth {shift * 1000:g} mm along {label}",
                            {"cloth.placement.translation": t}))
            elif colliders and ("centre" in colliders[0] or "point" in colliders[0]):
                key = "centre" if "centre" in colliders[0] else "point"
                p = list(colliders[0][key])
                p[axis] -= sign * shift
                out.append((f"shift{label}", f"the first collider {shift * 1000:g} mm along "
                            f"{'-' if sign > 0 else '+'}{name}", {f"colliders[0].{key}": p}))
    if colliders and "friction" in colliders[0]:
        friction = round(colliders[0]["friction"] - 0.01, 6)
        out.append(("friction", f"the first collider's friction {friction:g}", {"colliders[0].friction": friction}))
    return out


def number(text, form):
    return "" if text in ("", None) else form(float(text))


def row(what, r):
    status = r["status"] + (f" ({r['error']})" if r["error"] and r["status"] != "ok" else "")
    work = r["fail_safe_work_J"]
    work_text = "" if work == "" else (f"{float(work):,.0f}" if abs(float(work)) >= 100 else f"{float(work):.3g}")
    return (f"| {what} | {status} | {work_text} | {r['fail_safe_moves']} | {r['intersections']} | "
            f"{number(r['guard_parts_per_step'], lambda v: f'{v:.2f}')} | {r['halved_steps']} | "
            f"{number(r['wall_seconds'], lambda v: f'{v:.1f}')} |")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene", help="scene file (JSON)")
    p.add_argument("--out", required=True, help="folder for the sweep file and its runs")
    p.add_argument("--shift", type=float, default=0.001, help="how far to move the cloth, in metres (default 0.001)")
    p.add_argument("--jobs", type=int, default=1, help="runs at a time: the sweep's local workers (default 1)")
    p.add_argument("--weft", default="build/weft", help="the weft binary (default build/weft)")
    p.add_argument("--duration", type=float, help="simulated seconds of every run (default: the scene's)")
    p.add_argument("--method", help="the integrator of every run, a scene's integrator.method (default: the scene's)")
    p.add_argument("--alpha", type=float, help="the implicitness for --method alpha, bdf2-alpha or bdf2-alpha-guarded")
    p.add_argument("--fresh", action="store_true", help="run every variation again (default: the runs of an earlier "
                                                         "sweep into OUT with the same scene are kept)")
    a = p.parse_args()
    if not os.path.isfile(a.weft):
        sys.exit(f"perturb.py: no weft binary at {a.weft} (build first, or give --weft)")
    try:
        with open(a.scene) as f:
            scene = json.load(f)
    except (OSError, ValueError) as e:
        sys.exit(f"perturb.py: {a.scene}: {e}")
    todo = variations(scene, a.shift)
    fixed = {k: v for k, v in (("duration", a.duration), ("integrator.method", a.method),
                                ("integrator.alpha", a.alpha)) if v is not None}
    spec = {"weft_sweep": 1, "description": f"tools/perturb.py: {a.scene} and copies moved by {a.shift:g} m or with "
                                            "the first collider's friction lowered by 0.01",
            "scene": os.path.abspath(a.scene), "set": fixed,
            "vary": {"variation": {"named": {name: settings for name, _, settings in todo}}}}
    if a.fresh:
        shutil.rmtree(os.path.join(a.out, "runs"), ignore_errors=True)
    os.makedirs(a.out, exist_ok=True)
    sweep_file = os.path.join(a.out, "perturb.json")
    with open(sweep_file, "w") as f:
        json.dump(spec, f, indent=1)
        f.write("\n")
    proc = subprocess.run([a.weft, "sweep", sweep_file, "--out", a.out, "--workers", str(max(1, a.jobs)), "--quiet"])
    if proc.returncode not in (0, 7):  # 7: some run did not end ok, each has its row
        sys.exit(proc.returncode)
    with open(os.path.join(a.out, "results.csv")) as f:
        rows = {r["variation"]: r for r in csv.DictReader(f)}
    method = f", --method {a.method}" if a.method else ""
    method += f" --alpha {a.alpha:g}" if a.alpha is not None else ""
    lines = [f"{a.scene}{method}, one thread each, {a.jobs} at a time (weft sweep, {a.out}/results.csv):", "",
             "| variation | status | fail-safes' work (J) | fail-safe moves | intersecting pairs | guard parts per step "
             "| steps halved | wall (s) |",
             "|---|---|---|---|---|---|---|---|"]
    lines += [row(what, rows[name]) for name, what, _ in todo]
    text = "\n".join(lines) + "\n"
    with open(os.path.join(a.out, "results.md"), "w") as f:
        f.write(text)
    print(text, end="")
    sys.exit(0 if all(r["clear"] == "True" for r in rows.values()) else 1)


if __name__ == "__main__":
    main()
