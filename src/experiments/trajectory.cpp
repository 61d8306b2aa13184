#include "weft/experiments/trajectory.hpp"
#include "sim/simulation_core.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>

#include "weft/error.hpp"

namespace weft {

Scene configure_scene(const Scene& scene, const MethodConfiguration& c, double dt,
                      double rk45_tolerance, double cg_tolerance) {
  Scene s = scene;
  const std::string where = "experiment configuration '" + c.label + "'";
  set_method(s, c.method, c.alpha, where);
  s.integrator.dt = dt;
  s.damping_ratio = c.damping_ratio;
  if (s.integrator.method == Method::kRk45) s.integrator.error_tolerance = rk45_tolerance;
  if (cg_tolerance > 0) s.integrator.cg_tolerance = cg_tolerance;
  validate_timing(s, where);
  return s;
}

Trajectory run_trajectory(const Scene& configured, const MethodConfiguration& c,
                          bool keep_positions, const std::function<void(double)>& progress) {
  Trajectory t;
  t.configuration = c;
  t.scene = configured;
  Simulation sim(configured);
  RunCallbacks cb;
  if (keep_positions)
    cb.on_frame = [&](int, const Simulation& s) { t.positions.push_back(s.core().state().x); };
  cb.on_progress = progress;
  t.result = run_simulation(sim, cb);
  t.summary = summary_json(sim, t.result);
  return t;
}

double rms_distance(const VecX& a, const VecX& b) {
  const Eigen::Index n = a.size() / 3;
  if (n == 0) return 0.0;
  return std::sqrt((a - b).squaredNorm() / static_cast<double>(n));
}

std::vector<double> rms_distance_per_frame(const std::vector<VecX>& a,
                                           const std::vector<VecX>& reference) {
  std::vector<double> d;
  const size_t n = std::min(a.size(), reference.size());
  d.reserve(n);
  for (size_t f = 0; f < n; ++f) d.push_back(rms_distance(a[f], reference[f]));
  return d;
}

double root_mean_square(const std::vector<double>& values) {
  if (values.empty()) return 0.0;
  double sum = 0;
  for (double v : values) sum += v * v;
  return std::sqrt(sum / static_cast<double>(values.size()));
}

double median(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  const size_t m = values.size() / 2;
  return values.size() % 2 ? values[m] : 0.5 * (values[m - 1] + values[m]);
}

PendingFile pending_text_file(const std::filesystem::path& path, std::string content) {
  return {path, [content = std::move(content)](const std::filesystem::path& temporary) {
            std::ofstream o(temporary, std::ios::binary);
            o << content;
            if (!o.flush()) throw std::runtime_error("cannot write " + temporary.string());
          }};
}

void require_positive_finite(const std::string& option, double value) {
  if (!(value > 0) || !std::isfinite(value))
    throw InputError(option + " " + format_number(value) + ": expected a positive finite number");
}

void require_damping_ratio(const std::string& option, double value) {
  if (!(value >= 0 && value <= 10))
    throw InputError(option + " " + format_number(value) +
                     ": expected a damping ratio from 0 to 10");
}

std::string format_number(double value) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.10g", value);
  return buf;
}

}  // namespace weft
