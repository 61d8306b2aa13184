#!/usr/bin/env python3
"""weft and Blender's cloth on the same garment scene, timed side by side.

Runs the coat of scenes/walk.json in weft and in Blender's cloth (Debian's `blender`,
headless, tools/blender_cloth.py inside it), both single-threaded and interleaved (weft,
Blender, weft, Blender...), counts the crossings each leaves with `weft check`, and writes
OUT/results.csv and OUT/results.md. Blender's scene is built from weft's own exports: the
cloth's OBJ frames (triangles, start and rest positions) and the body's OBJ frames, played
in Blender as a point cache under a Collision modifier. Two cases:

  standing  the walk's first 0.48 s: the body stands, the coat settles (from frame 0)
  walking   a segment of the walk: weft resumes from a checkpoint taken at the frame after
            --walk-start (1.04 s for 1.0), Blender starts from weft's frame there (with zero
            velocity), both run for 0.48 s

docs/notes/blender.md says how weft's settings map onto Blender's, and what was measured.
Blender is not a dependency of weft's build or tests; this script needs it on PATH (or
--blender), and /usr/bin/python3.

Examples:
  tools/blender_compare.py --out out/blender                       # both cases, Blender at 5:2 and 10:5
  tools/blender_compare.py --out out/blender --no-weft --settings 5:2,10:5,20:10   # Blender only: the sweep
"""

import argparse
import csv
import json
import math
import os
import resource
import shutil
import signal
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SEGMENT = 0.48  # seconds simulated in each case


def die(message, status=2):
    print("blender_compare.py: error: " + message, file=sys.stderr)
    sys.exit(status)


def parse_settings(text, distance):
    """'5:2,10:5:10' -> [(5, 2, 0.004), (10, 5, 0.010)]: Blender's quality (steps per frame),
    collision quality and, optionally, the cloth-body collision distance in mm (else --distance)."""
    out = []
    for item in text.split(","):
        parts = item.strip().split(":")
        try:
            if len(parts) not in (2, 3):
                raise ValueError
            q, c = int(parts[0]), int(parts[1])
            d = float(parts[2]) / 1000.0 if len(parts) == 3 else distance
            if not (1 <= q <= 200 and 1 <= c <= 50 and 0.001 < d <= 0.1):
                raise ValueError
        except (ValueError, IndexError):
            die("--settings: %r is not QUALITY:COLLISION_QUALITY[:DISTANCE_MM] (quality 1-200, collision "
                "quality 1-50, distance above 1 and up to 100 mm)" % item)
        out.append((q, c, d))
    if not out:
        die("--settings is empty")
    return out


