// `weft experiment convergence`: observed orders of accuracy of every integrator
// (docs/method.md 2).
#include <cmath>
#include <cstdio>
#include <memory>

#include "command.hpp"
#include "experiment_common.hpp"
#include "weft/experiments/convergence.hpp"

namespace weft::app {
namespace {

struct ConvergenceArgs {
  std::string scene = default_experiment_scene(), out;
  ConvergenceOptions options;
  bool quiet = false;
};

int run_convergence(const ConvergenceArgs& a) {
  const Scene scene = load_scene(a.scene);
  check_output_folder(a.out);
  LabelledProgress progress("convergence", !a.quiet);
  const ConvergenceStudy st = run_convergence_study(scene, a.options, std::ref(progress));
  progress.finish();
  print_warnings(write_convergence_study(st, a.out));
  std::printf(
      "reference: rk45, tolerance %g, %ld steps, estimated error %.3g m (points below %.3g m not "
      "fitted)\n",
      st.options.reference_tolerance, st.reference_steps, st.reference_error_estimate,
      st.error_floor);
  std::printf("%-20s %9s %9s %7s  errors (m) for dt = ", "method", "expected", "slope", "points");
  for (const auto& p : st.series.front().points) std::printf("%g ", p.dt);
  std::printf("s\n");
  for (const auto& s : st.series) {
    std::printf("%-20s %9g %9.3f %7d ", s.method.configuration.label.c_str(),
                s.method.expected_order, s.slope, s.fitted_points);
    for (const auto& p : s.points)
      std::printf(" %10.3e%s", p.error, p.status == "ok" ? (p.in_fit ? "*" : " ") : "!");
    std::printf("\n");
  }
  std::printf(
      "(* fitted, ! unstable)\nresults in %s (convergence.csv, slopes.csv, convergence.json, "
      "convergence.png)\n",
      a.out.c_str());
  return kExitOk;
}

const RegisterCommand register_convergence{CommandSpec{
    "experiment", "convergence",
    "Observed order of accuracy of every integrator: error at a fixed time against a tight RK45 "
    "reference for dt halving",
    [](CLI::App& sub) {
      auto a = std::make_shared<ConvergenceArgs>();
      auto& o = a->options;
      add_common_options(sub, a->scene, a->out, a->quiet);
      sub.add_option("--time", o.time, "Time at which the error is measured (s)")
          ->capture_default_str();
      sub.add_option("--dt-max", o.dt_max, "Largest step (s); each level halves it")
          ->capture_default_str();
      sub.add_option("--levels", o.levels, "Number of step sizes")->capture_default_str();
      sub.add_option("--damping-ratio", o.damping_ratio,
                     "Adaptive damping, the same for every method and the reference")
          ->capture_default_str();
      sub.add_option("--reference-tolerance", o.reference_tolerance,
                     "RK45 reference local error tolerance")
          ->capture_default_str();
      sub.add_option("--cg-tolerance", o.cg_tolerance, "Relative residual of the implicit solves")
          ->capture_default_str();
      sub.add_option("--fit-points", o.fit_points, "Finest admissible points in each slope fit")
          ->capture_default_str();
      sub.footer(
          "Methods: forward-euler, backward-euler, implicit-midpoint-plain, bdf2, bdf2-alpha "
          "(1/sqrt(3)), rk4.\n"
          "Error: RMS vertex distance at --time from the RK45 reference. Unstable points are "
          "recorded and\n"
          "skipped; so are points below 100x the reference's estimated error. The slope is the\n"
          "least-squares fit of log(error) on log(dt) over the finest --fit-points admissible "
          "points.\n"
          "Writes DIR/convergence.{csv,json}, DIR/slopes.csv, DIR/series/*.csv, "
          "DIR/convergence.{gp,png,svg}.");
      return std::function<int()>([a] { return run_convergence(*a); });
    },
    61}};

}  // namespace
}  // namespace weft::app
