#include "weft/simulation.hpp"

#include "weft/error.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace weft {

Simulation::Simulation(const Scene& scene) : scene_(scene) {
  TriMesh mesh = build_cloth_mesh(scene.cloth);
  // Problems found while building the model (a degenerate triangle, a bad pin) name the
  // scene and the mesh they come from.
  const std::string where = (scene.file.empty() ? std::string("scene") : scene.file) + ": cloth" +
                            (scene.cloth.obj_path.empty() ? std::string(" grid") : " mesh " + scene.cloth.obj_path);
  try {
    const std::vector<int> pins = resolve_pins(scene.cloth, mesh);
    model_ = std::make_unique<ClothModel>(build_cloth_model(std::move(mesh), scene.cloth.material, scene.gravity, pins,
                                                            parse_bending_model(scene.cloth.bending_model, "cloth.bending_model")));
  } catch (const InputError& e) {
    throw InputError(where + ": " + e.what());
  }
  // RK45 steps adaptively: report its stiffness factors at the scene's (largest) step.
  DampingSettings damping{scene.effective_damping_ratio()};
  if (scene.integrator.method == Method::Rk45) damping.reference_dt = scene.integrator.dt;
  system_ = std::make_unique<ClothSystem>(*model_, damping);
  integrator_ = std::make_unique<Integrator>(*system_, scene.integrator);
  state_.x = model_->initial_positions();
  state_.v = VecX::Zero(state_.x.size());
  for (int i = 0; i < model_->num_vertices(); ++i)
    if (!model_->fixed[i]) node(state_.v, i) = scene.cloth.initial_velocity;
  state_.t = 0;
  set_energy_reference();
}

void Simulation::reset_state(const VecX& x, const VecX& v) {
  state_ = State{};
  state_.x = x;
  state_.v = v;
  set_energy_reference();
}

void Simulation::set_energy_reference() {
  gravity0_ = 0;
  total0_ = 0;
  system_->evaluate(state_.x, state_.v, false, eval_);
  gravity0_ = eval_.gravity_energy;
  const EnergyRow e0 = energies();
  total0_ = e0.total();
  Vec3 lo = node(state_.x, 0), hi = lo;
  for (int i = 1; i < model_->num_vertices(); ++i) {
    lo = lo.cwiseMin(node(state_.x, i));
    hi = hi.cwiseMax(node(state_.x, i));
  }
  energy_scale_ = e0.kinetic + e0.elastic + model_->mass.sum() * scene_.gravity.norm() * (hi - lo).norm() + 1e-12;
}

EnergyRow Simulation::energies() {
  system_->evaluate(state_.x, state_.v, false, eval_);
  EnergyRow r;
  r.time = state_.t;
  const VecX& m = model_->mass;
  for (int i = 0; i < model_->num_vertices(); ++i) r.kinetic += 0.5 * m[i] * node(state_.v, i).squaredNorm();
  r.elastic = eval_.elastic_energy;
  r.gravity = eval_.gravity_energy - gravity0_;
  r.viscous_dissipated = state_.viscous_dissipated;
  r.numerical_dissipated = total0_ - r.total() - r.viscous_dissipated;
  return r;
}

RunResult run_simulation(Simulation& sim, const RunCallbacks& cb) {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  RunResult res;
  const Scene& sc = sim.scene();
  res.damping_ratio = sc.effective_damping_ratio();
  res.vertices = sim.model().num_vertices();
  res.triangles = static_cast<long>(sim.model().mesh.triangles.size());
  const long frames = std::lround(std::floor(sc.duration / sc.frame_interval + 1e-9));
  const double total0 = [&] { return sim.energies().total(); }();
  for (long f = 0; f <= frames; ++f) {
    if (f > 0) sim.advance_to(std::min(sc.duration, f * sc.frame_interval));
    const EnergyRow e = sim.energies();
    const State& s = sim.state();
    std::string problem;
    if (!s.x.allFinite() || !s.v.allFinite() || !std::isfinite(e.total())) {
      problem = "positions or velocities became non-finite (NaN or infinity)";
    } else if (e.total() - total0 > sim.energy_scale()) {
      char buf[200];
      std::snprintf(buf, sizeof buf, "mechanical energy rose by %.3g J, above the scene's energy scale of %.3g J",
                    e.total() - total0, sim.energy_scale());
      problem = buf;
    }
    if (!problem.empty()) {
      res.status = "unstable";
      res.unstable_time = s.t;
      res.message = problem;
      break;
    }
    res.energy.push_back(e);
    if (cb.on_frame) cb.on_frame(static_cast<int>(f), sim);
    if (cb.on_progress) cb.on_progress(frames ? static_cast<double>(f) / frames : 1.0);
  }
  res.steps = sim.statistics();
  res.damping = sim.system().statistics();
  res.wall_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return res;
}

