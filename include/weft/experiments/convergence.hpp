#pragma once
// Orders of accuracy measured on a scene (docs/method.md 2): the RMS vertex error at a fixed time
// against a tight adaptive RK45 reference, for dt halving from dt_max, for every integrator;
// the slope of log(error) against log(dt) is the observed order.
#include <filesystem>
#include <string>
#include <vector>

#include "weft/experiments/energy.hpp"

namespace weft {

struct ConvergenceOptions {
  double time = 0.2;                   ///< when the error is measured (s)
  double dt_max = 0.02;                ///< largest step (s); then dt_max/2, dt_max/4, ...
  int levels = 12;                     ///< number of step sizes (forward Euler needs the finest)
  double damping_ratio = 0.0;          ///< the same for every method, so all solve one ODE
  double reference_tolerance = 1e-11;  ///< RK45 local error tolerance of the reference
  double cg_tolerance = 1e-12;         ///< relative residual of the implicit methods' solves
  int fit_points = 3;                  ///< finest admissible points used for the asymptotic slope
};

struct ConvergenceMethod {
  MethodConfiguration configuration;
  double expected_order = 0;  ///< docs/method.md 2
};
std::vector<ConvergenceMethod> convergence_methods(double damping_ratio);

struct ConvergencePoint {
  double dt = 0;
  long steps = 0;
  std::string status;   ///< "ok", or "unstable" (the run blew up; not used in fits)
  double error = 0;     ///< RMS vertex distance from the reference at `time` (m)
  bool in_fit = false;  ///< one of the points of the asymptotic slope
  double wall_seconds = 0;
};

struct ConvergenceSeries {
  ConvergenceMethod method;
  double alpha = 0;
  std::vector<ConvergencePoint> points;    ///< dt decreasing
  double slope = std::nan("");             ///< least-squares slope over the in_fit points
  double slope_all_stable = std::nan("");  ///< over every stable point above the floor
  int fitted_points = 0;
};

struct ConvergenceStudy {
  Scene scene;
  ConvergenceOptions options;
  long reference_steps = 0;
  /// Estimate of the reference's own error: its distance from a run 100x looser, divided by 100
  /// (Dormand-Prince's global error scales about linearly with the tolerance).
  double reference_error_estimate = 0;
  double error_floor = 0;  ///< errors below this (100x the estimate) are not fitted
  std::vector<ConvergenceSeries> series;
};

/// Least-squares slope of log(y) against log(x); NaN for fewer than two points.
double log_log_slope(const std::vector<double>& x, const std::vector<double>& y);

/// Runs the study. Throws InputError for bad options.
ConvergenceStudy run_convergence_study(const Scene& scene, const ConvergenceOptions& options,
                                       const ExperimentProgress& progress = {});

/// Writes DIR/convergence.{csv,json}, DIR/slopes.csv, DIR/series/LABEL.csv and the figure
/// DIR/convergence.{gp,png,svg}. Returns warnings (e.g. gnuplot missing).
std::vector<std::string> write_convergence_study(const ConvergenceStudy& study,
                                                 const std::filesystem::path& dir);

nlohmann::json convergence_json(const ConvergenceStudy& study);

}  // namespace weft