def parse_args(argv):
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="Blender runs as `blender --background --factory-startup -t 1 --python tools/blender_cloth.py`; "
        "weft as `weft --threads 1 run ...`. Exit status: 0 done, 2 bad arguments or a missing program, "
        "1 a run failed (its log is named).")
    p.add_argument("--out", required=True, help="output folder (created): the exports, every run's frames, results.csv, results.md")
    p.add_argument("--weft", default=os.path.join(ROOT, "build", "weft"), help="weft binary (default: build/weft)")
    p.add_argument("--blender", default="blender", help="Blender binary (default: blender on PATH)")
    p.add_argument("--scene", default=os.path.join(ROOT, "scenes", "walk.json"), help="weft scene (default: scenes/walk.json)")
    p.add_argument("--cases", default="standing,walking", help="comma-separated: standing, walking (default both)")
    p.add_argument("--settings", default="5:2,10:5",
                   help="Blender settings to run, QUALITY:COLLISION_QUALITY[:DISTANCE_MM],... (steps per frame, "
                   "collision iterations and the cloth-body distance, default --distance; Blender's defaults are 5:2)")
    p.add_argument("--repeats", type=int, default=1, help="rounds of the interleaved runs (default 1)")
    p.add_argument("--walk-start", type=float, default=1.0,
                   help="seconds into the walk where the walking case starts (default 1.0: the body has blended into the walk)")
    p.add_argument("--no-weft", action="store_true", help="run only Blender (after the exports exist): a sweep of --settings")
    p.add_argument("--results", default="results",
                   help="name of the results files in OUT (default results: OUT/results.csv, OUT/results.md)")
    p.add_argument("--distance", type=float, default=0.004,
                   help="Blender's cloth-body collision distance in m, the cloth's distance plus the body's outer "
                   "thickness (default 0.004, weft's body thickness)")
    p.add_argument("--self-distance", type=float, default=0.003,
                   help="Blender's self-collision distance in m (default 0.003, weft's cloth thickness)")
    a = p.parse_args(argv)
    a.cases = [c.strip() for c in a.cases.split(",") if c.strip()]
    for c in a.cases:
        if c not in ("standing", "walking"):
            die("--cases: %r is neither standing nor walking" % c)
    if a.repeats < 1:
        die("--repeats must be at least 1, not %d" % a.repeats)
    if not 0.5 <= a.walk_start <= 3.4:
        die("--walk-start must be in [0.5, 3.4] s (the walk lasts 4 s), not %g" % a.walk_start)
    if not 0.001 < a.distance <= 0.1:
        die("--distance must be in (0.001, 0.1] m, not %g" % a.distance)
    if not 0.0 < a.self_distance <= 0.1:
        die("--self-distance must be in (0, 0.1] m, not %g" % a.self_distance)
    a.settings = parse_settings(a.settings, a.distance)
    blender = shutil.which(a.blender)
    if blender is None:
        die("`%s` not found: install Blender (Debian: apt-get install blender) or name it with --blender" % a.blender)
    a.blender = blender
    if not (os.path.isfile(a.weft) and os.access(a.weft, os.X_OK)):
        die("weft binary %s not found: build it (cmake --build build --target weft) or name it with --weft" % a.weft)
    if not os.path.isfile(a.scene):
        die("scene %s not found" % a.scene)
    return a


def timed(cmd, log_path, env=None):
    """Runs cmd with stdout and stderr to log_path; returns (status, wall s, CPU s of the process)."""
    with open(log_path, "w") as log:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT, env=env)
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return proc.returncode, wall, cpu


def frame_files(folder, prefix):
    d = os.path.join(folder, "frames")
    return sorted(os.path.join(d, f) for f in os.listdir(d) if f.startswith(prefix) and f.endswith(".obj"))


def read_scene(path):
    with open(path) as f:
        scene = json.load(f)
    try:
        interval = scene["frame_interval"]
        material = scene["cloth"]["material"]
    except KeyError as e:
        die("%s: no %s" % (path, e))
    return scene, interval, material


# ---------------------------------------------------------------- exports (weft's own runs)

def weft_standing_cmd(a, out_dir):
    return [a.weft, "--threads", "1", "run", a.scene, "--duration", "%g" % SEGMENT, "--out", out_dir, "-q"]


def walk_frames(a, interval):
    """The frame at --walk-start, and the segment's last frame: SIGINT once the first is
    written stops weft at the next frame boundary, where the segment starts."""
    start = int(math.ceil(a.walk_start / interval - 1e-9))
    return start, start + 1 + int(round(SEGMENT / interval))


