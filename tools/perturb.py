#!/usr/bin/env python3
"""Runs a scene and copies of it changed by a little, and tabulates how each run ended.

A contact scene whose clean run is luck shows it here: moved by a millimetre, the same cloth
should still end `ok` with no intersecting pair (docs/collisions.md, "The body drape under
small changes, and the guarded step"). The variations:

- the cloth's placement moved by --shift metres along +x, -x, +y and +z (scenes whose cloth is
  an OBJ without a placement: the first collider's centre or point moved instead);
- the first collider's friction lowered by 0.01.

Each variation is written to OUT/NAME.json (file paths made absolute) and run with
`weft --threads 1 run -q --no-frames` into OUT/NAME/ (for --duration seconds and under
--method if given), --jobs at a time; the table goes to standard output and OUT/results.md. The exit status is 1
when any run did not end `ok`.

    tools/perturb.py scenes/body-drape.json --out out/perturb-body-drape --jobs 2
"""
import argparse
import copy
import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor


def absolutize(value, base):
    """Relative paths of files that exist next to the scene, made absolute."""
    if isinstance(value, dict):
        return {k: absolutize(v, base) for k, v in value.items()}
    if isinstance(value, list):
        return [absolutize(v, base) for v in value]
    if isinstance(value, str) and not os.path.isabs(value) and os.path.exists(os.path.join(base, value)):
        return os.path.abspath(os.path.join(base, value))
    return value


def variations(scene, shift):
    out = [("as-shipped", "nothing changed", scene)]
    placement = scene.get("cloth", {}).get("placement")
    colliders = scene.get("colliders", [])
    for axis, name in ((0, "x"), (1, "y"), (2, "z")):
        for sign in ((1, -1) if axis == 0 else (1,)):
            v = copy.deepcopy(scene)
            label = f"{'+' if sign > 0 else '-'}{name}"
            if placement is not None:
                t = v["cloth"]["placement"].setdefault("translation", [0, 0, 0])
                t[axis] += sign * shift
                what = f"the cloth {shift * 1000:g} mm along {label}"
            elif colliders and ("centre" in colliders[0] or "point" in colliders[0]):
                key = "centre" if "centre" in colliders[0] else "point"
                v["colliders"][0][key][axis] -= sign * shift
                what = f"the first collider {shift * 1000:g} mm along {'-' if sign > 0 else '+'}{name}"
            else:
                continue
            out.append((f"shift{label}", what, v))
    if colliders and "friction" in colliders[0]:
        v = copy.deepcopy(scene)
        v["colliders"][0]["friction"] = round(colliders[0]["friction"] - 0.01, 6)
        out.append(("friction", f"the first collider's friction {v['colliders'][0]['friction']:g}", v))
    return out


def run(weft, out, name, duration, method, alpha):
    folder = os.path.join(out, name)
    command = [weft, "--threads", "1", "run", "-q", "--no-frames", os.path.join(out, name + ".json"), "--out", folder]
    if duration is not None:
        command += ["--duration", str(duration)]
    if method is not None:
        command += ["--method", method]
    if alpha is not None:
        command += ["--alpha", str(alpha)]
    # A summary an earlier run left there must not stand for this one (a run refused as bad
    # input writes nothing).
    try:
        os.remove(os.path.join(folder, "summary.json"))
    except FileNotFoundError:
        pass
    proc = subprocess.run(command, capture_output=True, text=True)
    if proc.returncode not in (0, 3):  # ok, unstable: both write their summary
        return {"status": f"failed (exit {proc.returncode}): {proc.stderr.strip()[:200]}"}
    try:
        with open(os.path.join(folder, "summary.json")) as f:
            s = json.load(f)
    except (OSError, ValueError):
        return {"status": f"failed (exit {proc.returncode}): {proc.stderr.strip()[:200]}"}
    return s


def row(what, s):
    status = s.get("status", "?")
    if status == "unstable":
        status = f"unstable at {s.get('unstable_time', 0):.2f} s"
    if "contacts" not in s:
        return f"| {what} | {status} | | | | | |"
    inter = s.get("intersections", {})
    pairs = inter.get("total") if isinstance(inter, dict) else inter
    parts = (s.get("guard") or {}).get("parts_per_step")
    work = s["contacts"].get("fail_safe_work_J", 0)
    work_text = f"{work:,.0f}" if abs(work) >= 100 else f"{work:.3g}"
    parts_text = "" if parts is None else f"{parts:.2f}"
    halved = s["contacts"].get("halved_steps", 0)
    return f"| {what} | {status} | {work_text} | {pairs} | {parts_text} | {halved} | {s.get('wall_seconds', 0):.1f} |"


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene", help="scene file (JSON)")
    p.add_argument("--out", required=True, help="folder for the variations and their runs")
    p.add_argument("--shift", type=float, default=0.001, help="how far to move the cloth, in metres (default 0.001)")
    p.add_argument("--jobs", type=int, default=1, help="runs at a time (default 1)")
    p.add_argument("--weft", default="build/weft", help="the weft binary (default build/weft)")
    p.add_argument("--duration", type=float, help="simulated seconds of every run (default: the scene's)")
    p.add_argument("--method", help="the integrator of every run, as weft run's --method (default: the scene's)")
    p.add_argument("--alpha", type=float, help="the implicitness for --method alpha, bdf2-alpha or bdf2-alpha-guarded")
    a = p.parse_args()
    if not os.path.isfile(a.weft):
        sys.exit(f"perturb.py: no weft binary at {a.weft} (build first, or give --weft)")
    try:
        with open(a.scene) as f:
            scene = json.load(f)
    except (OSError, ValueError) as e:
        sys.exit(f"perturb.py: {a.scene}: {e}")
    scene = absolutize(scene, os.path.dirname(os.path.abspath(a.scene)))
    os.makedirs(a.out, exist_ok=True)
    todo = variations(scene, a.shift)
    for name, _, v in todo:
        with open(os.path.join(a.out, name + ".json"), "w") as f:
            json.dump(v, f, indent=1)
    with ThreadPoolExecutor(max_workers=max(1, a.jobs)) as pool:
        results = list(pool.map(lambda t: run(a.weft, a.out, t[0], a.duration, a.method, a.alpha), todo))
    method = f", --method {a.method}" if a.method else ""
    method += f" --alpha {a.alpha:g}" if a.alpha is not None else ""
    lines = [f"{a.scene}{method}, one thread each, {a.jobs} at a time:", "",
             "| variation | status | fail-safes' work (J) | intersecting pairs | guard parts per step | steps halved | wall (s) |",
             "|---|---|---|---|---|---|---|"]
    lines += [row(what, s) for (_, what, _), s in zip(todo, results)]
    text = "\n".join(lines) + "\n"
    with open(os.path.join(a.out, "results.md"), "w") as f:
        f.write(text)
    print(text, end="")
    bad = sum(1 for s in results if s.get("status") != "ok")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
