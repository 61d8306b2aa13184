// `weft experiment energy`: the paper's energy, accuracy and speed comparison (docs/method.md 7,
// figures 8-10) on one scene.
#include <cmath>
#include <cstdio>
#include <memory>

#include "command.hpp"
#include "experiment_common.hpp"
#include "weft/experiments/energy.hpp"

namespace weft::app {
namespace {

struct EnergyArgs {
  std::string scene = default_experiment_scene(), out;
  EnergyExperimentOptions options;
  std::optional<double> duration;
  bool quiet = false;
};

int run_energy(const EnergyArgs& a) {
  Scene scene = load_scene(a.scene);
  if (a.duration) {
    require_positive_finite("--duration", *a.duration);
    scene.duration = *a.duration;
  }
  check_output_folder(a.out);
  LabelledProgress progress("energy", !a.quiet);
  const EnergyExperiment ex = run_energy_experiment(scene, a.options, std::ref(progress));
  progress.finish();
  print_warnings(write_energy_experiment(ex, a.out));

  std::printf("%-26s %-9s %7s %9s %8s %12s %12s %12s %12s\n", "configuration", "status", "steps",
              "wall (s)", "CG/step", "kappa max", "dissip. (J)", "created (J)", "RMS dist (m)");
  for (const auto& run : ex.runs) {
    const RunResult& r = run.trajectory.result;
    const double dissipated = r.energy.empty() ? 0.0
                                               : r.energy.back().viscous_dissipated +
                                                     r.energy.back().numerical_dissipated;
    std::printf(
        "%-26s %-9s %7ld %9.3f %8.2f %12.4g %12.4g %12.4g %12s\n", run.entry.configuration.label.c_str(),
        r.status.c_str(), r.steps.steps, r.wall_seconds,
        r.steps.steps ? static_cast<double>(r.steps.cg_iterations) / r.steps.steps : 0.0,
        run.trajectory.summary["kappa"]["max"].get<double>(), dissipated, energy_created(r.energy).total,
        run.entry.reference.empty() ? "reference"
                                    : format_number(root_mean_square(run.rms_per_frame)).c_str());
    if (r.status != "ok")
      std::printf("  unstable at t = %.4f s: %s\n", r.unstable_time, r.message.c_str());
  }
  if (ex.speed.repeats > 0)
    std::printf(
        "speed (median of %d interleaved repeats): Implicit Midpoint / backward Euler = %.3f in "
        "wall time, "
        "%.3f in CG iterations per step\n",
        ex.speed.repeats, ex.speed.wall_ratio(), ex.speed.cg_ratio());
  if (ex.speed.unstable_runs > 0)
    std::printf(
        "warning: %d speed runs became unstable and stopped early; the speed ratio is not "
        "meaningful\n",
        ex.speed.unstable_runs);
  std::printf(
      "results in %s (results.json, results.csv, rms.csv, speed.csv, energy.png, rms.png, "
      "LABEL/energy.csv)\n",
      a.out.c_str());
  return kExitOk;
}

const RegisterCommand register_energy{CommandSpec{
    "experiment", "energy",
    "Energy, motion accuracy and speed of backward Euler, Implicit Midpoint, BDF-2 and BDF-2 "
    "alpha = 1/sqrt(3) against adaptive RK45 references (the paper's figures 8-10)",
    [](CLI::App& sub) {
      auto a = std::make_shared<EnergyArgs>();
      add_common_options(sub, a->scene, a->out, a->quiet);
      sub.add_option("--dt", a->options.dt,
                     "Step of the fixed-step methods and RK45's largest step (s)")
          ->capture_default_str();
      sub.add_option("--damping-ratio", a->options.damping_ratio,
                     "Adaptive damping of the damped configurations (fraction of critical)")
          ->capture_default_str();
      sub.add_option("--rk45-tolerance", a->options.rk45_tolerance,
                     "Local error tolerance of the RK45 references")
          ->capture_default_str();
      sub.add_option(
             "--repeats", a->options.speed_repeats,
             "Interleaved Implicit Midpoint / backward Euler runs for the speed ratio (0: none)")
          ->capture_default_str();
      sub.add_option("--duration", a->duration, "Simulated time (s; default: the scene's)");
      sub.add_flag("!--no-injection", a->options.injection,
                   "Skip the analysis of where Implicit Midpoint (damped) creates energy");
      sub.add_option("--newton", a->options.newton_iterations,
                     "Newton iterations the semi-implicit configurations may add to each step's "
                     "linearised solve (0: one linearisation per step; default: the scene's "
                     "integrator.newton_iterations)");
      sub.footer(
          "Configurations: backward-euler (undamped), implicit-midpoint-damped, bdf2 (undamped),\n"
          "bdf2-alpha-damped (alpha = 1/sqrt(3)), the guarded implicit-midpoint-guarded-damped and\n"
          "bdf2-alpha-guarded-damped, rk45-damped and rk45 (references). Damped ones use\n"
          "--damping-ratio; each is compared with the RK45 run of the same damping.\n"
          "Writes DIR/LABEL/{energy.csv,summary.json}, DIR/results.{json,csv}, DIR/rms.csv, "
          "DIR/speed.csv and\n"
          "DIR/energy.{gp,png,svg}, DIR/rms.{gp,png,svg} (figures need gnuplot; without it the "
          "scripts stay).\n"
          "A configuration that becomes unstable is recorded (status, time), not an error.\n"
          "results.json gives each configuration's energy_created (falls of the numerical dissipation\n"
          "between frames: the largest and the total); DIR/injection/ splits what Implicit Midpoint\n"
          "(damped) creates among the triangles (injection_triangles.csv, injection_steps.csv,\n"
          "injection.{gp,png,svg}).");
      return std::function<int()>([a] { return run_energy(*a); });
    },
    60}};

}  // namespace
}  // namespace weft::app
