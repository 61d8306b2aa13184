#include "weft/experiments/walk.hpp"
#include "sim/simulation_core.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "collision/colliders.hpp"
#include "weft/frame_check.hpp"
#include "weft/experiments/energy.hpp"
#include "weft/experiments/liveliness.hpp"
#include "weft/exports.hpp"
#include "io/gnuplot.hpp"
#include "weft/atomic_file.hpp"
#include "weft/error.hpp"

namespace weft {

namespace {

std::string number(double v) { return format_number(v); }

constexpr const char* kReference = "im-2ms";

}  // namespace

std::vector<WalkConfiguration> walk_configurations() {
  const double im_damping = 0.05;
  return {
      {{"im-5ms", "implicit-midpoint", std::nullopt, im_damping}, 0.005},
      {{kReference, "implicit-midpoint", std::nullopt, im_damping}, 0.002},
      {{"be-2ms", "backward-euler", std::nullopt, 0.0}, 0.002},
      {{"be-5ms", "backward-euler", std::nullopt, 0.0}, 0.005},
      {{"bdf2-2ms", "bdf2", std::nullopt, 0.0}, 0.002},
      {{"bdf2-alpha-2ms", "bdf2-alpha", 1.0 / std::sqrt(3.0), im_damping}, 0.002},
      // Not the paper's: weft's guarded BDF-2 (docs/guarded-midpoint.md) at the midpoint's 5 ms.
      {{"bdf2-alpha-guarded-5ms", "bdf2-alpha-guarded", 1.0 / std::sqrt(3.0), im_damping}, 0.005},
  };
}

WalkExperiment run_walk_experiment(const Scene& scene_in, const WalkExperimentOptions& o,
                                   const std::filesystem::path& dir, const WalkProgress& progress) {
  Scene scene = scene_in;
  if (o.duration) {
    require_positive_finite("--duration", *o.duration);
    scene.duration = *o.duration;
  }
  if (o.edge_length) {
    if (!scene.cloth.garment) throw InputError("--edge-length: the scene's cloth is not a garment (cloth.mesh.pattern)");
    if (!(*o.edge_length >= 0.005 && *o.edge_length <= 0.2))
      throw InputError("--edge-length " + number(*o.edge_length) + ": expected 0.005 to 0.2 m");
    scene.cloth.garment->edge_length_m = *o.edge_length;
  }
  int body_collider = -1;
  for (size_t k = 0; k < scene.colliders.size() && body_collider < 0; ++k)
    if (scene.colliders[k].shape == ColliderShape::kBody) body_collider = static_cast<int>(k);
  if (body_collider < 0) throw InputError(scene.file + ": the walk experiment needs a body collider");
  const BodyColliderSpec& body_spec = scene.bodies[scene.colliders[body_collider].body];
  const double moving_from = body_spec.bind_pose_hold + body_spec.blend;

  std::vector<WalkConfiguration> chosen;
  const auto all = walk_configurations();
  for (const auto& label : o.only) {
    const auto it = std::find_if(all.begin(), all.end(), [&](const WalkConfiguration& c) { return c.configuration.label == label; });
    if (it == all.end()) {
      std::string known;
      for (const auto& c : all) known += (known.empty() ? "" : ", ") + c.configuration.label;
      throw InputError("--configs: unknown configuration '" + label + "' (expected some of " + known + ")");
    }
    chosen.push_back(*it);
  }
  if (chosen.empty()) chosen = all;

  WalkExperiment ex;
  ex.scene = scene;
  for (const WalkConfiguration& entry : chosen) {
    const Scene configured = configure_scene(scene, entry.configuration, entry.dt, 1e-6);
    WalkRun run;
    run.entry = entry;
    Simulation sim(configured);
    const auto& cloth_triangles = sim.core().model().mesh.triangles;
    const std::vector<int> hem = lowest_boundary_loop(cloth_triangles, sim.core().state().x);
    const WalkingBody& body = *sim.core().bodies()[scene.colliders[body_collider].body];
    const std::vector<std::array<int, 3>> body_list = triangle_list(body.triangles());
    FrameChecker checker(0);
    Points body_x, body_v;
    std::vector<Vec3> body_centres;
    const std::filesystem::path frames = dir / entry.configuration.label / "frames";
    if (o.frames) std::filesystem::create_directories(frames);
    RunCallbacks cb;
    cb.on_frame = [&](int f, const Simulation& s) {
      const double t = s.core().state().t;
      body.positions(t, body_x);
      body.velocities(t, body_v);
      const RigidVelocity rigid = fit_rigid_velocity(body_x, body_v);
      run.time.push_back(t);
      run.relative_kinetic.push_back(relative_kinetic_energy(s.core().state().x, s.core().state().v, s.core().model().mass, rigid));
      body_centres.push_back(rigid.centre);
      run.hem_forward.push_back(0);  // the walking direction is known at the end
      run.positions.push_back(s.core().state().x);
      const FrameIntersections r = checker.check({s.core().state().x.data(), &cloth_triangles}, {{body_x.data(), &body_list}});
      run.intersections.push_back(static_cast<long>(r.count()));
      if (o.frames) {
        char name[64];
        std::snprintf(name, sizeof name, "frame_%05d.ply", f);
        const VecX eta = s.core().system().added_viscosity_per_vertex();
        write_file_atomically((frames / name).string(), [&](std::ostream& out) {
          write_ply_frame(out, s.core().state().x.data(), s.core().model().num_vertices(), eta.data(), cloth_triangles);
        });
        std::snprintf(name, sizeof name, "body0_%05d.obj", f);
        write_obj((frames / name).string(), body_x, body.triangles());
      }
    };
    if (progress) cb.on_progress = [&](double fraction) { progress(entry.configuration.label, fraction); };
    run.result = run_simulation(sim, cb);
    run.summary = summary_json(sim, run.result);
    // The walking direction: the body's horizontal travel over the run.
    Vec3 forward = body_centres.empty() ? Vec3::Zero() : Vec3(body_centres.back() - body_centres.front());
    forward.y() = 0;
    if (forward.norm() < 1e-6) forward = Vec3::UnitZ();
    forward.normalize();
    std::vector<Vec3> offsets;
    for (size_t f = 0; f < run.positions.size(); ++f) {
      const Vec3 offset = mean_of(run.positions[f], hem) - body_centres[f];
      run.hem_forward[f] = offset.dot(forward);
      if (run.time[f] >= moving_from) offsets.push_back(offset);
    }
    run.swing = swing_amplitude(offsets, forward);
    ex.runs.push_back(std::move(run));
  }
  const auto ref = std::find_if(ex.runs.begin(), ex.runs.end(), [](const WalkRun& r) { return r.entry.configuration.label == kReference; });
  if (ref != ex.runs.end()) {
    ex.reference = kReference;
    for (WalkRun& r : ex.runs) r.distance = rms_distance_per_frame(r.positions, ref->positions);
  }
  return ex;
}

namespace {

double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0.0 : s / static_cast<double>(v.size());
}

struct RunFigures {
  double wall = 0, ms_per_step = 0, cg_per_step = 0, detection_ms = 0, response_ms = 0, assembly_ms = 0, solve_ms = 0;
  long steps = 0, worst_intersections = 0, frames_with_intersections = 0;
};

RunFigures figures(const WalkRun& r) {
  RunFigures f;
  const StepStatistics& s = r.result.steps;
  f.steps = s.steps;
  f.wall = r.result.wall_seconds;
  const double n = std::max<long>(s.steps, 1);
  f.ms_per_step = 1e3 * f.wall / n;
  f.cg_per_step = static_cast<double>(s.cg_iterations) / n;
  f.detection_ms = 1e3 * s.detection_seconds / n;
  f.response_ms = 1e3 * s.response_seconds / n;
  f.assembly_ms = 1e3 * s.assembly_seconds / n;
  f.solve_ms = 1e3 * s.solve_seconds / n;
  for (long k : r.intersections) {
    f.worst_intersections = std::max(f.worst_intersections, k);
    if (k > 0) ++f.frames_with_intersections;
  }
  return f;
}

std::string status_text(const WalkRun& r) {
  if (r.result.status == "ok") return "ok";
  return r.result.status + " at " + number(r.result.unstable_time) + " s: " + r.result.message;
}

}  // namespace

