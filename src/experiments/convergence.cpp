#include "weft/experiments/convergence.hpp"

#include <cmath>
#include <sstream>

#include "io/gnuplot.hpp"
#include "weft/error.hpp"

namespace weft {

namespace {

void check_options(const ConvergenceOptions& o) {
  require_positive_finite("--time", o.time);
  require_positive_finite("--dt-max", o.dt_max);
  require_positive_finite("--reference-tolerance", o.reference_tolerance);
  require_positive_finite("--cg-tolerance", o.cg_tolerance);
  if (!(o.reference_tolerance < 1e-3))
    throw InputError("--reference-tolerance " + format_number(o.reference_tolerance) +
                     ": expected a value below 1e-3");
  if (!(o.cg_tolerance < 1))
    throw InputError("--cg-tolerance " + format_number(o.cg_tolerance) +
                     ": expected a value below 1");
  if (o.levels < 2 || o.levels > 12)
    throw InputError("--levels " + std::to_string(o.levels) + ": expected an integer from 2 to 12");
  if (o.fit_points < 2 || o.fit_points > o.levels)
    throw InputError("--fit-points " + std::to_string(o.fit_points) +
                     ": expected an integer from 2 to --levels (" + std::to_string(o.levels) + ")");
  require_damping_ratio("--damping-ratio", o.damping_ratio);
  const double steps = o.time / o.dt_max;
  if (steps < 1 - 1e-9 || std::abs(steps - std::round(steps)) > 1e-6 * steps)
    throw InputError("--dt-max " + format_number(o.dt_max) + ": expected --time (" +
                     format_number(o.time) + " s) to be a whole number of steps of it");
}

/// The scene cut to end at `time`, with a single output frame there.
Scene timed_scene(const Scene& scene, double time) {
  Scene s = scene;
  s.duration = time;
  s.frame_interval = time;
  return s;
}

}  // namespace

std::vector<ConvergenceMethod> convergence_methods(double zeta) {
  const double inv_sqrt3 = 1.0 / std::sqrt(3.0);
  return {
      {{"forward-euler", "forward-euler", std::nullopt, zeta}, 1},
      {{"backward-euler", "backward-euler", std::nullopt, zeta}, 1},
      {{"implicit-midpoint", "implicit-midpoint-plain", std::nullopt, zeta}, 2},
      {{"bdf2", "bdf2", std::nullopt, zeta}, 2},
      {{"bdf2-alpha", "bdf2-alpha", inv_sqrt3, zeta}, 2},
      {{"rk4", "rk4", std::nullopt, zeta}, 4},
  };
}

double log_log_slope(const std::vector<double>& x, const std::vector<double>& y) {
  const size_t n = x.size();
  if (n < 2 || y.size() != n) return std::nan("");
  double mx = 0, my = 0;
  for (size_t i = 0; i < n; ++i) {
    mx += std::log(x[i]);
    my += std::log(y[i]);
  }
  mx /= n;
  my /= n;
  double sxy = 0, sxx = 0;
  for (size_t i = 0; i < n; ++i) {
    const double dx = std::log(x[i]) - mx;
    sxy += dx * (std::log(y[i]) - my);
    sxx += dx * dx;
  }
  return sxx > 0 ? sxy / sxx : std::nan("");
}

ConvergenceStudy run_convergence_study(const Scene& scene, const ConvergenceOptions& options,
                                       const ExperimentProgress& progress) {
  check_options(options);
  ConvergenceStudy study;
  study.options = options;
  study.scene = timed_scene(scene, options.time);
  const auto methods = convergence_methods(options.damping_ratio);
  std::vector<double> dts;
  for (int l = 0; l < options.levels; ++l) dts.push_back(options.dt_max / std::ldexp(1.0, l));
  // Configure every run first: a step that does not divide the time fails before any work.
  std::vector<std::vector<Scene>> scenes;
  for (const auto& m : methods) {
    scenes.emplace_back();
    for (double dt : dts)
      scenes.back().push_back(
          configure_scene(study.scene, m.configuration, dt, 0, options.cg_tolerance));
  }

  auto final_positions = [&](const Scene& s, const MethodConfiguration& c,
                             Trajectory& t) -> const VecX* {
    auto report = [&](double f) {
      if (progress) progress(c.label, f);
    };
    t = run_trajectory(s, c, true, report);
    return t.result.status == "ok" && t.positions.size() == 2 && t.positions.back().allFinite()
               ? &t.positions.back()
               : nullptr;
  };
  const MethodConfiguration reference{"reference", "rk45", std::nullopt, options.damping_ratio};
  const MethodConfiguration loose{"reference-check", "rk45", std::nullopt, options.damping_ratio};
  Trajectory ref_run, loose_run;
  const VecX* ref = final_positions(
      configure_scene(study.scene, reference, dts.front(), options.reference_tolerance), reference,
      ref_run);
  if (!ref)
    throw std::runtime_error("the RK45 reference run became unstable: " + ref_run.result.message);
  study.reference_steps = ref_run.result.steps.steps;
  const VecX* check =
      final_positions(configure_scene(study.scene, loose, dts.front(),
                                      std::min(1e-3, 100 * options.reference_tolerance)),
                      loose, loose_run);
  study.reference_error_estimate = check ? rms_distance(*check, *ref) / 100 : std::nan("");
  study.error_floor = 100 * study.reference_error_estimate;

  for (size_t m = 0; m < methods.size(); ++m) {
    ConvergenceSeries series;
    series.method = methods[m];
    series.alpha = scenes[m].front().integrator.alpha;
    for (size_t l = 0; l < dts.size(); ++l) {
      Trajectory t;
      const VecX* x = final_positions(scenes[m][l], methods[m].configuration, t);
      ConvergencePoint p;
      p.dt = dts[l];
      p.steps = t.result.steps.steps;
      p.wall_seconds = t.result.wall_seconds;
      p.status = x ? "ok" : "unstable";
      p.error = x ? rms_distance(*x, *ref) : std::nan("");
      series.points.push_back(p);
    }
    // Admissible: stable, finite and above the reference's error floor. The asymptotic slope
    // uses the finest `fit_points` of them (small dt is where the leading error term rules).
    std::vector<size_t> admissible;
    for (size_t l = 0; l < series.points.size(); ++l) {
      const auto& p = series.points[l];
      if (p.status == "ok" && std::isfinite(p.error) && p.error > study.error_floor)
        admissible.push_back(l);
    }
    std::vector<double> x_all, y_all, x_fit, y_fit;
    for (size_t k = 0; k < admissible.size(); ++k) {
      auto& p = series.points[admissible[k]];
      x_all.push_back(p.dt);
      y_all.push_back(p.error);
      if (k + options.fit_points >= admissible.size()) {
        p.in_fit = true;
        x_fit.push_back(p.dt);
        y_fit.push_back(p.error);
      }
    }
    series.slope_all_stable = log_log_slope(x_all, y_all);
    series.slope = log_log_slope(x_fit, y_fit);
    series.fitted_points = static_cast<int>(x_fit.size());
    study.series.push_back(std::move(series));
  }
  return study;
}

nlohmann::json convergence_json(const ConvergenceStudy& st) {
  nlohmann::json j = experiment_json("convergence", st.scene);
  j["time"] = st.options.time;
  j["damping_ratio"] = st.options.damping_ratio;
  j["reference"] = {{"method", "rk45"},
                    {"tolerance", st.options.reference_tolerance},
                    {"steps", st.reference_steps},
                    {"error_estimate", st.reference_error_estimate},
                    {"error_floor", st.error_floor}};
  j["cg_tolerance"] = st.options.cg_tolerance;
  j["fit_points"] = st.options.fit_points;
  nlohmann::json series = nlohmann::json::array();
  for (const auto& s : st.series) {
    nlohmann::json points = nlohmann::json::array();
    for (const auto& p : s.points)
      points.push_back(
          {{"dt", p.dt},
           {"steps", p.steps},
           {"status", p.status},
           {"error", std::isfinite(p.error) ? nlohmann::json(p.error) : nlohmann::json()},
           {"in_fit", p.in_fit},
           {"wall_seconds", p.wall_seconds}});
    auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
    series.push_back({{"label", s.method.configuration.label},
                      {"method", s.method.configuration.method},
                      {"alpha", s.alpha},
                      {"expected_order", s.method.expected_order},
                      {"slope", num(s.slope)},
                      {"slope_all_stable", num(s.slope_all_stable)},
                      {"fitted_points", s.fitted_points},
                      {"points", points}});
  }
  j["series"] = series;
  return j;
}

namespace {

std::string optional_number(double v) {
  return std::isfinite(v) ? format_number(v) : std::string();
}

GnuplotFigure convergence_figure(const ConvergenceStudy& st) {
  std::ostringstream b;
  b << "set title "
    << gnuplot_quote("Error at t = " + format_number(st.options.time) +
                     " s against RK45 (tolerance " + format_number(st.options.reference_tolerance) +
                     "), damping ratio " + format_number(st.options.damping_ratio))
    << "\nset xlabel 'time step dt (ms)'\nset ylabel 'RMS vertex error (m)'\nset logscale xy\nset "
       "grid\n"
    << "set key bottom right font ',9'\nset format y '10^{%L}'\n";
  b << "plot ";
  for (size_t k = 0; k < st.series.size(); ++k) {
    const auto& s = st.series[k];
    char slope[64];
    std::snprintf(
        slope, sizeof slope,
        std::isfinite(s.slope) ? " (slope %.2f, expected %g)" : " (no slope, expected %g)",
        std::isfinite(s.slope) ? s.slope : s.method.expected_order, s.method.expected_order);
    b << (k ? ", \\\n     " : "")
      << gnuplot_quote("series/" + s.method.configuration.label + ".csv")
      << " every ::1 using (1000*$1):($3 > 0 ? $3 : NaN) with linespoints lw 1.5 pt "
      << 5 + 2 * static_cast<int>(k % 4) << " title "
      << gnuplot_quote(s.method.configuration.label + slope);
  }
  return {"convergence", b.str(), 1000, 600};
}

}  // namespace

std::vector<std::string> write_convergence_study(const ConvergenceStudy& st,
                                                 const std::filesystem::path& dir) {
  std::vector<PendingFile> files;
  std::ostringstream all, slopes;
  all << "label,method,alpha,expected_order,dt,steps,status,error,in_fit,wall_seconds\n";
  slopes << "label,method,alpha,expected_order,slope,fitted_points,dt_min_fit,dt_max_fit,slope_all_"
            "stable\n";
  for (const auto& s : st.series) {
    const auto& c = s.method.configuration;
    std::ostringstream one;
    one << "dt,status,error\n";
    double dt_min = 0, dt_max = 0;
    for (const auto& p : s.points) {
      all << c.label << ',' << c.method << ',' << format_number(s.alpha) << ','
          << format_number(s.method.expected_order) << ',' << format_number(p.dt) << ',' << p.steps
          << ',' << p.status << ',' << optional_number(p.error) << ',' << (p.in_fit ? 1 : 0) << ','
          << format_number(p.wall_seconds) << '\n';
      one << format_number(p.dt) << ',' << p.status << ',' << optional_number(p.error) << '\n';
      if (p.in_fit) {
        dt_min = dt_min > 0 ? std::min(dt_min, p.dt) : p.dt;
        dt_max = std::max(dt_max, p.dt);
      }
    }
    slopes << c.label << ',' << c.method << ',' << format_number(s.alpha) << ','
           << format_number(s.method.expected_order) << ',' << optional_number(s.slope) << ','
           << s.fitted_points << ',' << format_number(dt_min) << ',' << format_number(dt_max) << ','
           << optional_number(s.slope_all_stable) << '\n';
    files.push_back(pending_text_file(dir / "series" / (c.label + ".csv"), one.str()));
  }
  files.push_back(pending_text_file(dir / "convergence.csv", all.str()));
  files.push_back(pending_text_file(dir / "slopes.csv", slopes.str()));
  files.push_back(pending_text_file(dir / "convergence.json", convergence_json(st).dump(2) + "\n"));
  write_files_atomically(files);
  std::vector<std::string> warnings;
  std::string w = render_gnuplot_figure(dir, convergence_figure(st));
  if (!w.empty()) warnings.push_back(std::move(w));
  return warnings;
}

}  // namespace weft
