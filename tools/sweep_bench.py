#!/usr/bin/python3
"""Measures `weft sweep` (docs/sweeps.md, "Throughput"): the perturbation sweep
(examples/perturb.json, shortened to --duration simulated seconds) on local clusters of one and
two workers, and the driver's cost per run from sweeps of 1 and --tiny runs of 0.02 s of the
swing, less the time those runs take on their workers. Prints a Markdown table, with each
sweep's CPU time (its processes' and their children's, user + system) and the load average
before and after it: on a busy machine the CPU time says what the wall time cannot.

Each speed-up is split in two factors: how busy the sweep kept its workers (the runs' time on
the workers over the wall time: at most 1 for one worker, 2 for two; the driver's and Dask's
share), and how much longer each run took with two at once (the machine's: two processes
sharing caches, memory bandwidth, or cores that other work holds). speed-up = (busy with 2 /
busy with 1) / (runs' time with 2 / runs' time with 1).

    tools/sweep_bench.py --weft build/weft --out out/sweep-bench
"""
import argparse
import csv
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def cpu_seconds():
    """User + system seconds of this process's finished children (and theirs)."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def load():
    return "/".join(f"{x:.1f}" for x in os.getloadavg())


def machine():
    try:
        with open("/proc/cpuinfo") as f:
            name = next((l.split(":", 1)[1].strip() for l in f if l.startswith("model name")), "?")
    except OSError:
        name = "?"
    return f"{os.cpu_count()} cores, {name}"


def sweep(weft, spec, out, workers):
    """Runs a fresh sweep; returns (wall seconds, rows, CPU seconds, load averages before -> after)."""
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    path = os.path.join(out + ".json")
    with open(path, "w") as f:
        json.dump(spec, f)
    before, cpu = load(), cpu_seconds()
    start = time.monotonic()
    subprocess.run([weft, "sweep", path, "--out", out, "--workers", str(workers), "--quiet"], check=True,
                   stderr=subprocess.DEVNULL)
    wall = time.monotonic() - start
    with open(os.path.join(out, "results.csv")) as f:
        return wall, list(csv.DictReader(f)), cpu_seconds() - cpu, f"{before} -> {load()}"


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--weft", default=os.path.join(ROOT, "build", "weft"))
    p.add_argument("--out", default=os.path.join(ROOT, "out", "sweep-bench"))
    p.add_argument("--duration", type=float, default=0.4, help="simulated seconds of each perturbation run")
    p.add_argument("--tiny", type=int, default=100, help="runs of the overhead sweep")
    p.add_argument("--repeats", type=int, default=1, help="pairs of one- and two-worker sweeps (default 1)")
    a = p.parse_args()
    weft = os.path.abspath(a.weft)
    os.makedirs(a.out, exist_ok=True)
    with open(os.path.join(ROOT, "examples", "perturb.json")) as f:
        perturb = json.load(f)
    perturb["scene"] = os.path.join(ROOT, "scenes", "body-drape.json")
    perturb["set"] = {"duration": a.duration}
    lines = [f"{machine()}; load averages (1/5/15 min) before -> after each sweep", "",
             "| measure | value |", "|---|---|"]
    walls, busy, run_times = {}, {}, {}
    ratios, busy_ratios = [], []
    for repeat in range(a.repeats):  # one and two workers alternately, each pair a speed-up
        for workers in (1, 2):
            wall, rows, cpu, loads = sweep(weft, perturb, os.path.join(a.out, f"perturb-{workers}"), workers)
            assert all(r["status"] == "ok" for r in rows), rows
            walls[workers] = wall
            runs = sum(float(r["run_seconds"]) for r in rows)
            busy[workers], run_times[workers] = runs / wall, runs
            lines.append(f"| perturbation sweep ({len(rows)} runs of {a.duration:g} s), {workers} worker(s) | {wall:.1f} "
                         f"s wall, {len(rows) / wall * 3600:.0f} runs/hour; runs on the workers {runs:.1f} s in all "
                         f"(workers busy {busy[workers]:.2f} of {workers}); CPU {cpu:.1f} s; load {loads} |")
        ratios.append(walls[1] / walls[2])
        busy_ratios.append(busy[2] / busy[1])
        lines.append(f"| speed-up, 2 workers over 1 | {ratios[-1]:.2f} = {busy_ratios[-1]:.2f} (workers kept busy) / "
                     f"{run_times[2] / run_times[1]:.2f} (each run's time with two at once) |")
    if a.repeats > 1:
        lines.append(f"| median speed-up of {a.repeats} | {statistics.median(ratios):.2f}; workers kept busy "
                     f"{statistics.median(busy_ratios):.2f} times as much |")
    # The same runs one after another without Dask, as `weft --threads 1 run` of each run's scene.
    runs_dir = os.path.join(a.out, "perturb-1", "runs")
    before, cpu = load(), cpu_seconds()
    start = time.monotonic()
    for run_id in sorted(os.listdir(runs_dir)):
        proc = subprocess.run([weft, "--threads", "1", "run", "-q", "--no-frames",
                               os.path.join(runs_dir, run_id, "scene.json"), "--out", os.path.join(a.out, "sequential", run_id)])
        if proc.returncode not in (0, 5):  # 5: finished with crossed frames, as the sweep's row says
            sys.exit(f"sweep_bench.py: weft run of {run_id} failed (exit status {proc.returncode})")
    sequential = time.monotonic() - start
    lines.append(f"| the same runs one after another, no Dask | {sequential:.1f} s; 2 workers "
                 f"{sequential / walls[2]:.2f} times as fast; CPU {cpu_seconds() - cpu:.1f} s; load {before} -> {load()} |")
    swing = os.path.join(ROOT, "scenes", "swing.json")
    timing = {}
    for n in (1, a.tiny):
        spec = {"weft_sweep": 1, "scene": swing, "set": {"duration": 0.02},
                "vary": {"cloth.material.viscosity": [k * 1e-6 for k in range(n)]}}
        wall, rows, _, _ = sweep(weft, spec, os.path.join(a.out, f"tiny-{n}"), 1)
        timing[n] = (wall, sum(float(r["run_seconds"]) for r in rows))
    (w1, r1), (wn, rn) = timing[1], timing[a.tiny]
    per_run = ((wn - w1) - (rn - r1)) / (a.tiny - 1)
    lines.append(f"| sweep of 1 tiny run (cluster start and stop included) | {w1:.2f} s |")
    lines.append(f"| sweep of {a.tiny} tiny runs, 1 worker | {wn:.2f} s; on the worker {rn / a.tiny * 1e3:.1f} ms a run "
                 f"(weft run's process, its folder, its outputs read) |")
    lines.append(f"| the driver's and Dask's cost per run beyond the worker's | {per_run * 1e3:.1f} ms |")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