def prepare_walking(a, interval):
    """weft up to the checkpoint (interrupted at the frame boundary after --walk-start): OUT/walk-prefix."""
    prefix = os.path.join(a.out, "walk-prefix")
    start, end = walk_frames(a, interval)
    done = os.path.join(prefix, "checkpoint.weft")
    prepared = os.path.join(prefix, "prepared.json")
    if os.path.isfile(done) and os.path.isfile(prepared):
        with open(prepared) as f:
            p = json.load(f)
        if p.get("walk_start", 1.0) != a.walk_start:
            die("%s holds the walk from %g s, not --walk-start %g: remove %s or use another --out" % (
                prefix, p.get("walk_start", 1.0), a.walk_start, prefix))
        return p["checkpoint_frame"]
    # Run to the segment's end, but stop with SIGINT as soon as the frame at --walk-start is
    # written: weft then stops at the next frame boundary and writes its checkpoint there.
    # (The checkpoint's frame is read back; the run's duration, fixed at the start, is the
    # segment's end.)
    print("preparing the walking case: weft up to %.2f s, a checkpoint there (one thread)..." % ((start + 1) * interval),
          flush=True)
    duration = end * interval
    log = open(os.path.join(a.out, "walk-prefix.log"), "w")
    proc = subprocess.Popen([a.weft, "--threads", "1", "run", a.scene, "--duration", "%.6g" % duration,
                             "--out", prefix, "-q"], stdout=log, stderr=subprocess.STDOUT)
    trigger = os.path.join(prefix, "frames", "frame_%05d.obj" % start)
    while proc.poll() is None and not os.path.isfile(trigger):
        time.sleep(0.05)
    # weft looks for the interrupt once a frame is written: half a second later it is into the
    # next frame's steps (several seconds of them), so it stops at the frame after --walk-start
    time.sleep(0.5)
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    status = proc.wait()
    if status != 130 or not os.path.isfile(done):
        die("the walk's prefix run did not stop at a checkpoint (exit status %d): see %s" % (status, log.name), 1)
    checkpoint_frame = len(frame_files(prefix, "frame_")) - 1
    if checkpoint_frame != start + 1:
        print("note: weft stopped at frame %d (%.2f s), not %d: the walking case has %d frames" % (
            checkpoint_frame, checkpoint_frame * interval, start + 1, end - checkpoint_frame), flush=True)
    with open(os.path.join(prefix, "prepared.json"), "w") as f:
        json.dump({"checkpoint_frame": checkpoint_frame, "end_frame": end, "walk_start": a.walk_start}, f)
    return checkpoint_frame


def resume_copy(a, dst):
    """A fresh copy of the walk's checkpoint in dst, to resume from."""
    src = os.path.join(a.out, "walk-prefix")
    if os.path.isdir(dst):
        shutil.rmtree(dst)
    shutil.copytree(src, dst)
    return [a.weft, "--threads", "1", "run", "--resume", dst, "-q"]


# ---------------------------------------------------------------- Blender's settings

def mesh_area(path):
    verts, area = [], 0.0
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                verts.append([float(t) for t in line.split()[1:4]])
            elif line.startswith("f "):
                i, j, k = [verts[int(t.split("/")[0]) - 1] for t in line.split()[1:4]]
                u = [j[d] - i[d] for d in range(3)]
                v = [k[d] - i[d] for d in range(3)]
                c = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
                area += 0.5 * math.sqrt(sum(x * x for x in c))
    return len(verts), area


def mean_edge(path):
    verts, edges = [], set()
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                verts.append([float(t) for t in line.split()[1:4]])
            elif line.startswith("f "):
                idx = [int(t.split("/")[0]) - 1 for t in line.split()[1:4]]
                for m in range(3):
                    e = (min(idx[m], idx[(m + 1) % 3]), max(idx[m], idx[(m + 1) % 3]))
                    edges.add(e)
    return sum(math.dist(verts[i], verts[j]) for i, j in edges) / len(edges)


# The constants the mapping takes from weft's material presets (docs/materials.md, "Estimated
# presets"): density kg/m^2, the tensile tangent at zero strain (N/m, the mean of weft and
# warp, load and unload averaged), the shear tangent (N/m) and the bending rigidity (N m, the
# mean of weft and warp). Blender's springs are linear: they take the tangents at rest.
MATERIALS = {
    "wool": {"density": 0.330, "tensile": 0.5 * (390.0 + 490.0), "shear": 45.0, "bending": 0.5 * (1.8e-5 + 2.2e-5)},
    "cotton": {"density": 0.150, "tensile": 0.5 * (580.0 + 800.0), "shear": 68.0, "bending": 0.5 * (6.9e-6 + 9.8e-6)},
    "denim": {"density": 0.458, "tensile": 0.5 * (670.0 + 880.0), "shear": 101.0, "bending": 0.5 * (5.9e-5 + 9.8e-5)},
}

