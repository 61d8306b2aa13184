#!/usr/bin/env python3
"""Writes docs/results.md from the outputs of `weft experiment energy`, `weft experiment
convergence` and `weft run` (tools/results.sh), and copies their figures to docs/img/results/. Every number in the page comes
from those outputs; none is typed in here. Python standard library only.

Run from the repository root after the experiments (see the commands in the page it writes):
  python3 tools/results_md.py --energy out/energy --convergence out/convergence \
      --convergence-exact out/convergence-drum [--out docs/results.md] [--img docs/img/results]
"""
import argparse
import csv
import json
import math
import os
import shutil
import subprocess

# What the paper reports (Volino & Magnenat-Thalmann 2005, section 4 and figures 8-10) and what
# docs/method.md 2 derives; these are the claims the page checks, not results.
PAPER_SPEED = {"implicit_midpoint_s": 21, "backward_euler_s": 29}
PAPER_BDF2 = {"bdf2_s": 30, "bdf2_alpha_s": 25}
PAPER_RK45 = {"damped_s": 170, "undamped_s": 420}
EXPECTED_ORDER_NOTE = {
    "forward-euler": "1",
    "backward-euler": "1",
    "implicit-midpoint": "2",
    "bdf2": "2",
    "bdf2-alpha": "paper: 3; [method.md](method.md) 2: 2",
    "rk4": "4",
}


def read_json(path):
    with open(path) as f:
        return json.load(f)


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def g(x, digits=3):
    """A number with `digits` significant digits."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "n/a"
    return "%.*g" % (digits, x)


def lscpu_model():
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return None
    for line in out.splitlines():
        if line.startswith("Model name:"):
            return line.split(":", 1)[1].strip()
    return None


def os_name():
    try:
        with open("/etc/os-release") as f:
            for line in f:
                if line.startswith("PRETTY_NAME="):
                    return line.split("=", 1)[1].strip().strip('"')
    except OSError:
        pass
    return "unknown"


def energy_at(rows, t):
    """The energy row nearest to time t (s), or None past the end of the run."""
    if not rows or float(rows[-1]["time"]) < t - 1e-9:
        return None
    return min(rows, key=lambda r: abs(float(r["time"]) - t))


def dissipated(row):
    return float(row["viscous_dissipated"]) + float(row["numerical_dissipated"])


def table(header, rows):
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


SVG_LIMIT_BYTES = 100_000  # larger SVGs stay in the experiment's output folder


def copy_figures(src_dir, names, img_dir, prefix):
    copied = []
    for name in names:
        for ext in ("png", "svg"):
            src = os.path.join(src_dir, name + "." + ext)
            if os.path.exists(src) and (ext == "png" or os.path.getsize(src) <= SVG_LIMIT_BYTES):
                dst = os.path.join(img_dir, prefix + name + "." + ext)
                shutil.copyfile(src, dst)
                copied.append(dst)
    return copied


def local_slopes(points):
    """Slopes between consecutive stable points (dt decreasing), as 'dt_a->dt_b: s'."""
    out = []
    for a, b in zip(points, points[1:]):
        if a["status"] == "ok" and b["status"] == "ok" and a["error"] and b["error"]:
            s = math.log(a["error"] / b["error"]) / math.log(a["dt"] / b["dt"])
            out.append((a["dt"], b["dt"], s))
    return out


ORDER_TOLERANCE = 0.25  # as in tests/experiments: three points over a factor 4 in dt


def orders_verdict(exact_rows, swing_rows):
    """Compares measured slopes with docs/method.md 2's orders (expected_order in the outputs)."""
    def off(rows):
        return [label for label, s in rows.items()
                if s["slope"] is None or abs(s["slope"] - s["expected_order"]) > ORDER_TOLERANCE]
    parts = []
    bad = off(exact_rows)
    parts.append("drum: every slope within %s of [method.md](method.md) 2" % ORDER_TOLERANCE if not bad
                 else "drum: off for " + ", ".join(bad))
    if "bdf2-alpha" in exact_rows:
        parts.append("alpha = 1/sqrt(3) measures %s (paper: 3)" % g(exact_rows["bdf2-alpha"]["slope"], 2))
    bad = off(swing_rows)
    parts.append("swing: every slope as expected" if not bad
                 else "swing: lower than expected for " + ", ".join(bad) + " as dt goes to 0 (see notes)")
    return "; ".join(parts)


def convergence_rows(study):
    return {s["label"]: s for s in study["series"]}


def scene_path(energy):
    return os.path.relpath(energy["scene"]) if energy["scene"].startswith("/") else energy["scene"]


def load_energy(folder):
    energy = read_json(os.path.join(folder, "results.json"))
    runs = {r["label"]: r for r in energy["runs"]}
    rows = {label: read_csv(os.path.join(folder, label, "energy.csv")) for label in runs}
    return energy, runs, rows


def newton_max(energy):
    return max(r.get("newton_iterations", 0) for r in energy["runs"])


def status_text(r):
    return "stable" if r["status"] == "ok" else "unstable at t = %s s" % g(r.get("unstable_time"))


