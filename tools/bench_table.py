#!/usr/bin/env python3
"""Turns the JSON output of build-native/weft_bench (Google Benchmark, with repetitions) into the
Markdown table of docs/performance.md: medians of time per step and of the counters.

    build-native/weft_bench --benchmark_filter=Step --benchmark_repetitions=5 \
        --benchmark_format=json > bench.json
    tools/bench_table.py bench.json
"""
import json
import platform
import sys


def main(path):
    with open(path) as f:
        data = json.load(f)
    # The Step benchmarks only (a file from `make bench` also holds the solver and
    # skinning benchmarks).
    step_rows = [b for b in data["benchmarks"]
                 if b.get("aggregate_name") == "median" and b.get("run_name", "").startswith("Step/")]
    # The tables below are of one thread; the default configuration on two has its own.
    rows = [b for b in step_rows if int(b.get("threads", 1)) == 1]
    two = {(b["run_name"].split("/")[1], int(b["vertices"])): b for b in step_rows if int(b.get("threads", 1)) == 2}
    ctx = data["context"]
    cpu = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    print(f"Machine: {cpu}, {ctx.get('num_cpus')} CPUs, {platform.system()} {platform.release()}; "
          f"run {ctx.get('date')}; one thread; medians of {rows[0].get('repetitions', '?') if rows else '?'} repetitions.\n")
    print("| method | vertices | preconditioner | CG tolerance | ms/step | CG iterations/step | assembly ms "
          "| solve ms | step matrix MB | heap MB | peak RSS MB |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")

    names = {0: "block-Jacobi", 1: "multigrid", 2: "SSOR", 3: "SSOR (double)"}

    def key(b):
        return (b["run_name"].split("/")[1], int(b["vertices"]), int(b.get("preconditioner", 0)),
                float(f"{float(b.get('tolerance', 1e-6)):.0e}"))

    rows.sort(key=lambda b: (key(b)[0] != "ImplicitMidpoint", -key(b)[3], key(b)[1], key(b)[2]))
    for b in rows:
        method, vertices, mg, tol = key(b)
        unit = {"ms": 1.0, "us": 1e-3, "ns": 1e-6, "s": 1e3}[b.get("time_unit", "ns")]
        heap = f"{b['heap_MB']:.1f}" if "heap_MB" in b else "-"
        print(f"| {method} | {vertices} | {names[mg]} | {tol:.0e} | "
              f"{b['real_time'] * unit:.3f} | {b['cg_iterations']:.1f} | "
              f"{b['assembly_ms']:.3f} | {b['solve_ms']:.3f} | {b['matrix_MB']:.1f} | {heap} | "
              f"{b['peak_rss_MB']:.0f} |")
    by = {key(b): b for b in rows}
    sizes = sorted({k[1] for k in by})
    # Ratios from the same run: Implicit Midpoint / backward Euler, and each preconditioner
    # against block-Jacobi and SSOR against multigrid.
    print("\n| vertices | preconditioner | time IM / BE | CG iterations IM / BE |")
    print("|---|---|---|---|")
    for v in sizes:
        for pc in (0, 1, 2):
            im, be = by.get(("ImplicitMidpoint", v, pc, 1e-6)), by.get(("BackwardEuler", v, pc, 1e-6))
            if im and be:
                print(f"| {v} | {names[pc]} | {im['real_time'] / be['real_time']:.2f} | "
                      f"{im['cg_iterations'] / be['cg_iterations']:.2f} |")
    print("\n| vertices | method | CG tolerance | time multigrid / block-Jacobi | time SSOR / block-Jacobi "
          "| time SSOR / multigrid |")
    print("|---|---|---|---|---|---|")
    for method in ("ImplicitMidpoint", "BackwardEuler"):
        for tol in (1e-6, 1e-4):
            for v in sizes:
                bj, mg, ss = (by.get((method, v, pc, tol)) for pc in (0, 1, 2))
                if bj and mg and ss:
                    print(f"| {v} | {method} | {tol:.0e} | {mg['real_time'] / bj['real_time']:.2f} | "
                          f"{ss['real_time'] / bj['real_time']:.2f} | {ss['real_time'] / mg['real_time']:.2f} |")

    print("\n| vertices | time SSOR single / double precision | CG iterations single / double |")
    print("|---|---|---|")
    for v in sizes:
        sp, dp = by.get(("ImplicitMidpoint", v, 2, 1e-6)), by.get(("ImplicitMidpoint", v, 3, 1e-6))
        if sp and dp:
            print(f"| {v} | {sp['real_time'] / dp['real_time']:.2f} | "
                  f"{sp['cg_iterations'] / dp['cg_iterations']:.2f} |")

    if two:
        print("\n| method | vertices | ms/step, 1 thread | ms/step, 2 threads | 2 / 1 | assembly ms, 1 / 2 threads "
              "| solve ms, 1 / 2 threads |")
        print("|---|---|---|---|---|---|---|")
        for (method, v), b2 in sorted(two.items(), key=lambda kv: (kv[0][0] != "ImplicitMidpoint", kv[0][1])):
            b1 = by.get((method, v, 2, 1e-6))
            if not b1:
                continue
            print(f"| {method} | {v} | {b1['real_time']:.3f} | {b2['real_time']:.3f} | "
                  f"{b2['real_time'] / b1['real_time']:.2f} | {b1['assembly_ms']:.3f} / {b2['assembly_ms']:.3f} | "
                  f"{b1['solve_ms']:.3f} / {b2['solve_ms']:.3f} |")


if __name__ == "__main__":
    main(sys.argv[1])