# Blender's angular bending stiffness per N m of bending rigidity: a cantilever strip of
# right triangles 16 mm on a side (the coat's edge length) sagging under its weight gave
# 3e4 to 1e5 per N m at small deflections (docs/notes/blender.md); a rough middle.
BENDING_PER_RIGIDITY = 5.0e4


def material_constants(material):
    if material not in MATERIALS:
        die("the mapping onto Blender's settings knows the materials %s, not %r (add its constants to "
            "MATERIALS in tools/blender_compare.py from docs/materials.md)" % (", ".join(sorted(MATERIALS)), material))
    return dict(MATERIALS[material], bending_blender=BENDING_PER_RIGIDITY * MATERIALS[material]["bending"])


def blender_settings(distance, self_distance, rest_obj, fps, quality, collision_quality, consts):
    n, area = mesh_area(rest_obj)
    edge = mean_edge(rest_obj)
    # Blender's cloth works in frames of time with gravity scaled by 1/1000: with Speed
    # Multiplier sqrt(1000)/fps a free fall matches 9.81 m/s^2 in seconds, and the vertex
    # mass is then in grams; a spring's force is tension * stretch / (mean spring length).
    # A triangle lattice of springs k has the membrane modulus E = 2k/sqrt(3).
    vertex_mass_g = 1000.0 * consts["density"] * area / n
    k_spring = math.sqrt(3.0) / 2.0 * consts["tensile"]
    tension = k_spring * edge
    shear = math.sqrt(3.0) / 2.0 * consts["shear"] * edge
    cloth = {
        "quality": quality,
        "time_scale": math.sqrt(1000.0) / fps,
        "mass": vertex_mass_g,
        "air_damping": 0.0,
        "tension_stiffness": tension,
        "compression_stiffness": tension,
        "shear_stiffness": shear,
        "bending_stiffness": consts["bending_blender"],
    }
    distance_min = distance - 0.001  # plus the body's outer thickness, 1 mm (Blender's least)
    collision = {
        "use_collision": True,
        "collision_quality": collision_quality,
        "distance_min": distance_min,
        "use_self_collision": True,
        "self_distance_min": self_distance,
    }
    body = {"thickness_outer": 0.001}
    derived = {"vertices": n, "area_m2": round(area, 4), "mean_edge_m": round(edge, 5)}
    return cloth, collision, body, derived


# ---------------------------------------------------------------- the runs

def read_vertices(path):
    with open(path) as f:
        return [tuple(float(t) for t in line.split()[1:4]) for line in f if line.startswith("v ")]


def rms_distance(path_a, path_b):
    """RMS distance (m) between the vertices of two cloth frames of the same mesh."""
    va, vb = read_vertices(path_a), read_vertices(path_b)
    if len(va) != len(vb):
        die("%s and %s hold different meshes (%d and %d vertices)" % (path_a, path_b, len(va), len(vb)), 1)
    return math.sqrt(sum(math.dist(p, q) ** 2 for p, q in zip(va, vb)) / len(va))


def check(a, folder):
    """weft check's counts on a folder of frames: (frames with crossings, worst frame's pairs, total pairs)."""
    proc = subprocess.run([a.weft, "check", folder, "--json", "--examples", "0"], capture_output=True, text=True)
    if proc.returncode not in (0, 5):
        die("weft check %s failed (exit status %d): %s" % (folder, proc.returncode, proc.stderr.strip()), 1)
    r = json.loads(proc.stdout)
    per = [f["cloth_body"] + f["cloth_self"] for f in r["per_frame"]]
    return {"frames_with_crossings": r["frames_with_intersections"], "frames": r["frames"],
            "worst_pairs": max(per), "body_pairs": r["cloth_body_total"], "self_pairs": r["cloth_self_total"]}