def energy_claims(energy, runs, rows):
    """The paper's claims as measured by one `weft experiment energy` run: key -> (claim, measured, verdict)."""
    im, be = runs["implicit-midpoint-damped"], runs["backward-euler"]
    bdf2, bdfa = runs["bdf2"], runs["bdf2-alpha-damped"]
    rkd, rku = runs["rk45-damped"], runs["rk45"]
    duration = energy["duration"]
    dt_ms = 1e3 * energy["dt"]
    zeta_pct = 100 * energy["damping_ratio"]
    times = sorted({1.0, 2.0, duration})
    c = {}
    d = {t: (energy_at(rows[im["label"]], t), energy_at(rows[be["label"]], t), energy_at(rows[rkd["label"]], t))
         for t in times}
    diss = "; ".join("t = %g s: IM %s J, BE %s J, RK45 %g%% %s J" % (
        t, g(dissipated(a)) if a else "n/a", g(dissipated(b)) if b else "n/a", zeta_pct, g(dissipated(r)) if r else "n/a")
        for t, (a, b, r) in d.items())
    shown = [(t, a, b) for t, (a, b, _) in d.items() if a and b]
    if not shown:
        verdict = "not measurable: Implicit Midpoint %s" % status_text(im)
    else:
        holds = all(dissipated(a) < dissipated(b) for _, a, b in shown) and len(shown) == len(times)
        verdict = (("less at every time shown" if holds else "NOT less at every time shown") +
                   "; IM / BE: " + ", ".join("%s at %g s" % (g(dissipated(a) / dissipated(b), 2), t)
                                             for t, a, b in shown if dissipated(b) > 0))
    c["dissipation"] = ("Implicit Midpoint with 5% adaptive damping dissipates far less energy than undamped "
                        "backward Euler at dt = 20 ms (fig. 9)",
                        "total dissipated (viscous + numerical): " + diss, verdict)
    sp = energy.get("speed")
    paper_ratio = g(PAPER_SPEED["implicit_midpoint_s"] / PAPER_SPEED["backward_euler_s"], 2)
    claim = "Implicit Midpoint is faster than backward Euler at the same dt: %d s vs %d s (ratio %s)" % (
        PAPER_SPEED["implicit_midpoint_s"], PAPER_SPEED["backward_euler_s"], paper_ratio)
    if im["status"] != "ok":
        c["speed"] = (claim, "Implicit Midpoint stops at t = %s s" % g(im.get("unstable_time")),
                      "not measurable")
    elif sp:
        c["speed"] = (claim, "median of %d interleaved repeats: %s s vs %s s wall (ratio %s); CG iterations per "
                      "step %s vs %s (ratio %s)" % (
                          sp["repeats"], g(sp["implicit_midpoint"]["wall_seconds_median"]),
                          g(sp["backward_euler"]["wall_seconds_median"]), g(sp["wall_ratio_midpoint_over_backward_euler"]),
                          g(sp["implicit_midpoint"]["cg_iterations_per_step_median"]),
                          g(sp["backward_euler"]["cg_iterations_per_step_median"]),
                          g(sp["cg_ratio_midpoint_over_backward_euler"])),
                      ("faster" if sp["wall_ratio_midpoint_over_backward_euler"] < 1 else "NOT faster") +
                      (" (but %d runs were unstable)" % sp["unstable_runs"] if sp.get("unstable_runs") else ""))
    else:
        c["speed"] = (claim, "one run each: %s s vs %s s wall (ratio %s); CG iterations per step %s vs %s" % (
            g(im["wall_seconds"]), g(be["wall_seconds"]), g(im["wall_seconds"] / be["wall_seconds"]),
            g(im["cg_iterations_per_step"]), g(be["cg_iterations_per_step"])),
            "faster" if im["wall_seconds"] < be["wall_seconds"] else "NOT faster")
    claim = "BDF-2 undamped %d s vs alpha = 1/sqrt(3) damped %d s (ratio %s)" % (
        PAPER_BDF2["bdf2_s"], PAPER_BDF2["bdf2_alpha_s"], g(PAPER_BDF2["bdf2_alpha_s"] / PAPER_BDF2["bdf2_s"], 2))
    if bdfa["status"] != "ok" or bdf2["status"] != "ok":
        c["bdf2"] = (claim, "BDF-2 %s, alpha = 1/sqrt(3) %s" % (status_text(bdf2), status_text(bdfa)), "not measurable")
    else:
        c["bdf2"] = (claim, "one run each: %s s vs %s s wall (ratio %s); CG iterations per step %s vs %s (ratio %s)" % (
            g(bdf2["wall_seconds"]), g(bdfa["wall_seconds"]), g(bdfa["wall_seconds"] / bdf2["wall_seconds"]),
            g(bdf2["cg_iterations_per_step"]), g(bdfa["cg_iterations_per_step"]),
            g(bdfa["cg_iterations_per_step"] / bdf2["cg_iterations_per_step"])),
            "fewer CG iterations per step" if bdfa["cg_iterations_per_step"] < bdf2["cg_iterations_per_step"]
            else "NOT fewer CG iterations per step")
    c["rk45"] = ("Adaptive RK5 reference: %d s damped vs %d s undamped (ratio %s)" % (
        PAPER_RK45["damped_s"], PAPER_RK45["undamped_s"], g(PAPER_RK45["damped_s"] / PAPER_RK45["undamped_s"], 2)),
        "RK45 (tolerance %s) over %g s: %d steps, %s s damped; %d steps, %s s undamped (ratio %s)" % (
            g(energy["rk45_tolerance"]), duration, rkd["steps"], g(rkd["wall_seconds"]), rku["steps"],
            g(rku["wall_seconds"]), g(rkd["wall_seconds"] / rku["wall_seconds"])),
        "damped is cheaper" if rkd["wall_seconds"] < rku["wall_seconds"] else "damped is NOT cheaper")
    c["kappa"] = ("Element stiffness factors kappa roughly 20 to 200 at dt = 20 ms, depending on the deformation "
                  "(section 3.1)",
                  "backward Euler: %s to %s (median %s); Implicit Midpoint %g%%: %s to %s" % (
                      g(be["kappa"]["min"]), g(be["kappa"]["max"]), g(be["kappa"]["median"]), zeta_pct,
                      g(im["kappa"]["min"]), g(im["kappa"]["max"])),
                  "within the paper's range" if be["kappa"]["max"] <= 400 else
                  "far beyond the paper's range (the largest at the largest strains)")
    c["stable"] = ("%g%% damping suffices to keep Implicit Midpoint stable (fig. 5, 9)" % zeta_pct,
                   "dt = %g ms: Implicit Midpoint %g%% %s; BDF-2 alpha = 1/sqrt(3) %g%% %s; backward Euler %s; "
                   "BDF-2 %s" % (dt_ms, zeta_pct, status_text(im), zeta_pct, status_text(bdfa), status_text(be),
                                 status_text(bdf2)),
                   "stable here" if im["status"] == "ok" else "does NOT hold")
    created = []
    for label, r in runs.items():
        ec = r.get("energy_created")
        if ec:
            created.append("%s %s / %s J" % (label, g(ec["largest_J"], 2), g(ec["total_J"], 2)))
    c["created"] = ("(not a claim of the paper) Energy the integrator created: the largest fall of the numerical "
                    "dissipation over one frame / the sum of its falls",
                    "; ".join(created) + " (until a run stopped)",
                    "see \"Energy created\" below")
    return c