std::string walk_results_markdown(const WalkExperiment& ex) {
  std::ostringstream m;
  m << "| run | status | steps | wall (s) | ms/step | detection | response | assembly | solve | CG/step | frames with intersections | worst frame | mean relative KE (J) | hem swing (cm) | RMS distance from " << (ex.reference.empty() ? "im-2ms" : ex.reference) << " (cm) |\n";
  m << "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  char buf[512];
  for (const WalkRun& r : ex.runs) {
    const RunFigures f = figures(r);
    const std::string distance = r.distance.empty() ? "-" : number(std::round(1e3 * root_mean_square(r.distance)) / 10);
    std::snprintf(buf, sizeof buf, "| %s | %s | %ld | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %ld of %zu | %ld | %.4g | %.1f | %s |\n",
                  r.entry.configuration.label.c_str(), r.result.status.c_str(), f.steps, f.wall, f.ms_per_step, f.detection_ms,
                  f.response_ms, f.assembly_ms, f.solve_ms, f.cg_per_step, f.frames_with_intersections, r.intersections.size(),
                  f.worst_intersections, mean(r.relative_kinetic), 100 * r.swing, distance.c_str());
    m << buf;
  }
  m << "\nms per step: detection finds the contacts at the step's start, response is the constraints, friction and "
       "fail-safes, assembly builds the system, solve is the linear solves with the contact passes between them "
       "(their detection and response counted in those columns too). Intersections: cloth self plus cloth-body "
       "triangle pairs per frame (weft check). Relative KE: the garment's kinetic energy relative to the body's "
       "fitted rigid motion, mean over frames. Hem swing: half the range of the hem centre's position ahead of the "
       "body's centre once the body walks.\n";
  for (const WalkRun& r : ex.runs)
    if (r.result.status != "ok") m << "\n" << r.entry.configuration.label << ": " << status_text(r) << "\n";
  return m.str();
}