namespace {
nlohmann::json stats_json(const LogStatistics& s) {
  return {{"min", s.min()}, {"median", s.median()}, {"max", s.max()}, {"count", s.count()}};
}
}  // namespace

nlohmann::json summary_json(const Simulation& sim, const RunResult& r) {
  const Scene& sc = sim.scene();
  nlohmann::json j;
  j["weft_version"] = WEFT_VERSION;
  j["scene"] = sc.file;
  j["method"] = sc.method_name;
  j["alpha"] = sc.integrator.alpha;
  j["dt"] = sc.integrator.dt;
  j["duration"] = sc.duration;
  j["frame_interval"] = sc.frame_interval;
  j["vertices"] = r.vertices;
  j["triangles"] = r.triangles;
  j["steps"] = r.steps.steps;
  j["rejected_steps"] = r.steps.rejected_steps;
  j["wall_seconds"] = r.wall_seconds;
  j["assembly_seconds"] = r.steps.assembly_seconds;
  j["solve_seconds"] = r.steps.solve_seconds;
  j["solver_iterations_mean"] = r.steps.cg_solves ? static_cast<double>(r.steps.cg_iterations) / r.steps.cg_solves : 0.0;
  j["solver_iterations_total"] = r.steps.cg_iterations;
  j["solver_failures"] = r.steps.cg_failures;
  j["solver_tolerance"] = sc.integrator.cg_tolerance;
  j["preconditioner"] = preconditioner_name(sim.integrator().preconditioner());
  if (sim.integrator().preconditioner() == Preconditioner::kSsor) {
    j["ssor_relaxation"] = sim.integrator().ssor_relaxation();
    j["ssor_precision"] = sc.integrator.ssor_single_precision ? "single" : "double";
  }
  j["status"] = r.status;
  if (r.status != "ok") {
    j["unstable_time"] = r.unstable_time;
    j["message"] = r.message;
  }
  j["frames"] = r.energy.size();
  j["damping_ratio"] = r.damping_ratio;
  j["kappa"] = stats_json(r.damping.membrane_kappa);
  j["lambda"] = stats_json(r.damping.membrane_lambda);
  j["bending_kappa"] = stats_json(r.damping.bending_kappa);
  j["added_viscosity_Ns_m"] = {{"mean_over_raised", r.damping.added_viscosity.mean()},
                               {"max", r.damping.added_viscosity.max()},
                               {"material_viscosity", sim.model().material.viscosity_Ns_m},
                               {"raised_fraction", r.damping.element_steps
                                                        ? static_cast<double>(r.damping.raised_element_steps) / r.damping.element_steps
                                                        : 0.0}};
  if (!r.energy.empty()) {
    const EnergyRow& last = r.energy.back();
    j["energy_final"] = {{"kinetic", last.kinetic}, {"elastic", last.elastic}, {"gravity", last.gravity},
                         {"viscous_dissipated", last.viscous_dissipated},
                         {"numerical_dissipated", last.numerical_dissipated}};
  }
  return j;
}

std::string energy_csv(const std::vector<EnergyRow>& rows) {
  std::ostringstream out;
  out << "time,kinetic,elastic,gravity,viscous_dissipated,numerical_dissipated,total\n";
  char buf[256];
  for (const auto& e : rows) {
    std::snprintf(buf, sizeof buf, "%.6f,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g\n", e.time, e.kinetic, e.elastic, e.gravity,
                  e.viscous_dissipated, e.numerical_dissipated, e.total());
    out << buf;
  }
  return out.str();
}

}  // namespace weft
