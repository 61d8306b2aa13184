#include "weft/experiments/energy.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <thread>

#include "io/gnuplot.hpp"
#include "weft/atomic_file.hpp"
#include "weft/error.hpp"

namespace weft {

namespace {

const char* kMidpoint = "implicit-midpoint-damped";
const char* kBackwardEuler = "backward-euler";

std::string number(double v) { return format_number(v); }

double cg_per_step(const RunResult& r) {
  return r.steps.steps ? static_cast<double>(r.steps.cg_iterations) / r.steps.steps : 0.0;
}

double ratio_or_nan(double a, double b) {
  return b > 0 ? a / b : std::numeric_limits<double>::quiet_NaN();
}

void check_options(const EnergyExperimentOptions& o) {
  require_positive_finite("--dt", o.dt);
  require_positive_finite("--rk45-tolerance", o.rk45_tolerance);
  if (!(o.rk45_tolerance < 1))
    throw InputError("--rk45-tolerance " + number(o.rk45_tolerance) + ": expected a value below 1");
  require_damping_ratio("--damping-ratio", o.damping_ratio);
  if (o.speed_repeats < 0 || o.speed_repeats > 1000)
    throw InputError("--repeats " + std::to_string(o.speed_repeats) +
                     ": expected an integer from 0 to 1000");
  if (o.newton_iterations && (*o.newton_iterations < 0 || *o.newton_iterations > 100))
    throw InputError("--newton " + std::to_string(*o.newton_iterations) +
                     ": expected an integer from 0 to 100");
}

/// Total energy dissipated (viscous + numerical) at the last frame kept (J).
double dissipated_final(const RunResult& r) {
  return r.energy.empty()
             ? 0.0
             : r.energy.back().viscous_dissipated + r.energy.back().numerical_dissipated;
}

}  // namespace

std::vector<EnergyConfiguration> energy_configurations(double zeta) {
  const double inv_sqrt3 = 1.0 / std::sqrt(3.0);
  return {
      {{kBackwardEuler, "backward-euler", std::nullopt, 0.0}, "rk45"},
      {{kMidpoint, "implicit-midpoint-plain", std::nullopt, zeta}, "rk45-damped"},
      {{"bdf2", "bdf2", std::nullopt, 0.0}, "rk45"},
      {{"bdf2-alpha-damped", "bdf2-alpha", inv_sqrt3, zeta}, "rk45-damped"},
      // weft's guarded steps (docs/guarded-midpoint.md), beside the paper's plain ones.
      {{"implicit-midpoint-guarded-damped", "implicit-midpoint", std::nullopt, zeta}, "rk45-damped"},
      {{"bdf2-alpha-guarded-damped", "bdf2-alpha-guarded", inv_sqrt3, zeta}, "rk45-damped"},
      {{"rk45-damped", "rk45", std::nullopt, zeta}, ""},
      {{"rk45", "rk45", std::nullopt, 0.0}, ""},
  };
}

EnergyCreated energy_created(const std::vector<EnergyRow>& rows) {
  EnergyCreated c;
  for (size_t k = 1; k < rows.size(); ++k) {
    const double fall = rows[k - 1].numerical_dissipated - rows[k].numerical_dissipated;
    if (!(fall > 0)) continue;
    c.total += fall;
    ++c.frames;
    if (fall > c.largest) {
      c.largest = fall;
      c.time_of_largest = rows[k].time;
    }
  }
  return c;
}

double SpeedComparison::wall_ratio() const {
  return ratio_or_nan(median(midpoint_seconds), median(backward_euler_seconds));
}
double SpeedComparison::cg_ratio() const {
  return ratio_or_nan(median(midpoint_cg_per_step), median(backward_euler_cg_per_step));
}

EnergyExperiment run_energy_experiment(const Scene& scene, const EnergyExperimentOptions& options,
                                       const ExperimentProgress& progress) {
  check_options(options);
  EnergyExperiment ex;
  ex.scene = scene;
  ex.options = options;
  const auto entries = energy_configurations(options.damping_ratio);
  // Configure everything first so that a bad option fails before any long run.
  std::vector<Scene> scenes;
  for (const auto& e : entries) {
    scenes.push_back(configure_scene(scene, e.configuration, options.dt, options.rk45_tolerance));
    if (options.newton_iterations) scenes.back().integrator.newton_iterations = *options.newton_iterations;
  }
  for (size_t k = 0; k < entries.size(); ++k) {
    const std::string& label = entries[k].configuration.label;
    auto report = [&](double f) {
      if (progress) progress(label, f);
    };
    ex.runs.push_back(
        {entries[k], run_trajectory(scenes[k], entries[k].configuration, true, report), {}});
  }
  for (auto& run : ex.runs) {
    if (run.entry.reference.empty()) continue;
    for (const auto& ref : ex.runs)
      if (ref.entry.configuration.label == run.entry.reference)
        run.rms_per_frame =
            rms_distance_per_frame(run.trajectory.positions, ref.trajectory.positions);
  }

  if (options.injection) {
    if (progress) progress("injection " + entries[1].configuration.label, 0.0);
    ex.injection = analyse_energy_injection(scenes[1], entries[1].configuration.label);
  }

  // Speed: Implicit Midpoint and backward Euler alternately, alternating which goes first so
  // that neither always runs on a warmer cache or a quieter machine.
  SpeedComparison& sp = ex.speed;
  sp.repeats = options.speed_repeats;
  const Scene& midpoint = scenes[1];
  const Scene& backward = scenes[0];
  for (int r = 0; r < options.speed_repeats; ++r) {
    for (int half = 0; half < 2; ++half) {
      const bool run_midpoint = (half == 0) == (r % 2 == 0);
      const auto& cfg = entries[run_midpoint ? 1 : 0].configuration;
      auto report = [&](double f) {
        if (progress)
          progress("speed " + cfg.label + " " + std::to_string(r + 1) + "/" +
                       std::to_string(options.speed_repeats),
                   f);
      };
      const Trajectory t = run_trajectory(run_midpoint ? midpoint : backward, cfg, false, report);
      (run_midpoint ? sp.midpoint_seconds : sp.backward_euler_seconds)
          .push_back(t.result.wall_seconds);
      (run_midpoint ? sp.midpoint_cg_per_step : sp.backward_euler_cg_per_step)
          .push_back(cg_per_step(t.result));
      (run_midpoint ? sp.midpoint_steps : sp.backward_euler_steps) = t.result.steps.steps;
      if (t.result.status != "ok") ++sp.unstable_runs;
    }
  }
  return ex;
}

nlohmann::json machine_json() {
  std::ifstream in("/proc/cpuinfo");
  std::string line, model = "unknown";
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) model = line.substr(line.find_first_not_of(" \t", colon + 1));
      break;
    }
  }
  return {{"cpu_model", model}, {"logical_cores", std::thread::hardware_concurrency()}};
}