std::vector<std::string> write_walk_experiment(const WalkExperiment& ex, const std::filesystem::path& dir) {
  std::vector<PendingFile> files;
  auto text_file = [&](const std::filesystem::path& path, std::string content) {
    files.push_back(pending_text_file(path, std::move(content)));
  };
  nlohmann::json results = experiment_json("walk", ex.scene);
  results["reference"] = ex.reference;
  std::ostringstream csv, live;
  csv << "run,method,dt,damping_ratio,status,unstable_time,steps,wall_seconds,ms_per_step,detection_ms,response_ms,"
         "assembly_ms,solve_ms,cg_per_step,frames,frames_with_intersections,worst_intersections,"
         "mean_relative_kinetic_J,hem_swing_m,rms_distance_m\n";
  live << "time";
  size_t longest = 0;
  for (const WalkRun& r : ex.runs) {
    const std::string& label = r.entry.configuration.label;
    live << "," << label << "_relative_kinetic_J," << label << "_hem_forward_m," << label << "_distance_m";
    longest = std::max(longest, r.time.size());
    text_file(dir / label / "energy.csv", energy_csv(r.result.energy));
    text_file(dir / label / "summary.json", r.summary.dump(2) + "\n");
    const RunFigures f = figures(r);
    const double distance = r.distance.empty() ? 0.0 : root_mean_square(r.distance);
    csv << label << "," << r.entry.configuration.method << "," << number(r.entry.dt) << ","
        << number(r.entry.configuration.damping_ratio) << "," << r.result.status << ","
        << number(r.result.unstable_time) << "," << f.steps << "," << number(f.wall) << "," << number(f.ms_per_step) << ","
        << number(f.detection_ms) << "," << number(f.response_ms) << "," << number(f.assembly_ms) << ","
        << number(f.solve_ms) << "," << number(f.cg_per_step) << "," << r.intersections.size() << ","
        << f.frames_with_intersections << "," << f.worst_intersections << "," << number(mean(r.relative_kinetic)) << ","
        << number(r.swing) << "," << number(distance) << "\n";
    results["runs"].push_back({{"label", label},
                               {"method", r.entry.configuration.method},
                               {"dt", r.entry.dt},
                               {"damping_ratio", r.entry.configuration.damping_ratio},
                               {"status", r.result.status},
                               {"message", r.result.message},
                               {"unstable_time", r.result.unstable_time},
                               {"steps", f.steps},
                               {"wall_seconds", f.wall},
                               {"ms_per_step", {{"total", f.ms_per_step}, {"detection", f.detection_ms}, {"response", f.response_ms},
                                                {"assembly", f.assembly_ms}, {"solve", f.solve_ms}}},
                               {"cg_per_step", f.cg_per_step},
                               {"intersections_per_frame", r.intersections},
                               {"relative_kinetic_J", r.relative_kinetic},
                               {"hem_forward_m", r.hem_forward},
                               {"hem_swing_m", r.swing},
                               {"rms_distance_per_frame_m", r.distance}});
  }
  live << "\n";
  for (size_t f = 0; f < longest; ++f) {
    double t = 0;
    for (const WalkRun& r : ex.runs)
      if (f < r.time.size()) t = r.time[f];
    live << number(t);
    for (const WalkRun& r : ex.runs) {
      if (f < r.time.size())
        live << "," << number(r.relative_kinetic[f]) << "," << number(r.hem_forward[f]) << ","
             << (f < r.distance.size() ? number(r.distance[f]) : "");
      else
        live << ",,,";
    }
    live << "\n";
  }
  text_file(dir / "results.csv", csv.str());
  text_file(dir / "results.md", walk_results_markdown(ex));
  text_file(dir / "results.json", results.dump(2) + "\n");
  text_file(dir / "liveliness.csv", live.str());
  write_files_atomically(files);

  std::ostringstream b;
  b << "set termoption noenhanced\nset multiplot layout 3,1 title " << gnuplot_quote("Walk: " + ex.scene.file) << "\n"
    << "set datafile separator ','\nset grid\nset key outside right\nset xlabel 'time (s)'\n"
    << "set xrange [0:" << number(ex.scene.duration) << "]\n";
  const char* titles[3] = {"kinetic energy relative to the body (J)", "hem ahead of the body centre (m)",
                           "RMS distance from im-2ms (m)"};
  for (int k = 0; k < 3; ++k) {
    b << "set ylabel " << gnuplot_quote(titles[k]) << "\nplot ";
    if (k == 2 && ex.reference.empty()) {
      b << "NaN title 'no im-2ms run'\n";
      continue;
    }
    for (size_t r = 0; r < ex.runs.size(); ++r)
      b << (r ? ", \\\n     " : "") << "'liveliness.csv' every ::1 using 1:" << 2 + 3 * r + k
        << " with lines lw 1.5 title " << gnuplot_quote(ex.runs[r].entry.configuration.label);
    if (ex.runs.empty()) b << "NaN notitle";
    b << "\n";
  }
  b << "unset multiplot";
  std::vector<std::string> warnings;
  std::string w = render_gnuplot_figure(dir, {"liveliness", b.str(), 900, 900});
  if (!w.empty()) warnings.push_back(std::move(w));
  return warnings;
}

}  // namespace weft