def energy_table(runs, rows, times, duration, newton=False):
    """Per configuration: status, cost, kappa, dissipation at `times` and the energy created."""
    header = ["configuration", "status", "steps", "wall (s)", "CG / step"]
    if newton:
        header += ["Newton iterations / step", "steps above the Newton tolerance"]
    header += ["kappa min..max"]
    header += ["dissipated at %g s (J)" % t for t in times]
    header += ["numerical part at %g s (J)" % duration, "energy created: largest over a frame / total (J)"]
    er = []
    for label, r in runs.items():
        row = [label, "ok" if r["status"] == "ok" else status_text(r),
               r["steps"], g(r["wall_seconds"]), g(r["cg_iterations_per_step"])]
        if newton:
            nw = r.get("newton")
            row += [g(nw["iterations_per_step"]) if nw else "-", nw["unconverged_steps"] if nw else "-"]
        row.append("%s..%s" % (g(r["kappa"]["min"]), g(r["kappa"]["max"])))
        for t in times:
            e = energy_at(rows[label], t)
            row.append(g(dissipated(e)) if e else "n/a")
        last = energy_at(rows[label], duration)
        row.append(g(float(last["numerical_dissipated"])) if last else "n/a")
        ec = r.get("energy_created")
        row.append("%s / %s" % (g(ec["largest_J"], 2), g(ec["total_J"], 2)) if ec else "n/a")
        er.append(row)
    return table(header, er)


def injection_text(inj, name):
    """What the injection analysis found, in words, from its summary in results.json."""
    if not inj:
        return ""
    top = inj["top_triangles"]
    share = inj["membranes_in_those_steps_J"] / inj["created_total_J"] if inj["created_total_J"] > 0 else float("nan")
    lines = ["%s: %s over %s steps (%s, until t = %s s) created %s J in the steps that created energy; the membrane "
             "triangles' terms add up to %s of it in those steps, %s of the %s triangles created energy on balance "
             "over the run, and the top tenth of them hold %s of that creation." % (
                 name, inj["label"], inj["steps"], inj["status"], g(inj["time_reached"]), g(inj["created_total_J"], 2),
                 percent(share), inj["triangles_with_net_creation"], inj["triangles"],
                 percent(inj["top_tenth_share_of_creation"]))]
    if top:
        rows = []
        for tt in top[:5]:
            rows.append([tt["triangle"], "(%s, %s)" % (g(tt["centroid_uv"][0], 2), g(tt["centroid_uv"][1], 2)),
                         g(tt["net_J"], 2), g(tt["largest_step_J"], 2), g(tt["time_of_largest"]),
                         ", ".join(g(x, 2) for x in tt["strain_at_largest"]),
                         ", ".join(g(x, 2) for x in tt["strain_change_at_largest"]),
                         g(tt["turn_deg_at_largest"], 2), g(tt["max_strain"], 2)])
        lines.append(table(["triangle", "centroid u, v (m)", "net created (J)", "largest step (J)", "at t (s)",
                            "strain e_uu, e_vv, e_uv then", "its change in that step", "normal turned (deg)",
                            "largest strain in the run"], rows))
    return "\n\n".join(lines)