nlohmann::json experiment_json(const std::string& name, const Scene& scene) {
  return {{"experiment", name},
          {"weft_version", WEFT_VERSION},
          {"scene", scene.file},
          {"machine", machine_json()}};
}

nlohmann::json energy_results_json(const EnergyExperiment& ex) {
  nlohmann::json j = experiment_json("energy", ex.scene);
  j["duration"] = ex.scene.duration;
  j["frame_interval"] = ex.scene.frame_interval;
  j["dt"] = ex.options.dt;
  j["damping_ratio"] = ex.options.damping_ratio;
  j["rk45_tolerance"] = ex.options.rk45_tolerance;
  nlohmann::json runs = nlohmann::json::array();
  for (const auto& run : ex.runs) {
    const auto& c = run.entry.configuration;
    const RunResult& r = run.trajectory.result;
    const nlohmann::json& s = run.trajectory.summary;
    nlohmann::json o;
    o["label"] = c.label;
    o["method"] = c.method;
    o["alpha"] = run.trajectory.scene.integrator.alpha;
    o["damping_ratio"] = c.damping_ratio;
    o["reference"] = run.entry.reference;
    o["status"] = r.status;
    if (r.status != "ok") {
      o["unstable_time"] = r.unstable_time;
      o["message"] = r.message;
    }
    o["steps"] = r.steps.steps;
    o["rejected_steps"] = r.steps.rejected_steps;
    o["wall_seconds"] = r.wall_seconds;
    o["cg_iterations_per_step"] = cg_per_step(r);
    o["kappa"] = s["kappa"];
    o["added_viscosity_Ns_m"] = s["added_viscosity_Ns_m"];
    o["frames"] = r.energy.size();
    if (!r.energy.empty()) {
      const EnergyRow& first = r.energy.front();
      const EnergyRow& last = r.energy.back();
      o["energy_initial"] = first.total() + first.viscous_dissipated + first.numerical_dissipated;
      o["time_final"] = last.time;
      o["dissipated_final"] = {{"viscous", last.viscous_dissipated},
                               {"numerical", last.numerical_dissipated},
                               {"total", dissipated_final(r)}};
      const EnergyCreated created = energy_created(r.energy);
      o["energy_created"] = {{"largest_J", created.largest},
                             {"time_of_largest", created.time_of_largest},
                             {"total_J", created.total},
                             {"frames", created.frames}};
    }
    o["newton_iterations"] = run.trajectory.scene.integrator.newton_iterations;
    if (s.contains("newton")) o["newton"] = s["newton"];
    if (!run.entry.reference.empty()) {
      o["rms_distance_over_run"] = root_mean_square(run.rms_per_frame);
      o["rms_distance_final"] = run.rms_per_frame.empty() ? 0.0 : run.rms_per_frame.back();
      o["rms_distance_max"] =
          run.rms_per_frame.empty()
              ? 0.0
              : *std::max_element(run.rms_per_frame.begin(), run.rms_per_frame.end());
    }
    runs.push_back(o);
  }
  j["runs"] = runs;
  if (ex.injection) j["energy_injection"] = energy_injection_json(*ex.injection);
  const SpeedComparison& sp = ex.speed;
  if (sp.repeats > 0) {
    auto side = [](const char* label, const std::vector<double>& seconds,
                   const std::vector<double>& cg, long steps) {
      return nlohmann::json{{"label", label},
                            {"wall_seconds", seconds},
                            {"wall_seconds_median", median(seconds)},
                            {"cg_iterations_per_step", cg},
                            {"cg_iterations_per_step_median", median(cg)},
                            {"steps", steps}};
    };
    j["speed"] = {{"repeats", sp.repeats},
                  {"implicit_midpoint", side(kMidpoint, sp.midpoint_seconds,
                                             sp.midpoint_cg_per_step, sp.midpoint_steps)},
                  {"backward_euler", side(kBackwardEuler, sp.backward_euler_seconds,
                                          sp.backward_euler_cg_per_step, sp.backward_euler_steps)},
                  {"unstable_runs", sp.unstable_runs},
                  {"wall_ratio_midpoint_over_backward_euler", sp.wall_ratio()},
                  {"cg_ratio_midpoint_over_backward_euler", sp.cg_ratio()}};
  }
  return j;
}