def run_weft(a, case, label):
    out_dir = os.path.join(a.out, "weft-%s-%s" % (case["name"], label))
    cmd = resume_copy(a, out_dir) if case["name"] == "walking" else weft_standing_cmd(a, out_dir)
    log = out_dir + ".log"
    status, wall, cpu = timed(cmd, log)
    if status not in (0, 5):  # 5: finished with crossed frames, counted below
        die("weft failed (exit status %d): see %s" % (status, log), 1)
    with open(os.path.join(out_dir, "summary.json")) as f:
        summary = json.load(f)
    counts = summary["intersections"]
    per = counts["per_frame"]
    first = case["first_frame"]
    per = per[first:] if case["name"] == "walking" else per
    body = counts["cloth_body_per_frame"][first:]
    sim_wall = summary["wall_seconds"]
    if case["name"] == "walking":  # a resumed run's wall_seconds go on from the checkpoint's
        with open(os.path.join(a.out, "walk-prefix", "summary.json")) as f:
            sim_wall -= json.load(f)["wall_seconds"]
    return {"wall_s": wall, "cpu_s": cpu, "sim_wall_s": sim_wall,
            "frames_with_crossings": sum(1 for x in per if x), "worst_pairs": max(per) if per else 0,
            "body_pairs": sum(body), "self_pairs": sum(per) - sum(body), "status": summary["status"]}


def run_blender(a, case, quality, collision_quality, distance, label):
    name = "blender-%s-q%d-c%d-d%g-%s" % (case["name"], quality, collision_quality, 1000 * distance, label)
    out_dir = os.path.join(a.out, name)
    if os.path.isdir(out_dir):
        shutil.rmtree(out_dir)
    os.makedirs(os.path.join(out_dir, "frames"))
    cloth, collision, body, derived = blender_settings(distance, a.self_distance, case["rest"], case["fps"], quality,
                                                       collision_quality, case["consts"])
    spec = {"start": case["start"], "rest": case["rest"], "body": case["body"], "fps": case["fps"],
            "frames": case["frames"], "cloth": cloth, "collision": collision, "body_collision": body}
    spec_path = os.path.join(out_dir, "case.json")
    with open(spec_path, "w") as f:
        json.dump(dict(spec, derived=derived), f, indent=1)
    cmd = [a.blender, "--background", "--factory-startup", "-noaudio", "-t", "1",
           "--python", os.path.join(HERE, "blender_cloth.py"), "--", spec_path, out_dir]
    log = out_dir + ".log"
    status, wall, cpu = timed(cmd, log)
    if status != 0 or not os.path.isfile(os.path.join(out_dir, "blender.json")):
        die("Blender failed (exit status %d): see %s" % (status, log), 1)
    with open(os.path.join(out_dir, "blender.json")) as f:
        inner = json.load(f)
    # the body's frames beside the cloth's, numbered from the start, for `weft check`
    for k, path in enumerate(case["body"][:case["frames"] + 1]):
        dst = os.path.join(out_dir, "frames", "body0_%05d.obj" % k)
        try:
            os.link(path, dst)
        except OSError:
            shutil.copyfile(path, dst)
    last = os.path.join(out_dir, "frames", "frame_%05d.obj" % case["frames"])
    rms = rms_distance(last, case["weft_last"])
    counts = check(a, out_dir)  # the body's frames stay: `weft render` and `weft view` open the folder
    return {"wall_s": wall, "cpu_s": cpu, "sim_wall_s": inner["sim_wall_seconds"], "sim_cpu_s": inner["sim_cpu_seconds"],
            "frames_with_crossings": counts["frames_with_crossings"], "worst_pairs": counts["worst_pairs"],
            "body_pairs": counts["body_pairs"], "self_pairs": counts["self_pairs"], "status": "ok",
            "rms_from_weft_cm": round(100 * rms, 2)}