def paper_section(md, args, paper, runs, rows, newton, newton_runs, newton_rows):
    duration = paper["duration"]
    times = sorted({1.0, 2.0, duration})
    md.append("## The paper's own swing test\n")
    md.append("Scene `%s` (section 3.1 and figures 6-10 of the paper): a 50 cm square of the soft jersey of its "
              "figure 7 (`data/materials/jersey.json`, 100 g/m^2, shear half of tensile) attached along one edge, "
              "%g s at dt = %g ms, 1250 triangles. The scene's description and the material's `source` say what "
              "had to be guessed (the mesh, the start of the curve below 5%% strain, the strain measure, the "
              "bending rigidity). Every configuration as in the swing's energy section, with one linearisation "
              "per step (the paper's equations):\n" % (scene_path(paper), duration, 1e3 * paper["dt"]))
    md.append("![energies per method, the paper's swing test](img/results/paper-energy.png)\n")
    md.append(energy_table(runs, rows, times, duration) + "\n")
    if newton:
        md.append("### Stiffening fabric: Newton iterations within the step\n")
        md.append("The paper evaluates the Jacobian \"on the fly\" to follow the fabric's nonlinearity (its "
                  "section 3, citing its authors' 2001 comparison of integration methods); weft's step linearises "
                  "the forces once, at the step's start ([method.md](method.md) 1-2). On a curve that stiffens a hundredfold "
                  "between rest and 40%% strain, the start's tangent can let an element stretch far along the curve "
                  "within one step; the next step then meets a force hundreds of times larger. With "
                  "`integrator.newton_iterations` (or `--newton N`) each step re-linearises where it ends up (the "
                  "forces and the step matrix at x + alpha dx) and solves for a correction, with a backtracking "
                  "line search on the residual of the step's equations, until that residual is below "
                  "`newton_tolerance` (1e-3) of the step's change of velocity. The same configurations with at most "
                  "%s iterations per step:\n" % newton_max(newton))
        md.append("![energies per method with Newton iterations](img/results/paper-newton-energy.png)\n")
        md.append(energy_table(newton_runs, newton_rows, times, duration, newton=True) + "\n")
    if args.flat:
        flat_rows = []
        for name in sorted(os.listdir(args.flat)):
            f = os.path.join(args.flat, name, "summary.json")
            if not os.path.exists(f):
                continue
            s = read_json(f)
            nw = s.get("newton")
            flat_rows.append([s.get("method", name), nw["max_iterations"] if nw else 0,
                              "ok" if s["status"] == "ok" else "unstable at t = %s s" % g(s.get("unstable_time")),
                              g(s["wall_seconds"]), s["solver_iterations_total"],
                              g(nw["iterations_per_step"]) if nw else "-",
                              "%s..%s" % (g(s["kappa"]["min"]), g(s["kappa"]["max"]))])
        if flat_rows:
            md.append("The other reading of figure 7, a cubic that is flat at zero strain "
                      "(`scenes/paper-swing-flat.json`), at dt = 20 ms:\n")
            md.append(table(["method", "Newton iterations at most", "status", "wall (s)", "CG iterations",
                             "Newton iterations / step", "kappa min..max"], flat_rows) + "\n")
    if args.paper_guarded and os.path.exists(os.path.join(args.paper_guarded, "summary.json")):
        s = read_json(os.path.join(args.paper_guarded, "summary.json"))
        erows = read_csv(os.path.join(args.paper_guarded, "energy.csv"))
        falls = [float(a["numerical_dissipated"]) - float(b["numerical_dissipated"]) for a, b in zip(erows, erows[1:])]
        falls = [f for f in falls if f > 0]
        gd = s.get("guard", {})
        md.append("The guarded Implicit Midpoint ([guarded-midpoint.md](guarded-midpoint.md); `implicit-midpoint`, "
                  "%g%% damping, one linearisation per step) on the same scene: %s, %s s wall, %s parts per step "
                  "on average, alpha up to %s on %s of the steps; energy created: largest over a frame %s J, "
                  "total %s J; dissipated at %g s: %s J.\n" % (
                      100 * s["damping_ratio"],
                      "ok" if s["status"] == "ok" else "unstable at t = %s s" % g(s.get("unstable_time")),
                      g(s["wall_seconds"]), g(gd.get("parts_per_step")), g(gd.get("max_alpha")),
                      percent(gd.get("raised_fraction", 0.0)), g(max(falls) if falls else 0.0, 2), g(sum(falls), 2),
                      float(erows[-1]["time"]), g(dissipated(erows[-1]))))
    md.append("### Energy created: where and why\n")
    md.append("`energy created` is the energy no force put in: the falls of the numerical dissipation ([method.md](method.md) 6) "
              "from one output frame to the next, largest and summed. To see where it comes from, "
              "`weft experiment energy` steps Implicit Midpoint (damped) once more and splits each step's energy "
              "balance among the triangles: a triangle's term is its elastic energy change plus the work of the "
              "forces the step applied to it, E(x1) - E(x0) + f_step . dx (include/weft/experiments/energy_injection.hpp "
              "derives why these terms, less (alpha - 1/2) dv^T M dv, add up to the energy the step created). A "
              "linear element's term is exactly zero at alpha = 1/2; the terms come from the stiffening curve and "
              "from the elements' turning within the step, which the start's Jacobian does not follow.\n")
    md.append("![where Implicit Midpoint creates energy](img/results/paper-injection.png)\n")
    md.append(injection_text(paper.get("energy_injection"), "One linearisation per step") + "\n")
    findings = paper_findings(runs, newton_runs, paper.get("energy_injection"), args.flat, 1e3 * paper["dt"])
    if findings:
        md.append("What this shows:\n")
        md.append("\n".join("- " + f for f in findings) + "\n")
    if newton and newton.get("energy_injection"):
        md.append("![where Implicit Midpoint creates energy, with Newton iterations](img/results/paper-newton-injection.png)\n")
        md.append(injection_text(newton.get("energy_injection"), "With Newton iterations") + "\n")


MODES = ("weft (e_uu)", "warp (e_vv)", "shear (e_uv)")


def percent(x):
    return "n/a" if x is None or not math.isfinite(x) else "%s%%" % g(100 * x, 3)


def span(values):
    lo, hi = g(min(values), 2), g(max(values), 2)
    return lo if lo == hi else "%s to %s" % (lo, hi)