namespace {

std::string results_csv(const EnergyExperiment& ex) {
  std::ostringstream o;
  o << "label,method,alpha,damping_ratio,dt,status,unstable_time,steps,rejected_steps,wall_seconds,"
       "cg_iterations_per_step,kappa_min,kappa_median,kappa_max,energy_initial,viscous_dissipated,"
       "numerical_dissipated,total_dissipated,reference,rms_distance_over_run,rms_distance_final,"
       "energy_created_largest,energy_created_total\n";
  for (const auto& run : ex.runs) {
    const auto& c = run.entry.configuration;
    const RunResult& r = run.trajectory.result;
    const nlohmann::json& k = run.trajectory.summary["kappa"];
    const EnergyRow last = r.energy.empty() ? EnergyRow{} : r.energy.back();
    const EnergyRow first = r.energy.empty() ? EnergyRow{} : r.energy.front();
    const bool compared = !run.entry.reference.empty();
    o << c.label << ',' << c.method << ',' << number(run.trajectory.scene.integrator.alpha) << ','
      << number(c.damping_ratio) << ',' << number(ex.options.dt) << ',' << r.status << ','
      << (r.status == "ok" ? std::string() : number(r.unstable_time)) << ',' << r.steps.steps << ','
      << r.steps.rejected_steps << ',' << number(r.wall_seconds) << ',' << number(cg_per_step(r))
      << ',' << number(k["min"].get<double>()) << ',' << number(k["median"].get<double>()) << ','
      << number(k["max"].get<double>()) << ',' << number(first.total()) << ','
      << number(last.viscous_dissipated) << ',' << number(last.numerical_dissipated) << ','
      << number(dissipated_final(r)) << ',' << run.entry.reference << ','
      << (compared ? number(root_mean_square(run.rms_per_frame)) : std::string()) << ','
      << (compared && !run.rms_per_frame.empty() ? number(run.rms_per_frame.back()) : std::string())
      << ',' << number(energy_created(r.energy).largest) << ',' << number(energy_created(r.energy).total)
      << '\n';
  }
  return o.str();
}

std::string rms_csv(const EnergyExperiment& ex, std::vector<std::string>& columns) {
  std::vector<const EnergyRunResult*> compared;
  for (const auto& run : ex.runs)
    if (!run.entry.reference.empty()) compared.push_back(&run);
  size_t frames = 0;
  for (const auto& run : ex.runs) frames = std::max(frames, run.trajectory.result.energy.size());
  std::ostringstream o;
  o << "time";
  for (const auto* run : compared) {
    o << ',' << run->entry.configuration.label;
    columns.push_back(run->entry.configuration.label);
  }
  o << '\n';
  for (size_t f = 0; f < frames; ++f) {
    o << number(std::min(ex.scene.duration, static_cast<double>(f) * ex.scene.frame_interval));
    for (const auto* run : compared) {
      o << ',';
      if (f < run->rms_per_frame.size()) o << number(run->rms_per_frame[f]);
    }
    o << '\n';
  }
  return o.str();
}

std::string speed_csv(const SpeedComparison& sp) {
  std::ostringstream o;
  o << "repeat,method,wall_seconds,cg_iterations_per_step,steps\n";
  for (int r = 0; r < sp.repeats; ++r) {
    o << r << ',' << kMidpoint << ',' << number(sp.midpoint_seconds[r]) << ','
      << number(sp.midpoint_cg_per_step[r]) << ',' << sp.midpoint_steps << '\n';
    o << r << ',' << kBackwardEuler << ',' << number(sp.backward_euler_seconds[r]) << ','
      << number(sp.backward_euler_cg_per_step[r]) << ',' << sp.backward_euler_steps << '\n';
  }
  return o.str();
}

std::string panel_title(const EnergyRunResult& run) {
  const auto& c = run.entry.configuration;
  const RunResult& r = run.trajectory.result;
  char buf[256];
  std::snprintf(buf, sizeof buf, "%s, %g%% damping, %ld steps, %.2f s", c.label.c_str(),
                100 * c.damping_ratio, r.steps.steps, r.wall_seconds);
  std::string title = buf;
  if (r.status != "ok") title += ", UNSTABLE at " + number(r.unstable_time) + " s";
  return title;
}

GnuplotFigure energy_figure(const EnergyExperiment& ex) {
  double lo = 0, hi = 0;
  for (const auto& run : ex.runs)
    for (const auto& e : run.trajectory.result.energy)
      for (double v :
           {e.kinetic, e.elastic, e.gravity, e.viscous_dissipated + e.numerical_dissipated}) {
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
  const double pad = 0.05 * (hi - lo) + 1e-12;
  std::ostringstream b;
  const int n = static_cast<int>(ex.runs.size());
  const int columns = 2, rows = (n + columns - 1) / columns;
  b << "set multiplot layout " << rows << "," << columns << " title "
    << gnuplot_quote("Energies, " + ex.scene.file + " (dt = " + number(1e3 * ex.options.dt) +
                     " ms)")
    << "\n"
    << "set xlabel 'time (s)'\nset ylabel 'energy (J)'\nset grid\nset key top left font ',8'\n"
    << "set xrange [0:" << number(ex.scene.duration) << "]\n"
    << "set yrange [" << number(lo - pad) << ":" << number(hi + pad) << "]\n";
  for (const auto& run : ex.runs) {
    const std::string file = gnuplot_quote(run.entry.configuration.label + "/energy.csv");
    b << "set title " << gnuplot_quote(panel_title(run)) << " font ',9'\n"
      << "plot " << file << " every ::1 using 1:3 with lines lw 1.5 title 'elastic', \\\n"
      << "     " << file << " every ::1 using 1:2 with lines lw 1.5 title 'kinetic', \\\n"
      << "     " << file
      << " every ::1 using 1:4 with lines lw 1.5 title 'potential (gravity, from t = 0)', \\\n"
      << "     " << file
      << " every ::1 using 1:($5+$6) with lines lw 2 title 'dissipated (viscous + numerical)', \\\n"
      << "     " << file << " every ::1 using 1:6 with lines dt 2 title 'numerical dissipation'\n";
  }
  b << "unset multiplot";
  return {"energy", b.str(), 1100, 330 * rows};
}

GnuplotFigure rms_figure(const EnergyExperiment& ex, const std::vector<std::string>& columns) {
  std::ostringstream b;
  b << "set title "
    << gnuplot_quote("RMS vertex distance from the RK45 reference with the same damping") << "\n"
    << "set xlabel 'time (s)'\nset ylabel 'RMS distance (m)'\nset logscale y\nset grid\nset key "
       "bottom right\n"
    << "set xrange [0:" << number(ex.scene.duration) << "]\n";
  if (columns.empty()) {
    b << "set label 1 'no compared runs' at graph 0.5, 0.5 center\nplot NaN notitle";
  } else {
    b << "plot ";
    for (size_t k = 0; k < columns.size(); ++k)
      b << (k ? ", \\\n     " : "") << "'rms.csv' every ::1 using 1:(column(" << k + 2
        << ") > 0 ? column(" << k + 2 << ") : NaN) with lines lw 1.5 title "
        << gnuplot_quote(columns[k]);
  }
  return {"rms", b.str(), 900, 550};
}

}  // namespace

std::vector<std::string> write_energy_experiment(const EnergyExperiment& ex,
                                                 const std::filesystem::path& dir) {
  std::vector<PendingFile> files;
  auto text_file = [&](const std::filesystem::path& path, std::string content) {
    files.push_back(pending_text_file(path, std::move(content)));
  };
  for (const auto& run : ex.runs) {
    const auto sub = dir / run.entry.configuration.label;
    text_file(sub / "energy.csv", energy_csv(run.trajectory.result.energy));
    text_file(sub / "summary.json", run.trajectory.summary.dump(2) + "\n");
  }
  std::vector<std::string> columns;
  text_file(dir / "rms.csv", rms_csv(ex, columns));
  text_file(dir / "results.csv", results_csv(ex));
  text_file(dir / "speed.csv", speed_csv(ex.speed));
  text_file(dir / "results.json", energy_results_json(ex).dump(2) + "\n");
  write_files_atomically(files);

  std::vector<std::string> warnings;
  for (const auto& fig : {energy_figure(ex), rms_figure(ex, columns)}) {
    std::string w = render_gnuplot_figure(dir, fig);
    if (!w.empty()) warnings.push_back(std::move(w));
  }
  if (ex.injection) {
    std::filesystem::create_directories(dir / "injection");
    std::string w = write_energy_injection(*ex.injection, dir / "injection");
    if (!w.empty()) warnings.push_back(std::move(w));
  }
  return warnings;
}

}  // namespace weft