def make_cases(a):
    scene, interval, material = read_scene(a.scene)
    fps = 1.0 / interval
    consts = material_constants(material)
    standing_dir = os.path.join(a.out, "weft-standing-export")
    if not os.path.isfile(os.path.join(standing_dir, "summary.json")):
        print("preparing the standing case: weft's first %.2f s (one thread)..." % SEGMENT, flush=True)
        status, _, _ = timed(weft_standing_cmd(a, standing_dir), standing_dir + ".log")
        if status != 0:
            die("weft failed (exit status %d): see %s.log" % (status, standing_dir), 1)
    rest = frame_files(standing_dir, "frame_")[0]
    frames = int(round(SEGMENT / interval))
    cases = {}
    cases["standing"] = {"name": "standing", "start": rest, "rest": rest, "fps": fps, "frames": frames,
                         "body": frame_files(standing_dir, "body0_"), "first_frame": 0, "consts": consts,
                         "weft_last": frame_files(standing_dir, "frame_")[frames]}
    if "walking" in a.cases:
        first = prepare_walking(a, interval)
        walk_dir = os.path.join(a.out, "weft-walking-export")
        if not os.path.isfile(os.path.join(walk_dir, "summary.json")):
            print("preparing the walking case: weft from the checkpoint to the segment's end...", flush=True)
            status, _, _ = timed(resume_copy(a, walk_dir), walk_dir + ".log")
            if status != 0:
                die("weft failed (exit status %d): see %s.log" % (status, walk_dir), 1)
        cloth = frame_files(walk_dir, "frame_")
        body = frame_files(walk_dir, "body0_")
        cases["walking"] = {"name": "walking", "start": cloth[first], "rest": rest, "fps": fps,
                            "frames": len(cloth) - 1 - first, "body": body[first:], "first_frame": first,
                            "consts": consts, "weft_last": cloth[-1]}
    return [cases[c] for c in a.cases]


def write_results(a, rows):
    path = os.path.join(a.out, a.results + ".csv")
    keys = ["round", "case", "program", "setting", "wall_s", "cpu_s", "sim_wall_s", "sim_cpu_s",
            "frames_with_crossings", "worst_pairs", "body_pairs", "self_pairs", "rms_from_weft_cm", "status"]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: (round(v, 2) if isinstance(v, float) else v) for k, v in r.items()})
    lines = ["| round | case | program | setting | wall (s) | CPU (s) | simulation wall (s) | frames with crossings | worst frame (pairs) | cloth-body / self pairs, all frames | RMS from weft's last frame (cm) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append("| %d | %s | %s | %s | %.1f | %.1f | %.1f | %d of %d | %d | %d / %d | %s |" % (
            r["round"], r["case"], r["program"], r["setting"], r["wall_s"], r["cpu_s"], r["sim_wall_s"],
            r["frames_with_crossings"], r["frames"], r["worst_pairs"], r["body_pairs"], r["self_pairs"],
            r.get("rms_from_weft_cm", "")))
    with open(os.path.join(a.out, a.results + ".md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    return path


def main(argv):
    a = parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    cases = make_cases(a)
    rows = []
    for r in range(1, a.repeats + 1):
        for case in cases:
            order = ([("weft", None)] if not a.no_weft else []) + [("blender", s) for s in a.settings]
            for program, setting in order:
                label = "r%d" % r
                if program == "weft":
                    res = run_weft(a, case, label)
                    res.update(setting="dt 5 ms, --threads 1", sim_cpu_s="")
                else:
                    res = run_blender(a, case, setting[0], setting[1], setting[2], label)
                    res.update(setting="quality %d, collision quality %d, distance %g mm" % (
                        setting[0], setting[1], 1000 * setting[2]))
                res.update(round=r, case=case["name"], program=program, frames=case["frames"] + 1)
                rows.append(res)
                print("%-8s %-7s %-40s wall %7.1f s  CPU %7.1f s  sim %7.1f s  crossings: %d of %d frames (worst %d pairs)" % (
                    case["name"], program, res["setting"], res["wall_s"], res["cpu_s"], res["sim_wall_s"],
                    res["frames_with_crossings"], res["frames"], res["worst_pairs"]), flush=True)
                write_results(a, rows)
    print("wrote %s.csv and %s.md" % (os.path.join(a.out, a.results), a.results))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