def paper_findings(runs, newton_runs, inj, flat_dir, dt_ms):
    """Sentences, every number from the outputs, on what the paper's test shows."""
    out = []
    be, im = runs["backward-euler"], runs["implicit-midpoint-damped"]
    out.append("**Stiffness factors.** Backward Euler's elements reach kappa %s to %s (median %s) at dt = %g ms, "
               "against the paper's \"roughly from 20 to 200\": on this reading of figure 7 the swing stretches "
               "elements to strains where the jersey's tangent is tens to hundreds of times its value at rest. "
               "Either the paper's curve is stiffer near zero than the figure shows, or its cloth stayed within a "
               "few percent of strain; the figure alone does not say which." % (
                   g(be["kappa"]["min"]), g(be["kappa"]["max"]), g(be["kappa"]["median"]), dt_ms))
    if im["status"] != "ok":
        text = ("**Implicit Midpoint with 5%% damping does not survive the paper's own test here**: it stops at "
                "t = %s s with one linearisation per step" % g(im.get("unstable_time")))
        if newton_runs:
            imn = newton_runs["implicit-midpoint-damped"]
            text += (", and at t = %s s with the step's equations solved by Newton iterations (%s iterations per "
                     "step, %s steps above the tolerance)" % (
                         g(imn.get("unstable_time")) if imn["status"] != "ok" else "(the end)",
                         g(imn["newton"]["iterations_per_step"]) if imn.get("newton") else "n/a",
                         imn["newton"]["unconverged_steps"] if imn.get("newton") else "n/a"))
        text += (": the linearisation is not what fails. The midpoint rule itself puts energy in on a stiffening "
                 "curve once kappa is far past the paper's range (its energy error per step grows with the third "
                 "derivative of the energy along the step, that is with the cube of the step's stretch, and 5% of "
                 "critical damping is no match for it). "
                 "Backward Euler and BDF-2 stay stable; the guarded midpoint (above) is weft's answer.")
        out.append(text)
    if inj and inj.get("top_triangles"):
        top = inj["top_triangles"][:10]
        modes = [max(range(3), key=lambda k: abs(tt["strain_change_at_largest"][k])) for tt in top]
        dominant = max(set(modes), key=modes.count)
        vs = [tt["centroid_uv"][1] for tt in top]
        jumps = [abs(tt["strain_change_at_largest"][dominant]) for tt in top]
        turns = [tt["turn_deg_at_largest"] for tt in top]
        out.append("**Where the energy comes from.** In the steps that created energy the membrane terms account for "
                   "%s of it. The ten triangles that created the most lie %s m from the attached edge; in "
                   "%d of them the deformation that changed most in their worst step is %s, by %s to %s of strain "
                   "in one 20 ms step, while the triangle turned %s to %s degrees: each step carries these "
                   "elements from the soft start of the curve far up its stiff part, and the forces the step applies "
                   "(the start's tangent, or the midpoint's) do not follow the energy the element stores." % (
                       percent(inj["membranes_in_those_steps_J"] / inj["created_total_J"]) if inj["created_total_J"] else "n/a",
                       span(vs), modes.count(dominant), MODES[dominant], g(min(jumps), 2),
                       g(max(jumps), 2), g(min(turns), 2), g(max(turns), 2)))
    if newton_runs:
        ben = newton_runs["backward-euler"]
        if be["status"] == "ok" and ben["status"] == "ok":
            out.append("**What Newton iterations cost and change.** Backward Euler with at most %s iterations per "
                       "step: %s s wall against %s s (ratio %s), %s CG iterations per step against %s, %s Newton "
                       "iterations per step on average; it dissipates %s J by %g s against %s J, and its kappa "
                       "stays within %s..%s against %s..%s." % (
                           newton_max_runs(newton_runs), g(ben["wall_seconds"]), g(be["wall_seconds"]),
                           g(ben["wall_seconds"] / be["wall_seconds"], 2), g(ben["cg_iterations_per_step"]),
                           g(be["cg_iterations_per_step"]),
                           g(ben["newton"]["iterations_per_step"]) if ben.get("newton") else "n/a",
                           g(ben["dissipated_final"]["total"]), ben["time_final"], g(be["dissipated_final"]["total"]),
                           g(ben["kappa"]["min"]), g(ben["kappa"]["max"]), g(be["kappa"]["min"]), g(be["kappa"]["max"])))
        b, bn = runs["bdf2"], newton_runs["bdf2"]
        if b["status"] == "ok" and bn["status"] == "ok":
            out.append("BDF-2 with Newton iterations: %s s wall against %s s, %s Newton iterations per step (%s steps "
                       "above the tolerance after 4), kappa up to %s against %s, and it dissipates %s J by %g s "
                       "against %s J: %s of the linearised BDF-2 step's dissipation on this fabric is its "
                       "linearisation's." % (
                           g(bn["wall_seconds"]), g(b["wall_seconds"]),
                           g(bn["newton"]["iterations_per_step"]) if bn.get("newton") else "n/a",
                           bn["newton"]["unconverged_steps"] if bn.get("newton") else "n/a",
                           g(bn["kappa"]["max"]), g(b["kappa"]["max"]), g(bn["dissipated_final"]["total"]),
                           bn["time_final"], g(b["dissipated_final"]["total"]),
                           percent(1 - bn["dissipated_final"]["total"] / b["dissipated_final"]["total"])))
    if flat_dir and os.path.isdir(flat_dir):
        res = {}
        for name in os.listdir(flat_dir):
            f = os.path.join(flat_dir, name, "summary.json")
            if os.path.exists(f):
                res[name] = read_json(f)
        lin, nw = res.get("backward-euler-newton0"), res.get("backward-euler-newton4")
        if lin and nw:
            out.append("**The flat-started curve.** On `scenes/paper-swing-flat.json` backward Euler with one "
                       "linearisation per step is %s (kappa up to %s); with at most 4 Newton iterations per step "
                       "it is %s, kappa up to %s, at %s s wall." % (
                           "unstable at t = %s s" % g(lin.get("unstable_time")) if lin["status"] != "ok" else "stable",
                           g(lin["kappa"]["max"]), "stable to the end" if nw["status"] == "ok" else
                           "unstable at t = %s s" % g(nw.get("unstable_time")), g(nw["kappa"]["max"]),
                           g(nw["wall_seconds"])))
        if newton_runs:
            stable_with = {k for k, r in newton_runs.items() if r["status"] == "ok"}
            stable_without = {k for k, r in runs.items() if r["status"] == "ok"}
            if stable_with <= stable_without:
                out.append("Newton iterations stay off by default (`integrator.newton_iterations` 0): on "
                           "`scenes/paper-swing.json` every configuration that is stable with them is stable without "
                           "them, and cheaper; the flat-started curve needs them for backward Euler.")
            else:
                out.append("On `scenes/paper-swing.json` Newton iterations make %s stable; they stay off by default "
                           "(`integrator.newton_iterations` 0) for the other scenes' sake." % ", ".join(
                               sorted(stable_with - stable_without)))
    return out


