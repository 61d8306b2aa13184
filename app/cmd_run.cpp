// `weft run SCENE --out DIR`: simulate a scene and write frames, energies and a summary.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

#include "command.hpp"
#include "weft/atomic_file.hpp"
#include "progress.hpp"
#include "weft/error.hpp"
#include "weft/simulation.hpp"

namespace fs = std::filesystem;

namespace {

struct RunArgs {
  std::string scene, out, method, frame_format = "obj", preconditioner;
  std::optional<double> alpha, dt, duration, tolerance, damping_ratio;
  bool no_frames = false, quiet = false;
};

void write_ply(const std::string& path, const weft::Simulation& sim) {
  const auto& x = sim.state().x;
  const auto& tris = sim.model().mesh.triangles;
  const weft::VecX eta = sim.system().added_viscosity_per_vertex();
  weft::write_file_atomically(path, [&](std::ostream& out) {
    out << "ply\nformat ascii 1.0\ncomment weft frame; added_viscosity in N s/m (adaptive damping)\n"
        << "element vertex " << x.size() / 3 << "\nproperty float x\nproperty float y\nproperty float z\n"
        << "property float added_viscosity\nelement face " << tris.size()
        << "\nproperty list uchar int vertex_indices\nend_header\n";
    char buf[128];
    for (int i = 0; i < x.size() / 3; ++i) {
      std::snprintf(buf, sizeof buf, "%.9g %.9g %.9g %.6g\n", x[3 * i], x[3 * i + 1], x[3 * i + 2], eta[i]);
      out << buf;
    }
    for (const auto& t : tris) out << "3 " << t[0] << ' ' << t[1] << ' ' << t[2] << '\n';
  });
}

int run(const RunArgs& a) {
  using namespace weft;
  Scene scene = load_scene(a.scene);
  const std::string where = "command line";
  if (!a.method.empty() || a.alpha) set_method(scene, a.method.empty() ? scene.method_name : a.method, a.alpha, where);
  if (a.dt) scene.integrator.dt = *a.dt;
  if (a.duration) scene.duration = *a.duration;
  if (a.tolerance) (scene.integrator.method == Method::Rk45 ? scene.integrator.error_tolerance : scene.integrator.cg_tolerance) = *a.tolerance;
  if (a.damping_ratio) scene.damping_ratio = *a.damping_ratio;
  if (!a.preconditioner.empty()) scene.integrator.preconditioner = *parse_preconditioner(a.preconditioner);
  validate_timing(scene, where);
  Simulation sim(scene);  // validates the mesh, material and pins before anything is written
  std::vector<std::unique_ptr<WalkingBody>> bodies;
  for (const auto& b : scene.bodies) bodies.push_back(std::make_unique<WalkingBody>(b));
  if (!bodies.empty() && !a.quiet)
    std::fprintf(stderr, "note: the scene's body colliders are animated and written as frames/body<k>_NNNNN.obj; "
                         "the cloth does not collide with them in this version\n");

  const fs::path out(a.out);
  std::error_code ec;
  fs::create_directories(out / "frames", ec);
  if (ec) throw InputError(a.out + ": cannot create output folder: " + ec.message());
  if (!a.no_frames) {
    // Remove frames of an earlier run so the folder holds one consistent run.
    for (const auto& e : fs::directory_iterator(out / "frames"))
      if (e.path().filename().string().rfind("frame_", 0) == 0 || e.path().filename().string().rfind("body", 0) == 0)
        fs::remove(e.path());
  }

  app::Progress progress("weft run " + scene.method_name, !a.quiet);
  RunCallbacks cb;
  cb.on_frame = [&](int f, const Simulation& s) {
    if (a.no_frames) return;
    char name[64];
    std::snprintf(name, sizeof name, "frame_%05d.%s", f, a.frame_format.c_str());
    const std::string path = (out / "frames" / name).string();
    if (a.frame_format == "ply") write_ply(path, s); else write_obj(path, s.state().x, s.model().mesh.triangles);
    Points body_positions;
    for (size_t k = 0; k < bodies.size(); ++k) {
      std::snprintf(name, sizeof name, "body%zu_%05d.obj", k, f);
      bodies[k]->positions(s.state().t, body_positions);
      write_obj((out / "frames" / name).string(), body_positions, bodies[k]->triangles());
    }
  };
  cb.on_progress = [&](double fr) { progress.update(fr); };
  RunResult r = run_simulation(sim, cb);
  progress.finish();
  write_file_atomically((out / "energy.csv").string(), [&](std::ostream& o) { o << energy_csv(r.energy); });
  const nlohmann::json summary = summary_json(sim, r);
  write_file_atomically((out / "summary.json").string(), [&](std::ostream& o) { o << summary.dump(2) << "\n"; });

  if (!a.quiet) {
    std::fprintf(stderr, "%s: %ld steps in %.2f s (%.3f ms/step), CG %.1f iterations/step, kappa %.3g..%.3g, damping %.3g\n",
                 r.status.c_str(), r.steps.steps, r.wall_seconds, 1e3 * r.wall_seconds / std::max(1L, r.steps.steps),
                 summary["solver_iterations_mean"].get<double>(), r.damping.membrane_kappa.min(),
                 r.damping.membrane_kappa.max(), r.damping_ratio);
    std::fprintf(stderr, "results in %s (frames/, energy.csv, summary.json)\n", a.out.c_str());
  }
  if (r.status != "ok") {
    std::fprintf(stderr,
                 "weft: simulation became unstable at t = %.4f s: %s.\n"
                 "Kept %zu frames. Try a smaller --dt, a more implicit method (--method backward-euler) or more damping "
                 "(--damping-ratio 0.05).\n",
                 r.unstable_time, r.message.c_str(), r.energy.size());
    return app::kExitUnstable;
  }
  return app::kExitOk;
}

weft::app::RegisterCommand reg{{"", "run", "Simulate a scene file and write frames, energy.csv and summary.json",
  [](CLI::App& sub) {
    auto a = std::make_shared<RunArgs>();
    sub.add_option("scene", a->scene, "Scene file (JSON, see docs/scene-format.md)")->required();
    sub.add_option("--out,-o", a->out, "Output folder (created; frames/, energy.csv, summary.json)")->required();
    sub.add_option("--method,-m", a->method,
                   "Integrator: " + weft::method_names() + " (default: the scene's)");
    sub.add_option("--alpha", a->alpha, "Implicitness in [0, 1] for methods 'alpha' and 'bdf2-alpha'");
    sub.add_option("--dt", a->dt, "Time step in seconds (for rk45: the largest step)");
    sub.add_option("--duration", a->duration, "Simulated time in seconds");
    sub.add_option("--tolerance", a->tolerance,
                   "Conjugate-gradient relative residual (semi-implicit methods) or local error tolerance (rk45)");
    sub.add_option("--preconditioner", a->preconditioner,
                   "Conjugate-gradient preconditioner: auto (multigrid from " +
                       std::to_string(weft::kMultigridMinFreeNodes) + " free vertices, ssor below), "
                       "block-jacobi, ssor or multigrid (default: the scene's, else auto)")
        ->check(CLI::IsMember({"auto", "block-jacobi", "ssor", "multigrid"}));
    sub.add_option("--damping-ratio", a->damping_ratio,
                   "Adaptive damping target as a fraction of critical (0 turns it off; default 0.05 for "
                   "Implicit Midpoint and BDF-2, 0 for the others)");
    sub.add_option("--frame-format", a->frame_format, "obj, or ply with per-vertex added viscosity")
        ->check(CLI::IsMember({"obj", "ply"}));
    sub.add_flag("--no-frames", a->no_frames, "Do not write frames (energy.csv and summary.json only)");
    sub.add_flag("--quiet,-q", a->quiet, "No progress bar or summary line");
    sub.footer(
        "Writes DIR/frames/frame_00000.obj ... (one per output frame, the first at time 0), DIR/energy.csv\n"
        "(time,kinetic,elastic,gravity,viscous_dissipated,numerical_dissipated,total in J) and DIR/summary.json.\n"
        "Exit status: 0 ok, 2 bad input (nothing written), 3 unstable (frames so far kept).");
    return std::function<int()>([a] { return run(*a); });
  }, 10}};

}  // namespace
