#!/usr/bin/env python3
"""Turns the JSON output of build/weft_bench (Google Benchmark, with repetitions) into the
Markdown table of docs/performance.md: medians of time per step and of the counters.

    build/weft_bench --benchmark_filter=Step --benchmark_repetitions=5 \
        --benchmark_format=json > bench.json
    tools/bench_table.py bench.json
"""
import json
import platform
import sys


def main(path):
    with open(path) as f:
        data = json.load(f)
    rows = [b for b in data["benchmarks"] if b.get("aggregate_name") == "median"]
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
    print("| method | vertices | ms/step | CG iterations/step | assembly ms | solve ms | step matrices MB | peak RSS MB |")
    print("|---|---|---|---|---|---|---|---|")
    for b in rows:
        name = b["run_name"].split("/")
        method = name[1] if len(name) > 1 else b["run_name"]
        unit = {"ms": 1.0, "us": 1e-3, "ns": 1e-6, "s": 1e3}[b.get("time_unit", "ns")]
        print(f"| {method} | {int(b['vertices'])} | {b['real_time'] * unit:.3f} | {b['cg_iterations']:.1f} | "
              f"{b['assembly_ms']:.3f} | {b['solve_ms']:.3f} | {b['matrix_MB']:.1f} | {b['peak_rss_MB']:.0f} |")
    # Ratios Implicit Midpoint / backward Euler at equal size, from the same run.
    by = {(b["run_name"].split("/")[1], int(b["vertices"])): b for b in rows if len(b["run_name"].split("/")) > 2}
    sizes = sorted({v for (_, v) in by})
    if any(("ImplicitMidpoint", v) in by and ("BackwardEuler", v) in by for v in sizes):
        print("\n| vertices | time IM / BE | CG iterations IM / BE |")
        print("|---|---|---|")
        for v in sizes:
            im, be = by.get(("ImplicitMidpoint", v)), by.get(("BackwardEuler", v))
            if im and be:
                print(f"| {v} | {im['real_time'] / be['real_time']:.2f} | {im['cg_iterations'] / be['cg_iterations']:.2f} |")


if __name__ == "__main__":
    main(sys.argv[1])