def newton_max_runs(runs):
    return max(r.get("newton_iterations", 0) for r in runs.values())


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--energy", required=True, help="output folder of `weft experiment energy`")
    ap.add_argument("--convergence", required=True, help="output folder of `weft experiment convergence` (swing)")
    ap.add_argument("--convergence-exact", required=True,
                    help="output folder of `weft experiment convergence --scene scenes/drum.json`")
    ap.add_argument("--energy-stiff", default="",
                    help="output folder of `weft experiment energy --scene scenes/swing-21x21.json` (optional)")
    ap.add_argument("--energy-paper", default="",
                    help="output folder of `weft experiment energy --scene scenes/paper-swing.json` (optional)")
    ap.add_argument("--energy-paper-newton", default="",
                    help="the same with --newton N (optional)")
    ap.add_argument("--flat", default="",
                    help="folder of `weft run` outputs (summary.json) of scenes/paper-swing-flat.json, one "
                         "folder a run (optional)")
    ap.add_argument("--paper-guarded", default="",
                    help="output folder of `weft run scenes/paper-swing.json --method implicit-midpoint` (optional)")
    ap.add_argument("--out", default="docs/results.md")
    ap.add_argument("--img", default="docs/img/results")
    ap.add_argument("--commands", default="", help="file with the commands that produced the outputs")
    args = ap.parse_args()

    energy = read_json(os.path.join(args.energy, "results.json"))
    conv = read_json(os.path.join(args.convergence, "convergence.json"))
    exact = read_json(os.path.join(args.convergence_exact, "convergence.json"))
    runs = {r["label"]: r for r in energy["runs"]}
    rows = {label: read_csv(os.path.join(args.energy, label, "energy.csv")) for label in runs}
    os.makedirs(args.img, exist_ok=True)
    copy_figures(args.energy, ["energy", "rms"], args.img, "")
    copy_figures(args.convergence, ["convergence"], args.img, "swing-")
    copy_figures(args.convergence_exact, ["convergence"], args.img, "drum-")
    if args.energy_stiff:
        copy_figures(args.energy_stiff, ["energy"], args.img, "stiff-")
    if args.energy_paper:
        copy_figures(args.energy_paper, ["energy"], args.img, "paper-")
        copy_figures(os.path.join(args.energy_paper, "injection"), ["injection"], args.img, "paper-")
    if args.energy_paper_newton:
        copy_figures(args.energy_paper_newton, ["energy"], args.img, "paper-newton-")
        copy_figures(os.path.join(args.energy_paper_newton, "injection"), ["injection"], args.img, "paper-newton-")

    im, rkd = runs["implicit-midpoint-damped"], runs["rk45-damped"]
    duration = energy["duration"]
    dt_ms = 1e3 * energy["dt"]
    zeta_pct = 100 * energy["damping_ratio"]
    times = sorted({1.0, 2.0, duration})

    md = []
    md.append("# Results: the paper's accuracy and speed comparisons\n")
    md.append("Generated by `tools/results_md.py` from the outputs of `weft experiment energy`, "
              "`weft experiment convergence` and `weft run`; every number below comes from those runs. "
              "Rerun the commands at the end of this page to regenerate it.\n")
    machine = energy.get("machine", {})
    md.append("Machine: %s (%s logical cores; `lscpu` model name: %s), %s. weft %s. "
              "Wall times are from a shared machine and vary from run to run; CG iterations per step "
              "and step counts are deterministic.\n" % (
                  machine.get("cpu_model", "unknown"), machine.get("logical_cores", "?"),
                  lscpu_model() or "unavailable", os_name(), energy.get("weft_version", "?")))

    sp = energy.get("speed")
    # Claims: one column per scene.
    md.append("## Claims in the paper and what weft measures\n")
    scenes = [("`%s`" % scene_path(energy), energy_claims(energy, runs, rows))]
    paper = paper_rows = paper_runs = None
    if args.energy_paper:
        paper, paper_runs, paper_rows = load_energy(args.energy_paper)
        scenes.append(("`%s`" % scene_path(paper), energy_claims(paper, paper_runs, paper_rows)))
    newton = newton_runs = newton_rows = None
    if args.energy_paper_newton:
        newton, newton_runs, newton_rows = load_energy(args.energy_paper_newton)
        scenes.append(("`%s` with %s Newton iterations at most" % (scene_path(newton), newton_max(newton)),
                       energy_claims(newton, newton_runs, newton_rows)))
    stiff = read_json(os.path.join(args.energy_stiff, "results.json")) if args.energy_stiff else None
    if stiff:
        sr = {r["label"]: r for r in stiff["runs"]}

        def state(r):
            return "stable" if r["status"] == "ok" else "unstable at t = %s s" % g(r.get("unstable_time"))
        scenes[0][1]["stable_stiff"] = (
            "(same claim, stiffer cloth)",
            "`%s` at dt = %g ms, element kappa %s to %s: Implicit Midpoint %g%% %s; BDF-2 alpha = 1/sqrt(3) "
            "%g%% %s; backward Euler %s; BDF-2 %s" % (
                scene_path(stiff), 1e3 * stiff["dt"], g(sr["implicit-midpoint-damped"]["kappa"]["min"]),
                g(sr["backward-euler"]["kappa"]["max"]), 100 * stiff["damping_ratio"],
                state(sr["implicit-midpoint-damped"]), 100 * stiff["damping_ratio"],
                state(sr["bdf2-alpha-damped"]), state(sr["backward-euler"]), state(sr["bdf2"])),
            "does not hold beyond the paper's kappa range" if sr["implicit-midpoint-damped"]["status"] != "ok"
            else "holds here too")
    ex_rows, sw_rows = convergence_rows(exact), convergence_rows(conv)
    orders = "; ".join("%s %s" % (label, g(ex_rows[label]["slope"])) for label in EXPECTED_ORDER_NOTE if label in ex_rows)
    scenes[0][1]["orders"] = (
        "Orders: FE 1, BE 1, IM 2, BDF-2 2, RK4 4; BDF-2 at alpha = 1/sqrt(3) third order",
        "slopes on the drum (exact Jacobian): " + orders + "; on the swing (projected Jacobian), "
        "finest steps: " + "; ".join("%s %s" % (label, g(sw_rows[label]["slope"]))
                                     for label in EXPECTED_ORDER_NOTE if label in sw_rows),
        orders_verdict(ex_rows, sw_rows))
    keys = []
    for _, claims in scenes:
        keys += [k for k in claims if k not in keys]
    ct = []
    for k in keys:
        text = next(c[k][0] for _, c in scenes if k in c)
        row = [text]
        for _, claims in scenes:
            row.append("%s: **%s**" % (claims[k][1], claims[k][2]) if k in claims else "(not run)")
        ct.append(row)
    md.append(table(["claim in the paper"] + [name for name, _ in scenes], ct) + "\n")
    md.append("Each cell gives what weft measures on that scene, then the verdict in bold. Times are wall "
              "seconds of one run on this machine (the paper's are from a 2 GHz Pentium 4 and a different mesh "
              "and code, so only their ratios compare).\n")

    # Energy.
    md.append("## Energy (the paper's figures 9 and 10)\n")
    md.append("Scene `%s`: %g s, frames every %g s, fixed-step methods at dt = %g ms; damped configurations "
              "use %g%% of critical damping (adaptive, [method.md](method.md) 4), compared with the RK45 reference of the "
              "same damping. Potential energy is gravitational, relative to the start.\n" % (
                  os.path.relpath(energy["scene"]) if energy["scene"].startswith("/") else energy["scene"],
                  duration, energy["frame_interval"], dt_ms, zeta_pct))
    md.append("![energies per method](img/results/energy.png)\n")
    md.append(energy_table(runs, rows, times, duration) + "\n")
    if args.energy_stiff:
        md.append("The same configurations on the stiffer cloth (see the claims table); an unstable run's panel "
                  "ends where it was stopped:\n")
        md.append("![energies per method, stiffer cloth](img/results/stiff-energy.png)\n")
    md.append("Initial mechanical energy is zero by construction (gravity is measured from the start); "
              "the cloth can release up to about %s J of potential energy (the lowest potential reached by "
              "the damped reference).\n" % g(-min(float(r["gravity"]) for r in rows[rkd["label"]])))

    # Accuracy.
    md.append("## Motion accuracy\n")
    md.append("RMS distance of every vertex from the RK45 run with the same damping, per frame (figure) and "
              "over the run (table).\n")
    md.append("![RMS distance from the reference](img/results/rms.png)\n")
    ar = []
    for label, r in runs.items():
        if not r.get("reference"):
            continue
        ar.append([label, r["reference"], g(r["rms_distance_over_run"]), g(r["rms_distance_max"]),
                   g(r["rms_distance_final"])])
    ar.sort(key=lambda x: float(x[2]))
    md.append(table(["configuration (best first)", "reference", "RMS over run (m)", "largest (m)", "final (m)"], ar) + "\n")

    # Speed.
    if sp:
        md.append("## Speed side by side\n")
        md.append("Implicit Midpoint (%g%% damping) and backward Euler (undamped) at dt = %g ms, run alternately "
                  "%d times each (which goes first alternates), medians:\n" % (zeta_pct, dt_ms, sp["repeats"]))
        md.append(table(["", "wall (s), each repeat", "median wall (s)", "CG iterations / step"], [
            ["implicit-midpoint-damped", ", ".join(g(x) for x in sp["implicit_midpoint"]["wall_seconds"]),
             g(sp["implicit_midpoint"]["wall_seconds_median"]), g(sp["implicit_midpoint"]["cg_iterations_per_step_median"])],
            ["backward-euler", ", ".join(g(x) for x in sp["backward_euler"]["wall_seconds"]),
             g(sp["backward_euler"]["wall_seconds_median"]), g(sp["backward_euler"]["cg_iterations_per_step_median"])],
            ["ratio IM / BE", "", g(sp["wall_ratio_midpoint_over_backward_euler"]),
             g(sp["cg_ratio_midpoint_over_backward_euler"])]]) + "\n")
        md.append("The wall-time ratio is closer to 1 than the CG ratio because evaluating forces, Jacobians "
                  "and adaptive damping costs the same per step for both.\n")
        parts = []
        for label in ("implicit-midpoint-damped", "backward-euler"):
            f = os.path.join(args.energy, label, "summary.json")
            if os.path.exists(f):
                s = read_json(f)
                self_s = s.get("contacts", {}).get("self", {}).get("seconds")
                if self_s is not None:
                    parts.append("%s %s s of %s s" % (label, g(self_s), g(s["wall_seconds"])))
        if parts:
            md.append("So does self-collision, on in this scene: its detection and response took %s of wall time "
                      "(each configuration's `summary.json`, `contacts.self.seconds`), though the swinging square "
                      "never reaches itself.\n" % "; ".join(parts))

    # The paper's own test.
    if paper:
        paper_section(md, args, paper, paper_runs, paper_rows, newton, newton_runs, newton_rows)

    # Convergence.
    md.append("## Orders of accuracy\n")
    for name, study, fig in (("drum", exact, "drum-convergence"), ("swing", conv, "swing-convergence")):
        ref = study["reference"]
        md.append("### %s: `%s`\n" % (name, os.path.relpath(study["scene"]) if study["scene"].startswith("/") else study["scene"]))
        md.append("Error: RMS vertex distance at t = %g s from RK45 (tolerance %s, %d steps, estimated error %s m), "
                  "damping ratio %g for every method (the same ODE for all), CG tolerance %s. Slope: least squares "
                  "over the finest %d stable points above 100x the reference's error.\n" % (
                      study["time"], g(ref["tolerance"]), ref["steps"], g(ref["error_estimate"]), study["damping_ratio"],
                      g(study["cg_tolerance"]), study["fit_points"]))
        md.append("![convergence, %s](img/results/%s.png)\n" % (name, fig))
        cr = []
        for s in study["series"]:
            pts = s["points"]
            stable = [p for p in pts if p["status"] == "ok"]
            ls = local_slopes(pts)
            cr.append([s["label"], EXPECTED_ORDER_NOTE.get(s["label"], g(s["expected_order"])), g(s["slope"]),
                       "%s..%s ms" % (g(1e3 * min(p["dt"] for p in pts if p["in_fit"])), g(1e3 * max(p["dt"] for p in pts if p["in_fit"])))
                       if any(p["in_fit"] for p in pts) else "n/a",
                       "%s..%s ms" % (g(1e3 * min(p["dt"] for p in stable)), g(1e3 * max(p["dt"] for p in stable))) if stable else "none",
                       ", ".join(g(x[2], 2) for x in ls)])
        md.append(table(["method", "expected", "measured slope", "fitted dt", "stable dt",
                         "local slopes, coarse to fine"], cr) + "\n")

    # Notes.
    md.append("## Notes\n")
    swing_im = sw_rows.get("implicit-midpoint", {})
    md.append("- **Linearised second-order methods and the definite Jacobian.** weft makes each element's Hessian "
              "positive semi-definite before assembly ([method.md](method.md) 1: compressed or sheared membranes are projected). "
              "The linearised alpha-family and BDF-2 steps are second order only with the exact Jacobian; with the "
              "projected one they keep an O(dt) error term. On the drum nothing is projected and the slopes are the "
              "theoretical ones. On the swing, Implicit Midpoint's slope over the finest points is %s: second order "
              "over the middle of the range (local slopes above), first order as dt goes to 0. Making the Jacobian "
              "exact restores order 2 on the swing too, but the step matrix is then indefinite.\n" % g(swing_im.get("slope")))
    md.append("- **Stiffer cloth.** Linearised Implicit Midpoint with %g%% adaptive damping at dt = %g ms is stable "
              "on this code only while element stiffness factors kappa stay near the paper's range (the swing scene "
              "reaches %s); for finer or stiffer cloth it injects energy through large per-step element rotations "
              "(a known weakness of midpoint rules in nonlinear elastodynamics) and blows up, while backward Euler "
              "stays stable%s. `weft experiment energy` "
              "records such a run as unstable with its time instead of failing.\n" % (
                  zeta_pct, dt_ms, g(im["kappa"]["max"]), " (claims table, stiffer-cloth row)" if stiff else ""))
    md.append("- **Accuracy at dt = %g ms.** The fixed-step methods' RMS distances from their references reach "
              "%s to %s m (motion accuracy table): the comparison ranks the "
              "methods, it does not make any of them accurate at this step.\n" % (
                  dt_ms, g(min(r["rms_distance_max"] for r in runs.values() if r.get("reference"))),
                  g(max(r["rms_distance_max"] for r in runs.values() if r.get("reference")))))

    # Commands.
    md.append("## Commands\n")
    commands = ""
    if args.commands and os.path.exists(args.commands):
        with open(args.commands) as f:
            commands = f.read().strip()
    md.append("Build (Release), then run `sh tools/results.sh`, which is:\n")
    md.append("```sh\ncmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release && cmake --build build -j2\n```\n")
    md.append("```sh\n" + (commands or "(not recorded)") + "\n```\n")

    with open(args.out + ".tmp", "w") as f:
        f.write("\n".join(md))
    os.replace(args.out + ".tmp", args.out)
    print("wrote", args.out)


if __name__ == "__main__":
    main()
